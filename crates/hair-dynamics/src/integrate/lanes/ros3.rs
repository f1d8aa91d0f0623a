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
//! A lane whose check fails, whose state goes non-finite or whose embedded error estimate is over
//! the guard's tolerance is left untouched and redone by the scalar ROS3 step under its guard (the
//! last from two pieces: one piece is what the lanes just measured).

use super::{
    L, LANES, LaneBend, LaneOutcome, LaneScratch, M3, Strands, V3, gather, gather3, member,
    nan_unless_finite, not_finite, per_lane, prefetch_slice, publish_nodes, root_frames,
};
use crate::Vector;
use crate::integrate::rosenbrock::ROS3;
use crate::integrate::{Shared, StepSettings, TorqueModel};
use crate::run::Run;

/// What the ROS3 lane step keeps of joint `j` between its passes.
#[derive(Clone, Copy, Default)]
pub(super) struct StageJoint {
    /// Joint axes at the start of the step (the columns of the matrix's `A_j`) and at the
    /// second stage's state (its torques').
    a: [V3; 2],
    a_stage: [V3; 2],
    /// The Jacobian's column generators `V_j` and row generators `W_j`.
    v: [V3; 2],
    wg: [V3; 2],
    /// The elimination's factors, which every stage reuses: the 2 x 2 block's inverse, the rows
    /// of `G_j = M A_j + V_j` and of the gain `E_j`.
    inverse: [[L; 2]; 2],
    g: [V3; 2],
    gain: [V3; 2],
    /// Diagonal of the joint's two rows, and the diagonal inertia.
    d: [L; 2],
    inertia: L,
    /// The stage in hand: its right-hand side's rows `b`, the elimination's offsets `e_j`, the
    /// prefix sum `sum_{k<j} A_k r_k` of its angle half `r` and that half. (Its velocity half,
    /// the torque's shift `I r_w`, is worked out from the unknowns where it is needed.)
    b: [L; 2],
    offset: [L; 2],
    prefix: V3,
    r: [L; 2],
    /// The last stage's unknowns and its residual check's terms `h^2 W_j^T sum_{k<j} A_k x_k`.
    x: [L; 2],
    left: [L; 2],
    /// The first two stages' unknowns, angle and rate halves (`U_i`).
    uq: [[L; 2]; 2],
    uw: [[L; 2]; 2],
    /// The second stage's rates and torques (the third stage reuses them).
    w_stage: [L; 2],
    tau_stage: [L; 2],
    /// The joint's angles, rates and segment length at the start of the step.
    q: [L; 2],
    w: [L; 2],
    len: L,
}

/// Zero in every lane, as a mask: no lane.
#[inline(always)]
fn none() -> L {
    L::ZERO.simd_ne(L::ZERO)
}

/// A stage's residual check, accumulated joint by joint from the tip: the largest residual of a
/// row, the largest size of its terms, and a sum that is NaN where either is not finite (as the
/// scalar solve checks it).
#[derive(Clone, Copy)]
struct Check {
    suffix: V3,
    worst: L,
    scale: L,
    nan_if_failed: L,
}

impl Check {
    fn new() -> Self {
        Self {
            suffix: V3::default(),
            worst: L::ZERO,
            scale: L::ZERO,
            nan_if_failed: L::ZERO,
        }
    }

    /// Joint `joint`'s two rows, with the stage's unknowns and right-hand side kept in it.
    #[inline(always)]
    fn joint(&mut self, joint: &StageJoint, h2: L, chain: bool) {
        let (x, b) = (joint.x, joint.b);
        if !chain {
            self.suffix = V3::default();
        }
        self.suffix = self.suffix + joint.v[0] * x[0] + joint.v[1] * x[1];
        for t in 0..2 {
            let left = joint.left[t];
            let right = h2 * joint.a[t].dot(self.suffix);
            let diag = joint.d[t] * x[t];
            let residual = diag - left - right - b[t];
            let size = diag.abs() + left.abs() + right.abs() + b[t].abs();
            self.nan_if_failed += nan_unless_finite(residual) + nan_unless_finite(size);
            self.worst = self.worst.max(residual.abs());
            self.scale = self.scale.max(size);
        }
    }

    /// The lanes whose check fails.
    fn failed(&self) -> L {
        not_finite(self.nan_if_failed)
            | self
                .worst
                .simd_gt(L::splat(f32::EPSILON.sqrt()) * self.scale)
    }
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

/// A stage's unknowns at joint `joint` from the prefix sum `prefix` of `A x`, which they then
/// move one joint down; keeps them and the check's terms.
#[inline(always)]
fn unknowns(joint: &mut StageJoint, prefix: &mut V3, h2: L) -> [L; 2] {
    let x = [
        joint.gain[0].dot(*prefix) + joint.offset[0],
        joint.gain[1].dot(*prefix) + joint.offset[1],
    ];
    joint.x = x;
    joint.left = [h2 * joint.wg[0].dot(*prefix), h2 * joint.wg[1].dot(*prefix)];
    *prefix = *prefix + joint.a[0] * x[0] + joint.a[1] * x[1];
    x
}

/// What the loads on the nodes are made of (as `strand::forces` has them).
struct Loads<'a> {
    sh: &'a Shared<'a>,
    gravity: V3,
    drag: L,
    has_fields: bool,
    has_external: bool,
}

impl Loads<'_> {
    /// The load on a node of mass `mi` at `xi` moving at `vi`, its segment along `tangent` of
    /// length `len`, with the caller's load `external`. Not a closure: the step's closures were
    /// left out of line.
    #[inline(always)]
    fn at(&self, mi: L, xi: V3, vi: V3, tangent: V3, len: L, external: V3) -> V3 {
        let mut fi = self.gravity * mi;
        if let Some(air) = &self.sh.lane_air {
            let u = air.velocity(xi) - vi;
            let across = u - tangent * u.dot(tangent);
            fi = fi + across * (self.drag * len);
        }
        if self.has_fields {
            let m: [f32; LANES] = mi.to_array();
            fi = fi + per_lane(xi, |l, x| self.sh.env.field_force(&x, m[l]));
        }
        if self.has_external {
            fi = fi + external;
        }
        fi
    }
}

/// Advances the strands `members` (as [`super::step_group`]) by one ROS3 step.
pub(super) fn step_group_in(
    run: &mut Run<'_>,
    sh: &Shared<'_>,
    members: &[usize],
    n: usize,
    ls: &mut LaneScratch,
) -> [LaneOutcome; LANES] {
    let settings: &StepSettings = &sh.settings;
    let chain = settings.torque == TorqueModel::Chain;
    let local: [usize; LANES] = std::array::from_fn(|l| member(members, l));
    let global: [usize; LANES] =
        std::array::from_fn(|l| sh.state_offsets[run.first + local[l]] as usize);
    let in_run: [usize; LANES] = std::array::from_fn(|l| global[l] - run.node_base);
    // The coefficients in `f32`, as the scalar step in `f32` rounds them.
    let real = |x: f64| x as f32;
    let h_s = settings.dt;
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

    // Each field of the group, sliced to its strands and asked of memory (`Strands::new`), one
    // by one: through an array's `map` the closures were left out of line.
    let theta = Strands::new(&*run.theta, &in_run, n);
    let phi = Strands::new(&*run.phi, &in_run, n);
    let omega_theta = Strands::new(&*run.omega_theta, &in_run, n);
    let omega_phi = Strands::new(&*run.omega_phi, &in_run, n);
    let length = Strands::new(&*run.length, &in_run, n);
    let mass = Strands::new(sh.mass, &global, n);
    let wetness = Strands::new(sh.wetness, &global, n);
    let damping = Strands::new(sh.damping, &global, n);
    let k_theta = Strands::new(sh.k_theta, &global, n);
    let k_phi = Strands::new(sh.k_phi, &global, n);
    let rest_theta = Strands::new(sh.rest_theta, &global, n);
    let rest_phi = Strands::new(sh.rest_phi, &global, n);
    let k_stretch = Strands::new(sh.k_stretch, &global, n);
    let rest_length = Strands::new(sh.rest_length, &global, n);
    let rest_points = Strands::new(sh.rest_points, &global, n);
    let has_external = !sh.force.is_empty();
    let force = has_external.then(|| Strands::new(sh.force, &global, n));
    for l in 0..members.len() {
        prefetch_slice(&run.positions[in_run[l]..in_run[l] + n]);
        prefetch_slice(&run.velocities[in_run[l]..in_run[l] + n]);
    }
    let (root_pos, root_rot) = root_frames(run, &local);
    let gravity = {
        let g = sh.env.gravity;
        V3 {
            x: L::splat(g.x),
            y: L::splat(g.y),
            z: L::splat(g.z),
        }
    };
    let has_air = sh.lane_air.is_some();
    let loads = Loads {
        sh,
        gravity,
        drag: L::splat(sh.env.env.wind.drag),
        has_fields: !sh.env.env.fields.is_empty(),
        has_external,
    };

    let nodes = &mut ls.nodes[..n];
    gather(nodes, &theta, |node, v| node.theta = v);
    gather(nodes, &phi, |node, v| node.phi = v);
    gather(nodes, &omega_theta, |node, v| node.omega_theta = v);
    gather(nodes, &omega_phi, |node, v| node.omega_phi = v);
    gather(nodes, &length, |node, v| node.length = v);
    let joints = &mut ls.stages[..n - 1];

    // Pass 1, root to tip: kinematics at the start of the step and the prefix sums of A w.
    let mut rot = root_rot;
    let mut omega = V3::default();
    ls.pos[0] = root_pos;
    ls.vel[0] = V3::default();
    for i in 1..n {
        let node = &ls.nodes[i];
        let (x, y) = (node.theta, node.phi);
        let (wx, wy) = (node.omega_theta, node.omega_phi);
        let bend = LaneBend::new(x, y);
        let ax = rot.mul_v(bend.axis_x);
        let ay = rot.mul_v(bend.axis_y);
        rot = rot.mul_m(&bend.rotation);
        let t = rot.column(2);
        let len = node.length;
        let seg = t * len;
        let joint = &mut joints[i - 1];
        (joint.q, joint.w, joint.len) = ([x, y], [wx, wy], len);
        joint.a = [ax, ay];
        joint.prefix = omega;
        omega = omega + ax * wx + ay * wy;
        ls.tangent[i] = t;
        ls.pos[i] = ls.pos[i - 1] + seg;
        if has_air {
            ls.vel[i] = ls.vel[i - 1] + omega.cross(seg);
        }
    }

    let nodes = &mut ls.nodes[..n];
    gather(nodes, &mass, |node, v| node.mass = v);
    gather(nodes, &wetness, |node, v| node.wetness = v);
    gather(nodes, &damping, |node, v| node.damping = v);
    gather(nodes, &k_theta, |node, v| node.k_theta = v);
    gather(nodes, &k_phi, |node, v| node.k_phi = v);
    gather(nodes, &rest_theta, |node, v| node.rest_theta = v);
    gather(nodes, &rest_phi, |node, v| node.rest_phi = v);
    gather(nodes, &k_stretch, |node, v| node.k_stretch = v);
    gather(nodes, &rest_length, |node, v| node.rest_length = v);
    gather3(nodes, &rest_points, |node, v| node.rest_point = v);
    if let Some(force) = &force {
        gather3(nodes, force, |node, v| node.force = v);
    }

    // Pass 2, tip to root: torques and sums at the start of the step, generators, and the first
    // stage's right-hand side (`r = w`, no torque shift).
    let floor = L::splat(1e-2);
    let (mut s_f, mut t_vec, mut s_m, mut s_mp, mut s_mp2) = (
        V3::default(),
        V3::default(),
        L::ZERO,
        V3::default(),
        L::ZERO,
    );
    let (mut s_pf, mut s_fp) = (M3::default(), L::ZERO);
    let mut suffix_w = V3::default();
    let mut rest_next = ls.nodes[n - 1].rest_point;
    for i in (1..n).rev() {
        let j = i - 1;
        let (q, w, len) = {
            let joint = &joints[j];
            (joint.q, joint.w, joint.len)
        };
        let pivot = ls.pos[i - 1];
        let xi = ls.pos[i];
        let node = &ls.nodes[i];
        let mi = node.mass + node.wetness;
        let fi = loads.at(mi, xi, ls.vel[i], ls.tangent[i], len, node.force);
        let seg = xi - pivot;
        let rp = rest_next;
        let rc = ls.nodes[i - 1].rest_point;
        rest_next = rc;
        s_m += mi;
        s_mp = s_mp + rp * mi;
        s_mp2 += rp.norm_squared() * mi;
        let (inertia, torque, load_sum, p, s, sigma);
        if chain {
            inertia = s_mp2 - L::splat(2.0) * rc.dot(s_mp) + rc.norm_squared() * s_m;
            s_f = s_f + fi;
            t_vec = t_vec + seg.cross(s_f);
            torque = t_vec;
            load_sum = s_f;
            s_pf.add_outer(xi, fi);
            s_fp += fi.dot(xi);
            (p, s, sigma) = (s_pf, s_f, s_fp);
        } else {
            inertia = (rp - rc).norm_squared() * mi;
            torque = seg.cross(fi);
            load_sum = fi;
            let mut own = M3::default();
            own.add_outer(xi, fi);
            (p, s, sigma) = (own, fi, fi.dot(xi));
        }
        let inertia = inertia.max(floor * mi * len * len);
        ls.tension[i] = load_sum.dot(ls.tangent[i]);
        let damping = node.damping;
        let k = [node.k_theta, node.k_phi];
        let rest = [node.rest_theta, node.rest_phi];
        let joint = &mut joints[j];
        let a = joint.a;
        let sc_dot = sigma - s.dot(pivot);
        let column = |at: V3| p.mul_v(at) - pivot * s.dot(at) - at * sc_dot;
        let row = |at: V3| p.tr_mul_v(at) - s * at.dot(pivot) - at * sc_dot + at.cross(torque);
        let v = [column(a[0]), column(a[1])];
        let wg = [row(a[0]), row(a[1])];
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
        let (a, v, wg, d, b) = (joint.a, joint.v, joint.wg, joint.d, joint.b);
        let g = [gain_m.mul_v(a[0]) + v[0], gain_m.mul_v(a[1]) + v[1]];
        let b00 = d[0] - hg2 * a[0].dot(g[0]);
        let b01 = -hg2 * a[0].dot(g[1]);
        let b10 = -hg2 * a[1].dot(g[0]);
        let b11 = d[1] - hg2 * a[1].dot(g[1]);
        let det = b00 * b11 - b01 * b10;
        failed |= det.simd_eq(L::ZERO) | not_finite(nan_unless_finite(det));
        let inv_det = L::ONE / det;
        let inv = [
            [b11 * inv_det, -b01 * inv_det],
            [-b10 * inv_det, b00 * inv_det],
        ];
        let coupling = [
            (wg[0] + gain_m.tr_mul_v(a[0])) * hg2,
            (wg[1] + gain_m.tr_mul_v(a[1])) * hg2,
        ];
        let rr = [b[0] + hg2 * a[0].dot(gain_r), b[1] + hg2 * a[1].dot(gain_r)];
        let gain = [
            coupling[0] * inv[0][0] + coupling[1] * inv[0][1],
            coupling[0] * inv[1][0] + coupling[1] * inv[1][1],
        ];
        let offset = [
            inv[0][0] * rr[0] + inv[0][1] * rr[1],
            inv[1][0] * rr[0] + inv[1][1] * rr[1],
        ];
        gain_m.add_outer(g[0], gain[0]);
        gain_m.add_outer(g[1], gain[1]);
        gain_r = gain_r + g[0] * offset[0] + g[1] * offset[1];
        joint.gain = gain;
        joint.offset = offset;
        joint.inverse = inv;
        joint.g = g;
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
    let mut rot = root_rot;
    let mut omega = V3::default();
    let mut pos = root_pos;
    let mut vel = V3::default();
    for i in 1..n {
        let joint = &mut joints[i - 1];
        let q_stage = [joint.q[0] + joint.uq[0][0], joint.q[1] + joint.uq[0][1]];
        let bend = LaneBend::new(q_stage[0], q_stage[1]);
        let ax = rot.mul_v(bend.axis_x);
        let ay = rot.mul_v(bend.axis_y);
        rot = rot.mul_m(&bend.rotation);
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
        let node = &ls.nodes[i];
        let joint = &mut joints[i - 1];
        if !chain {
            suffix_r = V3::default();
            gain_r = V3::default();
        }
        let r = joint.r;
        suffix_r = suffix_r + joint.v[0] * r[0] + joint.v[1] * r[1];
        let k = [node.k_theta, node.k_phi];
        let mut b = [L::ZERO; 2];
        for t in 0..2 {
            let r_w = c10 * joint.uw[0][t];
            let jw = joint.wg[t].dot(joint.prefix) + joint.a[t].dot(suffix_r);
            b[t] = hg * (joint.tau_stage[t] + joint.inertia * r_w) + hg2 * (jw - k[t] * r[t]);
        }
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
        let node = &ls.nodes[i];
        let joint = &mut joints[i - 1];
        check.joint(joint, hg2, chain);
        if !chain {
            suffix_r = V3::default();
            gain_r = V3::default();
        }
        let r = joint.r;
        suffix_r = suffix_r + joint.v[0] * r[0] + joint.v[1] * r[1];
        let k = [node.k_theta, node.k_phi];
        let mut b = [L::ZERO; 2];
        for t in 0..2 {
            let r_w = c20 * joint.uw[0][t] + c21 * joint.uw[1][t];
            let jw = joint.wg[t].dot(joint.prefix) + joint.a[t].dot(suffix_r);
            b[t] = hg * (joint.tau_stage[t] + joint.inertia * r_w) + hg2 * (jw - k[t] * r[t]);
        }
        offsets(joint, b, &mut gain_r, hg2);
    }
    failed |= check.failed();

    // Pass 8, root to tip: the third stage's unknowns `U_2`, the new state
    // `y_n + sum m_i U_i` and the embedded estimate `sum e_i U_i` (angles, and rates times the
    // step); then, in a second loop, the end-of-step positions and velocities.
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
        let k_stretch = ls.nodes[i].k_stretch;
        let stretched = ls.nodes[i].rest_length * (L::ONE + ls.tension[i].max(L::ZERO) / k_stretch);
        let len = k_stretch.simd_gt(L::ZERO).select(stretched, joint.len);
        nan_if_bad += (nan_unless_finite(q[0]) + nan_unless_finite(q[1]))
            + (nan_unless_finite(w[0]) + nan_unless_finite(w[1]))
            + nan_unless_finite(len);
        let out = &mut ls.out[i];
        (out.q, out.w, out.len) = (q, w, len);
    }
    let mut rot = root_rot;
    let mut omega = V3::default();
    let mut pos = root_pos;
    let mut vel = V3::default();
    for out in &mut ls.out[1..n] {
        let (q, w) = (out.q, out.w);
        let bend = LaneBend::new(q[0], q[1]);
        let ax = rot.mul_v(bend.axis_x);
        let ay = rot.mul_v(bend.axis_y);
        rot = rot.mul_m(&bend.rotation);
        let seg = rot.column(2) * out.len;
        omega = omega + ax * w[0] + ay * w[1];
        pos = pos + seg;
        vel = vel + omega.cross(seg);
        (out.pos, out.vel) = (pos, vel);
    }
    let bad = not_finite(nan_if_bad);

    // The third stage's check.
    let mut check = Check::new();
    for joint in joints.iter().rev() {
        check.joint(joint, hg2, chain);
    }
    failed |= check.failed();

    let mut outcome = [LaneOutcome::Done; LANES];
    let (failed, bad, too_far) = (failed.to_bitmask(), bad.to_bitmask(), too_far.to_bitmask());
    for (l, o) in outcome.iter_mut().enumerate() {
        *o = if failed & (1 << l) != 0 {
            LaneOutcome::Declined
        } else if bad & (1 << l) != 0 {
            LaneOutcome::NonFinite
        } else if too_far & (1 << l) != 0 {
            LaneOutcome::Redo
        } else {
            LaneOutcome::Done
        };
    }
    let done: [bool; LANES] =
        std::array::from_fn(|l| l < members.len() && outcome[l] == LaneOutcome::Done);
    for l in (0..LANES).filter(|&l| done[l]) {
        let base = in_run[l];
        run.positions[base] = run.roots[local[l]].position;
        run.velocities[base] = Vector::zeros();
        run.roots[local[l]].history = 0;
    }
    publish_nodes(run, &ls.out, &done, &in_run, n);
    outcome
}
