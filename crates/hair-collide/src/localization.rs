//! Simulation localization (Ward, Galoppo & Lin §4.3): sections whose every cell has been quiet
//! freeze, and skeletons with no active section are not integrated.

use crate::{CollideError, Sections};
use hair_dynamics::{SkeletonId, StrandState};
use hair_grid::{Activity, ActivityConfig, ActivityInput, Grid, InfluenceVolume};
use hair_ssv::{Point, Real};

/// The localization stage with its state between steps (cell activity, the positions at the end
/// of the last step) and scratch buffers.
#[derive(Clone, Debug)]
pub struct Localization {
    activity: Activity,
    speeds: Vec<Real>,
    /// Node positions at the previous update (motion is measured by them).
    previous_positions: Vec<Point>,
    /// Sections the tools touch this step, and one tool's sections.
    touched: Vec<u32>,
    touched_by_one: Vec<u32>,
    frozen_skeleton: Vec<bool>,
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
            touched_by_one: Vec::new(),
            frozen_skeleton: Vec::new(),
        }
    }

    /// Forgets all activity and motion: every skeleton counts as moving again.
    pub fn clear(&mut self) {
        self.activity.clear();
        self.frozen_skeleton.clear();
        self.previous_positions.clear();
    }

    /// Per skeleton (all `skeletons` of the state): frozen by the last update. Empty before the
    /// first update.
    pub fn frozen(&self) -> &[bool] {
        &self.frozen_skeleton
    }

    /// Updates the cells' activity from how far each section of `sections` (in `grid`, rebuilt
    /// over them) moved since the last update, with the sections the pressed tools touch
    /// waking their cells; then freezes the skeletons of `front` with no active section (their rates zeroed,
    /// so that they wake with no motion) and activates the others.
    pub fn update(
        &mut self,
        state: &mut StrandState,
        grid: &Grid,
        sections: &Sections,
        front: &[u32],
        dt: Real,
        tools: &[InfluenceVolume],
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
        // A tool wakes the hair it reaches, not every cell its volume's cover holds: a wide
        // cone over one side must leave the other side dormant.
        self.touched.clear();
        for tool in tools {
            grid.sections_in(tool, &mut self.touched_by_one)?;
            self.touched.extend_from_slice(&self.touched_by_one);
        }
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
        self.frozen_skeleton.clear();
        self.frozen_skeleton.resize(state.skeleton_count(), true);
        for (sec, frozen) in self.activity.frozen().iter().enumerate() {
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
}
