//! Time integration: eight integrators behind one interface, run in parallel over skeletons.
//!
//! | integrator | method | where it fails |
//! |---|---|---|
//! | [`Integrator::ExplicitEuler`] | forward Euler on angles and angular velocities | stiff springs, any step above the spring's period |
//! | [`Integrator::SymplecticEuler`] | velocity first, then angle | stiff springs, steps above `2 / omega` |
//! | [`Integrator::Rk4`] | classic fourth order | stiff springs, steps above about `2.8 / omega` |
//! | [`Integrator::ImplicitAngular`] | Ward & Lin Appendix A per angle, damping folded in | loads treated explicitly: gravity-dominated soft strands at large steps |
//! | [`Integrator::ImplicitCoupled`] | linearly implicit Euler on the whole strand: springs, damping and the load's dependence on every angle, one `O(n)` structured solve per strand | none found in the stability sweep |
//! | [`Integrator::ImplicitRos2`] | two-stage L-stable Rosenbrock (second order) on the same system, two solves of the coupled step's kind | see `hair stability` |
//! | [`Integrator::ImplicitRos3`] | three-stage L-stable Rosenbrock (third order), two torque evaluations and three solves of one matrix (eight strands at a time in lanes); a step its error guard does not trust is split in up to four pieces, then taken as the coupled step in four pieces | none found in the stability sweep |
//! | [`Integrator::ImplicitBdf2`] | linearly implicit BDF2 (second order, L-stable) on the coupled system, one solve of the coupled step's kind, the previous step kept in the state | none found in the stability sweep |

mod bdf2;
mod implicit_coupled;
mod lanes;
mod rosenbrock;
mod rotating_frame;

use crate::environment::LocalEnv;
use crate::run::Run;
use crate::strand::{self, RootDyn, Scratch, StrandParams};
use crate::{DynamicsError, Environment, Point, Real, StrandState, Vector};
use nalgebra::{RealField, Vector3};
use rayon::prelude::*;
use std::cell::RefCell;

pub(crate) use bdf2::Previous;
pub use implicit_coupled::LinearSolver;

/// Which integrator advances the angles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[non_exhaustive]
pub enum Integrator {
    /// Forward Euler: angles and velocities from the state at the start of the step.
    ExplicitEuler,
    /// Semi-implicit (symplectic) Euler: velocity from the start state, angle from the new velocity.
    SymplecticEuler,
    /// Classic fourth-order Runge-Kutta.
    Rk4,
    /// Ward & Lin's per-angle implicit step (Appendix A) with damping folded in; loads explicit.
    ImplicitAngular,
    /// Linearly implicit Euler on every angle of a strand at once (one linear solve per strand,
    /// see [`LinearSolver`]).
    ImplicitCoupled,
    /// Verwer's two-stage Rosenbrock method ROS2 on the coupled system: second order, L-stable,
    /// two solves of the coupled step's system per step (`docs/dynamics.md`).
    ImplicitRos2,
    /// Sandu et al.'s three-stage Rosenbrock method ROS3 on the coupled system: third order,
    /// L-stable, two torque evaluations and three solves per step. A step whose embedded error
    /// estimate (angles and rates) exceeds 1e-3 rad is split in two or four pieces, and one that
    /// four pieces do not resolve is taken as the coupled step in four pieces (`docs/dynamics.md`).
    ImplicitRos3,
    /// The two-step backward differentiation formula BDF2 on the coupled system, linearised once
    /// per step: second order, L-stable, one solve of the coupled step's system per step. It
    /// reads the strand's previous step, kept in the state; the first step, and any step after
    /// the strand's angles, velocities or the time step were changed from outside, is the coupled
    /// step (backward Euler) (`docs/dynamics.md`).
    ImplicitBdf2,
}

impl Integrator {
    /// Every integrator, in chart order.
    pub const ALL: [Integrator; 8] = [
        Integrator::ExplicitEuler,
        Integrator::SymplecticEuler,
        Integrator::Rk4,
        Integrator::ImplicitAngular,
        Integrator::ImplicitCoupled,
        Integrator::ImplicitRos2,
        Integrator::ImplicitRos3,
        Integrator::ImplicitBdf2,
    ];

    /// A short stable name (`explicit_euler`, ...), used in JSON and on charts.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::ExplicitEuler => "explicit_euler",
            Integrator::SymplecticEuler => "symplectic_euler",
            Integrator::Rk4 => "rk4",
            Integrator::ImplicitAngular => "implicit_angular",
            Integrator::ImplicitCoupled => "implicit_coupled",
            Integrator::ImplicitRos2 => "implicit_ros2",
            Integrator::ImplicitRos3 => "implicit_ros3",
            Integrator::ImplicitBdf2 => "implicit_bdf2",
        }
    }

    /// Order of accuracy in the time step.
    pub fn order(self) -> u32 {
        match self {
            Integrator::Rk4 => 4,
            Integrator::ImplicitRos3 => 3,
            Integrator::ImplicitRos2 | Integrator::ImplicitBdf2 => 2,
            _ => 1,
        }
    }
}

/// Which load a joint's torque sees.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum TorqueModel {
    /// Each segment bears only its own node's load (Kurihara et al., Ward & Lin).
    Local,
    /// Each joint bears the whole load distal to it: converges to the elastica.
    Chain,
}

impl TorqueModel {
    /// `"local"` or `"chain"`.
    pub fn name(self) -> &'static str {
        match self {
            TorqueModel::Local => "local",
            TorqueModel::Chain => "chain",
        }
    }
}

/// Settings of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepSettings {
    /// Time step (s), positive and finite.
    pub dt: Real,
    /// Integrator.
    pub integrator: Integrator,
    /// Torque model.
    pub torque: TorqueModel,
    /// Linear solver of the coupled implicit step.
    pub solver: LinearSolver,
}

impl Default for StepSettings {
    fn default() -> Self {
        Self {
            dt: 1.0 / 60.0,
            integrator: Integrator::ImplicitCoupled,
            torque: TorqueModel::Chain,
            solver: LinearSolver::Structured,
        }
    }
}

/// What a step did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Skeletons integrated.
    pub integrated: usize,
    /// Skeletons skipped because they were dormant.
    pub dormant: usize,
    /// Bonds broken at the end of the step.
    pub bonds_broken: usize,
    /// Strands whose [`LinearSolver::Structured`] solve failed its residual check and was redone
    /// by the dense LU (0 for the other solvers and integrators).
    pub dense_fallbacks: usize,
    /// Strands whose Rosenbrock step ([`Integrator::ImplicitRos2`], [`Integrator::ImplicitRos3`])
    /// its error guard did not trust in one piece: split into pieces, or then taken as the
    /// coupled step (0 for the other integrators).
    pub rosenbrock_splits: usize,
    /// Of those, the strands whose step even the guard's most pieces did not resolve and that
    /// were taken as the coupled step in pieces.
    pub rosenbrock_fallbacks: usize,
}

/// Advances one strand by one step in the scalar type `T`. Returns the first non-finite node, if
/// any, after restoring the strand's coordinates. `previous` is the strand one step back, read by
/// [`Integrator::ImplicitBdf2`] only (`None`: its first step, backward Euler).
#[expect(
    clippy::too_many_arguments,
    reason = "the kernel's inputs are all distinct slices"
)]
pub(crate) fn step_strand<T: RealField + Copy>(
    root: &mut RootDyn<T>,
    q: &mut [T],
    w: &mut [T],
    length: &mut [T],
    rest_length: &[T],
    k_stretch: &[T],
    p: &StrandParams<'_, T>,
    env: &LocalEnv<'_, T>,
    settings: &StepSettings,
    previous: Option<&Previous<'_, T>>,
    sc: &mut Scratch<T>,
) -> Option<usize> {
    let n = length.len();
    let m2 = 2 * (n - 1);
    let h = T::from_f32(settings.dt).unwrap_or_else(T::zero);
    let coupled = matches!(
        settings.integrator,
        Integrator::ImplicitCoupled
            | Integrator::ImplicitRos2
            | Integrator::ImplicitRos3
            | Integrator::ImplicitBdf2
    );
    sc.reserve(n, coupled);
    sc.q0[..m2].copy_from_slice(q);
    sc.w0[..m2].copy_from_slice(w);
    sc.len0[..n].copy_from_slice(length);
    let root0 = *root;
    let model = settings.torque;
    // A turning head's Coriolis and centrifugal forces are implicit in the coupled step: held
    // explicit, the gyroscopic term gains energy every step (see `rotating_frame`).
    let spin = (env.has_frame_motion && env.omega.norm_squared() > T::zero()).then_some(env.omega);

    let eval =
        |root: &RootDyn<T>, q: &[T], w: &[T], length: &[T], jac: bool, sc: &mut Scratch<T>| {
            strand::forward(root, q, w, length, sc);
            strand::forces(root, p, length, env, sc);
            strand::torques(root, p, q, w, length, model, jac, sc);
        };

    match settings.integrator {
        Integrator::ExplicitEuler => {
            eval(root, q, w, length, false, sc);
            for c in 0..m2 {
                let a = sc.tau[c] / sc.inertia[c];
                q[c] += h * w[c];
                w[c] += h * a;
            }
            if root.free {
                root.position += root.velocity * h;
                root.velocity += sc.root_acc * h;
            }
        }
        Integrator::SymplecticEuler => {
            eval(root, q, w, length, false, sc);
            for c in 0..m2 {
                w[c] += h * sc.tau[c] / sc.inertia[c];
                q[c] += h * w[c];
            }
            symplectic_root(root, sc.root_acc, h);
        }
        Integrator::Rk4 => rk4(root, q, w, length, h, sc, &eval),
        Integrator::ImplicitAngular => {
            eval(root, q, w, length, false, sc);
            for c in 0..m2 {
                let i = c / 2 + 1;
                let k = spring_of(root, p, i, c);
                let g = p.damping[i];
                // (I + h g + h^2 k) dw = h tau - h^2 k w   (docs/dynamics.md)
                let dw = (h * sc.tau[c] - h * h * k * w[c]) / (sc.inertia[c] + h * g + h * h * k);
                w[c] += dw;
                q[c] += h * w[c];
            }
            symplectic_root(root, sc.root_acc, h);
        }
        Integrator::ImplicitCoupled | Integrator::ImplicitBdf2 => {
            eval(root, q, w, length, true, sc);
            match previous.filter(|_| settings.integrator == Integrator::ImplicitBdf2) {
                Some(previous) => {
                    if bdf2::solve_step(root, p, q, w, length, previous, h, settings, spin, sc) {
                        sc.bdf2_fallbacks += 1;
                    }
                }
                None => {
                    implicit_coupled::solve_step(root, p, q, w, h, settings, spin, sc);
                    symplectic_root(root, sc.root_acc, h);
                }
            }
        }
        Integrator::ImplicitRos2 => {
            if rosenbrock::advance(
                &rosenbrock::ROS2,
                root,
                p,
                q,
                w,
                length,
                h,
                settings,
                spin,
                sc,
                &eval,
            ) {
                sc.rosenbrock_fallbacks += 1;
            }
        }
        Integrator::ImplicitRos3 => {
            if rosenbrock::advance(
                &rosenbrock::ROS3,
                root,
                p,
                q,
                w,
                length,
                h,
                settings,
                spin,
                sc,
                &eval,
            ) {
                sc.rosenbrock_fallbacks += 1;
            }
        }
    }

    // Quasi-static stretch springs: each segment takes the length its tension asks for.
    for i in 1..n {
        if k_stretch[i] > T::zero() {
            let tension = sc.tension[i].max(T::zero());
            length[i] = rest_length[i] * (T::one() + tension / k_stretch[i]);
        }
    }

    // A free strand may wrap its first joint past half a turn: fold it back to the same rotation.
    if root.free && m2 >= 2 {
        let (x, y) = (q[0], q[1]);
        let a = (x * x + y * y).sqrt();
        if a > T::pi() {
            let f = (a - T::two_pi()) / a;
            q[0] = x * f;
            q[1] = y * f;
        }
    }

    let bad = (0..m2)
        .find(|&c| !(q[c].is_finite() && w[c].is_finite()))
        .map(|c| c / 2 + 1)
        .or_else(|| (0..n).find(|&i| !length[i].is_finite()))
        .or_else(|| {
            let ok = root
                .position
                .iter()
                .chain(root.velocity.iter())
                .all(|c| c.is_finite());
            (!ok).then_some(0)
        });
    if bad.is_some() {
        q.copy_from_slice(&sc.q0[..m2]);
        w.copy_from_slice(&sc.w0[..m2]);
        length.copy_from_slice(&sc.len0[..n]);
        *root = root0;
    }
    bad
}

fn symplectic_root<T: RealField + Copy>(root: &mut RootDyn<T>, acc: Vector3<T>, h: T) {
    if root.free {
        root.velocity += acc * h;
        root.position += root.velocity * h;
    }
}

#[inline]
pub(crate) fn spring_of<T: RealField + Copy>(
    root: &RootDyn<T>,
    p: &StrandParams<'_, T>,
    i: usize,
    c: usize,
) -> T {
    if root.free && i == 1 {
        T::zero()
    } else if c.is_multiple_of(2) {
        p.k_theta[i]
    } else {
        p.k_phi[i]
    }
}

fn rk4<T: RealField + Copy, F>(
    root: &mut RootDyn<T>,
    q: &mut [T],
    w: &mut [T],
    length: &[T],
    h: T,
    sc: &mut Scratch<T>,
    eval: &F,
) where
    F: Fn(&RootDyn<T>, &[T], &[T], &[T], bool, &mut Scratch<T>),
{
    let m2 = q.len();
    let half = h / (T::one() + T::one());
    let sixth = h / T::from_f64(6.0).unwrap_or_else(T::one);
    let mut stage_q = std::mem::take(&mut sc.stage_q);
    let mut stage_w = std::mem::take(&mut sc.stage_w);
    let mut acc_q = std::mem::take(&mut sc.acc_q);
    let mut acc_w = std::mem::take(&mut sc.acc_w);
    stage_q[..m2].copy_from_slice(q);
    stage_w[..m2].copy_from_slice(w);
    acc_q[..m2].iter_mut().for_each(|x| *x = T::zero());
    acc_w[..m2].iter_mut().for_each(|x| *x = T::zero());
    let mut stage_root = *root;
    let mut acc_rp = Vector3::zeros();
    let mut acc_rv = Vector3::zeros();
    let weights = [T::one(), T::one() + T::one(), T::one() + T::one(), T::one()];
    let steps = [half, half, h, T::zero()];
    for s in 0..4 {
        eval(
            &stage_root,
            &stage_q[..m2],
            &stage_w[..m2],
            length,
            false,
            sc,
        );
        let wt = weights[s];
        let next = steps[s];
        for c in 0..m2 {
            let dq = stage_w[c];
            let dw = sc.tau[c] / sc.inertia[c];
            acc_q[c] += wt * dq;
            acc_w[c] += wt * dw;
            stage_q[c] = q[c] + next * dq;
            stage_w[c] = w[c] + next * dw;
        }
        if root.free {
            let dp = stage_root.velocity;
            let dv = sc.root_acc;
            acc_rp += dp * wt;
            acc_rv += dv * wt;
            stage_root.position = root.position + dp * next;
            stage_root.velocity = root.velocity + dv * next;
        }
    }
    for c in 0..m2 {
        q[c] += sixth * acc_q[c];
        w[c] += sixth * acc_w[c];
    }
    if root.free {
        root.position += acc_rp * sixth;
        root.velocity += acc_rv * sixth;
    }
    sc.stage_q = stage_q;
    sc.stage_w = stage_w;
    sc.acc_q = acc_q;
    sc.acc_w = acc_w;
}

/// A worker's reusable buffers (see `SCRATCH`).
#[derive(Default)]
struct WorkerBuffers {
    sc: Scratch<Real>,
    q: Vec<Real>,
    w: Vec<Real>,
    prev_q: Vec<Real>,
    prev_w: Vec<Real>,
}

thread_local! {
    /// Per worker: the strand's scratch, its coordinates in the step's layout (`q`, `w`), and
    /// BDF2's previous step in the same layout.
    static SCRATCH: RefCell<WorkerBuffers> = RefCell::new(Default::default());
}

/// Read-only inputs shared by every worker.
struct Shared<'a> {
    state_offsets: &'a [u32],
    counts: &'a [u32],
    active: &'a [bool],
    rest_theta: &'a [Real],
    rest_phi: &'a [Real],
    rest_length: &'a [Real],
    mass: &'a [Real],
    wetness: &'a [Real],
    k_theta: &'a [Real],
    k_phi: &'a [Real],
    k_stretch: &'a [Real],
    damping: &'a [Real],
    rest_points: &'a [Vector],
    force: &'a [Vector],
    env: LocalEnv<'a, Real>,
    /// The air for the lane step, worked out once a step (`None` where no air drags).
    lane_air: Option<lanes::LaneAir>,
    settings: StepSettings,
}

/// Nodes per leaf of the parallel split: big enough to amortise the fork, small enough to balance.
const GRAIN_NODES: usize = 512;

/// What a run of skeletons reports.
#[derive(Default)]
struct RunOutcome {
    /// The first skeleton that went non-finite, and its node.
    first_bad: Option<(usize, usize)>,
    /// The counts of [`StepReport`]'s same names.
    dense_fallbacks: usize,
    rosenbrock_splits: usize,
    rosenbrock_fallbacks: usize,
}

impl RunOutcome {
    /// The outcome of two runs, `self` the earlier.
    fn and(self, later: RunOutcome) -> RunOutcome {
        RunOutcome {
            first_bad: self.first_bad.or(later.first_bad),
            dense_fallbacks: self.dense_fallbacks + later.dense_fallbacks,
            rosenbrock_splits: self.rosenbrock_splits + later.rosenbrock_splits,
            rosenbrock_fallbacks: self.rosenbrock_fallbacks + later.rosenbrock_fallbacks,
        }
    }
}

fn run_parallel(run: Run<'_>, sh: &Shared<'_>) -> RunOutcome {
    let count = run.roots.len();
    if count > 1 && run.theta.len() > GRAIN_NODES {
        let mid = run.first + count / 2;
        let at = sh.state_offsets[mid] as usize;
        let (a, b) = run.split(mid, at);
        let (ra, rb) = rayon::join(|| run_parallel(a, sh), || run_parallel(b, sh));
        return ra.and(rb);
    }
    run_sequential(run, sh)
}

fn run_sequential(mut run: Run<'_>, sh: &Shared<'_>) -> RunOutcome {
    SCRATCH.with(|cell| {
        let mut guard = cell.borrow_mut();
        let buffers = &mut *guard;
        let mut first_bad = None;
        let before = (
            buffers.sc.dense_fallbacks,
            buffers.sc.rosenbrock_splits,
            buffers.sc.rosenbrock_fallbacks,
        );
        // `first_pieces`: where a Rosenbrock step's guard starts (see `rosenbrock::advance`).
        let mut scalar =
            |run: &mut Run<'_>, local: usize, settings: &StepSettings, first_pieces| {
                buffers.sc.rosenbrock_first_pieces = first_pieces;
                if let Some(node) = step_skeleton(run, sh, local, settings, buffers) {
                    let s = run.first + local;
                    // The lanes finish out of order: keep the first skeleton, as the scalar loop does.
                    first_bad =
                        Some(first_bad.map_or((s, node), |b: (usize, usize)| b.min((s, node))));
                }
            };
        let (mut lane_fallbacks, mut lane_splits) = (0, 0);
        if lanes::covers(sh) {
            // Strands of equal node count (attached roots) eight at a time; the rest one by one.
            let dense = StepSettings {
                solver: LinearSolver::Hand,
                ..sh.settings
            };
            let ros3 = sh.settings.integrator == Integrator::ImplicitRos3;
            let mut group = [0usize; lanes::LANES];
            let mut members = 0;
            let mut group_n = 0;
            let flush =
                |run: &mut Run<'_>,
                 group: &[usize],
                 n: usize,
                 (fallbacks, splits): (&mut usize, &mut usize),
                 scalar: &mut dyn FnMut(&mut Run<'_>, usize, &StepSettings, u32)| {
                    let outcome = lanes::step_group(run, sh, group, n);
                    for (&local, (o, pieces)) in group.iter().zip(outcome) {
                        match o {
                            // The lanes left the strand's BDF2 history (or none).
                            lanes::LaneOutcome::Done => {}
                            // ROS3 in the pieces its guard asked for.
                            lanes::LaneOutcome::Split => *splits += 1,
                            // ROS3's scalar step redoes a declined stage by the dense solve
                            // itself, and counts it.
                            lanes::LaneOutcome::Declined if ros3 => {
                                scalar(run, local, &sh.settings, pieces)
                            }
                            lanes::LaneOutcome::Declined => {
                                *fallbacks += 1;
                                scalar(run, local, &dense, 1);
                            }
                            // ROS3's guard starts where the lanes stopped (and counts the split
                            // from two pieces on).
                            lanes::LaneOutcome::NonFinite | lanes::LaneOutcome::Redo => {
                                scalar(run, local, &sh.settings, pieces)
                            }
                        }
                    }
                };
            for local in 0..run.roots.len() {
                let s = run.first + local;
                if !sh.active[s] {
                    run.roots[local].history = 0;
                    continue;
                }
                let n = sh.counts[s] as usize;
                if run.roots[local].free {
                    scalar(&mut run, local, &sh.settings, 1);
                    continue;
                }
                if members > 0 && n != group_n {
                    flush(
                        &mut run,
                        &group[..members],
                        group_n,
                        (&mut lane_fallbacks, &mut lane_splits),
                        &mut scalar,
                    );
                    members = 0;
                }
                group_n = n;
                group[members] = local;
                members += 1;
                if members == lanes::LANES {
                    flush(
                        &mut run,
                        &group[..members],
                        group_n,
                        (&mut lane_fallbacks, &mut lane_splits),
                        &mut scalar,
                    );
                    members = 0;
                }
            }
            if members > 0 {
                flush(
                    &mut run,
                    &group[..members],
                    group_n,
                    (&mut lane_fallbacks, &mut lane_splits),
                    &mut scalar,
                );
            }
        } else {
            for local in 0..run.roots.len() {
                if sh.active[run.first + local] {
                    scalar(&mut run, local, &sh.settings, 1);
                } else {
                    // A dormant strand restarts BDF2 from backward Euler when it wakes.
                    run.roots[local].history = 0;
                }
            }
        }
        buffers.sc.dense_fallbacks += lane_fallbacks;
        buffers.sc.rosenbrock_splits += lane_splits;
        RunOutcome {
            first_bad,
            dense_fallbacks: buffers.sc.dense_fallbacks - before.0,
            rosenbrock_splits: buffers.sc.rosenbrock_splits - before.1,
            rosenbrock_fallbacks: buffers.sc.rosenbrock_fallbacks - before.2,
        }
    })
}

/// One strand by the scalar step (any integrator and solver): copied into the step's layout,
/// advanced, and written back; returns the first non-finite node, leaving the strand as it was.
fn step_skeleton(
    run: &mut Run<'_>,
    sh: &Shared<'_>,
    local: usize,
    settings: &StepSettings,
    buffers: &mut WorkerBuffers,
) -> Option<usize> {
    let WorkerBuffers {
        sc,
        q,
        w,
        prev_q,
        prev_w,
    } = buffers;
    let bdf2 = settings.integrator == Integrator::ImplicitBdf2;
    let s = run.first + local;
    let o = sh.state_offsets[s] as usize;
    let n = sh.counts[s] as usize;
    let lo = o - run.node_base;
    let r = lo..lo + n;
    let g = o..o + n;
    let m2 = 2 * (n - 1);
    if q.len() < m2 {
        q.resize(m2, 0.0);
        w.resize(m2, 0.0);
        prev_q.resize(m2, 0.0);
        prev_w.resize(m2, 0.0);
    }
    for i in 1..n {
        q[2 * i - 2] = run.theta[lo + i];
        q[2 * i - 1] = run.phi[lo + i];
        w[2 * i - 2] = run.omega_theta[lo + i];
        w[2 * i - 1] = run.omega_phi[lo + i];
    }
    let rs = &mut run.roots[local];
    // BDF2 reads the previous step only if the strand is as its last BDF2 step left it.
    let has_history = bdf2
        && rs.history != 0
        && rs.history == bdf2::history_tag(&q[..m2], &w[..m2], rs, sh.settings.dt);
    if has_history {
        for i in 1..n {
            prev_q[2 * i - 2] = run.prev_theta[lo + i];
            prev_q[2 * i - 1] = run.prev_phi[lo + i];
            prev_w[2 * i - 2] = run.prev_omega_theta[lo + i];
            prev_w[2 * i - 1] = run.prev_omega_phi[lo + i];
        }
    }
    let previous = has_history.then(|| Previous {
        q: &prev_q[..m2],
        w: &prev_w[..m2],
        root_position: rs.prev_position.coords,
        root_velocity: rs.prev_velocity,
    });
    let mut root = RootDyn {
        position: rs.position.coords,
        rotation: rs.rotation,
        velocity: rs.velocity,
        free: rs.free,
    };
    let params = StrandParams {
        rest_theta: &sh.rest_theta[g.clone()],
        rest_phi: &sh.rest_phi[g.clone()],
        mass: &sh.mass[g.clone()],
        wetness: &sh.wetness[g.clone()],
        k_theta: &sh.k_theta[g.clone()],
        k_phi: &sh.k_phi[g.clone()],
        damping: &sh.damping[g.clone()],
        rest_points: &sh.rest_points[g.clone()],
        external: &sh.force[g.clone()],
    };
    let bad = step_strand(
        &mut root,
        &mut q[..m2],
        &mut w[..m2],
        &mut run.length[r.clone()],
        &sh.rest_length[g.clone()],
        &sh.k_stretch[g.clone()],
        &params,
        &sh.env,
        settings,
        previous.as_ref(),
        sc,
    );
    if bad.is_some() {
        return bad;
    }
    if bdf2 {
        for i in 1..n {
            run.prev_theta[lo + i] = run.theta[lo + i];
            run.prev_phi[lo + i] = run.phi[lo + i];
            run.prev_omega_theta[lo + i] = run.omega_theta[lo + i];
            run.prev_omega_phi[lo + i] = run.omega_phi[lo + i];
        }
        rs.prev_position = rs.position;
        rs.prev_velocity = rs.velocity;
    }
    for i in 1..n {
        run.theta[lo + i] = q[2 * i - 2];
        run.phi[lo + i] = q[2 * i - 1];
        run.omega_theta[lo + i] = w[2 * i - 2];
        run.omega_phi[lo + i] = w[2 * i - 1];
    }
    rs.position = Point::from(root.position);
    rs.velocity = root.velocity;
    rs.history = if bdf2 {
        bdf2::history_tag(&q[..m2], &w[..m2], rs, sh.settings.dt)
    } else {
        0
    };
    // Positions and velocities at the end of the step, for collision and rendering.
    strand::forward(&root, &q[..m2], &w[..m2], &run.length[r.clone()], sc);
    for k in 0..n {
        run.positions[lo + k] = Point::from(sc.pos[k]);
        run.velocities[lo + k] = sc.vel[k];
    }
    None
}

impl StrandState {
    /// Advances every active skeleton by one step, in parallel over skeletons.
    ///
    /// Bond forces and [`StrandState::external_force_mut`] are applied; bonds stretched past their
    /// break distance at the end of the step are removed. A skeleton that goes non-finite is
    /// restored to its state before the step and reported as an error (the others keep their
    /// new state); results do not depend on the number of threads.
    pub fn step(
        &mut self,
        env: &Environment,
        settings: &StepSettings,
    ) -> Result<StepReport, DynamicsError> {
        if !(settings.dt.is_finite() && settings.dt > 0.0) {
            return Err(DynamicsError::InvalidTimeStep {
                dt: f64::from(settings.dt),
            });
        }
        env.validate()?;
        let mut force = std::mem::take(&mut self.force_scratch);
        force.clear();
        // The per-node forces for this step added in the same pass, and zeroed there for the
        // next response.
        if std::mem::take(&mut self.node_forces_pending) {
            force.par_extend(
                self.external_force
                    .par_iter()
                    .zip(&mut self.next_step_node_forces)
                    .map(|(e, g)| e + std::mem::replace(g, Vector::zeros())),
            );
        } else {
            force.extend_from_slice(&self.external_force);
        }
        for &(node, f) in &self.next_step_forces {
            force[node as usize] += f;
        }
        self.next_step_forces.clear();
        self.accumulate_bond_forces(&mut force);
        let nodes = self.theta.len();
        let skeletons = self.offsets.len();
        let dormant = self.active.iter().filter(|a| !**a).count();
        let max_count = self.counts.iter().max().map_or(0, |&c| c as usize);
        // Every worker's lane buffers grown at once, the first time this state steps in a
        // pool of this size or meets a longer skeleton (see `grow_every_worker`). Not from
        // inside a worker (states stepped in parallel, as `hair stability` steps its cells): a
        // worker waiting for the broadcast runs other queued jobs meanwhile, among them other
        // states' first steps, whose broadcasts nest on its stack until it overflows. There
        // the buffers grow at a worker's first group.
        let warmth = (rayon::current_num_threads(), max_count);
        if self.lanes_grown != Some(warmth)
            && lanes::covers_integrator(settings)
            && rayon::current_thread_index().is_none()
        {
            lanes::grow_every_worker(max_count);
            self.lanes_grown = Some(warmth);
        }
        let outcome = {
            let local = env.local();
            let lane_air = local.has_air.then(|| lanes::LaneAir::new(&local));
            let sh = Shared {
                state_offsets: &self.offsets,
                counts: &self.counts,
                active: &self.active,
                rest_theta: &self.rest_theta,
                rest_phi: &self.rest_phi,
                rest_length: &self.rest_length,
                mass: &self.mass,
                wetness: &self.wetness,
                k_theta: &self.k_theta,
                k_phi: &self.k_phi,
                k_stretch: &self.k_stretch,
                damping: &self.damping,
                rest_points: &self.rest_points,
                force: &force,
                env: local,
                lane_air,
                settings: *settings,
            };
            // The run borrows only its own fields: `sh` holds others.
            let run = crate::run::whole_run!(self);
            if skeletons == 0 {
                RunOutcome::default()
            } else {
                run_parallel(run, &sh)
            }
        };
        self.force_scratch = force;
        let step = self.steps;
        self.steps += 1;
        self.last_dt = settings.dt;
        debug_assert_eq!(nodes, self.theta.len());
        if let Some((skeleton, node)) = outcome.first_bad {
            return Err(DynamicsError::NonFiniteState {
                step,
                skeleton,
                node,
            });
        }
        let bonds_broken = self.break_stretched_bonds();
        Ok(StepReport {
            integrated: skeletons - dormant,
            dormant,
            bonds_broken,
            dense_fallbacks: outcome.dense_fallbacks,
            rosenbrock_splits: outcome.rosenbrock_splits,
            rosenbrock_fallbacks: outcome.rosenbrock_fallbacks,
        })
    }
}
