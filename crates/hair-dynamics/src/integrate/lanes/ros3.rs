//! ROS3 ([`crate::integrate::rosenbrock::ROS3`]) eight strands at a time, in the coupled lane
//! step's `f32x8` lanes.
//!
//! Every stage of a Rosenbrock step solves the coupled step's system with the step `h gamma`
//! and its own right-hand side (`super::super::rosenbrock`), so the matrix is eliminated once,
//! tip to root, and its per-joint factors (the 2 x 2 blocks' inverses, `G_j = M A_j + V_j` and
//! the gains `E_j`) are kept for the two later right-hand sides. A later stage then costs one
//! tip-to-root pass for its right-hand side's offsets and one root-to-tip pass for its unknowns.
//! Each pass that runs one way also does the work of the other stages that runs the same way,
//! so the step is nine passes over the nodes (some in two loops, where one carried more sums
//! than there are registers):
//! 1. root to tip: the kinematics at the start of the step and the prefix sums of `A w`;
//! 2. tip to root: forces, torques, inertia and the Jacobian's generators; the first stage's
//!    right-hand side;
//! 3. tip to root: the elimination, and the first stage's offsets;
//! 4. root to tip: the first stage's unknowns, the second stage's right-hand side `r` and the
//!    prefix sums of `A r`; then the kinematics at the second stage's state;
//! 5. tip to root: the first stage's residual check and the forces and torques at the second
//!    stage's state; then the second stage's offsets;
//! 6. root to tip: the second stage's unknowns and the third's right-hand side;
//! 7. tip to root: the second stage's check; the third stage's offsets;
//! 8. root to tip: the third stage's unknowns, the new state and its error estimate; then the
//!    end-of-step positions and velocities;
//! 9. tip to root: the third stage's check.
//!
//! The arithmetic of each stage is the scalar step's, in the same order where the order changes
//! the rounding of a sum of stages.
//!
//! The guard (`rosenbrock::advance`) runs in the lanes too: where a lane's embedded estimate is
//! over the tolerance, the group is stepped again from the start of the step in two pieces, then
//! in four, and only the lanes that needed it take the result; the other lanes keep theirs (the
//! same pieces and the same acceptance rule as the scalar guard, so the scalar guarded step's
//! results to `f32` rounding). A lane whose check fails or whose state goes non-finite, and one
//! that four pieces do not bring within the tolerance, is left untouched and redone by the scalar
//! ROS3 step, its guard starting at the pieces the lanes had reached (from four, it falls back to
//! the coupled step in four pieces).

use super::{
    Check, GroupFields, GroupLanes, Joint, L, LANES, LaneOutcome, LaneScratch, Loads, M3, TipSums,
    V3, eliminate, end_length, first_pass, link, nan_unless_finite, not_finite, prefetch_outputs,
    publish_nodes, root_frames, unknowns,
};
use crate::Vector;
use crate::integrate::rosenbrock::ROS3;
use crate::integrate::{Shared, StepSettings, TorqueModel};
use crate::run::Run;

/// What the ROS3 lane step keeps of joint `j` between its passes, beyond what the coupled step
/// keeps ([`Joint`]: there `b`, `offset`, `prefix` are the stage in hand's right-hand side, its
/// offsets and the prefix sum `sum_{k<j} A_k r_k` of its angle half `r`, and `x`, `left` the last
/// stage's unknowns and check terms).
#[derive(Clone, Copy, Default)]
pub(super) struct StageJoint {
    joint: Joint,
    /// Joint axes at the second stage's state (its torques').
    a_stage: [V3; 2],
    /// The elimination's factors, which every stage reuses: the 2 x 2 block's inverse and the
    /// rows of `G_j = M A_j + V_j` (the gain `E_j` is the joint's).
    inverse: [[L; 2]; 2],
    g: [V3; 2],
    /// The diagonal inertia.
    inertia: L,
    /// The stage in hand's angle half `r`. (Its velocity half, the torque's shift `I r_w`, is
    /// worked out from the unknowns where it is needed.)
    r: [L; 2],
    /// The first two stages' unknowns, angle and rate halves (`U_i`).
    uq: [[L; 2]; 2],
    uw: [[L; 2]; 2],
    /// The second stage's rates and torques (the third stage reuses them).
    w_stage: [L; 2],
    tau_stage: [L; 2],
}

impl std::ops::Deref for StageJoint {
    type Target = Joint;
    #[inline(always)]
    fn deref(&self) -> &Joint {
        &self.joint
    }
}

impl super::HasJoint for StageJoint {
    #[inline(always)]
    fn joint_mut(&mut self) -> &mut Joint {
        &mut self.joint
    }
}

impl std::ops::DerefMut for StageJoint {
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut Joint {
        &mut self.joint
    }
}

/// Zero in every lane, as a mask: no lane.
#[inline(always)]
fn none() -> L {
    L::ZERO.simd_ne(L::ZERO)
}

/// The elimination's offsets of a right-hand side `b` at joint `joint`, from the tip's affine
/// term `gain_r`, which they then move one joint up (`structured_solve_again`).
#[inline(always)]
fn offsets(joint: &mut StageJoint, b: [L; 2], gain_r: &mut V3, h2: L) {
    let a = joint.a;
    let rr = [b[0] + h2 * a[0].dot(*gain_r), b[1] + h2 * a[1].dot(*gain_r)];
    let inv = joint.inverse;
    let offset = [
        inv[0][0] * rr[0] + inv[0][1] * rr[1],
        inv[1][0] * rr[0] + inv[1][1] * rr[1],
    ];
    *gain_r = *gain_r + joint.g[0] * offset[0] + joint.g[1] * offset[1];
    joint.b = b;
    joint.offset = offset;
}

/// A later stage's right-hand side at joint `joint` (node `node`): the torque `tau(Y_1)` shifted
/// by `I r_w`, and the Jacobian's and springs' terms on the angle half `r`, whose column sums
/// `suffix_r` carries from the tip.
#[inline(always)]
fn stage_rhs(
    joint: &StageJoint,
    node: &super::NodeIn,
    r_w: [L; 2],
    suffix_r: V3,
    hg: L,
    hg2: L,
) -> [L; 2] {
    let r = joint.r;
    let k = [node.k_theta, node.k_phi];
    let mut b = [L::ZERO; 2];
    for t in 0..2 {
        let jw = joint.wg[t].dot(joint.prefix) + joint.a[t].dot(suffix_r);
        b[t] = hg * (joint.tau_stage[t] + joint.inertia * r_w[t]) + hg2 * (jw - k[t] * r[t]);
    }
    b
}

/// What a piece's lanes came to: the lanes whose residual checks failed, whose new state is not
/// finite, and whose embedded estimate is over the guard's tolerance.
struct PieceChecks {
    failed: L,
    bad: L,
    too_far: L,
}

/// What every piece of a group's step reads and does not change.
struct Piece<'a> {
    loads: Loads<'a>,
    root: (V3, M3),
    chain: bool,
    has_air: bool,
    n: usize,
}

/// The lanes whose bit is set in `bits`, as a mask.
#[inline(always)]
fn mask_of(bits: u32) -> L {
    let mut lanes = [0.0; LANES];
    for (l, lane) in lanes.iter_mut().enumerate() {
        if bits & (1 << l) != 0 {
            *lane = 1.0;
        }
    }
    L::from(lanes).simd_gt(L::ZERO)
}

/// Advances the strands `members` (as [`super::step_group`]) by one ROS3 step under its guard
/// (`rosenbrock::advance`): the whole step, then, for the lanes whose estimate is over the
/// tolerance, the step again in two pieces, then in four; the lanes already trusted keep their
/// result. Each lane's outcome comes with the pieces the scalar guard starts from where the
/// scalar step redoes it: a lane whose check fails or whose state goes non-finite in the pieces
/// of a split, and one that four pieces do not bring within the tolerance (which the scalar
/// guard then takes as the coupled step in four pieces).
pub(super) fn step_group_in(
    run: &mut Run<'_>,
    sh: &Shared<'_>,
    members: &[usize],
    n: usize,
    ls: &mut LaneScratch,
) -> [(LaneOutcome, u32); LANES] {
    let settings: &StepSettings = &sh.settings;
    let at = GroupLanes::new(run, sh, members);
    let (local, in_run) = (&at.local, &at.in_run);
    let fields = GroupFields::new(run, sh, &at, n);
    prefetch_outputs(run, in_run, members.len(), n);
    let piece = Piece {
        loads: Loads::new(sh),
        root: root_frames(run, local),
        chain: settings.torque == TorqueModel::Chain,
        has_air: sh.lane_air.is_some(),
        n,
    };
    fields.gather_state(&mut ls.nodes[..n]);
    first_pass(
        &ls.nodes,
        &mut ls.stages,
        &mut ls.pos,
        &mut ls.vel,
        &mut ls.tangent,
        piece.root,
        piece.has_air,
        n,
    );
    fields.gather_params(&mut ls.nodes[..n]);
    let checks = rest_of_piece(ls, &piece, settings.dt, true, none());
    let mut outcome = [(LaneOutcome::Done, 1); LANES];
    let open = decide(&mut outcome, (1 << LANES) - 1, &checks, 1);
    if open != 0 {
        split(ls, &piece, settings.dt, open, &mut outcome);
    }
    let done: [bool; LANES] = std::array::from_fn(|l| {
        l < members.len() && matches!(outcome[l].0, LaneOutcome::Done | LaneOutcome::Split)
    });
    for l in (0..LANES).filter(|&l| done[l]) {
        let base = in_run[l];
        run.positions[base] = run.roots[local[l]].position;
        run.velocities[base] = Vector::zeros();
        run.roots[local[l]].history = 0;
    }
    publish_nodes(run, &ls.out, &done, in_run, n);
    outcome
}

/// The outcomes of the lanes `open` after a step in `pieces` pieces whose checks are `checks`:
/// returns the lanes the guard sends on to twice the pieces.
#[inline(always)]
fn decide(
    outcome: &mut [(LaneOutcome, u32); LANES],
    open: u32,
    checks: &PieceChecks,
    pieces: u32,
) -> u32 {
    let (failed, bad, too_far) = (
        checks.failed.to_bitmask(),
        checks.bad.to_bitmask(),
        checks.too_far.to_bitmask(),
    );
    let mut next = 0;
    for (l, o) in outcome.iter_mut().enumerate() {
        let bit = 1 << l;
        if open & bit == 0 {
            continue;
        }
        *o = if failed & bit != 0 {
            (LaneOutcome::Declined, pieces)
        } else if bad & bit != 0 {
            (LaneOutcome::NonFinite, pieces)
        } else if too_far & bit != 0 {
            if pieces < ROS3.guard.max_pieces {
                next |= bit;
            }
            (LaneOutcome::Redo, pieces.max(2))
        } else if pieces == 1 {
            (LaneOutcome::Done, 1)
        } else {
            (LaneOutcome::Split, pieces)
        };
    }
    next
}

/// The guard's splits of a step of `h_s` for the lanes `open`, whose one-piece step it did not
/// trust: the group stepped again from the start of the step (in `ls.nodes`, pass 1 of the one
/// piece done) in two pieces, then, for the lanes still over the tolerance, in four. The lanes
/// not open keep their results in `ls.out`. Out of line: the one-piece step stays as short as
/// it was without it.
#[inline(never)]
fn split(
    ls: &mut LaneScratch,
    piece: &Piece<'_>,
    h_s: f32,
    mut open: u32,
    outcome: &mut [(LaneOutcome, u32); LANES],
) {
    let n = piece.n;
    // The start of the step, which the pieces overwrite.
    for (start, node) in ls.start[..n].iter_mut().zip(&ls.nodes[..n]) {
        *start = [node.theta, node.phi, node.omega_theta, node.omega_phi];
    }
    let mut pieces = 2;
    while open != 0 {
        if pieces > 2 {
            for (start, node) in ls.start[..n].iter().zip(&mut ls.nodes[..n]) {
                [node.theta, node.phi, node.omega_theta, node.omega_phi] = *start;
            }
        }
        // As the scalar guard divides the step.
        let h_piece = h_s / pieces as f32;
        let keep = !mask_of(open);
        let mut checks = PieceChecks {
            failed: none(),
            bad: none(),
            too_far: none(),
        };
        for p in 0..pieces {
            first_pass(
                &ls.nodes,
                &mut ls.stages,
                &mut ls.pos,
                &mut ls.vel,
                &mut ls.tangent,
                piece.root,
                piece.has_air,
                n,
            );
            let now = rest_of_piece(ls, piece, h_piece, p + 1 == pieces, keep);
            // The scalar guard stops a split at its first piece over the tolerance: what later
            // pieces do in that lane does not count.
            let live = !checks.too_far;
            checks.failed |= now.failed & live;
            checks.bad |= now.bad & live;
            checks.too_far |= now.too_far & live;
        }
        open = decide(outcome, open, &checks, pieces);
        pieces *= 2;
    }
}

/// Passes 2 to 9 of a ROS3 step of `h_s` from the state in `ls.nodes`, whose pass 1 (kinematics
/// and prefix sums, [`first_pass`]) is done. The last piece of a step (`last`) writes the new
/// state and the end-of-step positions and velocities to `ls.out`, but not in the lanes of
/// `keep`; another writes the new state to `ls.nodes`, where the next piece starts.
#[inline(always)]
fn rest_of_piece(
    ls: &mut LaneScratch,
    piece: &Piece<'_>,
    h_s: f32,
    last: bool,
    keep: L,
) -> PieceChecks {
    let Piece {
        loads,
        root: (root_pos, root_rot),
        chain,
        has_air,
        n,
    } = piece;
    let (chain, has_air, n) = (*chain, *has_air, *n);
    // The coefficients in `f32`, as the scalar step in `f32` rounds them.
    let real = |x: f64| x as f32;
    let hg_s = h_s * real(ROS3.gamma);
    let inv_h = 1.0 / h_s;
    let coef = |i: usize, j: usize| L::splat(real(ROS3.c[i][j]) * inv_h);
    let (c10, c20, c21) = (coef(1, 0), coef(2, 0), coef(2, 1));
    // Written out, as every small array here: in this function the closures of array `map`s
    // were left out of line.
    let [m0, m1, m2] = ROS3.m;
    let weight = [L::splat(real(m0)), L::splat(real(m1)), L::splat(real(m2))];
    let [e0, e1, e2] = ROS3.e;
    let estimate = [L::splat(real(e0)), L::splat(real(e1)), L::splat(real(e2))];
    let h = L::splat(h_s);
    let hg = L::splat(hg_s);
    let hg2 = hg * hg;
    let joints = &mut ls.stages[..n - 1];

    // Pass 2, tip to root: torques and sums at the start of the step, generators, and the first
    // stage's right-hand side (`r = w`, no torque shift).
    let (nodes, pos, vel) = (&ls.nodes[..n], &ls.pos[..n], &ls.vel[..n]);
    let (tangent, tension) = (&ls.tangent[..n], &mut ls.tension[..n]);
    let mut sums = TipSums::new(nodes[n - 1].rest_point);
    let mut suffix_w = V3::default();
    for i in (1..n).rev() {
        let joint = &mut joints[i - 1];
        let (q, w, len) = (joint.q, joint.w, joint.len);
        let pivot = pos[i - 1];
        let xi = pos[i];
        let node = &nodes[i];
        let mi = node.mass + node.wetness;
        let fi = loads.at(mi, xi, vel[i], tangent[i], len, node.force);
        let rc = nodes[i - 1].rest_point;
        let terms = sums.joint(chain, fi, xi, pivot, rc, mi, len, joint.a);
        tension[i] = terms.load.dot(tangent[i]);
        let (a, v, wg, inertia, torque) = (joint.a, terms.v, terms.wg, terms.inertia, terms.torque);
        let damping = node.damping;
        let k = [node.k_theta, node.k_phi];
        let rest = [node.rest_theta, node.rest_phi];
        if !chain {
            suffix_w = V3::default();
        }
        suffix_w = suffix_w + v[0] * w[0] + v[1] * w[1];
        let mut d = [L::ZERO; 2];
        let mut b = [L::ZERO; 2];
        for t in 0..2 {
            let tau = a[t].dot(torque) - k[t] * (q[t] - rest[t]) - damping * w[t];
            let jw = wg[t].dot(joint.prefix) + a[t].dot(suffix_w);
            d[t] = inertia + hg * damping + hg2 * k[t];
            b[t] = hg * tau + hg2 * (jw - k[t] * w[t]);
        }
        joint.v = v;
        joint.wg = wg;
        joint.d = d;
        joint.b = b;
        joint.inertia = inertia;
    }

    // Pass 3, tip to root: the elimination, its factors kept, and the first stage's offsets.
    let mut failed = none();
    let (mut gain_m, mut gain_r) = (M3::default(), V3::default());
    for joint in joints.iter_mut().rev() {
        if !chain {
            gain_m = M3::default();
            gain_r = V3::default();
        }
        let step = eliminate(joint, &mut gain_m, &mut gain_r, hg2, &mut failed);
        joint.gain = step.gain;
        joint.offset = step.offset;
        joint.inverse = step.inverse;
        joint.g = step.g;
    }

    // Pass 4, root to tip: the first stage's unknowns `U_0` (`r = w`) and the second stage's
    // right-hand side `r = w + U_0w + c_10 / h U_0q`, `r_w = c_10 / h U_0w`, with the prefix
    // sums of `A r`; then, in a second loop, the kinematics at the second stage's state
    // `y_n + U_0` (one loop carried more sums than there are registers).
    let mut prefix_x = V3::default();
    let mut prefix_r = V3::default();
    for joint in joints.iter_mut() {
        let x = unknowns(joint, &mut prefix_x, hg2);
        let w = joint.w;
        let uq = [hg * (w[0] + x[0]), hg * (w[1] + x[1])];
        let w_stage = [w[0] + x[0], w[1] + x[1]];
        let r = [w_stage[0] + c10 * uq[0], w_stage[1] + c10 * uq[1]];
        joint.prefix = prefix_r;
        prefix_r = prefix_r + joint.a[0] * r[0] + joint.a[1] * r[1];
        (joint.uq[0], joint.uw[0]) = (uq, x);
        (joint.w_stage, joint.r) = (w_stage, r);
    }
    let mut rot = *root_rot;
    let mut omega = V3::default();
    let mut pos = *root_pos;
    let mut vel = V3::default();
    for i in 1..n {
        let joint = &mut joints[i - 1];
        let q_stage = [joint.q[0] + joint.uq[0][0], joint.q[1] + joint.uq[0][1]];
        let [ax, ay] = link(&mut rot, q_stage[0], q_stage[1]);
        let t = rot.column(2);
        let seg = t * joint.len;
        joint.a_stage = [ax, ay];
        pos = pos + seg;
        ls.pos[i] = pos;
        ls.tangent[i] = t;
        if has_air {
            let w_stage = joint.w_stage;
            omega = omega + ax * w_stage[0] + ay * w_stage[1];
            vel = vel + omega.cross(seg);
            ls.vel[i] = vel;
        }
    }

    // Pass 5, tip to root: the first stage's check and the torques at the second stage's state;
    // then, in a second loop, the second stage's right-hand side (torque `tau(Y_1) + I r_w`) and
    // offsets.
    let mut check = Check::new();
    let (mut s_f, mut t_vec) = (V3::default(), V3::default());
    for i in (1..n).rev() {
        let node = &ls.nodes[i];
        let joint = &mut joints[i - 1];
        check.joint(joint, hg2, chain);
        let xi = ls.pos[i];
        let mi = node.mass + node.wetness;
        let fi = loads.at(mi, xi, ls.vel[i], ls.tangent[i], joint.len, node.force);
        let seg = xi - ls.pos[i - 1];
        let torque = if chain {
            s_f = s_f + fi;
            t_vec = t_vec + seg.cross(s_f);
            t_vec
        } else {
            seg.cross(fi)
        };
        let k = [node.k_theta, node.k_phi];
        let rest = [node.rest_theta, node.rest_phi];
        for t in 0..2 {
            let q_stage = joint.q[t] + joint.uq[0][t];
            joint.tau_stage[t] = joint.a_stage[t].dot(torque)
                - k[t] * (q_stage - rest[t])
                - node.damping * joint.w_stage[t];
        }
    }
    failed |= check.failed();
    let (mut suffix_r, mut gain_r) = (V3::default(), V3::default());
    for i in (1..n).rev() {
        let joint = &mut joints[i - 1];
        if !chain {
            suffix_r = V3::default();
            gain_r = V3::default();
        }
        let r = joint.r;
        suffix_r = suffix_r + joint.v[0] * r[0] + joint.v[1] * r[1];
        let r_w = [c10 * joint.uw[0][0], c10 * joint.uw[0][1]];
        let b = stage_rhs(joint, &ls.nodes[i], r_w, suffix_r, hg, hg2);
        offsets(joint, b, &mut gain_r, hg2);
    }

    // Pass 6, root to tip: the second stage's unknowns `U_1`, and the third stage's right-hand
    // side `r = w_stage + c_20 / h U_0q + c_21 / h U_1q`, `r_w = c_20 / h U_0w + c_21 / h U_1w`.
    let mut prefix_x = V3::default();
    let mut prefix_r = V3::default();
    for joint in joints.iter_mut() {
        let x = unknowns(joint, &mut prefix_x, hg2);
        let r1 = joint.r;
        let uq = [hg * (r1[0] + x[0]), hg * (r1[1] + x[1])];
        let uq0 = joint.uq[0];
        let r = [
            joint.w_stage[0] + c20 * uq0[0] + c21 * uq[0],
            joint.w_stage[1] + c20 * uq0[1] + c21 * uq[1],
        ];
        (joint.uq[1], joint.uw[1]) = (uq, x);
        joint.prefix = prefix_r;
        prefix_r = prefix_r + joint.a[0] * r[0] + joint.a[1] * r[1];
        joint.r = r;
    }

    // Pass 7, tip to root: the second stage's check; the third stage's right-hand side (the
    // second stage's torques) and offsets.
    let mut check = Check::new();
    let (mut suffix_r, mut gain_r) = (V3::default(), V3::default());
    for i in (1..n).rev() {
        let joint = &mut joints[i - 1];
        check.joint(joint, hg2, chain);
        if !chain {
            suffix_r = V3::default();
            gain_r = V3::default();
        }
        let r = joint.r;
        suffix_r = suffix_r + joint.v[0] * r[0] + joint.v[1] * r[1];
        let (uw0, uw1) = (joint.uw[0], joint.uw[1]);
        let r_w = [c20 * uw0[0] + c21 * uw1[0], c20 * uw0[1] + c21 * uw1[1]];
        let b = stage_rhs(joint, &ls.nodes[i], r_w, suffix_r, hg, hg2);
        offsets(joint, b, &mut gain_r, hg2);
    }
    failed |= check.failed();

    // Pass 8, root to tip: the third stage's unknowns `U_2`, the new state
    // `y_n + sum m_i U_i` and the embedded estimate `sum e_i U_i` (angles, and rates times the
    // step); then, in a second loop, the end-of-step positions and velocities (the last piece).
    let mut prefix_x = V3::default();
    let mut nan_if_bad = L::ZERO;
    let mut too_far = none();
    let tolerance = L::splat(real(ROS3.guard.tolerance));
    for i in 1..n {
        let joint = &mut joints[i - 1];
        let x = unknowns(joint, &mut prefix_x, hg2);
        let r = joint.r;
        let uq2 = [hg * (r[0] + x[0]), hg * (r[1] + x[1])];
        let (uq, uw) = (joint.uq, joint.uw);
        let mut q = [L::ZERO; 2];
        let mut w = [L::ZERO; 2];
        for t in 0..2 {
            q[t] = joint.q[t] + weight[0] * uq[0][t] + weight[1] * uq[1][t] + weight[2] * uq2[t];
            w[t] = joint.w[t] + weight[0] * uw[0][t] + weight[1] * uw[1][t] + weight[2] * x[t];
            let e = estimate[0] * uq[0][t] + estimate[1] * uq[1][t] + estimate[2] * uq2[t];
            let e_rate = (estimate[0] * uw[0][t] + estimate[1] * uw[1][t] + estimate[2] * x[t]) * h;
            let error = e_rate.abs().simd_gt(e.abs()).select(e_rate, e);
            // Written so that a NaN fails too.
            too_far |= !error.abs().simd_le(tolerance);
        }
        nan_if_bad += (nan_unless_finite(q[0]) + nan_unless_finite(q[1]))
            + (nan_unless_finite(w[0]) + nan_unless_finite(w[1]));
        if last {
            let len = end_length(&ls.nodes[i], ls.tension[i], joint.len);
            nan_if_bad += nan_unless_finite(len);
            let out = &mut ls.out[i];
            out.q = [keep.select(out.q[0], q[0]), keep.select(out.q[1], q[1])];
            out.w = [keep.select(out.w[0], w[0]), keep.select(out.w[1], w[1])];
            out.len = keep.select(out.len, len);
        } else {
            let node = &mut ls.nodes[i];
            (node.theta, node.phi) = (q[0], q[1]);
            (node.omega_theta, node.omega_phi) = (w[0], w[1]);
        }
    }
    if last {
        let mut rot = *root_rot;
        let mut omega = V3::default();
        let mut pos = *root_pos;
        let mut vel = V3::default();
        for out in &mut ls.out[1..n] {
            let (q, w) = (out.q, out.w);
            let [ax, ay] = link(&mut rot, q[0], q[1]);
            let seg = rot.column(2) * out.len;
            omega = omega + ax * w[0] + ay * w[1];
            pos = pos + seg;
            vel = vel + omega.cross(seg);
            (out.pos, out.vel) = (pos, vel);
        }
    }

    // Pass 9: the third stage's check.
    let mut check = Check::new();
    for joint in joints.iter().rev() {
        check.joint(joint, hg2, chain);
    }
    failed |= check.failed();
    PieceChecks {
        failed,
        bad: not_finite(nan_if_bad),
        too_far,
    }
}
