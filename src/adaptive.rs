//! The `adaptive` LOD policy inside the pipeline (Ward & Lin §6): each step the hierarchy's
//! active front is re-selected from what the camera sees and how fast the hair moves, and the
//! transitions carry the motion between levels.
//!
//! Every hierarchy node is a skeleton of the simulation's [`StrandState`] all the time; only the
//! front is integrated. Before selecting, the front's motion is read into a [`LodState`]
//! (deviations from rest, so a coarse node and its children share one description); after the
//! transitions, every node that became active gets its motion written back from it. Hair hidden
//! from the camera (outside the view, or behind the head) for [`HIDDEN_AFTER`] steps asks for the
//! coarsest level and, when all of a tree's hair is hidden, the tree collapses to its root strip.
//! Speeds are held against a decay ([`SPEED_HOLD`]) and merges need a margin
//! ([`hair_lod::MERGE_MARGIN`]): hysteresis, so that the front does not flicker.

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
    /// Per node: consecutive steps it has been active and out of sight.
    unseen_for: Vec<u32>,
    /// Per node: the speed it is judged by, its own held against a decay ([`SPEED_HOLD`]).
    held_speed: Vec<Real>,
    last: TransitionReport,
}

/// Steps an active node must stay out of sight before it counts as hidden (asks for the
/// coarsest level, and, with the rest of its tree, lets the tree collapse to its root strip).
/// Hair at the edge of sight goes in and out of it from one step to the next, and a node and
/// its parent are seen differently there (their points differ by up to the merge distance): on
/// the `wardlin` scene, judging each step afresh merged about 60 nodes or collapsed about 60
/// trees on one step and split or restored them on the next, every step, each time carrying the
/// motion across levels (a visible pop, and the work of the transitions). Seen counts at once.
pub const HIDDEN_AFTER: u32 = 15;

/// Fraction of its held speed a node keeps per step when it moves slower (a half-life of about
/// seven steps). Hair fluttering in gusty wind reaches a speed on one step and a third of it a
/// few steps later; judged by the speed of the moment, it split when fast and merged as soon as it
/// slowed. Judged by the held speed, hair gets detail as soon as it is fast and gives it up once
/// it has been slow for a while. (With this, [`HIDDEN_AFTER`] and [`hair_lod::MERGE_MARGIN`], the
/// 240 frames of `hair run zoom` made 8,559 splits and merges instead of 15,329 while hair-hair
/// pushes were summed; with their mean, the default, the hair settles and they make 763.)
pub const SPEED_HOLD: Real = 0.9;

impl AdaptiveLod {
    /// Becomes a copy of `initial`, keeping the plan's lists: the plan is refilled every step,
    /// and its lists keep the room they grew to, so the steps after a reset take no memory
    /// (every other buffer is sized by the hierarchy and comes back at full size).
    pub(crate) fn reset_to(&mut self, initial: &Self) {
        let plan = std::mem::take(&mut self.plan);
        *self = initial.clone();
        self.plan = plan;
    }

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
            unseen_for: vec![0; n],
            held_speed: vec![0.0; n],
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
                let now = velocities[r].iter().map(|v| v.norm()).fold(0.0, Real::max);
                let held = &mut self.held_speed[n];
                *held = now.max(*held * SPEED_HOLD);
                *held
            } else {
                0.0
            };
            self.activity[n] = if frozen.get(n).copied().unwrap_or(false) {
                LodActivity::Dormant
            } else {
                LodActivity::Moving
            };
        }
        if self.cull_hidden {
            for n in 0..h.node_count() {
                if self.front.is_active(n as u32) {
                    let unseen = &mut self.unseen_for[n];
                    *unseen = if self.visible[n] {
                        0
                    } else {
                        unseen.saturating_add(1)
                    };
                    self.visible[n] = *unseen < HIDDEN_AFTER;
                }
            }
            // An expanded tree is seen while any of its active nodes is (its root's own point,
            // on the scalp, is often behind the head while the hair hanging from it is in view).
            for t in 0..h.tree_count() as u32 {
                let root = h.tree_root(t);
                if !self.front.is_active(root) {
                    self.visible[root as usize] = h
                        .tree_nodes(t)
                        .any(|n| self.front.is_active(n) && self.visible[n as usize]);
                }
            }
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
        // The nodes that became active start out seen, but for a merged parent, which is as
        // unseen as the least unseen of its children, and a collapsed root strip, which is
        // hidden until it is seen. A merged parent holds the highest speed its children held; a
        // node split from its parent, or restored below it, the parent's.
        for n in 0..h.node_count() as u32 {
            let i = n as usize;
            if !self.front.is_active(n) || self.was_active[i] {
                continue;
            }
            let merged = h
                .children(n)
                .filter(|&c| self.was_active[c as usize])
                .map(|c| (self.unseen_for[c as usize], self.held_speed[c as usize]))
                .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)));
            let (unseen, held) = match merged {
                Some(m) => m,
                None => (0, h.parent(n).map_or(0.0, |p| self.held_speed[p as usize])),
            };
            self.unseen_for[i] = if self.front.is_hidden(h.tree_of(n)) {
                HIDDEN_AFTER
            } else {
                unseen
            };
            self.held_speed[i] = held;
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
