//! Split and merge: Ward & Lin 2003 §6.2 (adaptive subdivision) and §6.3 (adaptive merging).
//!
//! A split copies the parent's motion (bend away from rest, angular velocities) and styling
//! properties into every child; each child's own rest shape, the parent's plus its stored
//! offsets, places it. A merge needs every child active with the same live control-point count;
//! it measures how far each child's points are from where the merged parent would put them
//! (forward kinematics of the child's rest shape with the children's average motion). Within
//! `snap_distance` the parent takes the strand-weighted average state; within `merge_distance` a
//! spring first pulls each child's motion toward the average, one fraction per step; beyond, the
//! merge waits.

use crate::inherit::{average_up, copy_points, inherit_down, weighted_mean, weighted_mean_into};
use crate::{Front, Hierarchy, LodError, LodState, Plan, Point, Real, Vector};
use hair_dynamics::{Bend, bend_between};
use nalgebra::Matrix3;

/// Thresholds of the merge (Ward & Lin §6.3). SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MergeParams {
    /// Children farther than this from their merged place do not merge (m).
    pub merge_distance: Real,
    /// Children this close merge at once (m); below `merge_distance`.
    pub snap_distance: Real,
    /// Fraction of the way to the average motion the pulling spring moves each child per step,
    /// in (0, 1].
    pub pull_rate: Real,
}

impl Default for MergeParams {
    fn default() -> Self {
        Self {
            merge_distance: 0.02,
            snap_distance: 0.002,
            pull_rate: 0.5,
        }
    }
}

impl MergeParams {
    /// Checks the values and their order.
    pub fn validate(&self) -> Result<(), LodError> {
        crate::error::finite_non_negative("snap_distance", self.snap_distance)?;
        crate::error::finite_positive("merge_distance", self.merge_distance)?;
        crate::error::ordered(
            "snap_distance",
            self.snap_distance,
            "merge_distance",
            self.merge_distance,
        )?;
        if !(self.pull_rate.is_finite() && self.pull_rate > 0.0 && self.pull_rate <= 1.0) {
            return Err(LodError::InvalidParameter {
                name: "pull_rate",
                value: f64::from(self.pull_rate),
                expected: "in (0, 1]",
            });
        }
        Ok(())
    }
}

/// Whether a parent's children can merge now.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MergeCheck {
    /// Within the snap distance: merge.
    Ready {
        /// Largest distance of a child point from its merged place (m).
        gap: Real,
    },
    /// Within the merge distance: pull first.
    Pull {
        /// Largest distance of a child point from its merged place (m).
        gap: Real,
    },
    /// Too far apart: wait.
    TooFar {
        /// Largest distance of a child point from its merged place (m).
        gap: Real,
    },
    /// Children were cut to different lengths: they never merge.
    CountMismatch,
    /// A child is not active (it is split further, or the parent is active).
    NotReady,
}

/// What [`apply`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TransitionReport {
    /// Nodes split.
    pub splits: u32,
    /// Parents merged (including by collapse).
    pub merges: u32,
    /// Parents whose children were pulled toward merging.
    pub pulls: u32,
    /// Merges refused (too far, or counts differ).
    pub refused: u32,
    /// Trees collapsed to their root strip.
    pub collapses: u32,
    /// Trees restored after an occlusion.
    pub restores: u32,
}

/// Splits an active node into its children (Ward & Lin §6.2), which become active.
pub fn split(
    h: &Hierarchy,
    front: &mut Front,
    state: &mut LodState,
    node: u32,
) -> Result<(), LodError> {
    h.check(node)?;
    front.check(h)?;
    state.check(h)?;
    if !front.active[node as usize] {
        return Err(LodError::NotAllowed {
            node,
            reason: "only an active node splits",
        });
    }
    if h.is_leaf(node) {
        return Err(LodError::NotAllowed {
            node,
            reason: "a leaf has no children",
        });
    }
    for c in h.children(node) {
        for field in [
            &mut state.d_theta,
            &mut state.d_phi,
            &mut state.omega_theta,
            &mut state.omega_phi,
        ] {
            copy_points(field, h.control_point_range(node), h.control_point_range(c));
        }
        front.active[c as usize] = true;
    }
    inherit_down(h, state, node);
    front.active[node as usize] = false;
    Ok(())
}

/// Whether the children of `parent` can merge now, and how far they are from it.
pub fn merge_check(
    h: &Hierarchy,
    front: &Front,
    state: &LodState,
    parent: u32,
    params: &MergeParams,
) -> Result<MergeCheck, LodError> {
    h.check(parent)?;
    front.check(h)?;
    state.check(h)?;
    let kids = h.children(parent);
    if kids.is_empty()
        || front.active[parent as usize]
        || kids.clone().any(|c| !front.active[c as usize])
    {
        return Ok(MergeCheck::NotReady);
    }
    let count = state.count[kids.start as usize];
    if kids.clone().any(|c| state.count[c as usize] != count) {
        return Ok(MergeCheck::CountMismatch);
    }
    let gap = merge_gap(h, state, parent);
    Ok(if gap <= params.snap_distance {
        MergeCheck::Ready { gap }
    } else if gap <= params.merge_distance {
        MergeCheck::Pull { gap }
    } else {
        MergeCheck::TooFar { gap }
    })
}

/// Merges the children of `parent` into it now, whatever their distance: the parent takes the
/// strand-weighted average state and properties and the children's bonds. Children must all be
/// active with the same count.
pub fn merge(
    h: &Hierarchy,
    front: &mut Front,
    state: &mut LodState,
    parent: u32,
) -> Result<(), LodError> {
    match merge_check(h, front, state, parent, &MergeParams::default())? {
        MergeCheck::NotReady => Err(LodError::NotAllowed {
            node: parent,
            reason: "every child must be active to merge",
        }),
        MergeCheck::CountMismatch => Err(LodError::NotAllowed {
            node: parent,
            reason: "children with different control-point counts never merge",
        }),
        _ => {
            merge_unchecked(h, front, state, parent);
            Ok(())
        }
    }
}

fn merge_unchecked(h: &Hierarchy, front: &mut Front, state: &mut LodState, parent: u32) {
    for field in [
        &mut state.d_theta,
        &mut state.d_phi,
        &mut state.omega_theta,
        &mut state.omega_phi,
    ] {
        weighted_mean_into(h, field, parent);
    }
    average_up(h, state, parent);
    for c in h.children(parent) {
        front.active[c as usize] = false;
    }
    front.active[parent as usize] = true;
}

/// Merges if the children are within the snap distance, pulls them toward the average if within
/// the merge distance, and otherwise leaves them.
pub fn try_merge(
    h: &Hierarchy,
    front: &mut Front,
    state: &mut LodState,
    parent: u32,
    params: &MergeParams,
) -> Result<MergeCheck, LodError> {
    params.validate()?;
    let check = merge_check(h, front, state, parent, params)?;
    match check {
        MergeCheck::Ready { .. } => merge_unchecked(h, front, state, parent),
        MergeCheck::Pull { .. } => pull(h, state, parent, params.pull_rate),
        _ => {}
    }
    Ok(check)
}

/// Moves each child's motion `rate` of the way toward the children's average (the pulling
/// spring of §6.3).
fn pull(h: &Hierarchy, state: &mut LodState, parent: u32, rate: Real) {
    let n = h.control_points(parent);
    let kids = h.children(parent);
    for field in [
        &mut state.d_theta,
        &mut state.d_phi,
        &mut state.omega_theta,
        &mut state.omega_phi,
    ] {
        for j in 0..n {
            let mean = weighted_mean(h, field, parent, j);
            for c in kids.clone() {
                let x = &mut field[h.control_point_start(c) + j];
                *x += rate * (mean - *x);
            }
        }
    }
}

/// Largest distance of a child's live control point from where the merged parent would put it:
/// the child's rest shape bent by its own motion against the same rest shape bent by the
/// children's average motion.
fn merge_gap(h: &Hierarchy, state: &LodState, parent: u32) -> Real {
    MERGE_SCRATCH.with_borrow_mut(|scratch| merge_gap_with(h, state, parent, scratch))
}

/// Working lists of [`merge_gap`]: the mean deviations and three polylines.
#[derive(Default)]
struct MergeScratch {
    mean_t: Vec<Real>,
    mean_p: Vec<Real>,
    rest: Vec<Point>,
    own: Vec<Point>,
    merged: Vec<Point>,
}

thread_local! {
    /// Kept per thread between calls: the adaptive policy checks merges every step, and the
    /// step loop takes no memory.
    static MERGE_SCRATCH: std::cell::RefCell<MergeScratch> =
        std::cell::RefCell::new(MergeScratch::default());
}

fn merge_gap_with(
    h: &Hierarchy,
    state: &LodState,
    parent: u32,
    scratch: &mut MergeScratch,
) -> Real {
    let n = h.control_points(parent);
    let kids = h.children(parent);
    let mean = |field: &[Real], j: usize| weighted_mean(h, field, parent, j);
    let MergeScratch {
        mean_t,
        mean_p,
        rest,
        own,
        merged,
    } = scratch;
    mean_t.clear();
    mean_t.extend((0..n).map(|j| mean(&state.d_theta, j)));
    mean_p.clear();
    mean_p.extend((0..n).map(|j| mean(&state.d_phi, j)));
    let frame = *h.tree_frame(h.tree_of(parent)).matrix();
    let mut gap: Real = 0.0;
    for c in kids {
        let cs = h.control_point_start(c);
        let live = state.count[c as usize] as usize;
        h.rest_points_into(c, rest);
        let ct = &state.d_theta[cs..cs + n];
        let cp = &state.d_phi[cs..cs + n];
        if ct == &mean_t[..] && cp == &mean_p[..] {
            continue;
        }
        let lengths = &state.length[cs..cs + n];
        bent(&frame, rest, lengths, ct, cp, own);
        bent(&frame, rest, lengths, mean_t, mean_p, merged);
        for (a, b) in own.iter().zip(merged.iter()).take(live) {
            gap = gap.max((a - b).norm());
        }
    }
    gap
}

/// Points of a rest polyline re-bent: rest angles (read off `rest` against `frame`) plus
/// deviations, rest segment lengths times `length`.
fn bent(
    frame: &Matrix3<Real>,
    rest: &[Point],
    length: &[Real],
    d_theta: &[Real],
    d_phi: &[Real],
    out: &mut Vec<Point>,
) {
    out.clear();
    out.push(rest[0]);
    let mut rot_rest = *frame;
    let mut rot = *frame;
    let mut p = rest[0];
    for i in 1..rest.len() {
        let d = rest[i] - rest[i - 1];
        let len = d.norm();
        let (x, y) = if len > 0.0 {
            bend_between(&(rot_rest.transpose() * (d / len)))
        } else {
            (0.0, 0.0)
        };
        rot_rest *= Bend::new(x, y).rotation;
        rot *= Bend::new(x + d_theta[i], y + d_phi[i]).rotation;
        let t: Vector = rot.column(2).into_owned();
        p += t * (len * length[i]);
        out.push(p);
    }
}

/// Carries out a [`Plan`]: collapses (forced merges from the leaves up, as far as counts
/// allow), restores, merges (checked against [`MergeParams`]: merge, pull or wait), then splits.
pub fn apply(
    h: &Hierarchy,
    front: &mut Front,
    state: &mut LodState,
    plan: &Plan,
    params: &MergeParams,
) -> Result<TransitionReport, LodError> {
    params.validate()?;
    front.check(h)?;
    state.check(h)?;
    let mut report = TransitionReport::default();
    for &t in &plan.collapses {
        if t as usize >= h.tree_count() {
            return Err(LodError::Mismatch {
                what: "plan names an unknown tree",
            });
        }
        for p in h.tree_nodes(t).rev() {
            if h.is_leaf(p) {
                continue;
            }
            let kids = h.children(p);
            if kids.clone().all(|c| front.active[c as usize]) {
                let count = state.count[kids.start as usize];
                if kids.clone().all(|c| state.count[c as usize] == count) {
                    merge_unchecked(h, front, state, p);
                    report.merges += 1;
                } else {
                    report.refused += 1;
                }
            }
        }
        front.hidden[t as usize] = true;
        report.collapses += 1;
    }
    for &t in &plan.restores {
        if t as usize >= h.tree_count() {
            return Err(LodError::Mismatch {
                what: "plan names an unknown tree",
            });
        }
        front.hidden[t as usize] = false;
        report.restores += 1;
    }
    for &p in &plan.merges {
        match try_merge(h, front, state, p, params)? {
            MergeCheck::Ready { .. } => report.merges += 1,
            MergeCheck::Pull { .. } => report.pulls += 1,
            MergeCheck::TooFar { .. } | MergeCheck::CountMismatch => report.refused += 1,
            MergeCheck::NotReady => {}
        }
    }
    for &n in &plan.splits {
        if front.active[n as usize] {
            split(h, front, state, n)?;
            report.splits += 1;
        }
    }
    Ok(report)
}
