//! The `adaptive` LOD policy inside the pipeline (Ward & Lin §6): each step the hierarchy's
//! active front is re-selected from what the camera sees and how fast the hair moves, and the
//! transitions carry the motion between levels.
//!
//! Every hierarchy node is a skeleton of the simulation's [`StrandState`] all the time; only the
//! front is integrated. Before selecting, the front's motion is read into a [`LodState`]
//! (deviations from rest, so a coarse node and its children share one description); after the
//! transitions, every node that became active gets its motion written back from it. Hair hidden
//! from the camera (outside the view, or behind the head) asks for the coarsest level and, when a
//! whole root strip is hidden, collapses to it.

use crate::HairError;
use crate::scene::AdaptiveSpec;
use hair_dynamics::{SkeletonId, StrandState};
use hair_lod::{
    Activity as LodActivity, Front, Hierarchy, LodState, MergeParams, NodeInputs, Plan,
    SelectParams, TransitionReport,
};
use hair_ssv::{Point, Real, Vector};

/// What the camera sees, in the head frame.
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// Eye (m).
    pub eye: Point,
    /// Unit direction the camera looks along.
    pub forward: Vector,
    /// Cosine of the half-angle of the cone that holds the whole image.
    pub cos_half_angle: Real,
    /// An ellipsoid inside the head (centre, semi-axes) that hides what lies behind it.
    pub occluder: Option<(Point, Vector)>,
}

impl View {
    /// Whether `p` is inside the view cone and not behind the occluder.
    pub fn sees(&self, p: &Point) -> bool {
        let d = p - self.eye;
        let len = d.norm();
        if len <= 1e-9 {
            return true;
        }
        if d.dot(&self.forward) < self.cos_half_angle * len {
            return false;
        }
        let Some((c, axes)) = self.occluder else {
            return true;
        };
        // In coordinates where the ellipsoid is the unit sphere: does the segment eye -> p
        // cross it before reaching p?
        let o = (self.eye - c).component_div(&axes);
        let e = (p - self.eye).component_div(&axes);
        let a = e.norm_squared();
        let b = o.dot(&e);
        let cc = o.norm_squared() - 1.0;
        let disc = b * b - a * cc;
        if disc <= 0.0 || a <= 0.0 {
            return true;
        }
        let t = (-b - disc.sqrt()) / a;
        !(t > 0.0 && t < 1.0)
    }
}

/// The adaptive front and the motion that travels between its levels.
#[derive(Clone, Debug)]
pub struct AdaptiveLod {
    front: Front,
    lod: LodState,
    plan: Plan,
    select: SelectParams,
    merge: MergeParams,
    cull_hidden: bool,
    visible: Vec<bool>,
    distance: Vec<Real>,
    speed: Vec<Real>,
    activity: Vec<LodActivity>,
    was_active: Vec<bool>,
    last: TransitionReport,
}

impl AdaptiveLod {
    /// Starts at the coarsest front (every root strip).
    pub fn new(h: &Hierarchy, spec: &AdaptiveSpec) -> Result<Self, HairError> {
        let select = SelectParams {
            distance_finest: spec.distance_finest,
            distance_coarsest: spec.distance_coarsest,
            speed_coarsest: spec.speed_coarsest,
            speed_finest: spec.speed_finest,
        };
        let merge = MergeParams {
            merge_distance: spec.merge_distance,
            ..MergeParams::default()
        };
        let n = h.node_count();
        let front = Front::coarsest(h);
        let was_active = (0..n as u32).map(|v| front.is_active(v)).collect();
        Ok(Self {
            front,
            lod: LodState::new(h),
            plan: Plan::default(),
            select,
            merge,
            cull_hidden: spec.cull_hidden,
            visible: vec![true; n],
            distance: vec![0.0; n],
            speed: vec![0.0; n],
            activity: vec![LodActivity::Moving; n],
            was_active,
            last: TransitionReport::default(),
        })
    }

    /// The current front.
    pub fn front(&self) -> &Front {
        &self.front
    }

    /// What the last update did.
    pub fn last_report(&self) -> TransitionReport {
        self.last
    }

    /// The carried per-node state (water, stiffness and the other inherited properties).
    pub fn lod_state(&self) -> &LodState {
        &self.lod
    }

    /// Whether the tree of `node` is collapsed because the camera cannot see it.
    pub fn is_hidden(&self, h: &Hierarchy, node: u32) -> bool {
        self.front.is_hidden(h.tree_of(node))
    }

    /// One LOD stage: reads the front's motion, selects, transitions, writes the motion of every
    /// node that became active and updates the state's active flags. `frozen` marks skeletons
    /// localization froze last step (empty for none). Returns whether the front changed.
    pub fn update(
        &mut self,
        h: &Hierarchy,
        state: &mut StrandState,
        view: &View,
        frozen: &[bool],
    ) -> Result<bool, HairError> {
        for n in 0..h.node_count() as u32 {
            if self.front.is_active(n) {
                self.lod.read_motion(h, n, state, SkeletonId(n))?;
            }
        }
        let positions = state.positions();
        let velocities = state.velocities();
        for n in 0..h.node_count() {
            let id = SkeletonId(n as u32);
            let r = state.nodes(id);
            // Active nodes are judged by where they are; the others by their root, which
            // does not move in the head frame (their stored points are stale).
            let pts = if self.front.is_active(n as u32) {
                &positions[r.clone()]
            } else {
                &positions[r.start..r.start + 1]
            };
            self.distance[n] = pts
                .iter()
                .map(|p| (p - view.eye).norm())
                .fold(Real::INFINITY, Real::min);
            self.visible[n] = !self.cull_hidden || pts.iter().any(|p| view.sees(p));
            self.speed[n] = if self.front.is_active(n as u32) {
                velocities[r].iter().map(|v| v.norm()).fold(0.0, Real::max)
            } else {
                0.0
            };
            self.activity[n] = if frozen.get(n).copied().unwrap_or(false) {
                LodActivity::Dormant
            } else {
                LodActivity::Moving
            };
        }
        let inputs = NodeInputs {
            visible: &self.visible,
            distance: &self.distance,
            speed: &self.speed,
            activity: &self.activity,
        };
        hair_lod::select_into(h, &self.front, &inputs, &self.select, &mut self.plan)?;
        self.last = hair_lod::apply(h, &mut self.front, &mut self.lod, &self.plan, &self.merge)?;
        // Children pulled toward their parent's average (not merged yet) carry the pull.
        for i in 0..self.plan.merges.len() {
            let p = self.plan.merges[i];
            if self.front.is_active(p) {
                continue;
            }
            for c in h.children(p) {
                if self.front.is_active(c) && self.was_active[c as usize] {
                    self.lod.write_motion(h, c, state, SkeletonId(c))?;
                }
            }
        }
        let mut changed = false;
        for n in 0..h.node_count() {
            let now = self.front.is_active(n as u32);
            if now != self.was_active[n] {
                changed = true;
                let id = SkeletonId(n as u32);
                if now {
                    self.lod.write_motion(h, n as u32, state, id)?;
                }
                state.set_active(id, now);
                self.was_active[n] = now;
            }
        }
        Ok(changed)
    }
}
