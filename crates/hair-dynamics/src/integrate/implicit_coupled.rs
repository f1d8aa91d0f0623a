//! The coupled implicit step: one linearly implicit Euler step on every angle of a strand.
//!
//! Ward & Lin's Appendix A linearises only each angle's own spring. Here the whole generalised
//! torque is linearised: `I dw = h tau(q + h (w + dw), w + dw)` with
//! `tau(q + dq, w + dw) ~ tau + (J - K) dq - G dw`, which gives the system
//! `(I + h G + h^2 (K - J)) dw = h tau + h^2 (J - K) w` per strand (derivation in
//! `docs/dynamics.md`). `J` is the derivative of the load's torque with respect to every angle:
//! dense in angle coordinates, but of rank three on either side of each joint (`J_lk = a_k . w_l`
//! left of `l`'s joint, `a_l . V_k` at and right of it). The default solver uses that structure to
//! eliminate the joints from the tip to the root in `O(n)` and checks its residual; the dense
//! `O(n^3)` LU (hand-written, or faer's as the reference) is kept as its fallback and oracle.

use super::{StepSettings, rotating_frame, spring_of};
use crate::TorqueModel;
use crate::strand::{self, RootDyn, Scratch, StrandParams};
use nalgebra::{Matrix2, Matrix3, Matrix3x2, RealField, Vector2, Vector3};

/// The linear solver of the coupled implicit step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum LinearSolver {
    /// `O(n)`: eliminates the joints from the tip to the root through the Jacobian's rank-3
    /// generators (a 2 x 2 solve per joint), then checks the residual of the whole system; a solve
    /// that fails the check is redone by [`LinearSolver::Hand`] and counted in
    /// [`crate::StepReport::dense_fallbacks`].
    #[default]
    Structured,
    /// Hand-written dense LU with partial pivoting, in place in the strand's scratch (no
    /// allocation), `O(n^3)`.
    Hand,
    /// faer's partial-pivoting LU (the reference; allocates per solve).
    Faer,
}

impl LinearSolver {
    /// A short stable name (`structured`, `hand`, `faer`).
    pub fn name(self) -> &'static str {
        match self {
            LinearSolver::Structured => "structured",
            LinearSolver::Hand => "hand",
            LinearSolver::Faer => "faer",
        }
    }
}

/// One coupled implicit step of a strand whose torques (with the Jacobian's sums) are in `sc`, by
/// `settings`' torque model and solver (`h` is `settings.dt` in `T`). `frame_spin` is the head
/// frame's angular velocity when it turns: its Coriolis and centrifugal terms are then implicit
/// too (see `rotating_frame`).
#[expect(
    clippy::too_many_arguments,
    reason = "the kernel's inputs are all distinct slices"
)]
pub(super) fn solve_step<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    q: &mut [T],
    w: &mut [T],
    h: T,
    settings: &StepSettings,
    frame_spin: Option<Vector3<T>>,
    sc: &mut Scratch<T>,
) {
    let m2 = q.len();
    if !solve_system(root, p, w, h, settings, frame_spin, sc) {
        // A singular system (an unstable equilibrium hit exactly) poisons the state on purpose:
        // the caller restores the strand and reports it rather than carrying a guess.
        sc.rhs[..m2]
            .iter_mut()
            .for_each(|x| *x = T::zero() / T::zero());
    }
    for c in 0..m2 {
        w[c] += sc.rhs[c];
        q[c] += h * w[c];
    }
}

/// Solves `(I + h G + h^2 (K - J)) x = h tau + h^2 (J - K) w` into `sc.rhs` by `settings`' solver
/// (the structured solve falling back to the dense LU), with `tau` from `sc.tau` and `J` from the
/// kinematics and sums in `sc`; with `frame_spin`, the turning frame's terms join the system
/// (`rotating_frame`). Returns `false` on an exactly singular system.
pub(super) fn solve_system<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    w: &[T],
    h: T,
    settings: &StepSettings,
    frame_spin: Option<Vector3<T>>,
    sc: &mut Scratch<T>,
) -> bool {
    let model = settings.torque;
    sc.sweep_factored = false;
    if let Some(omega) = frame_spin {
        rotating_frame::prepare(p, w.len() / 2, h, &omega, model, sc);
    }
    let spinning = frame_spin.is_some();
    match settings.solver {
        LinearSolver::Structured => {
            let solved = if spinning {
                rotating_frame::structured_solve(root, p, w, h, model, sc)
            } else {
                structured_solve(root, p, w, h, model, sc)
            };
            solved || {
                sc.dense_fallbacks += 1;
                dense_solve(root, p, w, h, model, LinearSolver::Hand, spinning, sc)
            }
        }
        dense => dense_solve(root, p, w, h, model, dense, spinning, sc),
    }
}

/// [`solve_system`] for the system it was last given (same strand, kinematics, Jacobian sums,
/// step and no turning frame), with the new right-hand side's `w` and `sc.tau`: the structured
/// solve then reuses that system's per-joint factors (the 2 x 2 blocks' inverses and gains) and
/// redoes only the right-hand side's passes and the residual check. The answer is bit for bit
/// that of [`solve_system`]; where the last system had no structured factors (another solver, a
/// singular block) it is [`solve_system`].
pub(super) fn solve_system_again<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    w: &[T],
    h: T,
    settings: &StepSettings,
    sc: &mut Scratch<T>,
) -> bool {
    if settings.solver != LinearSolver::Structured || !sc.sweep_factored {
        return solve_system(root, p, w, h, settings, None, sc);
    }
    let model = settings.torque;
    structured_solve_again(root, p, w, h, model, sc) || {
        sc.dense_fallbacks += 1;
        dense_solve(root, p, w, h, model, LinearSolver::Hand, false, sc)
    }
}

/// Builds the dense system and solves it into `sc.rhs` (with the turning frame's terms, prepared
/// in `sc`, when `spinning`). Returns `false` on an exactly singular system.
#[expect(
    clippy::too_many_arguments,
    reason = "the kernel's inputs are all distinct slices"
)]
fn dense_solve<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    w: &[T],
    h: T,
    model: TorqueModel,
    solver: LinearSolver,
    spinning: bool,
    sc: &mut Scratch<T>,
) -> bool {
    let m2 = w.len();
    dense_system(root, p, w, h, model, spinning, sc);
    match solver {
        LinearSolver::Faer => faer_solve(&sc.lu[..m2 * m2], &mut sc.rhs[..m2], m2),
        _ => lu_solve_in_place(
            &mut sc.lu[..m2 * m2],
            &mut sc.perm[..m2],
            &mut sc.rhs[..m2],
            m2,
        ),
    }
}

/// The dense system of the coupled step: its matrix in `sc.lu` (row-major), its right-hand side
/// in `sc.rhs`; with `spinning`, minus the turning frame's `h (C + h Z)` and plus `h^2 Z w`.
fn dense_system<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    w: &[T],
    h: T,
    model: TorqueModel,
    spinning: bool,
    sc: &mut Scratch<T>,
) {
    let m2 = w.len();
    let h2 = h * h;
    strand::jacobian_of_load(m2, model, sc);
    for l in 0..m2 {
        let row = l * m2;
        let mut jw = T::zero();
        for c in 0..m2 {
            let j = sc.jac[row + c];
            jw += j * w[c];
            sc.lu[row + c] = -h2 * j;
        }
        let (d, b) = diagonal_and_rhs(root, p, sc, w, h, l, jw);
        sc.lu[row + l] += d;
        sc.rhs[l] = b;
        if spinning {
            for c in 0..m2 {
                let entry = rotating_frame::frame_entry(sc, model, l, c);
                sc.lu[row + c] -= h * entry;
            }
            sc.rhs[l] += h2 * sc.frame_zw[l];
        }
    }
}

/// Row `l` of the coupled system `diag(D) - h^2 J`, `b`, apart from `J`: the diagonal
/// `D_l = I_l + h g + h^2 k` and the right-hand side `b_l = h tau_l + h^2 ((J w)_l - k w_l)`,
/// given `(J w)_l`.
#[inline]
pub(super) fn diagonal_and_rhs<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    sc: &Scratch<T>,
    w: &[T],
    h: T,
    l: usize,
    jw: T,
) -> (T, T) {
    let i = l / 2 + 1;
    let k = spring_of(root, p, i, l);
    let h2 = h * h;
    (
        sc.inertia[l] + h * p.damping[i] + h2 * k,
        h * sc.tau[l] + h2 * (jw - k * w[l]),
    )
}

/// The axes of joint `j` (0-based) as the columns of a 3 x 2 matrix.
#[inline]
pub(super) fn joint_axes<T: RealField + Copy>(sc: &Scratch<T>, j: usize) -> Matrix3x2<T> {
    Matrix3x2::from_columns(&[sc.axes[2 * j], sc.axes[2 * j + 1]])
}

/// Solves the system of [`dense_solve`] in `O(n)` into `sc.rhs`. Returns `false`, leaving `sc.rhs`
/// unspecified, when a joint's 2 x 2 block is singular or the residual check fails.
///
/// With `x_j` the two unknowns of joint `j`, `A_j` its axes, `W_j` and `V_j` the Jacobian's
/// generators (`load_row_generator`, `load_column_generator`), the rows of joint `j` read
/// `D_j x_j - h^2 (W_j^T pre_j + A_j^T suf_j) = b_j`, with `pre_j = sum_{k<j} A_k x_k` and
/// `suf_j = sum_{k>=j} V_k x_k` (only `k = j` for the local model). From the tip, `suf_{j+1}` is an
/// affine function of `pre_{j+1}` (`M pre + r`, zero past the tip), so each joint's rows give
/// `x_j = E_j pre_j + e_j` from one 2 x 2 solve, and `M`, `r` move one joint up. From the root,
/// `pre_1 = 0` then gives every `x_j` in turn.
fn structured_solve<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    w: &[T],
    h: T,
    model: TorqueModel,
    sc: &mut Scratch<T>,
) -> bool {
    let joints = w.len() / 2;
    let h2 = h * h;
    let chain = model == TorqueModel::Chain;
    let velocity = |j: usize| Vector2::new(w[2 * j], w[2 * j + 1]);
    velocity_prefix_sums(w, sc);

    // Tip to root: J w, the right-hand side, and the elimination.
    let mut gain_m = Matrix3::zeros();
    let mut gain_r = Vector3::zeros();
    let mut suffix_w = Vector3::zeros();
    for j in (0..joints).rev() {
        let node = j + 1;
        let a = joint_axes(sc, j);
        let v = Matrix3x2::from_columns(&[
            strand::load_column_generator(sc, node, a.column(0).into_owned()),
            strand::load_column_generator(sc, node, a.column(1).into_owned()),
        ]);
        let wg = Matrix3x2::from_columns(&[
            strand::load_row_generator(sc, node, a.column(0).into_owned()),
            strand::load_row_generator(sc, node, a.column(1).into_owned()),
        ]);
        if !chain {
            // The local model's load couples a joint to itself and the joints before it only.
            gain_m = Matrix3::zeros();
            gain_r = Vector3::zeros();
            suffix_w = Vector3::zeros();
        }
        let wj = velocity(j);
        suffix_w += v * wj;
        let jw = wg.tr_mul(&sc.sweep_prefix[j]) + a.tr_mul(&suffix_w);
        let mut d = Vector2::zeros();
        let mut b = Vector2::zeros();
        for t in 0..2 {
            (d[t], b[t]) = diagonal_and_rhs(root, p, sc, w, h, 2 * j + t, jw[t]);
        }
        // suf_j = G x_j + M pre_j + r with G = M A_j + V_j.
        let g = gain_m * a + v;
        let block = Matrix2::from_diagonal(&d) - a.tr_mul(&g) * h2;
        let Some(inverse) = invert_2x2(&block) else {
            return false;
        };
        let coupling = (wg.transpose() + a.tr_mul(&gain_m)) * h2;
        let gain = inverse * coupling;
        let offset = inverse * (b + a.tr_mul(&gain_r) * h2);
        gain_m += g * gain;
        gain_r += g * offset;
        sc.sweep_v[j] = v;
        sc.sweep_w[j] = wg;
        sc.sweep_gain[j] = gain;
        sc.sweep_offset[j] = offset;
        sc.sweep_diag[j] = d;
        sc.sweep_rhs[j] = b;
        sc.sweep_inverse[j] = inverse;
        sc.sweep_g[j] = g;
    }
    sc.sweep_factored = true;
    solve_and_check(joints, h2, chain, sc)
}

/// Root to tip, the prefix sums `sum_{k<j} A_k w_k` of the joints' rates `w` into
/// `sc.sweep_prefix` (J w needs them on the right-hand side).
pub(super) fn velocity_prefix_sums<T: RealField + Copy>(w: &[T], sc: &mut Scratch<T>) {
    let mut prefix = Vector3::zeros();
    for j in 0..w.len() / 2 {
        sc.sweep_prefix[j] = prefix;
        prefix += joint_axes(sc, j) * Vector2::new(w[2 * j], w[2 * j + 1]);
    }
}

/// [`structured_solve`] for a new right-hand side of the system whose factors `sc.sweep_*`
/// hold: the same arithmetic on the right-hand side, in the same order, without the matrix's.
fn structured_solve_again<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    w: &[T],
    h: T,
    model: TorqueModel,
    sc: &mut Scratch<T>,
) -> bool {
    let joints = w.len() / 2;
    let h2 = h * h;
    let chain = model == TorqueModel::Chain;
    let velocity = |j: usize| Vector2::new(w[2 * j], w[2 * j + 1]);
    velocity_prefix_sums(w, sc);
    let mut gain_r = Vector3::zeros();
    let mut suffix_w = Vector3::zeros();
    for j in (0..joints).rev() {
        let a = joint_axes(sc, j);
        if !chain {
            gain_r = Vector3::zeros();
            suffix_w = Vector3::zeros();
        }
        suffix_w += sc.sweep_v[j] * velocity(j);
        let jw = sc.sweep_w[j].tr_mul(&sc.sweep_prefix[j]) + a.tr_mul(&suffix_w);
        let mut b = Vector2::zeros();
        for t in 0..2 {
            b[t] = diagonal_and_rhs(root, p, sc, w, h, 2 * j + t, jw[t]).1;
        }
        let offset = sc.sweep_inverse[j] * (b + a.tr_mul(&gain_r) * h2);
        gain_r += sc.sweep_g[j] * offset;
        sc.sweep_offset[j] = offset;
        sc.sweep_rhs[j] = b;
    }
    solve_and_check(joints, h2, chain, sc)
}

/// The structured solve's last two passes, from the gains and offsets in `sc.sweep_*`: the
/// unknowns root to tip into `sc.rhs`, then the residual check tip to root.
fn solve_and_check<T: RealField + Copy>(
    joints: usize,
    h2: T,
    chain: bool,
    sc: &mut Scratch<T>,
) -> bool {
    // Root to tip: the unknowns; the prefix sums of A x are kept for the residual.
    let mut prefix = Vector3::zeros();
    for j in 0..joints {
        let x = sc.sweep_gain[j] * prefix + sc.sweep_offset[j];
        sc.rhs[2 * j] = x[0];
        sc.rhs[2 * j + 1] = x[1];
        sc.sweep_prefix[j] = prefix;
        prefix += joint_axes(sc, j) * x;
    }

    // Tip to root: the residual of every row against the size of its terms. An elimination
    // without pivoting can lose accuracy where a partial system is near singular; the check
    // catches that and the caller redoes the solve densely.
    let mut suffix = Vector3::zeros();
    let mut worst = T::zero();
    let mut scale = T::zero();
    for j in (0..joints).rev() {
        let x = Vector2::new(sc.rhs[2 * j], sc.rhs[2 * j + 1]);
        if !chain {
            suffix = Vector3::zeros();
        }
        suffix += sc.sweep_v[j] * x;
        let left = sc.sweep_w[j].tr_mul(&sc.sweep_prefix[j]) * h2;
        let right = joint_axes(sc, j).tr_mul(&suffix) * h2;
        let diag = sc.sweep_diag[j].component_mul(&x);
        let b = sc.sweep_rhs[j];
        for t in 0..2 {
            let residual = diag[t] - left[t] - right[t] - b[t];
            let size = diag[t].abs() + left[t].abs() + right[t].abs() + b[t].abs();
            // `max` would pass over a NaN: an overflowed solve fails here instead.
            if !(residual.is_finite() && size.is_finite()) {
                return false;
            }
            worst = worst.max(residual.abs());
            scale = scale.max(size);
        }
    }
    worst <= residual_tolerance::<T>() * scale
}

/// Relative residual the structured solve must meet: the square root of the precision (3e-4 in
/// f32, 1.5e-8 in f64), far above a sound solve's rounding and far below a broken one's error.
pub(super) fn residual_tolerance<T: RealField + Copy>() -> T {
    T::default_epsilon().sqrt()
}

/// The inverse of a 2 x 2 matrix, or `None` if its determinant is zero or not finite.
#[inline]
pub(super) fn invert_2x2<T: RealField + Copy>(m: &Matrix2<T>) -> Option<Matrix2<T>> {
    let det = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
    if det == T::zero() || !det.is_finite() {
        return None;
    }
    let inv = T::one() / det;
    Some(Matrix2::new(
        m[(1, 1)] * inv,
        -m[(0, 1)] * inv,
        -m[(1, 0)] * inv,
        m[(0, 0)] * inv,
    ))
}

/// Solves `A x = b` for a row-major `n x n` matrix in place (`b` becomes `x`). Returns `false`
/// when a pivot is exactly zero.
pub(crate) fn lu_solve_in_place<T: RealField + Copy>(
    a: &mut [T],
    perm: &mut [usize],
    b: &mut [T],
    n: usize,
) -> bool {
    for (i, p) in perm.iter_mut().enumerate().take(n) {
        *p = i;
    }
    for k in 0..n {
        // Pivot: the largest magnitude in column k at or below the diagonal.
        let mut piv = k;
        let mut best = a[k * n + k].abs();
        for r in k + 1..n {
            let v = a[r * n + k].abs();
            if v > best {
                best = v;
                piv = r;
            }
        }
        if best == T::zero() {
            return false;
        }
        if piv != k {
            for c in 0..n {
                a.swap(k * n + c, piv * n + c);
            }
            b.swap(k, piv);
            perm.swap(k, piv);
        }
        let inv = T::one() / a[k * n + k];
        for r in k + 1..n {
            let f = a[r * n + k] * inv;
            if f != T::zero() {
                a[r * n + k] = f;
                let (top, bottom) = a.split_at_mut(r * n);
                let pivot_row = &top[k * n + k + 1..k * n + n];
                let row = &mut bottom[k + 1..n];
                for (x, y) in row.iter_mut().zip(pivot_row) {
                    *x -= f * *y;
                }
                let bk = b[k];
                b[r] -= f * bk;
            }
        }
    }
    for k in (0..n).rev() {
        let mut s = b[k];
        for c in k + 1..n {
            s -= a[k * n + c] * b[c];
        }
        b[k] = s / a[k * n + k];
    }
    true
}

/// faer's LU as the reference solver (f32 and f64).
fn faer_solve<T: RealField + Copy>(a: &[T], b: &mut [T], n: usize) -> bool {
    // faer is generic over its own field trait; go through f64, which is exact for f32 input.
    let m = faer::Mat::<f64>::from_fn(n, n, |r, c| {
        nalgebra::try_convert::<T, f64>(a[r * n + c]).unwrap_or(f64::NAN)
    });
    let rhs = faer::Mat::<f64>::from_fn(n, 1, |r, _| {
        nalgebra::try_convert::<T, f64>(b[r]).unwrap_or(f64::NAN)
    });
    let lu = m.partial_piv_lu();
    let x = faer::linalg::solvers::Solve::solve(&lu, &rhs);
    let mut ok = true;
    for r in 0..n {
        let v = x[(r, 0)];
        ok &= v.is_finite();
        b[r] = T::from_f64(v).unwrap_or_else(T::zero);
    }
    ok
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Environment;
    use nalgebra::Matrix3 as M3;
    use proptest::prelude::*;

    /// A random strand in `T` with its torques and the Jacobian's sums evaluated, ready to solve.
    #[derive(Clone)]
    struct Case<T: RealField + Copy + Default> {
        root: RootDyn<T>,
        q: Vec<T>,
        w: Vec<T>,
        length: Vec<T>,
        params: Vec<Vec<T>>,
        rest_points: Vec<Vector3<T>>,
        external: Vec<Vector3<T>>,
        /// The head frame's angular velocity (rad/s), zero for a still head.
        spin: crate::Vector,
    }

    /// A strand of `n` nodes: angles up to `bend` rad (and velocities to `6 bend` rad/s) from
    /// straight, a random load of up to `load` N per node (the weight is about 2e-4 N).
    fn case<T: RealField + Copy + Default>(
        n: usize,
        seed: u64,
        bend: f64,
        load: f64,
        free: bool,
    ) -> Case<T> {
        let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut rnd = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let t = |x: f64| T::from_f64(x).unwrap();
        let q = (0..2 * (n - 1)).map(|_| t(2.0 * bend * rnd())).collect();
        let w = (0..2 * (n - 1)).map(|_| t(12.0 * bend * rnd())).collect();
        let length: Vec<T> = (0..n).map(|_| t(0.01 * (1.0 + rnd()))).collect();
        let mut rest = vec![Vector3::zeros(); n];
        for i in 1..n {
            rest[i] = rest[i - 1] + Vector3::new(t(rnd()), t(-1.0), t(rnd())) * length[i];
        }
        // rest_theta, rest_phi, mass, wetness, k_theta, k_phi, damping
        let scales = [1.0, 1.0, 2e-5, 1e-5, 2e-4, 2e-4, 2e-6];
        let params = scales
            .iter()
            .map(|s| (0..n).map(|_| t(s * (0.6 + rnd()))).collect())
            .collect();
        let external = (0..n)
            .map(|_| Vector3::new(t(rnd()), t(rnd()), t(rnd())) * t(load))
            .collect();
        Case {
            root: RootDyn {
                position: Vector3::new(t(0.01), t(0.1), t(0.0)),
                rotation: M3::identity(),
                velocity: Vector3::new(t(rnd()), t(rnd()), t(rnd())),
                free,
            },
            q,
            w,
            length,
            params,
            rest_points: rest,
            external,
            spin: crate::Vector::zeros(),
        }
    }

    impl<T: RealField + Copy + Default> Case<T> {
        fn params(&self) -> StrandParams<'_, T> {
            StrandParams {
                rest_theta: &self.params[0],
                rest_phi: &self.params[1],
                mass: &self.params[2],
                wetness: &self.params[3],
                k_theta: &self.params[4],
                k_phi: &self.params[5],
                damping: &self.params[6],
                rest_points: &self.rest_points,
                external: &self.external,
            }
        }

        /// The same strand in a head frame turning at `spin` (rad/s).
        fn spinning(mut self, spin: crate::Vector) -> Self {
            self.spin = spin;
            self
        }

        /// The turning frame's angular velocity in `T`, if it turns.
        fn frame_spin(&self) -> Option<Vector3<T>> {
            (self.spin.norm_squared() > 0.0).then(|| self.spin.map(|x| T::from_f32(x).unwrap()))
        }

        /// `dw` of the coupled step by `solver` (`None` if it declined).
        fn solve(&self, h: f64, model: TorqueModel, solver: LinearSolver) -> Option<Vec<T>> {
            let mut sc = self.evaluated(model);
            let h = T::from_f64(h).unwrap();
            let p = self.params();
            let spin = self.frame_spin();
            if let Some(omega) = spin {
                rotating_frame::prepare(&p, self.w.len() / 2, h, &omega, model, &mut sc);
            }
            let ok = match (solver, spin) {
                (LinearSolver::Structured, None) => {
                    structured_solve(&self.root, &p, &self.w, h, model, &mut sc)
                }
                (LinearSolver::Structured, Some(_)) => {
                    rotating_frame::structured_solve(&self.root, &p, &self.w, h, model, &mut sc)
                }
                (dense, spin) => dense_solve(
                    &self.root,
                    &p,
                    &self.w,
                    h,
                    model,
                    dense,
                    spin.is_some(),
                    &mut sc,
                ),
            };
            ok.then(|| sc.rhs[..self.w.len()].to_vec())
        }

        /// The dense system (row-major matrix, right-hand side).
        fn system(&self, h: f64, model: TorqueModel) -> (Vec<T>, Vec<T>) {
            let mut sc = self.evaluated(model);
            let m2 = self.w.len();
            let h = T::from_f64(h).unwrap();
            let spin = self.frame_spin();
            if let Some(omega) = spin {
                rotating_frame::prepare(&self.params(), m2 / 2, h, &omega, model, &mut sc);
            }
            dense_system(
                &self.root,
                &self.params(),
                &self.w,
                h,
                model,
                spin.is_some(),
                &mut sc,
            );
            (sc.lu[..m2 * m2].to_vec(), sc.rhs[..m2].to_vec())
        }

        fn evaluated(&self, model: TorqueModel) -> Scratch<T> {
            let mut env = Environment::default();
            env.head.angular_velocity = self.spin;
            let local = env.local::<T>();
            let p = self.params();
            let mut sc = Scratch::default();
            sc.reserve(self.length.len(), true);
            strand::forward(&self.root, &self.q, &self.w, &self.length, &mut sc);
            strand::forces(&self.root, &p, &self.length, &local, &mut sc);
            strand::torques(
                &self.root,
                &p,
                &self.q,
                &self.w,
                &self.length,
                model,
                true,
                &mut sc,
            );
            sc
        }
    }

    /// Normwise backward error of `x` for `A x = b`: `|A x - b| / (|A| |x| + |b|)` (infinity norms).
    fn backward_error(a: &[f64], b: &[f64], x: &[f64]) -> f64 {
        let n = b.len();
        let mut residual = 0.0_f64;
        let mut norm_a = 0.0_f64;
        for r in 0..n {
            let row = &a[r * n..(r + 1) * n];
            let ax: f64 = row.iter().zip(x).map(|(a, x)| a * x).sum();
            residual = residual.max((ax - b[r]).abs());
            norm_a = norm_a.max(row.iter().map(|v| v.abs()).sum());
        }
        residual / (norm_a * max_abs(x) + max_abs(b))
    }

    /// Infinity-norm condition number of the dense `n x n` matrix `a` (row-major), by
    /// Gauss-Jordan inversion with partial pivoting: how far a tiny backward error can move the
    /// answer.
    fn condition(a: &[f64], n: usize) -> f64 {
        let norm = |m: &[f64]| {
            (0..n)
                .map(|r| m[r * n..(r + 1) * n].iter().map(|v| v.abs()).sum::<f64>())
                .fold(0.0, f64::max)
        };
        let (mut m, mut inv) = (a.to_vec(), vec![0.0; n * n]);
        for i in 0..n {
            inv[i * n + i] = 1.0;
        }
        for c in 0..n {
            let p = (c..n)
                .max_by(|&i, &j| m[i * n + c].abs().total_cmp(&m[j * n + c].abs()))
                .unwrap_or(c);
            for k in 0..n {
                m.swap(c * n + k, p * n + k);
                inv.swap(c * n + k, p * n + k);
            }
            let d = m[c * n + c];
            for k in 0..n {
                m[c * n + k] /= d;
                inv[c * n + k] /= d;
            }
            for r in (0..n).filter(|&r| r != c) {
                let f = m[r * n + c];
                for k in 0..n {
                    m[r * n + k] -= f * m[c * n + k];
                    inv[r * n + k] -= f * inv[c * n + k];
                }
            }
        }
        norm(a) * norm(&inv)
    }

    fn max_abs<T: RealField + Copy>(v: &[T]) -> T {
        v.iter().fold(T::zero(), |m, x| m.max(x.abs()))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)))]

        /// The structured solve solves the dense system: wherever it accepts its answer, the
        /// answer's backward error in the dense system is at rounding level (f64), for both load
        /// models, clamped and free roots, any step and loads up to a thousand times the weight
        /// (compressive ones included); and on systems faer solves with a modest answer it is
        /// faer's answer, within what the system's conditioning allows.
        #[test]
        fn the_structured_solve_agrees_with_faer(n in 2usize..40, seed in any::<u64>(),
                                                 h in 1e-4f64..0.1, load in 0.0f64..0.2,
                                                 chain in any::<bool>(), free in any::<bool>()) {
            let c = case::<f64>(n, seed, 1.5, load, free);
            let model = if chain { TorqueModel::Chain } else { TorqueModel::Local };
            let faer = c.solve(h, model, LinearSolver::Faer).expect("random systems are not singular");
            let (a, b) = c.system(h, model);
            let structured = c.solve(h, model, LinearSolver::Structured);
            if let Some(x) = structured {
                let error = backward_error(&a, &b, &x);
                // What the residual check guarantees (sqrt of the precision), normwise.
                prop_assert!(error <= 2e-8, "backward error {error:e} (n {n})");
                if max_abs(&faer) < 1e3 {
                    let scale = (1.0 + max_abs(&faer)) * condition(&a, b.len()).max(1.0);
                    for (s, f) in x.iter().zip(&faer) {
                        prop_assert!((s - f).abs() <= 1e-9 * scale, "{s} vs {f} (n {n})");
                    }
                }
            }
        }

        /// A second right-hand side with the same matrix (as the Rosenbrock stages solve), by
        /// `solve_system_again` after `solve_system`, gives the bits a fresh `solve_system` gives,
        /// in f32, for both load models, clamped and free roots; and it reuses the factors
        /// (checked by spoiling the kept inverses afterwards: the answer changes or fails the
        /// residual check, which a full solve would not).
        #[test]
        fn solving_again_with_the_kept_factors_gives_the_fresh_solves_bits(
            n in 2usize..33, seed in any::<u64>(), h in 1e-3f64..0.05,
            chain in any::<bool>(), free in any::<bool>()) {
            let c = case::<f32>(n, seed, 0.8, 0.0, free);
            let model = if chain { TorqueModel::Chain } else { TorqueModel::Local };
            let settings = StepSettings { torque: model, ..StepSettings::default() };
            let p = c.params();
            let h = h as f32;
            let m2 = c.w.len();
            let second_w: Vec<f32> = c.w.iter().map(|x| 0.5 * x - 0.1).collect();
            let second_tau = |sc: &mut Scratch<f32>| {
                for (l, t) in sc.tau[..m2].iter_mut().enumerate() {
                    *t = 1e-5 * (l as f32 - 3.0);
                }
            };
            let mut fresh = c.evaluated(model);
            second_tau(&mut fresh);
            let fresh_ok = solve_system(&c.root, &p, &second_w, h, &settings, None, &mut fresh);
            let mut again = c.evaluated(model);
            prop_assert!(solve_system(&c.root, &p, &c.w, h, &settings, None, &mut again));
            second_tau(&mut again);
            let again_ok = solve_system_again(&c.root, &p, &second_w, h, &settings, &mut again);
            prop_assert_eq!(fresh_ok, again_ok);
            prop_assert_eq!(fresh.dense_fallbacks, again.dense_fallbacks);
            let bits = |sc: &Scratch<f32>| sc.rhs[..m2].iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(bits(&fresh), bits(&again));
            if again.dense_fallbacks == 0 {
                again.sweep_inverse.iter_mut().for_each(|m| *m *= 2.0);
                second_tau(&mut again);
                solve_system_again(&c.root, &p, &second_w, h, &settings, &mut again);
                // The spoiled factors give another answer, or one the residual check declines.
                prop_assert!(bits(&fresh) != bits(&again) || again.dense_fallbacks == 1);
            }
        }

        /// In f32, the runtime's precision, it agrees with the f64 dense solve to the f32 solve's
        /// own accuracy.
        #[test]
        fn the_f32_structured_solve_is_as_accurate_as_f32_lu(n in 2usize..33, seed in any::<u64>(),
                                                             h in 1e-3f64..0.05) {
            let exact = case::<f64>(n, seed, 1.5, 2e-4, false).solve(h, TorqueModel::Chain, LinearSolver::Faer).unwrap();
            let c = case::<f32>(n, seed, 1.5, 2e-4, false);
            let lu = c.solve(h, TorqueModel::Chain, LinearSolver::Hand).unwrap();
            // A decline is redone densely (see the test of the decline rate below).
            let Some(x) = c.solve(h, TorqueModel::Chain, LinearSolver::Structured) else {
                return Ok(());
            };
            let err = |v: &[f32]| v.iter().zip(&exact).map(|(a, b)| (f64::from(*a) - b).abs()).fold(0.0, f64::max);
            let scale = 1.0 + max_abs(&exact);
            prop_assert!(err(&x) <= 1e-4 * scale + 8.0 * err(&lu), "structured {} lu {} scale {scale}", err(&x), err(&lu));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256)))]

        /// In a turning head frame (the Coriolis and centrifugal terms in the system) the
        /// structured solve still solves the dense system: its accepted answers have a backward
        /// error at rounding level and match faer's, for both load models and both roots, at
        /// turning rates up to 20 rad/s (a head shaking 35 degrees at 1.2 Hz peaks at 4.6).
        #[test]
        fn in_a_turning_frame_the_structured_solve_agrees_with_faer(
            n in 2usize..40, seed in any::<u64>(), h in 1e-4f64..0.1, load in 0.0f64..0.2,
            chain in any::<bool>(), free in any::<bool>(),
            spin in prop::array::uniform3(-20.0f32..20.0)) {
            let c = case::<f64>(n, seed, 1.5, load, free).spinning(crate::Vector::from(spin));
            let model = if chain { TorqueModel::Chain } else { TorqueModel::Local };
            let faer = c.solve(h, model, LinearSolver::Faer).expect("random systems are not singular");
            let (a, b) = c.system(h, model);
            if let Some(x) = c.solve(h, model, LinearSolver::Structured) {
                let error = backward_error(&a, &b, &x);
                prop_assert!(error <= 2e-8, "backward error {error:e} (n {n})");
                if max_abs(&faer) < 1e3 {
                    // Two answers at rounding-level backward error differ by up to the
                    // condition number times it: the Coriolis terms make some systems
                    // conditioned in the hundreds.
                    let scale = (1.0 + max_abs(&faer)) * condition(&a, b.len()).max(1.0);
                    for (s, f) in x.iter().zip(&faer) {
                        prop_assert!((s - f).abs() <= 1e-9 * scale, "{s} vs {f} (n {n})");
                    }
                }
            }
        }
    }

    /// The turning frame's terms are the derivatives they stand for: `C` (the `h = 0` part of
    /// `rotating_frame::frame_entry`) matches central differences of the fictitious forces'
    /// torque in the angular velocities (spinning minus still, so springs, damping and gravity
    /// cancel), for both load models; and the centrifugal part `Z`, built from the same `S`, times
    /// `w` is `Z w` as computed directly from the node velocities.
    #[test]
    fn the_turning_frame_terms_are_the_torques_derivatives() {
        let spin = crate::Vector::new(1.5, -4.0, 2.5);
        let eps = 1e-6;
        for model in [TorqueModel::Chain, TorqueModel::Local] {
            let base = case::<f64>(7, 5, 1.0, 0.0, false).spinning(spin);
            let m2 = base.w.len();
            let omega = base.frame_spin().unwrap();
            let entries = |h: f64| {
                let mut sc = base.evaluated(model);
                rotating_frame::prepare(&base.params(), m2 / 2, h, &omega, model, &mut sc);
                let e: Vec<f64> = (0..m2 * m2)
                    .map(|i| rotating_frame::frame_entry(&sc, model, i / m2, i % m2))
                    .collect();
                (e, sc.frame_zw[..m2].to_vec())
            };
            let fictitious = |c: &Case<f64>| {
                let still = Case {
                    spin: crate::Vector::zeros(),
                    ..c.clone()
                };
                let turning = c.evaluated(model).tau[..m2].to_vec();
                let resting = still.evaluated(model).tau[..m2].to_vec();
                turning
                    .iter()
                    .zip(&resting)
                    .map(|(a, b)| a - b)
                    .collect::<Vec<_>>()
            };
            let (coriolis, _) = entries(0.0);
            let mut worst = 0.0_f64;
            let mut largest = 0.0_f64;
            for k in 0..m2 {
                let (mut up, mut down) = (base.clone(), base.clone());
                up.w[k] += eps;
                down.w[k] -= eps;
                let (tu, td) = (fictitious(&up), fictitious(&down));
                for l in 0..m2 {
                    let fd = (tu[l] - td[l]) / (2.0 * eps);
                    worst = worst.max((coriolis[l * m2 + k] - fd).abs());
                    largest = largest.max(fd.abs());
                }
            }
            assert!(
                largest > 0.0 && worst <= 1e-6 * largest,
                "{model:?}: C off by {worst:e} of {largest:e}"
            );
            let (with_z, zw) = entries(1.0);
            for l in 0..m2 {
                let z_w: f64 = (0..m2)
                    .map(|k| (with_z[l * m2 + k] - coriolis[l * m2 + k]) * base.w[k])
                    .sum();
                assert!(
                    (z_w - zw[l]).abs() <= 1e-9 * (1.0 + zw[l].abs()),
                    "{model:?}: (Z w)[{l}] {z_w:e} vs {:e}",
                    zw[l]
                );
            }
        }
    }

    /// How often the structured solve declines (and is redone densely), in f32 on 32-point
    /// strands: never on gently bent strands under their weight, rarely on wildly bent ones under
    /// absurd loads. `--nocapture` prints the rates.
    #[test]
    fn the_structured_solve_rarely_declines() {
        let rate = |bend: f64, load: f64, h: f64, model: TorqueModel| {
            let declined = (0..1000)
                .filter(|&seed| {
                    let c = case::<f32>(32, seed, bend, load, false);
                    c.solve(h, model, LinearSolver::Structured).is_none()
                })
                .count();
            println!(
                "bend {bend} rad, load {load} N, h {h} s, {model:?}: {declined} of 1000 declined"
            );
            declined
        };
        for model in [TorqueModel::Chain, TorqueModel::Local] {
            assert_eq!(rate(0.3, 2e-4, 1.0 / 60.0, model), 0);
            assert!(rate(1.5, 2e-4, 0.05, model) <= 10);
            assert!(rate(1.5, 0.2, 0.05, model) <= 50);
        }
    }

    /// A solve that overflows (a torque near the largest f32) is declined, not accepted with a
    /// residual that `max` passed over.
    #[test]
    fn an_overflowing_solve_is_declined() {
        let c = case::<f32>(8, 3, 1.5, 2e-4, false);
        let model = TorqueModel::Chain;
        let mut sc = c.evaluated(model);
        sc.tau[5] = 3e38;
        assert!(!structured_solve(
            &c.root,
            &c.params(),
            &c.w,
            0.01,
            model,
            &mut sc
        ));
    }

    /// A system whose tip block is singular while the whole is not: the elimination from the
    /// tip cannot go on; `solve_step` counts a fallback and gets the dense answer.
    #[test]
    fn a_singular_tip_block_falls_back_to_the_dense_solve() {
        let c = case::<f64>(3, 7, 1.5, 0.05, false);
        let env = Environment::default();
        let local = env.local::<f64>();
        let p = c.params();
        let (h, model) = (0.01, TorqueModel::Chain);
        let mut sc = Scratch::default();
        sc.reserve(3, true);
        strand::forward(&c.root, &c.q, &c.w, &c.length, &mut sc);
        strand::forces(&c.root, &p, &c.length, &local, &mut sc);
        strand::torques(&c.root, &p, &c.q, &c.w, &c.length, model, true, &mut sc);
        // Choose the tip joint's inertia so that its block diag(d) - h^2 A^T V has a zero
        // determinant: d0 = h^2 X00 + 1, d1 = h^2 X11 + h^4 X01 X10.
        let a = joint_axes(&sc, 1);
        let v = Matrix3x2::from_columns(&[
            strand::load_column_generator(&sc, 2, a.column(0).into_owned()),
            strand::load_column_generator(&sc, 2, a.column(1).into_owned()),
        ]);
        let x = a.tr_mul(&v);
        let h2 = h * h;
        let target = [
            h2 * x[(0, 0)] + 1.0,
            h2 * x[(1, 1)] + h2 * h2 * x[(0, 1)] * x[(1, 0)],
        ];
        for t in 0..2 {
            let k = spring_of(&c.root, &p, 2, 2 + t);
            sc.inertia[2 + t] = target[t] - h * p.damping[2] - h2 * k;
        }
        let mut reference = sc.rhs.clone();
        {
            let mut dense = Scratch::default();
            dense.reserve(3, true);
            dense.pos.clone_from(&sc.pos);
            dense.axes.clone_from(&sc.axes);
            dense.tau.clone_from(&sc.tau);
            dense.inertia.clone_from(&sc.inertia);
            dense.sum_pf.clone_from(&sc.sum_pf);
            dense.sum_f.clone_from(&sc.sum_f);
            dense.sum_fp.clone_from(&sc.sum_fp);
            dense.torque_vec.clone_from(&sc.torque_vec);
            assert!(dense_solve(
                &c.root,
                &p,
                &c.w,
                h,
                model,
                LinearSolver::Faer,
                false,
                &mut dense
            ));
            reference[..4].copy_from_slice(&dense.rhs[..4]);
        }
        let (mut q, mut w) = (c.q.clone(), c.w.clone());
        let settings = StepSettings {
            dt: h as f32,
            torque: model,
            solver: LinearSolver::Structured,
            ..StepSettings::default()
        };
        solve_step(&c.root, &p, &mut q, &mut w, h, &settings, None, &mut sc);
        assert_eq!(sc.dense_fallbacks, 1);
        for l in 0..4 {
            let dw = w[l] - c.w[l];
            assert!(
                (dw - reference[l]).abs() <= 1e-9 * (1.0 + reference[l].abs()),
                "{dw} vs {}",
                reference[l]
            );
        }
    }

    #[test]
    fn hand_lu_matches_faer_on_random_systems() {
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 33) as f64 / (1u64 << 31) as f64) - 0.5
        };
        for n in [1usize, 2, 5, 38, 62] {
            let a: Vec<f64> = (0..n * n)
                .map(|i| rnd() + if i % (n + 1) == 0 { 0.1 } else { 0.0 })
                .collect();
            let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut x_hand = b.clone();
            let mut lu = a.clone();
            let mut perm = vec![0; n];
            assert!(lu_solve_in_place(&mut lu, &mut perm, &mut x_hand, n));
            let mut x_faer = b.clone();
            assert!(faer_solve(&a, &mut x_faer, n));
            for (h, f) in x_hand.iter().zip(&x_faer) {
                assert!((h - f).abs() <= 1e-9 * (1.0 + f.abs()), "n={n}: {h} vs {f}");
            }
        }
    }

    #[test]
    fn singular_matrix_is_reported() {
        let mut a = vec![1.0_f64, 2.0, 2.0, 4.0];
        let mut b = vec![1.0, 1.0];
        let mut perm = vec![0; 2];
        assert!(!lu_solve_in_place(&mut a, &mut perm, &mut b, 2));
    }
}
