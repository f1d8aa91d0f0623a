//! The per-strand kernel: forward kinematics, forces, generalised torques, inertia, Jacobian.
//!
//! Kurihara et al. §2 and Ward & Lin §5.6: every bend angle obeys `I q'' + gamma q' = M`, with `M`
//! the hinge spring plus the moment of the external forces. The kernel is generic over the scalar
//! so the f32 runtime and the f64 reference share one implementation.

use crate::TorqueModel;
use crate::bend::Bend;
use crate::environment::LocalEnv;
use nalgebra::{
    Matrix2, Matrix2x3, Matrix3, Matrix3x2, Matrix6, RealField, SMatrix, Vector2, Vector3, Vector6,
};

/// Read-only per-node parameters of one strand (slices of length `n`).
#[derive(Clone, Copy)]
pub(crate) struct StrandParams<'a, T> {
    pub rest_theta: &'a [T],
    pub rest_phi: &'a [T],
    pub mass: &'a [T],
    pub wetness: &'a [T],
    pub k_theta: &'a [T],
    pub k_phi: &'a [T],
    pub damping: &'a [T],
    /// Rest shape (any frame): fixes each coordinate's inertia, see [`torques`].
    pub rest_points: &'a [Vector3<T>],
    /// Extra force per node (head frame), or empty.
    pub external: &'a [Vector3<T>],
}

/// The root of a strand during a step (head frame).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RootDyn<T: RealField + Copy> {
    pub position: Vector3<T>,
    pub rotation: Matrix3<T>,
    pub velocity: Vector3<T>,
    pub free: bool,
}

/// Scratch for one strand; grows to the longest strand seen and is then reused.
#[derive(Default)]
pub(crate) struct Scratch<T: RealField + Copy> {
    pub pos: Vec<Vector3<T>>,
    pub vel: Vec<Vector3<T>>,
    pub tangent: Vec<Vector3<T>>,
    /// World axes of the two coordinates of each joint: `axes[2i]`, `axes[2i+1]` for joint i+1.
    pub axes: Vec<Vector3<T>>,
    pub force: Vec<Vector3<T>>,
    /// Generalised torque per coordinate (spring, damping and external).
    pub tau: Vec<T>,
    /// Diagonal inertia per coordinate.
    pub inertia: Vec<T>,
    /// Axial tension of each segment (N), for stretch springs.
    pub tension: Vec<T>,
    /// Acceleration of a free root.
    pub root_acc: Vector3<T>,
    // Suffix sums for the Jacobian, per joint.
    pub sum_pf: Vec<Matrix3<T>>,
    pub sum_f: Vec<Vector3<T>>,
    pub sum_fp: Vec<T>,
    pub torque_vec: Vec<Vector3<T>>,
    /// Dense Jacobian of the external torque, row-major `2m x 2m` (dense solvers only).
    pub jac: Vec<T>,
    // The structured solve, per joint: the Jacobian's generators `V` (columns beyond the joint)
    // and `W` (columns before it), the elimination's gain `E` and offset `e`, the prefix sum of
    // the axes weighted by a vector, and the diagonal and right-hand side of the joint's rows.
    pub sweep_v: Vec<Matrix3x2<T>>,
    pub sweep_w: Vec<Matrix3x2<T>>,
    pub sweep_gain: Vec<Matrix2x3<T>>,
    pub sweep_offset: Vec<Vector2<T>>,
    pub sweep_prefix: Vec<Vector3<T>>,
    pub sweep_diag: Vec<Vector2<T>>,
    pub sweep_rhs: Vec<Vector2<T>>,
    /// The structured solve's per-joint factors that depend on the matrix only (the 2 x 2
    /// block's inverse, `G = M A + V`), kept so that another right-hand side with the same
    /// matrix skips the elimination's matrix work (the Rosenbrock stages).
    pub sweep_inverse: Vec<Matrix2<T>>,
    pub sweep_g: Vec<Matrix3x2<T>>,
    /// Whether `sweep_*` hold the factors of the last system `solve_system` was given.
    pub sweep_factored: bool,
    // The turning head frame's terms (`integrate::rotating_frame`), per joint: the sum `S` over
    // the nodes it carries, the suffix and row generators, the gain, the prefix sum of the twists;
    // and `Z w` per coordinate. Sized on first use in a turning frame.
    pub frame_s: Vec<Matrix6<T>>,
    pub frame_u: Vec<SMatrix<T, 9, 2>>,
    pub frame_l: Vec<SMatrix<T, 6, 2>>,
    pub frame_gain: Vec<SMatrix<T, 2, 6>>,
    pub frame_prefix: Vec<Vector6<T>>,
    pub frame_zw: Vec<T>,
    /// Structured solves that failed their residual check and were redone densely.
    pub dense_fallbacks: usize,
    /// BDF2 steps whose error estimate failed and that were redone as the coupled step.
    pub bdf2_fallbacks: usize,
    /// Rosenbrock steps whose guard found no split within its tolerance and that were redone as
    /// the coupled step.
    pub rosenbrock_fallbacks: usize,
    /// Rosenbrock steps whose guard split them (those redone as the coupled step included).
    pub rosenbrock_splits: usize,
    /// The pieces the next Rosenbrock step's guard starts from (0 or 1: one piece), reset by
    /// that step: a strand the lanes already took in one piece, and whose estimate the guard
    /// did not trust, starts at two.
    pub rosenbrock_first_pieces: u32,
    // Integrator stages.
    pub q0: Vec<T>,
    pub w0: Vec<T>,
    pub stage_q: Vec<T>,
    pub stage_w: Vec<T>,
    pub acc_q: Vec<T>,
    pub acc_w: Vec<T>,
    pub lu: Vec<T>,
    pub rhs: Vec<T>,
    pub perm: Vec<usize>,
    pub len0: Vec<T>,
    // Rosenbrock steps: the stages' unknowns (`uq`, `uw`, stage-major), the stage's torques and
    // angle right-hand side, and spare kinematics buffers (see `integrate::rosenbrock`).
    pub ros_uq: Vec<T>,
    pub ros_uw: Vec<T>,
    pub ros_ftau: Vec<T>,
    pub ros_rq: Vec<T>,
    pub ros_pos: Vec<Vector3<T>>,
    pub ros_axes: Vec<Vector3<T>>,
    pub ros_tension: Vec<T>,
}

impl<T: RealField + Copy> Scratch<T> {
    /// Sizes every buffer for a strand of `n` nodes; allocates only when `n` grows.
    pub fn reserve(&mut self, n: usize, jacobian: bool) {
        let m2 = 2 * n.saturating_sub(1);
        let z3 = Vector3::zeros();
        grow(&mut self.pos, n, z3);
        grow(&mut self.vel, n, z3);
        grow(&mut self.tangent, n, z3);
        grow(&mut self.axes, m2, z3);
        grow(&mut self.force, n, z3);
        grow(&mut self.tau, m2, T::zero());
        grow(&mut self.inertia, m2, T::zero());
        grow(&mut self.tension, n, T::zero());
        grow(&mut self.sum_pf, n + 1, Matrix3::zeros());
        grow(&mut self.sum_f, n + 1, z3);
        grow(&mut self.sum_fp, n + 1, T::zero());
        grow(&mut self.torque_vec, n + 1, z3);
        grow(&mut self.q0, m2, T::zero());
        grow(&mut self.w0, m2, T::zero());
        grow(&mut self.stage_q, m2, T::zero());
        grow(&mut self.stage_w, m2, T::zero());
        grow(&mut self.acc_q, m2, T::zero());
        grow(&mut self.acc_w, m2, T::zero());
        grow(&mut self.rhs, m2, T::zero());
        grow(&mut self.perm, m2, 0);
        grow(&mut self.len0, n, T::zero());
        if jacobian {
            // The dense buffers too: the structured solve falls back to them.
            grow(&mut self.jac, m2 * m2, T::zero());
            grow(&mut self.lu, m2 * m2, T::zero());
            let joints = m2 / 2;
            grow(&mut self.sweep_v, joints, Matrix3x2::zeros());
            grow(&mut self.sweep_w, joints, Matrix3x2::zeros());
            grow(&mut self.sweep_gain, joints, Matrix2x3::zeros());
            grow(&mut self.sweep_offset, joints, Vector2::zeros());
            grow(&mut self.sweep_prefix, joints, z3);
            grow(&mut self.sweep_diag, joints, Vector2::zeros());
            grow(&mut self.sweep_rhs, joints, Vector2::zeros());
            grow(&mut self.sweep_inverse, joints, Matrix2::zeros());
            grow(&mut self.sweep_g, joints, Matrix3x2::zeros());
        }
    }
}

impl<T: RealField + Copy> Scratch<T> {
    /// Sizes the Rosenbrock buffers for a strand of `n` nodes (after [`Scratch::reserve`]).
    pub fn reserve_rosenbrock(&mut self, n: usize) {
        let m2 = 2 * n.saturating_sub(1);
        grow(&mut self.ros_uq, 3 * m2, T::zero());
        grow(&mut self.ros_uw, 3 * m2, T::zero());
        grow(&mut self.ros_ftau, m2, T::zero());
        grow(&mut self.ros_rq, m2, T::zero());
        grow(&mut self.ros_pos, n, Vector3::zeros());
        grow(&mut self.ros_axes, m2, Vector3::zeros());
        grow(&mut self.ros_tension, n, T::zero());
    }
}

fn grow<V: Clone>(v: &mut Vec<V>, n: usize, fill: V) {
    if v.len() < n {
        v.resize(n, fill);
    }
}

/// Positions and velocities of every node from the coordinates (`q`, `w` interleaved as
/// `theta_1, phi_1, theta_2, ...`) and segment lengths.
pub(crate) fn forward<T: RealField + Copy>(
    root: &RootDyn<T>,
    q: &[T],
    w: &[T],
    length: &[T],
    sc: &mut Scratch<T>,
) {
    let n = length.len();
    let mut rot = root.rotation;
    let mut omega = Vector3::zeros();
    sc.pos[0] = root.position;
    sc.vel[0] = if root.free {
        root.velocity
    } else {
        Vector3::zeros()
    };
    for i in 1..n {
        let c = 2 * (i - 1);
        let bend = Bend::new(q[c], q[c + 1]);
        let ax = rot * bend.axis_x;
        let ay = rot * bend.axis_y;
        rot *= bend.rotation;
        let t = rot.column(2).into_owned();
        let seg = t * length[i];
        omega += ax * w[c] + ay * w[c + 1];
        sc.axes[c] = ax;
        sc.axes[c + 1] = ay;
        sc.tangent[i] = t;
        sc.pos[i] = sc.pos[i - 1] + seg;
        sc.vel[i] = sc.vel[i - 1] + omega.cross(&seg);
    }
    if n > 1 {
        sc.tangent[0] = sc.tangent[1];
    }
}

/// Forces on every node (head frame), after [`forward`].
pub(crate) fn forces<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    length: &[T],
    env: &LocalEnv<'_, T>,
    sc: &mut Scratch<T>,
) {
    let n = length.len();
    let two = T::one() + T::one();
    let drag = T::from_f32(env.env.wind.drag).unwrap_or_else(T::zero);
    let has_fields = !env.env.fields.is_empty();
    let mut total_f = Vector3::zeros();
    let mut total_m = T::zero();
    for i in 0..n {
        let m = p.mass[i] + p.wetness[i];
        let x = sc.pos[i];
        let v = sc.vel[i];
        let mut f = env.gravity * m;
        if env.has_frame_motion {
            let fict = env.alpha.cross(&x)
                + env.omega.cross(&env.omega.cross(&x))
                + env.omega.cross(&v) * two;
            f -= fict * m;
        }
        if env.has_air {
            let u = env.air_velocity(&x) - v;
            let t = sc.tangent[i];
            let normal = u - t * u.dot(&t);
            // The root's half segment belongs to segment 1; each node carries its own segment.
            let l = if i == 0 {
                length[1.min(n - 1)]
            } else {
                length[i]
            };
            f += normal * (drag * l);
        }
        if has_fields {
            f += env.field_force(&x, m);
        }
        if !p.external.is_empty() {
            f += p.external[i];
        }
        total_f += f;
        total_m += m;
        sc.force[i] = f;
    }
    sc.root_acc = Vector3::zeros();
    if root.free && total_m > T::zero() {
        // The root translates with the strand's total force; in the root's accelerating frame every
        // node feels the matching fictitious force, so a freely falling piece does not spin.
        let a = total_f / total_m;
        sc.root_acc = a;
        for i in 0..n {
            let m = p.mass[i] + p.wetness[i];
            sc.force[i] -= a * m;
        }
    }
}

/// Generalised torques and diagonal inertia of every coordinate, after [`forces`].
///
/// With `jacobian`, also keeps the suffix sums the derivative of the external torque is made of
/// (see [`jacobian_of_load`] and `docs/dynamics.md`).
#[expect(
    clippy::too_many_arguments,
    reason = "the kernel's inputs are all distinct slices"
)]
pub(crate) fn torques<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    q: &[T],
    w: &[T],
    length: &[T],
    model: TorqueModel,
    jacobian: bool,
    sc: &mut Scratch<T>,
) {
    let n = length.len();
    let floor = T::from_f64(1e-2).unwrap_or_else(T::zero);
    // Suffix sums from the tip: force, mass-weighted moments for the chain inertia.
    let mut s_f = Vector3::zeros();
    let mut t_vec = Vector3::zeros(); // torque of the distal load about the current node
    let mut s_m = T::zero();
    let mut s_mp = Vector3::zeros();
    let mut s_mp2 = T::zero();
    let mut s_pf = Matrix3::zeros();
    let mut s_fp = T::zero();
    if jacobian {
        sc.sum_pf[n] = Matrix3::zeros();
        sc.sum_f[n] = Vector3::zeros();
        sc.sum_fp[n] = T::zero();
        sc.torque_vec[n] = Vector3::zeros();
    }
    for i in (1..n).rev() {
        let c = 2 * (i - 1);
        let pivot = sc.pos[i - 1];
        let fi = sc.force[i];
        let xi = sc.pos[i];
        let mi = p.mass[i] + p.wetness[i];
        let seg = xi - pivot;
        // Inertia about the joint of the load it carries, measured on the rest shape so it does not
        // depend on the configuration: the model is then Hamiltonian (docs/dynamics.md).
        let rp = p.rest_points[i];
        s_m += mi;
        s_mp += rp * mi;
        s_mp2 += rp.norm_squared() * mi;
        let rc = p.rest_points[i - 1];
        let inertia = match model {
            TorqueModel::Chain => s_mp2 - two(rc.dot(&s_mp)) + rc.norm_squared() * s_m,
            TorqueModel::Local => (rp - rc).norm_squared() * mi,
        };
        let (torque, load);
        match model {
            TorqueModel::Chain => {
                s_f += fi;
                t_vec += seg.cross(&s_f);
                torque = t_vec;
                load = s_f;
            }
            TorqueModel::Local => {
                torque = seg.cross(&fi);
                load = fi;
            }
        }
        let min_inertia = floor * mi * length[i] * length[i];
        sc.inertia[c] = inertia.max(min_inertia);
        sc.inertia[c + 1] = sc.inertia[c];
        // A free strand's first joint has no spring: nothing holds it to a scalp.
        let spring = if root.free && i == 1 {
            T::zero()
        } else {
            T::one()
        };
        sc.tau[c] = sc.axes[c].dot(&torque)
            - spring * p.k_theta[i] * (q[c] - p.rest_theta[i])
            - p.damping[i] * w[c];
        sc.tau[c + 1] = sc.axes[c + 1].dot(&torque)
            - spring * p.k_phi[i] * (q[c + 1] - p.rest_phi[i])
            - p.damping[i] * w[c + 1];
        sc.tension[i] = load.dot(&sc.tangent[i]);
        if jacobian {
            match model {
                TorqueModel::Chain => {
                    s_pf += xi * fi.transpose();
                    s_fp += fi.dot(&xi);
                    sc.sum_pf[i] = s_pf;
                    sc.sum_f[i] = s_f;
                    sc.sum_fp[i] = s_fp;
                }
                TorqueModel::Local => {
                    sc.sum_pf[i] = xi * fi.transpose();
                    sc.sum_f[i] = fi;
                    sc.sum_fp[i] = fi.dot(&xi);
                }
            }
            sc.torque_vec[i] = torque;
        }
    }
}

#[inline]
fn two<T: RealField + Copy>(x: T) -> T {
    x + x
}

/// Fills `sc.jac` (row `l`, column `k`) with d(external torque of coordinate l)/d(coordinate k).
///
/// Turning coordinate k (axis `a_k`, pivot `c_k`) by `d` moves every node distal to its joint by
/// `d a_k x (x - c_k)`. With the forces held fixed, for k at or beyond l's joint this changes l's
/// lever arms only: `J_lk = a_l . V_k`, `V_k = P a_k - c_k (S . a_k) - a_k (sigma - S . c_k)`
/// with the suffix sums `P = sum x F^T`, `S = sum F`, `sigma = sum F . x` over the nodes k moves.
/// For k proximal to l the whole of l's subtree turns rigidly, axis included:
/// `J_lk = a_k . w_l`, `w_l = P_l^T a_l - (a_l . c_l) S_l - (sigma_l - S_l . c_l) a_l + a_l x T_l`.
pub(crate) fn jacobian_of_load<T: RealField + Copy>(
    m2: usize,
    model: TorqueModel,
    sc: &mut Scratch<T>,
) {
    let mut jac = std::mem::take(&mut sc.jac);
    for l in 0..m2 {
        let jl = l / 2 + 1;
        let al = sc.axes[l];
        let wl = load_row_generator(sc, jl, al);
        let row = &mut jac[l * m2..(l + 1) * m2];
        for (k, entry) in row.iter_mut().enumerate() {
            let jk = k / 2 + 1;
            let ak = sc.axes[k];
            *entry = if jk < jl {
                ak.dot(&wl)
            } else if jk == jl || model == TorqueModel::Chain {
                // For the chain, the nodes moved are those distal to jk, whose sums sit at jk;
                // for the local model only jk == jl is left, whose sums are the node's own.
                al.dot(&load_column_generator(sc, jk, ak))
            } else {
                T::zero()
            };
        }
    }
    sc.jac = jac;
}

/// Joint `j`'s pivot `c` and the suffix sums `P`, `S`, `sigma` of the load it carries.
#[inline]
fn joint_sums<T: RealField + Copy>(
    sc: &Scratch<T>,
    j: usize,
) -> (Vector3<T>, Matrix3<T>, Vector3<T>, T) {
    (sc.pos[j - 1], sc.sum_pf[j], sc.sum_f[j], sc.sum_fp[j])
}

/// `w_l` of [`jacobian_of_load`] for a coordinate of joint `j` with axis `a`: row `l` of the
/// Jacobian left of `l`'s joint is `a_k . w_l`.
#[inline]
pub(crate) fn load_row_generator<T: RealField + Copy>(
    sc: &Scratch<T>,
    j: usize,
    a: Vector3<T>,
) -> Vector3<T> {
    let (c, p, s, sigma) = joint_sums(sc, j);
    p.transpose() * a - s * a.dot(&c) - a * (sigma - s.dot(&c)) + a.cross(&sc.torque_vec[j])
}

/// `V_k` of [`jacobian_of_load`] for a coordinate of joint `j` with axis `a`: column `k` of the
/// Jacobian at and below `k`'s joint is `a_l . V_k`.
#[inline]
pub(crate) fn load_column_generator<T: RealField + Copy>(
    sc: &Scratch<T>,
    j: usize,
    a: Vector3<T>,
) -> Vector3<T> {
    let (c, p, s, sigma) = joint_sums(sc, j);
    p * a - c * s.dot(&a) - a * (sigma - s.dot(&c))
}

/// Writes the node positions of a strand from `q` and `length` only (no velocities).
pub(crate) fn positions_only<T: RealField + Copy>(
    root: &RootDyn<T>,
    q: &[T],
    length: &[T],
    out: &mut [Vector3<T>],
) {
    let mut rot = root.rotation;
    out[0] = root.position;
    for i in 1..length.len() {
        let c = 2 * (i - 1);
        rot *= Bend::new(q[c], q[c + 1]).rotation;
        out[i] = out[i - 1] + rot.column(2) * length[i];
    }
}
