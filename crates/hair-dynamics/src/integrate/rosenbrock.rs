//! Rosenbrock steps on the coupled system: second- and third-order L-stable linearly implicit
//! steps that reuse the coupled step's linear solve.
//!
//! A Rosenbrock method (Hairer & Wanner, *Solving ODEs II*, §IV.7, in the form of their eq. 7.25)
//! advances `y' = f(y)` with one Jacobian `A = f'(y_n)` and `s` linear solves with the same matrix:
//! `(I / (h g) - A) U_i = f(Y_i) + sum_{j<i} (c_ij / h) U_j`, `Y_i = y_n + sum_{j<i} a_ij U_j`,
//! `y_{n+1} = y_n + sum_i m_i U_i`. For the strand, `y = (q, w)` and
//! `A = [[0, 1], [I^-1 (J - K), -I^-1 G]]`; eliminating the angle half of `U` leaves exactly the
//! coupled step's system with the step `h g` (derivation in `docs/dynamics.md`), so each stage is
//! one call of [`super::implicit_coupled::solve_system`] with a right-hand side built from the
//! stage's torques.

use super::StepSettings;
use super::implicit_coupled::{solve_system, solve_system_again};
use crate::strand::{RootDyn, Scratch, StrandParams};
use nalgebra::{RealField, Vector3};

/// The coefficients of a Rosenbrock method in Hairer & Wanner's transformed form.
pub(super) struct Tableau {
    /// Number of stages (at most three).
    pub stages: usize,
    /// The diagonal `gamma` of the method.
    pub gamma: f64,
    /// `a_ij`: where stage `i` evaluates the torques.
    pub a: [[f64; 3]; 3],
    /// `c_ij`: the earlier stages' share of stage `i`'s right-hand side.
    pub c: [[f64; 3]; 3],
    /// `m_i`: the weights of the new state.
    pub m: [f64; 3],
    /// `e_i`: the weights of the embedded method's difference (the local error estimate).
    pub e: [f64; 3],
    /// Whether stage `i` evaluates the torques anew (otherwise it reuses stage `i - 1`'s).
    pub new_f: [bool; 3],
    /// When a step is trusted, and what replaces one that is not.
    pub guard: Guard,
}

/// The error guard of a Rosenbrock step (`docs/dynamics.md`): the linearisation at the start of a
/// piece is only trusted for a bounded local error, so a step whose embedded estimate exceeds
/// `tolerance` is redone in 2, 4, ... up to `max_pieces` equal pieces. The pieces depend only on
/// the state, so runs are deterministic.
pub(super) struct Guard {
    /// Largest embedded error estimate a piece may have (rad).
    pub tolerance: f64,
    /// Whether the estimate includes the rates' error times the piece (rad), not only the
    /// angles'. A tip's whip is a burst of rate error before it is an angle error.
    pub rates: bool,
    /// Most pieces a step is split into.
    pub max_pieces: u32,
    /// What a step over the tolerance in `max_pieces` pieces becomes: `true`, the coupled step
    /// (backward Euler) in `max_pieces` pieces from the start of the step; `false`, the last
    /// split as it is.
    pub backward_euler: bool,
}

/// `1 + 1/sqrt(2)`: the `gamma` of Verwer's ROS2.
const ROS2_GAMMA: f64 = 1.707_106_781_186_547_6;

/// ROS2 (Verwer, Spee, Blom & Hundsdorfer 1999): two stages, second order for any matrix,
/// L-stable with `gamma = 1 + 1/sqrt(2)`.
pub(super) const ROS2: Tableau = Tableau {
    stages: 2,
    gamma: ROS2_GAMMA,
    a: [[0.0; 3], [1.0 / ROS2_GAMMA, 0.0, 0.0], [0.0; 3]],
    c: [[0.0; 3], [-2.0 / ROS2_GAMMA, 0.0, 0.0], [0.0; 3]],
    m: [1.5 / ROS2_GAMMA, 0.5 / ROS2_GAMMA, 0.0],
    e: [0.5 / ROS2_GAMMA, 0.5 / ROS2_GAMMA, 0.0],
    new_f: [true, true, false],
    guard: Guard {
        tolerance: 0.01,
        rates: false,
        max_pieces: 16,
        backward_euler: false,
    },
};

/// `gamma` of Sandu et al.'s ROS3, the root of the L-stability condition.
const ROS3_GAMMA: f64 = 0.435_866_521_508_459;

/// ROS3 (Sandu, Verwer, Blom et al. 1997, *Benchmarking stiff ODE solvers for atmospheric
/// chemistry II*): three stages and two torque evaluations, third order, L-stable.
pub(super) const ROS3: Tableau = Tableau {
    stages: 3,
    gamma: ROS3_GAMMA,
    a: [[0.0; 3], [1.0, 0.0, 0.0], [1.0, 0.0, 0.0]],
    c: [
        [0.0; 3],
        [-1.015_617_108_387_770_2, 0.0, 0.0],
        [4.075_995_645_253_77, 9.207_679_429_833_079, 0.0],
    ],
    m: [1.0, 6.169_794_704_382_824_5, -0.427_722_565_432_185_7],
    e: [0.5, -2.907_955_871_680_547, 0.223_540_698_978_115_7],
    new_f: [true, true, false],
    guard: ROS3_GUARD,
};

/// ROS3's guard. Measured on the grid of `hair stability` (`docs/perf/dynamics.md`): the old
/// guard (0.01 rad on the angles, up to 16 pieces, no fallback) let through the phase error
/// that makes a soft strand's tip crack late and hard at 1/100 s, and at 1/10 s its 16 pieces
/// tracked the true motion, whose peak speed sampled every 1/10 s rises in the second second in
/// 9 of 19 stiffnesses. 1e-3 rad on angles and rates keeps every cell within 0.75 of the first
/// second's peak; four pieces bound the cost; backward Euler in four pieces damps a step four
/// pieces do not resolve (in one piece it blew up on the softest strands at 1/25 s).
const ROS3_GUARD: Guard = Guard {
    tolerance: 1e-3,
    rates: true,
    max_pieces: 4,
    backward_euler: true,
};

/// The evaluation of the kinematics, forces and torques at a state (`jacobian`: keep the sums
/// the coupled solve needs).
pub(super) trait Evaluate<T: RealField + Copy>:
    Fn(&RootDyn<T>, &[T], &[T], &[T], bool, &mut Scratch<T>)
{
}

impl<T: RealField + Copy, F: Fn(&RootDyn<T>, &[T], &[T], &[T], bool, &mut Scratch<T>)> Evaluate<T>
    for F
{
}

/// One step of `h` by `tab` under its [`Guard`]: split into 2, 4, ... `max_pieces` equal
/// pieces while any piece's embedded error estimate exceeds the tolerance, and, if the guard says
/// so, redone as the coupled step in `max_pieces` pieces when even those exceed it. `q0`, `w0`
/// in `sc` are the coordinates at the start of the step (the caller's copies); `frame_spin` as
/// in the coupled step (the Rosenbrock stages keep a turning frame's terms explicit, the
/// fallback does not). The guard starts at `sc.rosenbrock_first_pieces` pieces (one if 0), and
/// counts a step it splits in `sc.rosenbrock_splits`. Returns whether the step fell back to
/// backward Euler.
#[expect(
    clippy::too_many_arguments,
    reason = "the kernel's inputs are all distinct slices"
)]
pub(super) fn advance<T: RealField + Copy>(
    tab: &Tableau,
    root: &mut RootDyn<T>,
    p: &StrandParams<'_, T>,
    q: &mut [T],
    w: &mut [T],
    length: &[T],
    h: T,
    settings: &StepSettings,
    frame_spin: Option<Vector3<T>>,
    sc: &mut Scratch<T>,
    eval: &impl Evaluate<T>,
) -> bool {
    let m2 = q.len();
    let root0 = *root;
    let guard = &tab.guard;
    let tol = T::from_f64(guard.tolerance).unwrap_or_else(T::zero);
    let mut pieces = std::mem::take(&mut sc.rosenbrock_first_pieces).clamp(1, guard.max_pieces);
    if pieces > 1 {
        sc.rosenbrock_splits += 1;
    }
    loop {
        let piece = h / T::from_u32(pieces).unwrap_or_else(T::one);
        let mut ok = true;
        for _ in 0..pieces {
            let error = step(tab, root, p, q, w, length, piece, settings, sc, eval);
            if !error.is_finite() || error > tol {
                ok = false;
                break;
            }
        }
        if ok || (pieces >= guard.max_pieces && !guard.backward_euler) {
            return false;
        }
        if pieces == 1 {
            sc.rosenbrock_splits += 1;
        }
        q.copy_from_slice(&sc.q0[..m2]);
        w.copy_from_slice(&sc.w0[..m2]);
        *root = root0;
        if pieces >= guard.max_pieces {
            for _ in 0..pieces {
                eval(root, q, w, length, true, sc);
                super::implicit_coupled::solve_step(root, p, q, w, piece, settings, frame_spin, sc);
                super::symplectic_root(root, sc.root_acc, piece);
            }
            return true;
        }
        pieces *= 2;
    }
}

/// One Rosenbrock step of a strand by `tab`; returns the embedded error estimate (the largest
/// change of an angle between the method and its embedded partner, rad, and with
/// [`Guard::rates`] of a rate times the step). A singular stage system leaves the angles
/// non-finite on purpose, so the caller restores the strand and reports it.
#[expect(
    clippy::too_many_arguments,
    reason = "the kernel's inputs are all distinct slices"
)]
pub(super) fn step<T: RealField + Copy>(
    tab: &Tableau,
    root: &mut RootDyn<T>,
    p: &StrandParams<'_, T>,
    q: &mut [T],
    w: &mut [T],
    length: &[T],
    h: T,
    settings: &StepSettings,
    sc: &mut Scratch<T>,
    eval: &impl Evaluate<T>,
) -> T {
    let m2 = q.len();
    let n = length.len();
    sc.reserve_rosenbrock(n);
    let real = |x: f64| T::from_f64(x).unwrap_or_else(T::zero);
    let hg = h * real(tab.gamma);
    let inv_h = T::one() / h;

    // The Jacobian's point: the state at the start of the step.
    eval(root, q, w, length, true, sc);
    let mut uq = std::mem::take(&mut sc.ros_uq);
    let mut uw = std::mem::take(&mut sc.ros_uw);
    let mut ftau = std::mem::take(&mut sc.ros_ftau);
    let mut rq = std::mem::take(&mut sc.ros_rq);
    let mut stage_q = std::mem::take(&mut sc.stage_q);
    let mut stage_w = std::mem::take(&mut sc.stage_w);
    ftau[..m2].copy_from_slice(&sc.tau[..m2]);
    stage_w[..m2].copy_from_slice(w);
    let mut f_vel = root.velocity;
    let mut f_acc = sc.root_acc;
    let mut u_pos = [Vector3::zeros(); 3];
    let mut u_vel = [Vector3::zeros(); 3];
    let mut solved = true;

    for i in 0..tab.stages {
        if i > 0 && tab.new_f[i] {
            let a = tab.a[i].map(real);
            for c in 0..m2 {
                let (mut sq, mut sw) = (q[c], w[c]);
                for j in 0..i {
                    sq += a[j] * uq[j * m2 + c];
                    sw += a[j] * uw[j * m2 + c];
                }
                stage_q[c] = sq;
                stage_w[c] = sw;
            }
            let mut stage_root = *root;
            if root.free {
                for j in 0..i {
                    stage_root.position += u_pos[j] * a[j];
                    stage_root.velocity += u_vel[j] * a[j];
                }
            }
            // The stage's torques go through the same scratch; the kinematics the Jacobian was
            // built from are swapped out meanwhile and back in for the solve.
            swap_kinematics(sc);
            eval(
                &stage_root,
                &stage_q[..m2],
                &stage_w[..m2],
                length,
                false,
                sc,
            );
            swap_kinematics(sc);
            ftau[..m2].copy_from_slice(&sc.tau[..m2]);
            f_vel = stage_root.velocity;
            f_acc = sc.root_acc;
        }
        // R_i = f(Y_i) + sum_j (c_ij / h) U_j. The solve takes R's angle half as its `w` and the
        // inertia times its velocity half as its torque.
        let coef = tab.c[i].map(|x| real(x) * inv_h);
        for c in 0..m2 {
            let (mut r_q, mut r_w) = (stage_w[c], T::zero());
            for j in 0..i {
                r_q += coef[j] * uq[j * m2 + c];
                r_w += coef[j] * uw[j * m2 + c];
            }
            rq[c] = r_q;
            sc.tau[c] = ftau[c] + sc.inertia[c] * r_w;
        }
        // Every stage solves with the same matrix: the first factors it, the others reuse that.
        let solved_stage = if i == 0 {
            solve_system(root, p, &rq[..m2], hg, settings, None, sc)
        } else {
            solve_system_again(root, p, &rq[..m2], hg, settings, sc)
        };
        if !solved_stage {
            solved = false;
            break;
        }
        for c in 0..m2 {
            uw[i * m2 + c] = sc.rhs[c];
            uq[i * m2 + c] = hg * (rq[c] + sc.rhs[c]);
        }
        if root.free {
            // The root's translation has no stiffness of its own: its rows of A are [0 1; 0 0].
            let (mut r_p, mut r_v) = (f_vel, f_acc);
            for j in 0..i {
                r_p += u_pos[j] * coef[j];
                r_v += u_vel[j] * coef[j];
            }
            u_vel[i] = r_v * hg;
            u_pos[i] = (r_p + u_vel[i]) * hg;
        }
    }

    let mut error = T::zero();
    if solved {
        let weights = tab.m.map(real);
        let estimate = tab.e.map(real);
        for c in 0..m2 {
            let (mut e, mut e_rate) = (T::zero(), T::zero());
            for i in 0..tab.stages {
                q[c] += weights[i] * uq[i * m2 + c];
                w[c] += weights[i] * uw[i * m2 + c];
                e += estimate[i] * uq[i * m2 + c];
                e_rate += estimate[i] * uw[i * m2 + c];
            }
            if tab.guard.rates && (e_rate * h).abs() > e.abs() {
                e = e_rate * h;
            }
            // `max` would pass over a NaN.
            if !e.is_finite() || e.abs() > error {
                error = e.abs();
            }
        }
        if root.free {
            for i in 0..tab.stages {
                root.position += u_pos[i] * weights[i];
                root.velocity += u_vel[i] * weights[i];
            }
        }
    } else {
        q.iter_mut().for_each(|x| *x = T::zero() / T::zero());
        error = T::zero() / T::zero();
    }
    sc.ros_uq = uq;
    sc.ros_uw = uw;
    sc.ros_ftau = ftau;
    sc.ros_rq = rq;
    sc.stage_q = stage_q;
    sc.stage_w = stage_w;
    error
}

/// Swaps the kinematics a solve reads (positions, joint axes) and the tensions with their spare
/// buffers.
fn swap_kinematics<T: RealField + Copy>(sc: &mut Scratch<T>) {
    std::mem::swap(&mut sc.pos, &mut sc.ros_pos);
    std::mem::swap(&mut sc.axes, &mut sc.ros_axes);
    std::mem::swap(&mut sc.tension, &mut sc.ros_tension);
}
