//! The coupled step in a turning head frame: the Coriolis and centrifugal forces made implicit.
//!
//! In the head's frame every node feels `f = -m (w x (w x x) + 2 w x v)` (`w` the head's angular
//! velocity). Held as a dead load, the Coriolis part is an explicit gyroscopic term: explicit Euler
//! on a skew term gains energy every step, and a fast-turning head (the `shake` scene) blows up.
//! Here its derivative with respect to the angular velocities (`C`) and the centrifugal force's
//! derivative with respect to the node positions (`Z`, a stiffness) join the step's matrix:
//! `(I + h G + h^2 (K - J) - h C - h^2 Z) dw = h tau + h^2 ((J + Z) w - K w)`.
//!
//! Both are of the form `xi_l^T S xi_k` with `xi_k = (a_k, c_k x a_k)` the twist of coordinate `k`
//! (axis `a_k` through pivot `c_k`) and `S` the sum, over the nodes both coordinates move, of
//! `[[x]x; 1] N [-[x]x, 1]`, where `N = -m [w]x (2 + h [w]x)` turns a node's velocity change into
//! the force change (`C + h Z` at once; the matrix takes `h` times it). The elimination of the structured solve then carries
//! six-dimensional prefix sums (the twists) and nine-dimensional suffix sums (the load's three and
//! the twists' six) in place of three and three: still `O(n)`.

use super::implicit_coupled::{self, diagonal_and_rhs, invert_2x2, joint_axes, residual_tolerance};
use crate::TorqueModel;
use crate::strand::{self, RootDyn, Scratch, StrandParams};
use nalgebra::{Matrix2, Matrix3, Matrix6, RealField, SMatrix, Vector2, Vector3, Vector6};

type Twists<T> = SMatrix<T, 6, 2>;
type Suffix<T> = SMatrix<T, 9, 2>;

/// Sizes the rotating-frame buffers for `joints` joints; allocates only when the strand grows.
fn reserve<T: RealField + Copy>(sc: &mut Scratch<T>, joints: usize) {
    let grow = |len: usize| joints.saturating_sub(len);
    let extra = grow(sc.frame_s.len());
    sc.frame_s
        .extend(std::iter::repeat_n(Matrix6::zeros(), extra));
    let extra = grow(sc.frame_u.len());
    sc.frame_u
        .extend(std::iter::repeat_n(Suffix::zeros(), extra));
    let extra = grow(sc.frame_l.len());
    sc.frame_l
        .extend(std::iter::repeat_n(Twists::zeros(), extra));
    let extra = grow(sc.frame_gain.len());
    sc.frame_gain
        .extend(std::iter::repeat_n(SMatrix::<T, 2, 6>::zeros(), extra));
    let extra = grow(sc.frame_prefix.len());
    sc.frame_prefix
        .extend(std::iter::repeat_n(Vector6::zeros(), extra));
    let extra = (2 * joints).saturating_sub(sc.frame_zw.len());
    sc.frame_zw.extend(std::iter::repeat_n(T::zero(), extra));
}

/// The skew matrix `[v]x` (`[v]x u = v x u`).
#[inline]
fn skew<T: RealField + Copy>(v: &Vector3<T>) -> Matrix3<T> {
    v.cross_matrix()
}

/// The twists of joint `j`'s two coordinates as the columns of a 6 x 2 matrix.
#[inline]
fn joint_twists<T: RealField + Copy>(sc: &Scratch<T>, j: usize) -> Twists<T> {
    let c = sc.pos[j];
    let mut xi = Twists::zeros();
    for t in 0..2 {
        let a = sc.axes[2 * j + t];
        xi.fixed_view_mut::<3, 1>(0, t).copy_from(&a);
        xi.fixed_view_mut::<3, 1>(3, t).copy_from(&c.cross(&a));
    }
    xi
}

/// Fills, from the kinematics in `sc`, each joint's `S` (with `C + h Z` in it) and `Z w` per
/// coordinate (for the right-hand side). `omega` is the head's angular velocity (head frame).
pub(super) fn prepare<T: RealField + Copy>(
    p: &StrandParams<'_, T>,
    joints: usize,
    h: T,
    omega: &Vector3<T>,
    model: TorqueModel,
    sc: &mut Scratch<T>,
) {
    reserve(sc, joints);
    let two = T::one() + T::one();
    let wx = skew(omega);
    let gain = -(wx * (Matrix3::identity() * two + wx * h));
    let mut s = Matrix6::zeros();
    let mut load = Vector3::zeros();
    let mut torque = Vector3::zeros();
    for j in (0..joints).rev() {
        let i = j + 1;
        let m = p.mass[i] + p.wetness[i];
        let x = sc.pos[i];
        let xx = skew(&x);
        // H = [[x]x; 1] (m gain) [-[x]x, 1].
        let n = gain * m;
        let mut h_node = Matrix6::zeros();
        h_node
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(-(xx * n * xx)));
        h_node.fixed_view_mut::<3, 3>(0, 3).copy_from(&(xx * n));
        h_node.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-(n * xx)));
        h_node.fixed_view_mut::<3, 3>(3, 3).copy_from(&n);
        // Z w: the torque of the centrifugal force's change along the velocity the angles make.
        let u = sc.vel[i] - sc.vel[0];
        let f = -omega.cross(&omega.cross(&u)) * m;
        let seg = x - sc.pos[j];
        match model {
            TorqueModel::Chain => {
                s += h_node;
                load += f;
                torque += seg.cross(&load);
            }
            TorqueModel::Local => {
                s = h_node;
                torque = seg.cross(&f);
            }
        }
        sc.frame_s[j] = s;
        sc.frame_zw[2 * j] = sc.axes[2 * j].dot(&torque);
        sc.frame_zw[2 * j + 1] = sc.axes[2 * j + 1].dot(&torque);
    }
}

/// `(C + h Z)_lk` after `prepare`: row `l`, column `k` of the frame's terms.
pub(super) fn frame_entry<T: RealField + Copy>(
    sc: &Scratch<T>,
    model: TorqueModel,
    l: usize,
    k: usize,
) -> T {
    let (jl, jk) = (l / 2, k / 2);
    let s = match model {
        TorqueModel::Chain => &sc.frame_s[jl.max(jk)],
        // A joint's own node only, which the joints at and before it move.
        TorqueModel::Local if jk <= jl => &sc.frame_s[jl],
        TorqueModel::Local => return T::zero(),
    };
    let xl = joint_twists(sc, jl).column(l % 2).into_owned();
    let xk = joint_twists(sc, jk).column(k % 2).into_owned();
    xl.dot(&(s * xk))
}

/// The structured solve of the rotating frame's system into `sc.rhs` (see the module's top), after
/// `prepare`. Returns `false` where the plain solve would: a singular 2 x 2 block or a failed
/// residual check.
///
/// With `x_j` joint `j`'s unknowns, `pre_j = sum_{k<j} xi_k x_k` and
/// `sig_j = (sum_{k>=j} V_k x_k, sum_{k>=j} S_k xi_k x_k)`, joint `j`'s rows read
/// `D_j x_j - L_j^T pre_j - R_j^T sig_j = b_j` with `L_j = (h^2 W_j, 0) + h S_j^T xi_j` and
/// `R_j = (h^2 A_j, h xi_j)`; from the tip `sig` is affine in `pre` as in the plain solve.
pub(super) fn structured_solve<T: RealField + Copy>(
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
    implicit_coupled::velocity_prefix_sums(w, sc);

    let mut gain_m = SMatrix::<T, 9, 6>::zeros();
    let mut gain_r = SMatrix::<T, 9, 1>::zeros();
    let mut suffix_w = Vector3::zeros();
    for j in (0..joints).rev() {
        let node = j + 1;
        let a = joint_axes(sc, j);
        let xi = joint_twists(sc, j);
        let col = |f: fn(&Scratch<T>, usize, Vector3<T>) -> Vector3<T>, t: usize| {
            f(sc, node, a.column(t).into_owned())
        };
        let v = nalgebra::Matrix3x2::from_columns(&[
            col(strand::load_column_generator, 0),
            col(strand::load_column_generator, 1),
        ]);
        let wg = nalgebra::Matrix3x2::from_columns(&[
            col(strand::load_row_generator, 0),
            col(strand::load_row_generator, 1),
        ]);
        if !chain {
            gain_m = SMatrix::zeros();
            gain_r = SMatrix::zeros();
            suffix_w = Vector3::zeros();
        }
        let wj = velocity(j);
        suffix_w += v * wj;
        let jw = wg.tr_mul(&sc.sweep_prefix[j]) + a.tr_mul(&suffix_w);
        let mut d = Vector2::zeros();
        let mut b = Vector2::zeros();
        for t in 0..2 {
            let l = 2 * j + t;
            (d[t], b[t]) = diagonal_and_rhs(root, p, sc, w, h, l, jw[t]);
            b[t] += h2 * sc.frame_zw[l];
        }
        let s = sc.frame_s[j];
        let mut u = Suffix::zeros();
        u.fixed_view_mut::<3, 2>(0, 0).copy_from(&v);
        u.fixed_view_mut::<6, 2>(3, 0).copy_from(&(s * xi));
        let mut r = Suffix::zeros();
        r.fixed_view_mut::<3, 2>(0, 0).copy_from(&(a * h2));
        r.fixed_view_mut::<6, 2>(3, 0).copy_from(&(xi * h));
        let mut left = s.tr_mul(&xi) * h;
        let top = left.fixed_view::<3, 2>(0, 0) + wg * h2;
        left.fixed_view_mut::<3, 2>(0, 0).copy_from(&top);

        let g = u + gain_m * xi;
        let block = Matrix2::from_diagonal(&d) - r.tr_mul(&g);
        let Some(inverse) = invert_2x2(&block) else {
            return false;
        };
        let gain = inverse * (left.transpose() + r.tr_mul(&gain_m));
        let offset = inverse * (b + r.tr_mul(&gain_r));
        gain_m += g * gain;
        gain_r += g * offset;
        sc.frame_u[j] = u;
        sc.frame_l[j] = left;
        sc.frame_gain[j] = gain;
        sc.sweep_offset[j] = offset;
        sc.sweep_diag[j] = d;
        sc.sweep_rhs[j] = b;
    }

    // Root to tip: the unknowns, keeping the twists' prefix sums for the residual.
    let mut prefix = Vector6::zeros();
    for j in 0..joints {
        let x = sc.frame_gain[j] * prefix + sc.sweep_offset[j];
        sc.rhs[2 * j] = x[0];
        sc.rhs[2 * j + 1] = x[1];
        sc.frame_prefix[j] = prefix;
        prefix += joint_twists(sc, j) * x;
    }

    // Tip to root: the residual of every row against the size of its terms.
    let mut suffix = SMatrix::<T, 9, 1>::zeros();
    let mut worst = T::zero();
    let mut scale = T::zero();
    for j in (0..joints).rev() {
        let x = Vector2::new(sc.rhs[2 * j], sc.rhs[2 * j + 1]);
        if !chain {
            suffix = SMatrix::zeros();
        }
        suffix += sc.frame_u[j] * x;
        let mut r = Suffix::zeros();
        r.fixed_view_mut::<3, 2>(0, 0)
            .copy_from(&(joint_axes(sc, j) * h2));
        r.fixed_view_mut::<6, 2>(3, 0)
            .copy_from(&(joint_twists(sc, j) * h));
        let left = sc.frame_l[j].tr_mul(&sc.frame_prefix[j]);
        let right = r.tr_mul(&suffix);
        let diag = sc.sweep_diag[j].component_mul(&x);
        let b = sc.sweep_rhs[j];
        for t in 0..2 {
            let residual = diag[t] - left[t] - right[t] - b[t];
            let size = diag[t].abs() + left[t].abs() + right[t].abs() + b[t].abs();
            if !(residual.is_finite() && size.is_finite()) {
                return false;
            }
            worst = worst.max(residual.abs());
            scale = scale.max(size);
        }
    }
    worst <= residual_tolerance::<T>() * scale
}
