//! Active and dormant cells (salon paper §4.4): each cell tracks the sections entering and leaving
//! it and their speed; a cell quiet for long enough goes dormant and freezes its sections until a
//! tool touches it, a section enters it, or an active neighbouring node pulls hard enough.

use crate::cell_key::CellKey;
use crate::grid::Grid;
use crate::influence::InfluenceVolume;
use crate::{GridError, Real};

/// Thresholds of the activity rules. SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct ActivityConfig {
    /// Seconds a cell must stay quiet (no section entering or leaving, every section slower than
    /// `speed_threshold`, no tool) before it goes dormant. Default 0.5 s.
    pub dormant_after: Real,
    /// Speeds at or below this (m/s) count as zero velocity. Default 1e-2 m/s: 0.17 mm a
    /// frame at 60 Hz, a fifth of a pixel where a head fills a 720-pixel frame. (Until 2026-12
    /// it was 1e-3 m/s, under which wet hair settling under its water's weight stayed awake
    /// for seconds; rigid-body engines put bodies to sleep at a few centimetres a second.)
    pub speed_threshold: Real,
    /// A dormant cell wakes when a section in it feels a force above this (newtons) from an
    /// active neighbouring node. Default 1e-4 N.
    pub wake_force: Real,
}

impl ActivityConfig {
    /// Checks the thresholds and a step `dt` (s): each finite and >= 0.
    ///
    /// # Errors
    /// [`GridError::InvalidConfig`] naming the first bad value.
    pub fn validate(&self, dt: Real) -> Result<(), GridError> {
        for (field, value) in [
            ("ActivityConfig::dormant_after", self.dormant_after),
            ("ActivityConfig::speed_threshold", self.speed_threshold),
            ("ActivityConfig::wake_force", self.wake_force),
            ("ActivityInput::dt", dt),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(GridError::InvalidConfig {
                    field,
                    value,
                    requirement: "must be finite and >= 0",
                });
            }
        }
        Ok(())
    }
}

impl Default for ActivityConfig {
    fn default() -> Self {
        Self {
            dormant_after: 0.5,
            speed_threshold: 1e-2,
            wake_force: 1e-4,
        }
    }
}

/// State of a cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellState {
    /// Simulated.
    Active,
    /// Frozen: its sections are not integrated.
    Dormant,
}

/// Activity of one non-empty cell after an update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CellActivity {
    /// The cell.
    pub key: CellKey,
    /// Its state.
    pub state: CellState,
    /// Seconds the cell has been quiet (reset to 0 by any activity).
    pub quiet_for: Real,
    /// Sections in the cell now that were not in it at the previous update.
    pub entering: u32,
    /// Sections in the cell at the previous update that are not in it now.
    pub leaving: u32,
    /// Largest speed of a section in the cell, m/s.
    pub max_speed: Real,
}

/// What happened during one step, per section of the grid (by section index).
#[derive(Clone, Copy, Debug, Default)]
pub struct ActivityInput<'a> {
    /// Time since the previous update, seconds (>= 0).
    pub dt: Real,
    /// Speed of each section, m/s (one per section of the grid).
    pub speeds: &'a [Real],
    /// Magnitude of the force each section receives from active neighbouring nodes, newtons
    /// (one per section, or empty for none).
    pub neighbour_forces: &'a [Real],
    /// Tools acting this step; every cell their volumes cover wakes.
    pub tools: &'a [InfluenceVolume],
    /// Sections a tool touches this step (indices into the grid, any order); the cells they
    /// lie in wake. Finer than `tools`: a wide cone wakes only the hair it reaches.
    pub touched_sections: &'a [u32],
}

/// Per-cell activity tracking across steps; feed it the grid after each rebuild.
///
/// Sections are matched across updates by index: when the number of sections changes (LOD split
/// or merge), every cell is treated as entered and wakes.
#[derive(Clone, Debug, Default)]
pub struct Activity {
    config: ActivityConfig,
    prev_keys: Vec<u64>,
    prev_start: Vec<u32>,
    cur_keys: Vec<u64>,
    cur_start: Vec<u32>,
    states: Vec<CellActivity>,
    next: Vec<CellActivity>,
    events: Vec<(u64, bool)>,
    tool_cells: Vec<u64>,
    touched: Vec<CellKey>,
    frozen: Vec<bool>,
    integrate: Vec<u32>,
}

fn packed(k: CellKey) -> u64 {
    // Grid cells lie in the lattice, so packing succeeds.
    k.pack().unwrap_or(u64::MAX)
}

impl Activity {
    /// A tracker with no history (every cell starts active).
    pub fn new(config: ActivityConfig) -> Self {
        Self {
            config,
            ..Self::default()
        }
    }

    /// Forgets the history (every cell starts active again, as after [`Activity::new`]),
    /// keeping the configuration and the buffers.
    pub fn clear(&mut self) {
        let Self {
            config: _,
            prev_keys,
            prev_start,
            cur_keys,
            cur_start,
            states,
            next,
            events,
            tool_cells,
            touched,
            frozen,
            integrate,
        } = self;
        prev_keys.clear();
        prev_start.clear();
        cur_keys.clear();
        cur_start.clear();
        states.clear();
        next.clear();
        events.clear();
        tool_cells.clear();
        touched.clear();
        frozen.clear();
        integrate.clear();
    }

    /// The configuration.
    pub fn config(&self) -> &ActivityConfig {
        &self.config
    }

    /// Updates every cell of `grid` from this step's input and decides which sections are frozen.
    ///
    /// Rules, per non-empty cell: it is *quiet* when no section entered or left it, every
    /// section in it moves at most `speed_threshold`, and no tool touches it. An active cell that
    /// has been quiet for `dormant_after` seconds goes dormant. A dormant cell wakes (quiet time
    /// reset) when it is not quiet, or when a section in it feels more than `wake_force` from an
    /// active neighbour. A new cell starts active. A section is frozen when every cell it covers
    /// is dormant, so a moving section is never frozen.
    ///
    /// # Errors
    /// [`GridError::LengthMismatch`] for per-section slices of the wrong length,
    /// [`GridError::InvalidConfig`] for a bad `dt` or threshold, and the errors of
    /// [`Grid::cells_touched_by`] for a bad tool.
    pub fn update(&mut self, grid: &Grid, input: &ActivityInput<'_>) -> Result<(), GridError> {
        let n = grid.len();
        self.config.validate(input.dt)?;
        if input.speeds.len() != n {
            return Err(GridError::LengthMismatch {
                what: "ActivityInput::speeds",
                expected: n,
                found: input.speeds.len(),
            });
        }
        if !input.neighbour_forces.is_empty() && input.neighbour_forces.len() != n {
            return Err(GridError::LengthMismatch {
                what: "ActivityInput::neighbour_forces",
                expected: n,
                found: input.neighbour_forces.len(),
            });
        }
        // Tool cells.
        self.tool_cells.clear();
        for tool in input.tools {
            grid.cells_touched_by(tool, &mut self.touched)?;
            self.tool_cells
                .extend(self.touched.iter().map(|&k| packed(k)));
        }
        for &i in input.touched_sections {
            if i as usize >= n {
                return Err(GridError::UnknownSection {
                    what: "ActivityInput::touched_sections",
                    index: i,
                    sections: n,
                });
            }
            let keys = grid.item_keys(i as usize);
            self.tool_cells.extend_from_slice(keys);
        }
        self.tool_cells.sort_unstable();
        self.tool_cells.dedup();

        // Current cells of every section, packed keys ascending.
        self.cur_keys.clear();
        self.cur_start.clear();
        self.cur_start.push(0);
        for i in 0..n {
            self.cur_keys.extend_from_slice(grid.item_keys(i));
            self.cur_start.push(self.cur_keys.len() as u32);
        }
        let same_sections = self.prev_start.len() == n + 1;

        // Entering and leaving events.
        self.events.clear();
        for i in 0..n {
            let cur = &self.cur_keys[self.cur_start[i] as usize..self.cur_start[i + 1] as usize];
            let prev: &[u64] = if same_sections {
                &self.prev_keys[self.prev_start[i] as usize..self.prev_start[i + 1] as usize]
            } else {
                &[]
            };
            let (mut p, mut q) = (0, 0);
            while p < prev.len() || q < cur.len() {
                if q == cur.len() || (p < prev.len() && prev[p] < cur[q]) {
                    self.events.push((prev[p], false));
                    p += 1;
                } else if p == prev.len() || cur[q] < prev[p] {
                    self.events.push((cur[q], true));
                    q += 1;
                } else {
                    p += 1;
                    q += 1;
                }
            }
        }
        self.events.sort_unstable();

        // New state of every non-empty cell, in key order (merging with the old states).
        self.next.clear();
        let (mut e, mut s, mut t) = (0usize, 0usize, 0usize);
        for (key, items) in grid.cells() {
            let k = packed(key);
            let (mut entering, mut leaving) = (0u32, 0u32);
            while e < self.events.len() && self.events[e].0 < k {
                e += 1;
            }
            while e < self.events.len() && self.events[e].0 == k {
                if self.events[e].1 {
                    entering += 1;
                } else {
                    leaving += 1;
                }
                e += 1;
            }
            while t < self.tool_cells.len() && self.tool_cells[t] < k {
                t += 1;
            }
            let tool = t < self.tool_cells.len() && self.tool_cells[t] == k;
            while s < self.states.len() && packed(self.states[s].key) < k {
                s += 1;
            }
            let old = (s < self.states.len() && self.states[s].key == key).then(|| self.states[s]);
            let mut max_speed: Real = 0.0;
            let mut max_force: Real = 0.0;
            let mut nan = false;
            for &i in items {
                let i = i as usize;
                let v = input.speeds[i];
                nan |= v.is_nan();
                max_speed = max_speed.max(v);
                if let Some(&f) = input.neighbour_forces.get(i) {
                    nan |= f.is_nan();
                    max_force = max_force.max(f);
                }
            }
            // A NaN speed or force counts as activity.
            let moving = nan || max_speed > self.config.speed_threshold;
            let pulled = nan || max_force > self.config.wake_force;
            let quiet = entering == 0 && leaving == 0 && !moving && !tool;
            let (state, quiet_for) = match old {
                None => (CellState::Active, 0.0),
                Some(o) => match o.state {
                    CellState::Dormant if quiet && !pulled => (CellState::Dormant, o.quiet_for),
                    CellState::Dormant => (CellState::Active, 0.0),
                    CellState::Active if quiet => {
                        let q = o.quiet_for + input.dt;
                        if q >= self.config.dormant_after {
                            (CellState::Dormant, q)
                        } else {
                            (CellState::Active, q)
                        }
                    }
                    CellState::Active => (CellState::Active, 0.0),
                },
            };
            self.next.push(CellActivity {
                key,
                state,
                quiet_for,
                entering,
                leaving,
                max_speed,
            });
        }
        std::mem::swap(&mut self.states, &mut self.next);

        // Frozen sections and skeletons to integrate.
        self.frozen.clear();
        self.frozen.resize(n, true);
        for (c, st) in self.states.iter().enumerate() {
            if st.state == CellState::Active {
                for &i in grid.cell_sections_at(c) {
                    self.frozen[i as usize] = false;
                }
            }
        }
        self.integrate.clear();
        self.integrate.extend(
            (0..n)
                .filter(|&i| !self.frozen[i])
                .map(|i| grid.pbox(i).skeleton),
        );
        self.integrate.sort_unstable();
        self.integrate.dedup();

        std::mem::swap(&mut self.prev_keys, &mut self.cur_keys);
        std::mem::swap(&mut self.prev_start, &mut self.cur_start);
        Ok(())
    }

    /// Activity of every non-empty cell after the last update, in increasing key order.
    pub fn cells(&self) -> &[CellActivity] {
        &self.states
    }

    /// State of cell `key` (`None` when it held no section at the last update).
    pub fn cell_state(&self, key: CellKey) -> Option<CellState> {
        self.states
            .binary_search_by(|c| c.key.cmp(&key))
            .ok()
            .map(|i| self.states[i].state)
    }

    /// Per section (by index in the grid): whether it is frozen this step.
    pub fn frozen(&self) -> &[bool] {
        &self.frozen
    }

    /// Skeleton ids with at least one section not frozen, ascending: the ones to integrate.
    pub fn skeletons_to_integrate(&self) -> &[u32] {
        &self.integrate
    }

    /// Number of active and dormant cells.
    pub fn counts(&self) -> (usize, usize) {
        let dormant = self
            .states
            .iter()
            .filter(|c| c.state == CellState::Dormant)
            .count();
        (self.states.len() - dormant, dormant)
    }
}
