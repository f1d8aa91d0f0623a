//! BDF2 on the coupled system: a second-order, L-stable step through the coupled step's solve.
//!
//! The two-step backward differentiation formula `y_{n+1} = 4/3 y_n - 1/3 y_{n-1} + b f(y_{n+1})`,
//! `b = 2 h / 3`, linearised once at `y_n` as the coupled step is. With `y = (q, w)`,
//! `a = (q_n - q_{n-1}) / 3`, `c = (w_n - w_{n-1}) / 3` and the unknown `x = w_{n+1} - w_n`, the
//! velocity rows become
//!
//! `(I + b G + b^2 (K - J)) x = b (tau + I c / b) + b^2 (J - K) (w + a / b)`,
//!
//! the coupled step's system with `h` replaced by `b`, the torque by `tau + I c / b` and the
//! velocities on the right by `w + a / b`; then `q_{n+1} = q_n + a + b w_{n+1}` (derivation in
//! `docs/dynamics.md`). With `a = c = 0` and `b = h` it is the coupled step itself, which is what
//! the first step of a strand runs. Linearising once costs nothing in order: the torque's error
//! is `O(|y_{n+1} - y_n|^2) = O(h^2)`, times `b`, a local error of `O(h^3)`.

use super::StepSettings;
use super::implicit_coupled::solve_system;
use crate::strand::{self, RootDyn, Scratch, StrandParams};
use nalgebra::{RealField, Vector3};

/// A strand's coordinates one step back (the `y_{n-1}` of BDF2), in the step's layout.
pub(crate) struct Previous<'a, T: RealField + Copy> {
    /// Angles, interleaved `theta_1, phi_1, ...`.
    pub q: &'a [T],
    /// Angular velocities, interleaved likewise.
    pub w: &'a [T],
    /// A free root's position (unused for an attached root).
    pub root_position: Vector3<T>,
    /// A free root's velocity (unused for an attached root).
    pub root_velocity: Vector3<T>,
}

/// Largest local error (rad, BDF2's estimate on any angle) a BDF2 step may make; a step that
/// exceeds it is redone as the coupled step (backward Euler) from the same state.
pub(super) const ERROR_TOLERANCE: f64 = 0.01;

/// One BDF2 step of a strand whose torques and Jacobian sums at `y_n` (`q`, `w`, `root`) are in
/// `sc`, and `y_n` itself in `sc.q0`, `sc.w0`. `frame_spin` as in the coupled step. A free root's
/// translation takes BDF2 with its acceleration at `y_n`.
///
/// The linearisation at `y_n` is only trusted for a bounded change of the angles: where a soft
/// strand whips at a large step it fails, and BDF2, which damps far less than backward Euler,
/// then gains energy. So the step estimates its local error from the velocities it has,
/// `(2/9) h^3 q'''` as `(b / 3) (w_{n+1} - 2 w_n + w_{n-1})`, and a step whose estimate exceeds
/// [`ERROR_TOLERANCE`] on any angle is redone as the coupled step. Returns whether it was. A
/// singular system leaves the angles non-finite on purpose (the caller restores the strand and
/// reports it).
#[expect(
    clippy::too_many_arguments,
    reason = "the kernel's inputs are all distinct slices"
)]
pub(super) fn solve_step<T: RealField + Copy>(
    root: &mut RootDyn<T>,
    p: &StrandParams<'_, T>,
    q: &mut [T],
    w: &mut [T],
    length: &[T],
    previous: &Previous<'_, T>,
    h: T,
    settings: &StepSettings,
    frame_spin: Option<Vector3<T>>,
    sc: &mut Scratch<T>,
) -> bool {
    let m2 = q.len();
    let root0 = *root;
    let three = T::one() + T::one() + T::one();
    let b = (h + h) / three;
    let mut shift = std::mem::take(&mut sc.stage_q);
    let mut w_eff = std::mem::take(&mut sc.stage_w);
    let mut tau0 = std::mem::take(&mut sc.acc_q);
    tau0[..m2].copy_from_slice(&sc.tau[..m2]);
    for c in 0..m2 {
        let a = (q[c] - previous.q[c]) / three;
        let dv = (w[c] - previous.w[c]) / three;
        shift[c] = a;
        w_eff[c] = w[c] + a / b;
        sc.tau[c] += sc.inertia[c] * dv / b;
    }
    if frame_spin.is_some() {
        // The centrifugal stiffness's term `b^2 Z (w + a / b)` is built from the node velocities:
        // make them those of `w + a / b` (same angles, so the same positions and axes).
        strand::forward(root, q, &w_eff[..m2], length, sc);
    }
    let solved = solve_system(root, p, &w_eff[..m2], b, settings, frame_spin, sc);
    let tol = T::from_f64(ERROR_TOLERANCE).unwrap_or_else(T::zero);
    let mut within = solved;
    if solved {
        for c in 0..m2 {
            let w_new = w[c] + sc.rhs[c];
            let error = b / three * (w_new - (w[c] + w[c]) + previous.w[c]);
            // Written so that a NaN fails too.
            within &= error.abs() <= tol;
            w[c] = w_new;
            q[c] += shift[c] + b * w_new;
        }
    }
    if within && root.free {
        let velocity =
            root.velocity + (root.velocity - previous.root_velocity) / three + sc.root_acc * b;
        root.position += (root.position - previous.root_position) / three + velocity * b;
        root.velocity = velocity;
    }
    if !within {
        // Backward Euler from `y_n` with the torques at `y_n`.
        q.copy_from_slice(&sc.q0[..m2]);
        w.copy_from_slice(&sc.w0[..m2]);
        sc.tau[..m2].copy_from_slice(&tau0[..m2]);
        *root = root0;
        if frame_spin.is_some() {
            strand::forward(root, q, w, length, sc);
        }
        super::implicit_coupled::solve_step(root, p, q, w, h, settings, frame_spin, sc);
        super::symplectic_root(root, sc.root_acc, h);
    }
    sc.stage_q = shift;
    sc.stage_w = w_eff;
    sc.acc_q = tau0;
    !within
}

/// A tag of a strand's coordinates (`q`, `w`), its root (position, rotation, velocity) and the
/// time step, never 0: equal tags mean, but for a collision of 64-bit hashes, that nothing
/// rewrote the strand since the step that left the tag (a collision response, a cut, a tool, a
/// caller's `*_mut` edit) and that the step is the same, so BDF2 may read the previous step.
/// Exact bits are hashed: any change counts.
pub(super) fn history_tag(
    q: &[crate::Real],
    w: &[crate::Real],
    root: &crate::state::RootState,
    dt: crate::Real,
) -> u64 {
    history_tag_of(q.len(), q.iter().chain(w).copied(), root, dt)
}

/// [`history_tag`] of the `m2` coordinates `values` (the interleaved angles, then the
/// interleaved rates), from wherever they are stored.
pub(super) fn history_tag_of(
    m2: usize,
    values: impl Iterator<Item = crate::Real>,
    root: &crate::state::RootState,
    dt: crate::Real,
) -> u64 {
    let mut tag = 0xcbf2_9ce4_8422_2325_u64 ^ m2 as u64;
    let mut mix = |x: crate::Real| {
        tag = (tag.rotate_left(23) ^ u64::from(x.to_bits())).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    };
    mix(dt);
    root.position
        .coords
        .iter()
        .chain(root.velocity.iter())
        .chain(root.rotation.iter())
        .for_each(|x| mix(*x));
    values.for_each(mix);
    tag | 1
}
