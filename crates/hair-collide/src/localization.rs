//! Simulation localization (Ward, Galoppo & Lin §4.3): sections whose every cell has been quiet
//! freeze, and skeletons with no active section are not integrated.
//!
//! The cells matter because hair in one cell can collide: a section moving through a cell must
//! wake the hair resting there. With no hair-hair interaction nothing passes between strands
//! through a cell, and waking a cell's every section for one strand moving in it keeps combed,
//! overlapping hair awake around a few moving strands. [`Localization::uncoupled`] then lets
//! each section go dormant on its own quiet (its motion and the tools).

use crate::{CollideError, HairHairModel, Sections};
use hair_dynamics::{SkeletonId, StrandState};
use hair_grid::{Activity, ActivityConfig, ActivityInput, Grid};
use hair_ssv::{Point, Real};

/// The localization stage with its state between steps (cell activity, the positions at the end
/// of the last step) and scratch buffers.
#[derive(Clone, Debug)]
pub struct Localization {
    activity: Activity,
    speeds: Vec<Real>,
    /// Node positions at the previous update (motion is measured by them).
    previous_positions: Vec<Point>,
    /// Sections a tool touched over the last step, and per node whether it is the end of one.
    touched: Vec<u32>,
    node_touched: Vec<bool>,
    frozen_skeleton: Vec<bool>,
    /// Whether sections wake each other through their cells (hair-hair interaction on).
    coupled: bool,
    /// Uncoupled: per node, seconds quiet as the end of a section (this update's and the
    /// last's: 0 for a node that ended no section then), and per section whether frozen.
    node_quiet: Vec<Real>,
    last_quiet: Vec<Real>,
    section_frozen: Vec<bool>,
}

impl Default for Localization {
    fn default() -> Self {
        Self::new(ActivityConfig::default())
    }
}

impl Localization {
    /// A stage with the grid's activity thresholds.
    pub fn new(config: ActivityConfig) -> Self {
        Self {
            activity: Activity::new(config),
            speeds: Vec::new(),
            previous_positions: Vec::new(),
            touched: Vec::new(),
            node_touched: Vec::new(),
            frozen_skeleton: Vec::new(),
            coupled: true,
            node_quiet: Vec::new(),
            last_quiet: Vec::new(),
            section_frozen: Vec::new(),
        }
    }

    /// The stage a hair-hair model calls for: cells coupling their sections when strands
    /// interact, [`Localization::uncoupled`] under [`HairHairModel::Off`].
    pub fn for_model(model: &HairHairModel) -> Self {
        match model {
            HairHairModel::Off => Self::uncoupled(ActivityConfig::default()),
            HairHairModel::Volume(_) | HairHairModel::Pairs => Self::default(),
        }
    }

    /// A stage for hair with no hair-hair interaction: a section freezes once it has been quiet
    /// (no faster than the speed threshold, untouched by any tool) for `dormant_after`,
    /// whatever moves in its cells. The cells' activity is not tracked.
    pub fn uncoupled(config: ActivityConfig) -> Self {
        Self {
            coupled: false,
            ..Self::new(config)
        }
    }

    /// Forgets all activity and motion: every skeleton counts as moving again.
    pub fn clear(&mut self) {
        self.activity.clear();
        self.frozen_skeleton.clear();
        self.previous_positions.clear();
        self.node_quiet.clear();
    }

    /// Per skeleton (all `skeletons` of the state): frozen by the last update. Empty before the
    /// first update.
    pub fn frozen(&self) -> &[bool] {
        &self.frozen_skeleton
    }

    /// Updates the cells' activity from how far each section of `sections` (in `grid`, rebuilt
    /// over them) moved since the last update, with the sections a tool acted on over the last
    /// step (`touched`: their end nodes, state node indices) waking their cells; then freezes
    /// the skeletons of `front` with no active section (their rates zeroed, so that they wake
    /// with no motion) and activates the others.
    pub fn update(
        &mut self,
        state: &mut StrandState,
        grid: &Grid,
        sections: &Sections,
        front: &[u32],
        dt: Real,
        touched: &[u32],
    ) -> Result<(), CollideError> {
        // Motion is measured by how far nodes moved over the last step, not by their
        // velocity: a node resting on the body keeps a velocity into it that the push-out
        // cancels every step, and hair lying still must not count as moving.
        self.speeds.clear();
        let p = state.positions();
        if self.previous_positions.len() == p.len() {
            let (before, inv_dt) = (&self.previous_positions, 1.0 / dt);
            self.speeds.extend(sections.nodes.iter().map(|&i| {
                let i = i as usize;
                (p[i] - before[i])
                    .norm()
                    .max((p[i - 1] - before[i - 1]).norm())
                    * inv_dt
            }));
        } else {
            let v = state.velocities();
            self.speeds.extend(
                sections
                    .nodes
                    .iter()
                    .map(|&i| v[i as usize].norm().max(v[i as usize - 1].norm())),
            );
        }
        // A tool wakes the hair it acted on, not every cell its volume's cover holds: a wide
        // cone over one side must leave the other side dormant. Nodes, unlike section indices,
        // keep their numbers through a cut.
        self.node_touched.clear();
        self.node_touched.resize(state.node_count(), false);
        for &node in touched {
            if let Some(t) = self.node_touched.get_mut(node as usize) {
                *t = true;
            }
        }
        self.touched.clear();
        let ends = sections.nodes.iter().enumerate();
        let hit = ends.filter(|(_, e)| self.node_touched[**e as usize]);
        self.touched.extend(hit.map(|(i, _)| i as u32));
        let frozen_sections = if self.coupled {
            self.activity.update(
                grid,
                &ActivityInput {
                    dt,
                    speeds: &self.speeds,
                    neighbour_forces: &[],
                    tools: &[],
                    touched_sections: &self.touched,
                },
            )?;
            self.activity.frozen()
        } else {
            self.quiet_sections(sections, dt)?;
            &self.section_frozen
        };
        self.frozen_skeleton.clear();
        self.frozen_skeleton.resize(state.skeleton_count(), true);
        for (sec, frozen) in frozen_sections.iter().enumerate() {
            if !frozen {
                self.frozen_skeleton[sections.sections[sec].skeleton as usize] = false;
            }
        }
        for &node in front {
            let id = SkeletonId(node);
            let active = !self.frozen_skeleton[node as usize];
            if !active && state.is_active(id) {
                // Frozen at rest: it wakes with no motion, not with the velocity into the
                // body it had while resting there.
                let r = state.nodes(id);
                state.omega_theta_mut()[r.clone()].fill(0.0);
                state.omega_phi_mut()[r].fill(0.0);
                state.refresh_positions(id);
            }
            state.set_active(id, active);
        }
        // Recorded here, not at the end of the step: nothing moves between the end of one step
        // and the next update, so motion measured from there would always be zero.
        self.previous_positions.clear();
        self.previous_positions.extend_from_slice(state.positions());
        Ok(())
    }

    /// The uncoupled rule: each section's quiet time (kept by its end node, which a cut does
    /// not renumber) from its own speed and the tools, and whether it is frozen.
    fn quiet_sections(&mut self, sections: &Sections, dt: Real) -> Result<(), CollideError> {
        let config = self.activity.config();
        config.validate(dt)?;
        let (after, threshold) = (config.dormant_after, config.speed_threshold);
        std::mem::swap(&mut self.node_quiet, &mut self.last_quiet);
        self.node_quiet.clear();
        self.node_quiet.resize(self.node_touched.len(), 0.0);
        self.section_frozen.clear();
        for (&end, &speed) in sections.nodes.iter().zip(&self.speeds) {
            let e = end as usize;
            // A NaN speed counts as motion.
            let quiet = if self.node_touched[e] || speed.is_nan() || speed > threshold {
                0.0
            } else {
                self.last_quiet.get(e).copied().unwrap_or(0.0) + dt
            };
            self.node_quiet[e] = quiet;
            self.section_frozen.push(quiet >= after);
        }
        Ok(())
    }
}
