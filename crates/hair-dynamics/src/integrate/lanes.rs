//! The coupled implicit step, BDF2 and ROS3 eight strands at a time, in `f32x8` lanes (ROS3 in
//! [`ros3`], on this module's lane types).
//!
//! The same model and the same linear solve as [`super::implicit_coupled`]'s structured solve,
//! specialised to what the runtime runs most: `f32`, attached roots and a head that does not
//! turn. Air drag and force fields are loads the step treats explicitly, as the scalar step does:
//! the air's velocity in lanes (the same wind model), the fields per node and lane by the
//! environment's own scalar functions. BDF2 is the same system with the step, the right-hand
//! side's rates and the torque shifted ([`super::bdf2`]); a lane without BDF2 history takes the
//! coupled step.
//!
//! Strands of equal node count in a worker's run are grouped by eight; a group's data are laid
//! out lane by lane (lane `l` of every vector is strand `l`), so each arithmetic instruction
//! advances eight strands. A group short of eight repeats its last strand in the spare lanes and
//! drops their results, so a strand's answer never depends on which strands share its group
//! (results are the same for any thread count).
//!
//! Per step and group, after the group's fields are gathered into lane layout (8 x 8
//! transposes), four passes over the nodes:
//! 1. root to tip: the kinematics (positions, tangents, joint axes, and velocities where air
//!    drags) and the prefix sums of `A w` (the frame's angular velocity, which the kinematics
//!    accumulates anyway);
//! 2. tip to root: forces, torques, inertia and the Jacobian's suffix sums, and in the same
//!    iteration the joint's generators (no sums stored); then, in a second tip-to-root loop,
//!    each joint's step of the elimination;
//! 3. root to tip: the unknowns, and with them the new state and the end-of-step positions and
//!    velocities (the kinematics again);
//! 4. tip to root: the residual check, on values pass 2 and 3 kept;
//!
//! and the results transposed back to the state. A lane whose check fails, whose state goes
//! non-finite or whose BDF2 error estimate is over its bound is left untouched and redone by
//! the scalar step (the check's failures counted as dense fallbacks).

use super::{Integrator, LinearSolver, Shared, StepSettings, TorqueModel, bdf2};
use crate::run::Run;
use crate::{Point, Vector};
use std::cell::RefCell;
use std::ops::{Add, Mul, Sub};
use wide::f32x8;

mod ros3;

/// Strands advanced together.
pub(super) const LANES: usize = 8;

type L = f32x8;

/// A 3-vector of lanes.
#[derive(Clone, Copy, Default)]
struct V3 {
    x: L,
    y: L,
    z: L,
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}

impl Mul<L> for V3 {
    type Output = V3;
    #[inline(always)]
    fn mul(self, s: L) -> V3 {
        V3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

impl V3 {
    #[inline(always)]
    fn dot(self, o: V3) -> L {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    fn cross(self, o: V3) -> V3 {
        V3 {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }

    #[inline(always)]
    fn norm_squared(self) -> L {
        self.dot(self)
    }
}

/// A 3 x 3 matrix of lanes, row-major.
#[derive(Clone, Copy, Default)]
struct M3 {
    r: [V3; 3],
}

impl M3 {
    #[inline(always)]
    fn mul_v(&self, v: V3) -> V3 {
        V3 {
            x: self.r[0].dot(v),
            y: self.r[1].dot(v),
            z: self.r[2].dot(v),
        }
    }

    /// `self^T v`.
    #[inline(always)]
    fn tr_mul_v(&self, v: V3) -> V3 {
        self.r[0] * v.x + self.r[1] * v.y + self.r[2] * v.z
    }

    #[inline(always)]
    fn column(&self, c: usize) -> V3 {
        let pick = |row: &V3| match c {
            0 => row.x,
            1 => row.y,
            _ => row.z,
        };
        V3 {
            x: pick(&self.r[0]),
            y: pick(&self.r[1]),
            z: pick(&self.r[2]),
        }
    }

    #[inline(always)]
    fn mul_m(&self, o: &M3) -> M3 {
        M3 {
            r: [
                o.tr_mul_v(self.r[0]),
                o.tr_mul_v(self.r[1]),
                o.tr_mul_v(self.r[2]),
            ],
        }
    }

    /// `self + a b^T`.
    #[inline(always)]
    fn add_outer(&mut self, a: V3, b: V3) {
        self.r[0] = self.r[0] + b * a.x;
        self.r[1] = self.r[1] + b * a.y;
        self.r[2] = self.r[2] + b * a.z;
    }
}

/// What the coupled step and ROS3 keep alike of joint `j` for the elimination, the unknowns and
/// the residual check.
#[derive(Clone, Copy, Default)]
struct Joint {
    /// Joint axes (the two columns of `A_j`).
    a: [V3; 2],
    /// The Jacobian's column generators `V_j` and row generators `W_j`.
    v: [V3; 2],
    wg: [V3; 2],
    /// Rows of the gain `E_j` and the offset `e_j`: `x_j = E_j pre_j + e_j`.
    gain: [V3; 2],
    offset: [L; 2],
    /// Diagonal and right-hand side of the joint's two rows.
    d: [L; 2],
    b: [L; 2],
    /// Prefix sum `sum_{k<j} A_k w_k` (pass 1; ROS3's later stages, of their right-hand side).
    prefix: V3,
    /// The unknowns.
    x: [L; 2],
    /// The residual check's terms `h^2 W_j^T sum_{k<j} A_k x_k`.
    left: [L; 2],
    /// The joint's angles, rates and segment length at the start of the step.
    q: [L; 2],
    w: [L; 2],
    len: L,
}

/// What BDF2's lane step keeps of joint `j` beyond the coupled step's [`Joint`]: the rates the
/// right-hand side reads, `w + a / b`, the shift of the angles `a = (q_n - q_{n-1}) / 3` and the
/// previous rates (`a` zero in a lane without history).
#[derive(Clone, Copy, Default)]
struct Bdf2Joint {
    w_rhs: [L; 2],
    shift: [L; 2],
    w_prev: [L; 2],
}

/// A step's per-joint record that holds a [`Joint`] (the coupled step's is one).
trait HasJoint {
    fn joint_mut(&mut self) -> &mut Joint;
}

impl HasJoint for Joint {
    #[inline(always)]
    fn joint_mut(&mut self) -> &mut Joint {
        self
    }
}

/// Per-node lane buffers, grown to the state's longest skeleton and then reused.
#[derive(Default)]
struct LaneScratch {
    pos: Vec<V3>,
    /// Node velocities at the start of the step (filled only where air drags).
    vel: Vec<V3>,
    tangent: Vec<V3>,
    tension: Vec<L>,
    joints: Vec<Joint>,
    bdf2: Vec<Bdf2Joint>,
    out: Vec<NodeOut>,
    /// The group's per-node inputs in lane layout (`gather`, `gather3`).
    nodes: Vec<NodeIn>,
    /// ROS3's joints (`ros3`), and the start of the step while it is split: each node's
    /// angles and rates.
    stages: Vec<ros3::StageJoint>,
    start: Vec<[L; 4]>,
}

/// A node's inputs of the group's eight strands, lane by lane: gathered from the state's
/// strand-by-strand layout eight nodes at a time by transposes, not node by node (one strided
/// load per lane and value).
#[derive(Clone, Copy, Default)]
struct NodeIn {
    theta: L,
    phi: L,
    omega_theta: L,
    omega_phi: L,
    length: L,
    mass: L,
    wetness: L,
    damping: L,
    k_theta: L,
    k_phi: L,
    rest_theta: L,
    rest_phi: L,
    k_stretch: L,
    rest_length: L,
    rest_point: V3,
    force: V3,
    /// BDF2 only: the previous step's angles and rates.
    prev: [L; 4],
}

/// A node's state at the end of the step, held until every lane's finiteness is known.
#[derive(Clone, Copy, Default)]
struct NodeOut {
    q: [L; 2],
    w: [L; 2],
    len: L,
    pos: V3,
    vel: V3,
}

impl LaneScratch {
    fn reserve(&mut self, n: usize) {
        if self.pos.len() < n {
            self.pos.resize(n, V3::default());
            self.vel.resize(n, V3::default());
            self.tangent.resize(n, V3::default());
            self.tension.resize(n, L::ZERO);
            self.joints.resize(n, Joint::default());
            self.bdf2.resize(n, Bdf2Joint::default());
            self.out.resize(n, NodeOut::default());
            self.nodes.resize(n, NodeIn::default());
            self.stages.resize(n, ros3::StageJoint::default());
            self.start.resize(n, [L::ZERO; 4]);
        }
    }
}

thread_local! {
    static LANE_SCRATCH: RefCell<LaneScratch> = RefCell::new(LaneScratch::default());
}

/// Grows the lane buffers of every thread of the current pool to `n` nodes. A worker's buffers
/// otherwise grew at the first group it met, in whatever step work stealing first gave it one:
/// a step long after the first could allocate, or not, by the schedule.
pub(super) fn grow_every_worker(n: usize) {
    rayon::broadcast(|_| LANE_SCRATCH.with(|cell| cell.borrow_mut().reserve(n)));
}

/// Whether the lane step covers these settings and environment: the coupled step by its
/// structured solve, with no turning or accelerating-in-rotation head.
pub(super) fn covers(sh: &Shared<'_>) -> bool {
    covers_integrator(&sh.settings) && !sh.env.has_frame_motion
}

/// Whether the lane step covers these settings in some environment.
pub(super) fn covers_integrator(s: &StepSettings) -> bool {
    matches!(
        s.integrator,
        Integrator::ImplicitCoupled | Integrator::ImplicitBdf2 | Integrator::ImplicitRos3
    ) && s.solver == LinearSolver::Structured
}

/// What became of one lane's strand.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum LaneOutcome {
    /// Advanced and written back.
    Done,
    /// The residual check failed: redo by the dense solve, and count it.
    Declined,
    /// Went non-finite: redo by the scalar step, which restores and reports it.
    NonFinite,
    /// BDF2's or ROS3's error estimate exceeded its bound: redo by the scalar step, which falls
    /// back to the coupled step as its own BDF2 step does, or splits the ROS3 step as its guard
    /// does, and counts it.
    Redo,
    /// ROS3 only: advanced in the pieces its guard asked for and written back; count it as a
    /// split.
    Split,
}

/// Advances the strands `members` (local indices into `run`, all attached, all of `n` nodes, at
/// most [`LANES`]) by one step of the integrator (the coupled step, BDF2 or ROS3), writing back
/// those that succeed. Each lane's outcome comes with the pieces a scalar ROS3 step that redoes
/// it starts its guard at (1 for the other integrators).
pub(super) fn step_group(
    run: &mut Run<'_>,
    sh: &Shared<'_>,
    members: &[usize],
    n: usize,
) -> [(LaneOutcome, u32); LANES] {
    LANE_SCRATCH.with(|cell| {
        let mut guard = cell.borrow_mut();
        // Grown already by `grow_every_worker`, so this allocates nothing; except for states
        // stepped from inside a pool's worker (see `StrandState::step`), whose workers' buffers
        // grow here, at the first group each meets.
        guard.reserve(n);
        if sh.settings.integrator == Integrator::ImplicitRos3 {
            ros3::step_group_in(run, sh, members, n, &mut guard)
        } else {
            step_group_in(run, sh, members, n, &mut guard).map(|o| (o, 1))
        }
    })
}

/// One field of a group's eight strands, each lane's slice cut to its strand's `n` nodes (so
/// reading node `i < n` needs no bounds check per lane).
struct Strands<'a, T>([&'a [T]; LANES]);

impl<'a, T: Copy> Strands<'a, T> {
    /// `field[base[l]..base[l] + n]` for every lane `l`, asked of memory at once: a group reads
    /// some twenty fields of eight strands each, every one its own stream in memory, more than
    /// the hardware prefetchers follow, so without the hints most first reads of a step wait on
    /// memory one after another. The hints do not wait.
    #[inline(always)]
    fn new(field: &'a [T], base: &[usize; LANES], n: usize) -> Self {
        let lanes: [&'a [T]; LANES] = std::array::from_fn(|l| &field[base[l]..base[l] + n]);
        for strand in &lanes {
            prefetch_slice(strand);
        }
        Self(lanes)
    }
}

impl Strands<'_, f32> {
    /// Node `i` of every lane.
    #[inline(always)]
    fn at(&self, i: usize) -> L {
        L::from(std::array::from_fn::<f32, LANES, _>(|l| self.0[l][i]))
    }
}

impl Strands<'_, Vector> {
    /// Node `i` of every lane.
    #[inline(always)]
    fn at3(&self, i: usize) -> V3 {
        let v: [Vector; LANES] = std::array::from_fn(|l| self.0[l][i]);
        V3 {
            x: L::from(v.map(|p| p.x)),
            y: L::from(v.map(|p| p.y)),
            z: L::from(v.map(|p| p.z)),
        }
    }
}

// The gathers and scatters below, and the passes' small arrays, use loops of constant trip
// count or are written out, not `array::from_fn` or `map`: in a function as large as
// `step_group_in` the closures of those were at times left out of line, at several times the
// instructions (docs/perf/dynamics.md); whether they are depends on the rest of the crate (the
// ROS3 lane step's arrival tipped the coupled step's).

/// Eight nodes of eight strands' `f32` field from `start`: a transposed 8 x 8 block, row `k`
/// node `start + k` of every lane.
#[inline(always)]
fn block(field: &Strands<'_, f32>, start: usize) -> [L; 8] {
    let mut rows = [L::ZERO; 8];
    for l in 0..LANES {
        let row: [f32; 8] = field.0[l][start..start + 8]
            .try_into()
            .expect("eight nodes");
        rows[l] = L::from(row);
    }
    L::transpose(rows)
}

/// The start of each block of eight nodes that covers `n >= 8` nodes: every eighth node, the
/// last block moved back to end at `n` (it overlaps the one before, which is rewritten with the
/// same values).
#[inline(always)]
fn blocks(n: usize) -> impl Iterator<Item = usize> {
    (0..n.div_ceil(8)).map(move |b| (8 * b).min(n - 8))
}

/// Eight 3-vectors' 24 coordinates in a row, cut in three rows of eight.
#[inline(always)]
fn thirds<T: Copy>(v: &[[T; 3]; 8]) -> [[T; 8]; 3] {
    let flat = v.as_flattened();
    let row = |o: usize| -> [T; 8] { flat[o..o + 8].try_into().expect("eight coordinates") };
    [row(0), row(8), row(16)]
}

/// `field` of the group's `n` nodes into `set(node, lanes)`.
#[inline(always)]
fn gather(nodes: &mut [NodeIn], field: &Strands<'_, f32>, set: impl Fn(&mut NodeIn, L)) {
    let n = nodes.len();
    if n < 8 {
        for (i, node) in nodes.iter_mut().enumerate() {
            set(node, field.at(i));
        }
        return;
    }
    for start in blocks(n) {
        let rows = block(field, start);
        for k in 0..8 {
            set(&mut nodes[start + k], rows[k]);
        }
    }
}

/// A 3-vector field of the group's `n` nodes into `set(node, lanes)`: as [`gather`] on the
/// strands' coordinates read as one run of `3 n` floats, three 8 x 8 blocks for eight nodes.
#[inline(always)]
fn gather3(nodes: &mut [NodeIn], field: &Strands<'_, Vector>, set: impl Fn(&mut NodeIn, V3)) {
    let n = nodes.len();
    if n < 8 {
        for (i, node) in nodes.iter_mut().enumerate() {
            set(node, field.at3(i));
        }
        return;
    }
    for start in blocks(n) {
        let mut rows = [[L::ZERO; 8]; 3];
        for l in 0..LANES {
            let v = &field.0[l][start..start + 8];
            let mut xyz = [[0.0; 3]; 8];
            for k in 0..8 {
                xyz[k] = [v[k].x, v[k].y, v[k].z];
            }
            let t = thirds(&xyz);
            for third in 0..3 {
                rows[third][l] = L::from(t[third]);
            }
        }
        let rows = [
            L::transpose(rows[0]),
            L::transpose(rows[1]),
            L::transpose(rows[2]),
        ];
        let flat = rows.as_flattened();
        for k in 0..8 {
            let v = V3 {
                x: flat[3 * k],
                y: flat[3 * k + 1],
                z: flat[3 * k + 2],
            };
            set(&mut nodes[start + k], v);
        }
    }
}

/// Eight nodes' lanes `value(k)` (`k` in `0..8`) into `field[at[l]..at[l] + 8]` of every lane
/// `l` that is `done`: [`block`]'s transpose the other way.
#[inline(always)]
fn scatter(
    done: &[bool; LANES],
    at: &[usize; LANES],
    field: &mut [f32],
    value: impl Fn(usize) -> L,
) {
    let mut rows = [L::ZERO; 8];
    for k in 0..8 {
        rows[k] = value(k);
    }
    let rows = L::transpose(rows);
    for l in 0..LANES {
        if done[l] {
            field[at[l]..at[l] + 8].copy_from_slice(rows[l].as_array());
        }
    }
}

/// Eight nodes' 3-vectors `value(k)` to `store(l, xyz)` of every lane `l` that is `done`, the
/// coordinates of the eight in a row: as [`scatter`] on the 24 coordinates, three 8 x 8 blocks.
#[inline(always)]
fn scatter3(
    done: &[bool; LANES],
    mut store: impl FnMut(usize, &[f32; 24]),
    value: impl Fn(usize) -> V3,
) {
    let mut xyz = [[L::ZERO; 3]; 8];
    for k in 0..8 {
        let v = value(k);
        xyz[k] = [v.x, v.y, v.z];
    }
    let t = thirds(&xyz);
    let rows = [L::transpose(t[0]), L::transpose(t[1]), L::transpose(t[2])];
    for l in 0..LANES {
        if done[l] {
            let mut flat = [0.0; 24];
            for third in 0..3 {
                flat[8 * third..8 * third + 8].copy_from_slice(rows[third][l].as_array());
            }
            store(l, &flat);
        }
    }
}

/// Asks for every 64-byte line of `items` (see [`Strands::new`]): one address a line, and the
/// last element, for a range that straddles one line more. Plain address arithmetic: an
/// iterator chain here cost more instructions than the rest of the group's set-up
/// (docs/perf/dynamics.md).
#[inline(always)]
fn prefetch_slice<T>(items: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        let start = items.as_ptr().cast::<u8>();
        let bytes = std::mem::size_of_val(items);
        let mut offset = 0;
        while offset < bytes {
            prefetch(start.wrapping_add(offset));
            offset += 64;
        }
        if let Some(last) = items.last() {
            prefetch(std::ptr::from_ref(last).cast());
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = items;
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[expect(
    unsafe_code,
    reason = "a prefetch hint reads nothing and cannot fault; the addresses are within live slices"
)]
fn prefetch(x: *const u8) {
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
    // SAFETY: `_mm_prefetch` only hints the cache and never faults, whatever the address; SSE is
    // part of every x86-64 target.
    unsafe { _mm_prefetch::<_MM_HINT_T0>(x.cast()) };
}

/// The air's velocity relative to the head, in the head's frame, for eight points at once: the
/// model of `LocalEnv::air_velocity` (the wind at the step's time, seen from the moving head)
/// with the head's turn as a matrix and the turbulence's sines in lanes. Three vector sines do
/// the work of twenty-four calls of `sinf`.
pub(super) struct LaneAir {
    /// Head to world.
    turn: M3,
    position: V3,
    linear_velocity: V3,
    angular_velocity: V3,
    mean: V3,
    /// Scale, the three phases, drift and amplitude of the turbulence.
    turbulence: Option<(L, [L; 3], L, L)>,
}

impl LaneAir {
    pub(super) fn new(env: &crate::environment::LocalEnv<'_, f32>) -> Self {
        let head = &env.env.head;
        let splat = |v: &Vector| V3 {
            x: L::splat(v.x),
            y: L::splat(v.y),
            z: L::splat(v.z),
        };
        let m = head.rotation.matrix();
        Self {
            turn: M3 {
                r: [0, 1, 2].map(|i| V3 {
                    x: L::splat(m[(i, 0)]),
                    y: L::splat(m[(i, 1)]),
                    z: L::splat(m[(i, 2)]),
                }),
            },
            position: splat(&head.position.coords),
            linear_velocity: splat(&head.linear_velocity),
            angular_velocity: splat(&head.angular_velocity),
            mean: splat(&env.wind.mean),
            turbulence: env.wind.turbulence.map(|t| {
                (
                    L::splat(t.scale),
                    t.phases.map(L::splat),
                    L::splat(t.drift),
                    L::splat(t.amplitude),
                )
            }),
        }
    }

    /// At head-frame points `x`.
    #[inline(always)]
    fn velocity(&self, x: V3) -> V3 {
        let turned = self.turn.mul_v(x);
        let world = self.position + turned;
        let mut wind = self.mean;
        if let Some((scale, phases, drift, amplitude)) = self.turbulence {
            let q = [world.y, world.z, world.x].map(|c| c / scale);
            let [a, b, c] = [0, 1, 2].map(|k| (q[k] + phases[k] + drift).sin_cos().0);
            wind = wind + V3 { x: a, y: b, z: c } * amplitude;
        }
        let frame = self.linear_velocity + self.angular_velocity.cross(turned);
        self.turn.tr_mul_v(wind - frame)
    }
}

/// Zero where `v` is finite, NaN where it is infinite or NaN. A sum of these is zero exactly
/// when every term's value is finite, so [`not_finite`] of the sum is an `is_finite` test of
/// them all: one float subtraction and one addition a value where `f32x8::is_finite` takes
/// integer instructions, which AVX without AVX2 runs as two halves each
/// (docs/perf/dynamics.md).
#[inline(always)]
#[expect(
    clippy::eq_op,
    reason = "v - v is the test: NaN exactly when v is not finite"
)]
fn nan_unless_finite(v: L) -> L {
    v - v
}

/// The lanes where `nan_if_not` (a sum of [`nan_unless_finite`] terms) is not zero.
#[inline(always)]
fn not_finite(nan_if_not: L) -> L {
    !nan_if_not.simd_eq(L::ZERO)
}

/// A scalar function of a point, evaluated lane by lane (the environment's force fields).
#[inline(always)]
fn per_lane(p: V3, f: impl Fn(usize, Vector) -> Vector) -> V3 {
    let (x, y, z) = (p.x.to_array(), p.y.to_array(), p.z.to_array());
    let v: [Vector; LANES] = std::array::from_fn(|l| f(l, Vector::new(x[l], y[l], z[l])));
    V3 {
        x: L::from(v.map(|a| a.x)),
        y: L::from(v.map(|a| a.y)),
        z: L::from(v.map(|a| a.z)),
    }
}

/// The coordinates of the strand at `lo` in `run` (`n` nodes) in the order BDF2's history tag
/// reads them: the angles interleaved, then the rates interleaved.
fn coordinates<'a>(run: &'a Run<'_>, lo: usize, n: usize) -> impl Iterator<Item = f32> + 'a {
    let angles = (lo + 1..lo + n).flat_map(|i| [run.theta[i], run.phi[i]]);
    let rates = (lo + 1..lo + n).flat_map(|i| [run.omega_theta[i], run.omega_phi[i]]);
    angles.chain(rates)
}

/// Lane `l`'s strand: `members[l]`, or the last member in a spare lane.
#[inline(always)]
fn member(members: &[usize], l: usize) -> usize {
    members[l.min(members.len() - 1)]
}

/// The roots' positions and turns of the group's lanes (`local`: each lane's strand in `run`).
#[inline(always)]
fn root_frames(run: &Run<'_>, local: &[usize; LANES]) -> (V3, M3) {
    let (mut position, mut turn) = ([[0.0; LANES]; 3], [[[0.0; LANES]; 3]; 3]);
    for l in 0..LANES {
        let root = &run.roots[local[l]];
        for i in 0..3 {
            position[i][l] = root.position[i];
            for j in 0..3 {
                turn[i][j][l] = root.rotation[(i, j)];
            }
        }
    }
    let lanes3 = |v: [[f32; LANES]; 3]| V3 {
        x: L::from(v[0]),
        y: L::from(v[1]),
        z: L::from(v[2]),
    };
    let rows = [lanes3(turn[0]), lanes3(turn[1]), lanes3(turn[2])];
    (lanes3(position), M3 { r: rows })
}

/// Where each lane's strand is: its index in the run (`local`), where its nodes start in the
/// shared arrays (`global`) and in the run's slices (`in_run`).
struct GroupLanes {
    local: [usize; LANES],
    global: [usize; LANES],
    in_run: [usize; LANES],
}

impl GroupLanes {
    #[inline(always)]
    fn new(run: &Run<'_>, sh: &Shared<'_>, members: &[usize]) -> Self {
        let local: [usize; LANES] = std::array::from_fn(|l| member(members, l));
        let global: [usize; LANES] =
            std::array::from_fn(|l| sh.state_offsets[run.first + local[l]] as usize);
        let in_run: [usize; LANES] = std::array::from_fn(|l| global[l] - run.node_base);
        Self {
            local,
            global,
            in_run,
        }
    }
}

/// Each field of a group that the coupled step and ROS3 read, sliced to its strands and asked of
/// memory (`Strands::new`). Every field is its own statement: through an array's `map` the
/// closures were left out of line (docs/perf/dynamics.md).
struct GroupFields<'a> {
    theta: Strands<'a, f32>,
    phi: Strands<'a, f32>,
    omega_theta: Strands<'a, f32>,
    omega_phi: Strands<'a, f32>,
    length: Strands<'a, f32>,
    mass: Strands<'a, f32>,
    wetness: Strands<'a, f32>,
    damping: Strands<'a, f32>,
    k_theta: Strands<'a, f32>,
    k_phi: Strands<'a, f32>,
    rest_theta: Strands<'a, f32>,
    rest_phi: Strands<'a, f32>,
    k_stretch: Strands<'a, f32>,
    rest_length: Strands<'a, f32>,
    rest_points: Strands<'a, Vector>,
    /// `None` where no strand has a load of its caller's.
    force: Option<Strands<'a, Vector>>,
}

impl<'a> GroupFields<'a> {
    #[inline(always)]
    fn new(run: &'a Run<'_>, sh: &'a Shared<'_>, at: &GroupLanes, n: usize) -> Self {
        let (in_run, global) = (&at.in_run, &at.global);
        Self {
            theta: Strands::new(&*run.theta, in_run, n),
            phi: Strands::new(&*run.phi, in_run, n),
            omega_theta: Strands::new(&*run.omega_theta, in_run, n),
            omega_phi: Strands::new(&*run.omega_phi, in_run, n),
            length: Strands::new(&*run.length, in_run, n),
            mass: Strands::new(sh.mass, global, n),
            wetness: Strands::new(sh.wetness, global, n),
            damping: Strands::new(sh.damping, global, n),
            k_theta: Strands::new(sh.k_theta, global, n),
            k_phi: Strands::new(sh.k_phi, global, n),
            rest_theta: Strands::new(sh.rest_theta, global, n),
            rest_phi: Strands::new(sh.rest_phi, global, n),
            k_stretch: Strands::new(sh.k_stretch, global, n),
            rest_length: Strands::new(sh.rest_length, global, n),
            rest_points: Strands::new(sh.rest_points, global, n),
            force: (!sh.force.is_empty()).then(|| Strands::new(sh.force, global, n)),
        }
    }

    /// What the first pass reads: the state.
    #[inline(always)]
    fn gather_state(&self, nodes: &mut [NodeIn]) {
        gather(nodes, &self.theta, |node, v| node.theta = v);
        gather(nodes, &self.phi, |node, v| node.phi = v);
        gather(nodes, &self.omega_theta, |node, v| node.omega_theta = v);
        gather(nodes, &self.omega_phi, |node, v| node.omega_phi = v);
        gather(nodes, &self.length, |node, v| node.length = v);
    }

    /// The rest, gathered after the first pass: their prefetches then have its time to arrive.
    #[inline(always)]
    fn gather_params(&self, nodes: &mut [NodeIn]) {
        gather(nodes, &self.mass, |node, v| node.mass = v);
        gather(nodes, &self.wetness, |node, v| node.wetness = v);
        gather(nodes, &self.damping, |node, v| node.damping = v);
        gather(nodes, &self.k_theta, |node, v| node.k_theta = v);
        gather(nodes, &self.k_phi, |node, v| node.k_phi = v);
        gather(nodes, &self.rest_theta, |node, v| node.rest_theta = v);
        gather(nodes, &self.rest_phi, |node, v| node.rest_phi = v);
        gather(nodes, &self.k_stretch, |node, v| node.k_stretch = v);
        gather(nodes, &self.rest_length, |node, v| node.rest_length = v);
        gather3(nodes, &self.rest_points, |node, v| node.rest_point = v);
        if let Some(force) = &self.force {
            gather3(nodes, force, |node, v| node.force = v);
        }
    }
}

/// The end-of-step positions and velocities of the group's `members` strands are only written,
/// at the end: asked for at the start, their lines are in cache by then rather than each first
/// store waiting for one.
#[inline(always)]
fn prefetch_outputs(run: &Run<'_>, in_run: &[usize; LANES], members: usize, n: usize) {
    for &base in &in_run[..members] {
        prefetch_slice(&run.positions[base..base + n]);
        prefetch_slice(&run.velocities[base..base + n]);
    }
}

/// `v` in every lane.
#[inline(always)]
fn splat3(v: &Vector) -> V3 {
    V3 {
        x: L::splat(v.x),
        y: L::splat(v.y),
        z: L::splat(v.z),
    }
}

/// What the loads on the nodes are made of (as `strand::forces` has them).
struct Loads<'a> {
    sh: &'a Shared<'a>,
    gravity: V3,
    drag: L,
    has_fields: bool,
    has_external: bool,
}

impl<'a> Loads<'a> {
    #[inline(always)]
    fn new(sh: &'a Shared<'a>) -> Self {
        Self {
            sh,
            gravity: splat3(&sh.env.gravity),
            drag: L::splat(sh.env.env.wind.drag),
            has_fields: !sh.env.env.fields.is_empty(),
            has_external: !sh.force.is_empty(),
        }
    }

    /// The load on a node of mass `mi` at `xi` moving at `vi`, its segment along `tangent` of
    /// length `len`, with the caller's load `external`. Not a closure: the step's closures were
    /// left out of line.
    #[inline(always)]
    fn at(&self, mi: L, xi: V3, vi: V3, tangent: V3, len: L, external: V3) -> V3 {
        let mut fi = self.gravity * mi;
        if let Some(air) = &self.sh.lane_air {
            // Drag on the air's velocity across the segment.
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

/// The joint of angles `(x, y)` after the frame `rot` (which it then turns to the joint's
/// child): the joint's axes in the parent's frame, `rot`'s columns turned on.
#[inline(always)]
fn link(rot: &mut M3, x: L, y: L) -> [V3; 2] {
    let bend = LaneBend::new(x, y);
    let ax = rot.mul_v(bend.axis_x);
    let ay = rot.mul_v(bend.axis_y);
    *rot = rot.mul_m(&bend.rotation);
    [ax, ay]
}

/// Pass 1 of both steps, root to tip: the kinematics at the state in `nodes` (positions,
/// tangents, joint axes, and velocities where air drags) and the prefix sums of `A w`, into
/// `joints` (the joint's state, axes and prefix sum) and the per-node buffers.
#[inline(always)]
#[expect(
    clippy::too_many_arguments,
    reason = "the pass's buffers are distinct fields of the scratch"
)]
fn first_pass<J: HasJoint>(
    nodes: &[NodeIn],
    joints: &mut [J],
    pos: &mut [V3],
    vel: &mut [V3],
    tangent: &mut [V3],
    (root_pos, root_rot): (V3, M3),
    has_air: bool,
    n: usize,
) {
    let (nodes, joints) = (&nodes[..n], &mut joints[..n - 1]);
    let (pos, vel, tangent) = (&mut pos[..n], &mut vel[..n], &mut tangent[..n]);
    let mut rot = root_rot;
    let mut omega = V3::default();
    pos[0] = root_pos;
    vel[0] = V3::default();
    for i in 1..n {
        let node = &nodes[i];
        let (x, y) = (node.theta, node.phi);
        let (wx, wy) = (node.omega_theta, node.omega_phi);
        let [ax, ay] = link(&mut rot, x, y);
        let t = rot.column(2);
        let len = node.length;
        let seg = t * len;
        let joint = joints[i - 1].joint_mut();
        (joint.q, joint.w, joint.len) = ([x, y], [wx, wy], len);
        joint.a = [ax, ay];
        joint.prefix = omega;
        omega = omega + ax * wx + ay * wy;
        tangent[i] = t;
        pos[i] = pos[i - 1] + seg;
        if has_air {
            vel[i] = vel[i - 1] + omega.cross(seg);
        }
    }
}

/// The sums pass 2 carries from the tip to the root (as `strand::torques` keeps them).
struct TipSums {
    s_f: V3,
    t_vec: V3,
    s_m: L,
    s_mp: V3,
    s_mp2: L,
    s_pf: M3,
    s_fp: L,
    /// The rest point of the node below the last joint summed.
    rest_next: V3,
}

/// What pass 2 finds at a joint.
struct JointTerms {
    inertia: L,
    torque: V3,
    /// The load on the segment (the chain's: on it and everything beyond).
    load: V3,
    /// The Jacobian's column and row generators (`strand::load_column_generator`,
    /// `load_row_generator`).
    v: [V3; 2],
    wg: [V3; 2],
}

impl TipSums {
    /// Before the tip's joint, whose child node has the rest point `rest_tip`.
    #[inline(always)]
    fn new(rest_tip: V3) -> Self {
        Self {
            s_f: V3::default(),
            t_vec: V3::default(),
            s_m: L::ZERO,
            s_mp: V3::default(),
            s_mp2: L::ZERO,
            s_pf: M3::default(),
            s_fp: L::ZERO,
            rest_next: rest_tip,
        }
    }

    /// The joint between `pivot` and the node at `xi` (mass `mi`, load `fi`, segment length
    /// `len`, axes `a`), whose pivot rests at `rc`.
    #[inline(always)]
    #[expect(
        clippy::too_many_arguments,
        reason = "the joint's inputs are all distinct lanes"
    )]
    fn joint(
        &mut self,
        chain: bool,
        fi: V3,
        xi: V3,
        pivot: V3,
        rc: V3,
        mi: L,
        len: L,
        a: [V3; 2],
    ) -> JointTerms {
        let seg = xi - pivot;
        let rp = self.rest_next;
        self.rest_next = rc;
        self.s_m += mi;
        self.s_mp = self.s_mp + rp * mi;
        self.s_mp2 += rp.norm_squared() * mi;
        let (inertia, torque, load, p, s, sigma);
        if chain {
            inertia = self.s_mp2 - L::splat(2.0) * rc.dot(self.s_mp) + rc.norm_squared() * self.s_m;
            self.s_f = self.s_f + fi;
            self.t_vec = self.t_vec + seg.cross(self.s_f);
            torque = self.t_vec;
            load = self.s_f;
            self.s_pf.add_outer(xi, fi);
            self.s_fp += fi.dot(xi);
            (p, s, sigma) = (self.s_pf, self.s_f, self.s_fp);
        } else {
            inertia = (rp - rc).norm_squared() * mi;
            torque = seg.cross(fi);
            load = fi;
            let mut own = M3::default();
            own.add_outer(xi, fi);
            (p, s, sigma) = (own, fi, fi.dot(xi));
        }
        let inertia = inertia.max(L::splat(1e-2) * mi * len * len);
        let sc_dot = sigma - s.dot(pivot);
        let column = |at: V3| p.mul_v(at) - pivot * s.dot(at) - at * sc_dot;
        let row = |at: V3| p.tr_mul_v(at) - s * at.dot(pivot) - at * sc_dot + at.cross(torque);
        JointTerms {
            inertia,
            torque,
            load,
            v: [column(a[0]), column(a[1])],
            wg: [row(a[0]), row(a[1])],
        }
    }
}

/// What a joint's step of the elimination gives.
struct Eliminated {
    /// The 2 x 2 block's inverse.
    inverse: [[L; 2]; 2],
    /// `G_j = M A_j + V_j`, the gain `E_j` and the offset `e_j`.
    g: [V3; 2],
    gain: [V3; 2],
    offset: [L; 2],
}

/// Joint `joint`'s step of the elimination, tip to root, with the step `h` (`h2 = h^2`): from
/// the affine map `suf = M pre + r` of the joints beyond (`gain_m`, `gain_r`), which it then
/// moves one joint up; `failed` gains the lanes whose block is singular.
#[inline(always)]
fn eliminate(joint: &Joint, gain_m: &mut M3, gain_r: &mut V3, h2: L, failed: &mut L) -> Eliminated {
    let (a, v, wg, d, b) = (joint.a, joint.v, joint.wg, joint.d, joint.b);
    // suf_j = G x_j + M pre_j + r with G = M A_j + V_j; the joint's 2 x 2 block.
    let g = [gain_m.mul_v(a[0]) + v[0], gain_m.mul_v(a[1]) + v[1]];
    let b00 = d[0] - h2 * a[0].dot(g[0]);
    let b01 = -h2 * a[0].dot(g[1]);
    let b10 = -h2 * a[1].dot(g[0]);
    let b11 = d[1] - h2 * a[1].dot(g[1]);
    let det = b00 * b11 - b01 * b10;
    *failed |= det.simd_eq(L::ZERO) | not_finite(nan_unless_finite(det));
    let inv_det = L::ONE / det;
    let inv = [
        [b11 * inv_det, -b01 * inv_det],
        [-b10 * inv_det, b00 * inv_det],
    ];
    let coupling = [
        (wg[0] + gain_m.tr_mul_v(a[0])) * h2,
        (wg[1] + gain_m.tr_mul_v(a[1])) * h2,
    ];
    let rr = [b[0] + h2 * a[0].dot(*gain_r), b[1] + h2 * a[1].dot(*gain_r)];
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
    *gain_r = *gain_r + g[0] * offset[0] + g[1] * offset[1];
    Eliminated {
        inverse: inv,
        g,
        gain,
        offset,
    }
}

/// The unknowns at joint `joint` from the prefix sum `prefix` of `A x`, which they then move one
/// joint down (`x_j = E_j pre_j + e_j`); keeps them and the residual check's terms that read the
/// prefix sum.
#[inline(always)]
fn unknowns(joint: &mut Joint, prefix: &mut V3, h2: L) -> [L; 2] {
    let x = [
        joint.gain[0].dot(*prefix) + joint.offset[0],
        joint.gain[1].dot(*prefix) + joint.offset[1],
    ];
    joint.x = x;
    joint.left = [h2 * joint.wg[0].dot(*prefix), h2 * joint.wg[1].dot(*prefix)];
    *prefix = *prefix + joint.a[0] * x[0] + joint.a[1] * x[1];
    x
}

/// The segment's length at the end of the step: a quasi-static stretch spring takes the length
/// its tension asks for; without one, `len`.
#[inline(always)]
fn end_length(node: &NodeIn, tension: L, len: L) -> L {
    let stretched = node.rest_length * (L::ONE + tension.max(L::ZERO) / node.k_stretch);
    node.k_stretch.simd_gt(L::ZERO).select(stretched, len)
}

/// A solve's residual check, accumulated joint by joint from the tip: the largest residual of a
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
    #[inline(always)]
    fn new() -> Self {
        Self {
            suffix: V3::default(),
            worst: L::ZERO,
            scale: L::ZERO,
            nan_if_failed: L::ZERO,
        }
    }

    /// Joint `joint`'s two rows, with the unknowns and right-hand side kept in it.
    #[inline(always)]
    fn joint(&mut self, joint: &Joint, h2: L, chain: bool) {
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
    #[inline(always)]
    fn failed(&self) -> L {
        not_finite(self.nan_if_failed)
            | self
                .worst
                .simd_gt(L::splat(f32::EPSILON.sqrt()) * self.scale)
    }
}

fn step_group_in(
    run: &mut Run<'_>,
    sh: &Shared<'_>,
    members: &[usize],
    n: usize,
    ls: &mut LaneScratch,
) -> [LaneOutcome; LANES] {
    let settings: &StepSettings = &sh.settings;
    let chain = settings.torque == TorqueModel::Chain;
    let bdf2 = settings.integrator == Integrator::ImplicitBdf2;
    let at = GroupLanes::new(run, sh, members);
    let (local, in_run) = (&at.local, &at.in_run);
    // BDF2 reads a strand's previous step only if the strand is as its last BDF2 step left it
    // (`bdf2::history_tag`); a lane without that history takes the coupled step, `b = h`.
    let m2 = 2 * (n - 1);
    let history: [bool; LANES] = std::array::from_fn(|l| {
        let (lo, rs) = (in_run[l], &run.roots[local[l]]);
        bdf2 && rs.history != 0
            && rs.history == bdf2::history_tag_of(m2, coordinates(run, lo, n), rs, settings.dt)
    });
    // `h` from here on is each lane's step in the system: BDF2's `b = 2h/3` where it has history.
    let b_step = (settings.dt + settings.dt) / 3.0;
    let has_history = L::from(history.map(|has| if has { 1.0 } else { 0.0 })).simd_gt(L::ZERO);
    let h = has_history.select(L::splat(b_step), L::splat(settings.dt));
    let h2 = h * h;
    let third = L::splat(3.0);
    let fields = GroupFields::new(run, sh, &at, n);
    let previous = bdf2.then(|| {
        [
            &*run.prev_theta,
            &*run.prev_phi,
            &*run.prev_omega_theta,
            &*run.prev_omega_phi,
        ]
        .map(|field| Strands::new(field, in_run, n))
    });
    prefetch_outputs(run, in_run, members.len(), n);
    let (root_pos, root_rot) = root_frames(run, local);
    let loads = Loads::new(sh);

    // What pass 1 reads, in lane layout (the other fields later: their prefetches then have
    // pass 1's time to arrive).
    let nodes = &mut ls.nodes[..n];
    fields.gather_state(nodes);
    if let Some(previous) = &previous {
        for (t, field) in previous.iter().enumerate() {
            gather(nodes, field, |node, v| node.prev[t] = v);
        }
    }

    // Pass 1, root to tip: kinematics and the prefix sums of A w.
    let has_air = sh.lane_air.is_some();
    first_pass(
        &ls.nodes,
        &mut ls.joints,
        &mut ls.pos,
        &mut ls.vel,
        &mut ls.tangent,
        (root_pos, root_rot),
        has_air,
        n,
    );
    if bdf2 {
        // BDF2 (`integrate::bdf2`): the coupled system with `h -> b`, the rates on the right
        // `w + a / b` (and the prefix sums of `A` on them), and the torque `tau + I c / b`
        // (pass 2).
        let mut omega_rhs = V3::default();
        for i in 1..n {
            let [pq0, pq1, pw0, pw1] = ls.nodes[i].prev;
            let joint = &mut ls.joints[i - 1];
            let ([x, y], [wx, wy]) = (joint.q, joint.w);
            let shift =
                [(x - pq0) / third, (y - pq1) / third].map(|a| has_history.select(a, L::ZERO));
            let w_rhs = [wx + shift[0] / h, wy + shift[1] / h];
            ls.bdf2[i - 1] = Bdf2Joint {
                w_rhs,
                shift,
                w_prev: [pw0, pw1],
            };
            joint.prefix = omega_rhs;
            omega_rhs = omega_rhs + joint.a[0] * w_rhs[0] + joint.a[1] * w_rhs[1];
        }
    }

    fields.gather_params(&mut ls.nodes[..n]);

    // Pass 2, tip to root: torques and sums, generators (the elimination in pass 2b: each loop
    // then keeps fewer sums live than the sixteen registers, where one loop spilled most of them;
    // docs/perf/dynamics.md).
    let (nodes, joints) = (&ls.nodes[..n], &mut ls.joints[..n - 1]);
    let (pos, vel, tangent, tension) = (
        &ls.pos[..n],
        &ls.vel[..n],
        &ls.tangent[..n],
        &mut ls.tension[..n],
    );
    let mut sums = TipSums::new(nodes[n - 1].rest_point);
    let mut suffix_w = V3::default();
    for i in (1..n).rev() {
        let j = i - 1;
        let joint = &mut joints[j];
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
        let w_rhs = if bdf2 { ls.bdf2[j].w_rhs } else { w };
        suffix_w = suffix_w + v[0] * w_rhs[0] + v[1] * w_rhs[1];
        let mut d = [L::ZERO; 2];
        let mut b = [L::ZERO; 2];
        for t in 0..2 {
            let mut tau = a[t].dot(torque) - k[t] * (q[t] - rest[t]) - damping * w[t];
            if bdf2 {
                let c = has_history.select((w[t] - ls.bdf2[j].w_prev[t]) / third, L::ZERO);
                tau += inertia * c / h;
            }
            let jw = wg[t].dot(joint.prefix) + a[t].dot(suffix_w);
            d[t] = inertia + h * damping + h2 * k[t];
            b[t] = h * tau + h2 * (jw - k[t] * w_rhs[t]);
        }
        joint.v = v;
        joint.wg = wg;
        joint.d = d;
        joint.b = b;
    }

    // Pass 2b, tip to root: the elimination.
    let mut failed = L::ZERO.simd_ne(L::ZERO); // all false
    let (mut gain_m, mut gain_r) = (M3::default(), V3::default());
    for joint in ls.joints[..n - 1].iter_mut().rev() {
        if !chain {
            gain_m = M3::default();
            gain_r = V3::default();
        }
        let step = eliminate(joint, &mut gain_m, &mut gain_r, h2, &mut failed);
        joint.gain = step.gain;
        joint.offset = step.offset;
    }

    // Pass 3, root to tip: the unknowns (`x_j = E_j pre_j + e_j` on the prefix sums of `A x`),
    // the new state and the end-of-step positions and velocities; and the check's terms that
    // read the prefix sums, while they are at hand.
    let mut prefix = V3::default();
    let mut rot = root_rot;
    let mut omega = V3::default();
    let mut pos = root_pos;
    let mut vel = V3::default();
    // Zero, or NaN in a lane with a value of its new state that is not finite.
    let mut nan_if_bad = L::ZERO;
    let mut too_far = L::ZERO.simd_ne(L::ZERO); // all false
    let tolerance = L::splat(bdf2::ERROR_TOLERANCE as f32);
    let members_len = members.len();
    for i in 1..n {
        let joint = &mut ls.joints[i - 1];
        let x = unknowns(joint, &mut prefix, h2);
        let w = [joint.w[0] + x[0], joint.w[1] + x[1]];
        let q = if bdf2 {
            for t in 0..2 {
                // BDF2's local error `(b / 3) (w_{n+1} - 2 w_n + w_{n-1})`, as `bdf2::solve_step`
                // estimates it; written so that a NaN fails too.
                let error =
                    h / third * (w[t] - (joint.w[t] + joint.w[t]) + ls.bdf2[i - 1].w_prev[t]);
                too_far |= has_history & !error.abs().simd_le(tolerance);
            }
            [
                joint.q[0] + (ls.bdf2[i - 1].shift[0] + h * w[0]),
                joint.q[1] + (ls.bdf2[i - 1].shift[1] + h * w[1]),
            ]
        } else {
            [joint.q[0] + h * w[0], joint.q[1] + h * w[1]]
        };
        let len = end_length(&ls.nodes[i], ls.tension[i], joint.len);
        nan_if_bad += (nan_unless_finite(q[0]) + nan_unless_finite(q[1]))
            + (nan_unless_finite(w[0]) + nan_unless_finite(w[1]))
            + nan_unless_finite(len);
        let [ax, ay] = link(&mut rot, q[0], q[1]);
        let seg = rot.column(2) * len;
        omega = omega + ax * w[0] + ay * w[1];
        pos = pos + seg;
        vel = vel + omega.cross(seg);
        ls.out[i] = NodeOut {
            q,
            w,
            len,
            pos,
            vel,
        };
    }
    let bad = not_finite(nan_if_bad);

    // Pass 4, tip to root: the residual of every row against the size of its terms (as the
    // scalar solve checks it).
    let mut check = Check::new();
    for joint in ls.joints[..n - 1].iter().rev() {
        check.joint(joint, h2, chain);
    }
    failed |= check.failed();

    let mut outcome = [LaneOutcome::Done; LANES];
    let failed = failed.to_bitmask();
    for (l, o) in outcome.iter_mut().enumerate() {
        if failed & (1 << l) != 0 {
            *o = LaneOutcome::Declined;
        }
    }
    let (bad, too_far) = (bad.to_bitmask(), too_far.to_bitmask());
    for (l, o) in outcome.iter_mut().enumerate() {
        if *o == LaneOutcome::Done && bad & (1 << l) != 0 {
            *o = LaneOutcome::NonFinite;
        } else if *o == LaneOutcome::Done && too_far & (1 << l) != 0 {
            *o = LaneOutcome::Redo;
        }
    }
    // Back to the run: only the strands that succeeded.
    let done: [bool; LANES] =
        std::array::from_fn(|l| l < members_len && outcome[l] == LaneOutcome::Done);
    for l in (0..LANES).filter(|&l| done[l]) {
        let base = in_run[l];
        run.positions[base] = run.roots[local[l]].position;
        run.velocities[base] = Vector::zeros();
        if bdf2 {
            // The step one back, for the next BDF2 step (the root is attached and keeps its
            // place).
            let span = base + 1..base + n;
            run.prev_theta[span.clone()].copy_from_slice(&run.theta[span.clone()]);
            run.prev_phi[span.clone()].copy_from_slice(&run.phi[span.clone()]);
            run.prev_omega_theta[span.clone()].copy_from_slice(&run.omega_theta[span.clone()]);
            run.prev_omega_phi[span.clone()].copy_from_slice(&run.omega_phi[span]);
            let rs = &mut run.roots[local[l]];
            (rs.prev_position, rs.prev_velocity) = (rs.position, rs.velocity);
        }
    }
    publish_nodes(run, &ls.out, &done, in_run, n);
    for l in (0..LANES).filter(|&l| done[l]) {
        run.roots[local[l]].history = if bdf2 {
            let rs = &run.roots[local[l]];
            bdf2::history_tag_of(m2, coordinates(run, in_run[l], n), rs, settings.dt)
        } else {
            0
        };
    }
    outcome
}

/// The end-of-step state `out` of the group's nodes `1..n` into the run, for every lane that is
/// `done`.
#[inline(always)]
fn publish_nodes(
    run: &mut Run<'_>,
    out: &[NodeOut],
    done: &[bool; LANES],
    in_run: &[usize; LANES],
    n: usize,
) {
    if n > 8 {
        // Eight nodes at a time, transposed back to strand by strand: each lane's eight values
        // of a field are one store.
        for start in blocks(n - 1).map(|b| b + 1) {
            let out = &out[start..start + 8];
            let mut at = [0; LANES];
            for l in 0..LANES {
                at[l] = in_run[l] + start;
            }
            scatter(done, &at, &mut *run.theta, |k| out[k].q[0]);
            scatter(done, &at, &mut *run.phi, |k| out[k].q[1]);
            scatter(done, &at, &mut *run.omega_theta, |k| out[k].w[0]);
            scatter(done, &at, &mut *run.omega_phi, |k| out[k].w[1]);
            scatter(done, &at, &mut *run.length, |k| out[k].len);
            scatter3(
                done,
                |l, flat| {
                    let dst = &mut run.positions[at[l]..at[l] + 8];
                    for (p, c) in dst.iter_mut().zip(flat.chunks_exact(3)) {
                        *p = Point::new(c[0], c[1], c[2]);
                    }
                },
                |k| out[k].pos,
            );
            scatter3(
                done,
                |l, flat| {
                    let dst = &mut run.velocities[at[l]..at[l] + 8];
                    for (v, c) in dst.iter_mut().zip(flat.chunks_exact(3)) {
                        *v = Vector::new(c[0], c[1], c[2]);
                    }
                },
                |k| out[k].vel,
            );
        }
    } else {
        for l in (0..LANES).filter(|&l| done[l]) {
            let base = in_run[l];
            for i in 1..n {
                let out = &out[i];
                let lane = |v: &L| v.as_array()[l];
                let at = base + i;
                run.theta[at] = lane(&out.q[0]);
                run.phi[at] = lane(&out.q[1]);
                run.omega_theta[at] = lane(&out.w[0]);
                run.omega_phi[at] = lane(&out.w[1]);
                run.length[at] = lane(&out.len);
                run.positions[at] =
                    Point::new(lane(&out.pos.x), lane(&out.pos.y), lane(&out.pos.z));
                run.velocities[at] =
                    Vector::new(lane(&out.vel.x), lane(&out.vel.y), lane(&out.vel.z));
            }
        }
    }
}

/// The bend `(x, y)` in lanes: as [`crate::bend::Bend::new`].
struct LaneBend {
    rotation: M3,
    axis_x: V3,
    axis_y: V3,
}

impl LaneBend {
    #[inline(always)]
    fn new(x: L, y: L) -> Self {
        let a2 = x * x + y * y;
        let small_limit = L::splat(1e-4);
        let small = a2.simd_lt(small_limit);
        let one = L::ONE;
        // The closed forms on a clamped angle, so that the lanes not taking them stay finite;
        // the series near zero, where the closed forms cancel (worked out only when a lane
        // needs them: five divisions a joint, and a joint is rarely that straight).
        let a2c = a2.max(small_limit);
        let a = a2c.sqrt();
        let (sin, cos) = a.sin_cos();
        let (mut s, mut c, mut e) = (sin / a, (one - cos) / a2c, (a - sin) / (a2c * a));
        if small.any() {
            let s_series = one - a2 / L::splat(6.0) + a2 * a2 / L::splat(120.0);
            let c_series = L::splat(0.5) - a2 / L::splat(24.0) + a2 * a2 / L::splat(720.0);
            let e_series = one / L::splat(6.0) - a2 / L::splat(120.0);
            s = small.select(s_series, s);
            c = small.select(c_series, c);
            e = small.select(e_series, e);
        }
        let cxy = c * x * y;
        let rotation = M3 {
            r: [
                V3 {
                    x: one - c * y * y,
                    y: cxy,
                    z: s * y,
                },
                V3 {
                    x: cxy,
                    y: one - c * x * x,
                    z: -s * x,
                },
                V3 {
                    x: -s * y,
                    y: s * x,
                    z: one - c * a2,
                },
            ],
        };
        let exy = e * x * y;
        Self {
            rotation,
            axis_x: V3 {
                x: one - e * y * y,
                y: exy,
                z: -c * y,
            },
            axis_y: V3 {
                x: exy,
                y: one - e * x * x,
                z: c * x,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::step_strand;
    use crate::strand::{RootDyn, Scratch, StrandParams};
    use crate::{
        Environment, Integrator, LinearSolver, Material, Point, Real, Root, SkeletonDesc,
        StepSettings, StrandState, TorqueModel, Vector,
    };
    use nalgebra::Rotation3;
    use proptest::prelude::*;

    /// A small deterministic generator for the strands' shapes.
    struct Rng(u64);

    impl Rng {
        fn unit(&mut self) -> Real {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 40) as Real / (1u64 << 24) as Real
        }

        fn signed(&mut self) -> Real {
            2.0 * self.unit() - 1.0
        }
    }

    /// `count` attached strands of `n` nodes, 20 cm, in a seeded tilt, bent by up to `bend` rad
    /// per joint from their straight rest shape and turning at up to `rate` rad/s, with joint
    /// stiffness `k`; with `load`, a seeded force of up to that many newtons on every node.
    fn strands(
        count: usize,
        n: usize,
        seed: u64,
        bend: Real,
        rate: Real,
        k: Real,
        load: Real,
    ) -> StrandState {
        let mut rng = Rng(seed);
        let mut state = StrandState::new();
        for s in 0..count {
            let axis = Vector::new(rng.signed(), rng.signed(), rng.signed());
            let frame = Rotation3::new(axis * 1.5);
            let root = Point::new(0.01 * s as Real, 0.0, 0.0);
            let d = 0.2 / (n - 1) as Real;
            let points: Vec<Point> = (0..n)
                .map(|i| root + frame * Vector::z() * (d * i as Real))
                .collect();
            let id = state
                .add_skeleton(&SkeletonDesc {
                    root: Root::Attached {
                        position: root,
                        frame,
                    },
                    points,
                    material: Material {
                        linear_density: 0.02,
                        bending_stiffness: k * d,
                        damping: 1e-6,
                        ..Material::default()
                    },
                })
                .expect("a valid strand");
            for i in state.nodes(id).skip(1) {
                state.theta_mut()[i] = bend * rng.signed();
                state.phi_mut()[i] = bend * rng.signed();
                state.omega_theta_mut()[i] = rate * rng.signed();
                state.omega_phi_mut()[i] = rate * rng.signed();
                if load > 0.0 {
                    state.external_force_mut()[i] =
                        Vector::new(rng.signed(), rng.signed(), rng.signed()) * load;
                }
            }
            state.refresh_positions(id);
        }
        state
    }

    fn settings(h: Real, model: TorqueModel, solver: LinearSolver) -> StepSettings {
        StepSettings {
            dt: h,
            integrator: Integrator::ImplicitCoupled,
            torque: model,
            solver,
        }
    }

    /// One step of every strand by the scalar structured step (`step_strand`, one strand at a
    /// time), returning the new angles (theta and phi of every node).
    fn scalar_structured(state: &StrandState, h: Real, model: TorqueModel) -> (Vec<Real>, usize) {
        let (after, fallbacks) = scalar_structured_coordinates(state, h, model);
        (after.angles, fallbacks)
    }

    /// A state's coordinates after a step, each field theta's nodes then phi's (lengths once).
    struct Coordinates {
        angles: Vec<Real>,
        rates: Vec<Real>,
        lengths: Vec<Real>,
    }

    /// [`scalar_structured`]'s step, returning every coordinate it changes.
    fn scalar_structured_coordinates(
        state: &StrandState,
        h: Real,
        model: TorqueModel,
    ) -> (Coordinates, usize) {
        scalar_structured_in(&Environment::default(), state, h, model)
    }

    /// [`scalar_structured_coordinates`] in the environment `env`.
    fn scalar_structured_in(
        env: &Environment,
        state: &StrandState,
        h: Real,
        model: TorqueModel,
    ) -> (Coordinates, usize) {
        let (after, sc) = scalar_in(env, state, &settings(h, model, LinearSolver::Structured));
        (after, sc.dense_fallbacks)
    }

    /// Every strand of `state` stepped once by the scalar step (`step_strand`) under `set` in
    /// `env`: the coordinates after, and the scratch with its counts.
    fn scalar_in(
        env: &Environment,
        state: &StrandState,
        set: &StepSettings,
    ) -> (Coordinates, Scratch<Real>) {
        let local = env.local::<Real>();
        let mut theta = state.theta.clone();
        let mut phi = state.phi.clone();
        let mut omega_theta = state.omega_theta.clone();
        let mut omega_phi = state.omega_phi.clone();
        let mut lengths = state.length.clone();
        let mut sc = Scratch::default();
        for s in 0..state.skeleton_count() {
            let g = state.nodes(crate::SkeletonId(s as u32));
            let n = g.len();
            let mut q: Vec<Real> = (1..n)
                .flat_map(|i| [state.theta[g.start + i], state.phi[g.start + i]])
                .collect();
            let mut w: Vec<Real> = (1..n)
                .flat_map(|i| [state.omega_theta[g.start + i], state.omega_phi[g.start + i]])
                .collect();
            let mut root: RootDyn<Real> = state.root_dyn(s);
            let mut length = state.length[g.clone()].to_vec();
            let p = StrandParams {
                rest_theta: &state.rest_theta[g.clone()],
                rest_phi: &state.rest_phi[g.clone()],
                mass: &state.mass[g.clone()],
                wetness: &state.wetness[g.clone()],
                k_theta: &state.k_theta[g.clone()],
                k_phi: &state.k_phi[g.clone()],
                damping: &state.damping[g.clone()],
                rest_points: &state.rest_points[g.clone()],
                external: &state.external_force[g.clone()],
            };
            let bad = step_strand(
                &mut root,
                &mut q,
                &mut w,
                &mut length,
                &state.rest_length[g.clone()],
                &state.k_stretch[g.clone()],
                &p,
                &local,
                set,
                None,
                &mut sc,
            );
            assert_eq!(bad, None, "the scalar step of strand {s} went non-finite");
            for i in 1..n {
                theta[g.start + i] = q[2 * i - 2];
                phi[g.start + i] = q[2 * i - 1];
                omega_theta[g.start + i] = w[2 * i - 2];
                omega_phi[g.start + i] = w[2 * i - 1];
            }
            lengths[g.clone()].copy_from_slice(&length);
        }
        let after = Coordinates {
            angles: theta.into_iter().chain(phi).collect(),
            rates: omega_theta.into_iter().chain(omega_phi).collect(),
            lengths,
        };
        (after, sc)
    }

    /// One step through `StrandState::step` (the lanes for the structured solver, the scalar
    /// dense step for the others): the new angles and the report's dense fallbacks.
    fn stepped(
        state: &StrandState,
        h: Real,
        model: TorqueModel,
        solver: LinearSolver,
    ) -> (Vec<Real>, usize) {
        stepped_in(&Environment::default(), state, h, model, solver)
    }

    /// [`stepped`] in the environment `env`.
    fn stepped_in(
        env: &Environment,
        state: &StrandState,
        h: Real,
        model: TorqueModel,
        solver: LinearSolver,
    ) -> (Vec<Real>, usize) {
        let mut s = state.clone();
        let report = s
            .step(env, &settings(h, model, solver))
            .expect("a finite step");
        (
            s.theta.iter().chain(&s.phi).copied().collect(),
            report.dense_fallbacks,
        )
    }

    /// The proptests' strands: `count` of `n` nodes, bent up to 1.2 rad a joint or near
    /// straight (1e-5 rad), joints of stiffness `10^log_k`, and the load model.
    fn random_group(
        count: usize,
        n: usize,
        seed: u64,
        straight: bool,
        log_k: f32,
        chain: bool,
    ) -> (StrandState, TorqueModel) {
        let bend = if straight { 1e-5 } else { 1.2 };
        let state = strands(count, n, seed, bend, 2.0, 10f32.powf(log_k), 0.0);
        let model = if chain {
            TorqueModel::Chain
        } else {
            TorqueModel::Local
        };
        (state, model)
    }

    fn worst(a: &[Real], b: &[Real]) -> Real {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, Real::max)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64)))]

        /// The lane step gives the scalar structured step's and the dense (faer) step's angles
        /// to 1e-5 rad, on random strands: 1 to 19 of them (full and padded groups), 2 to 40
        /// nodes, bent up to 1.2 rad a joint or near straight (1e-5 rad, the bend's series
        /// branch), soft to stiff joints (k from 1e-6 to 1 N m/rad), both load models.
        #[test]
        fn the_lane_step_agrees_with_the_scalar_and_dense_steps(
            count in 1usize..20, n in 2usize..40, seed in any::<u64>(),
            straight in any::<bool>(), log_k in -6.0f32..0.0, h in 1e-3f32..0.02,
            chain in any::<bool>()) {
            let (state, model) = random_group(count, n, seed, straight, log_k, chain);
            let (lanes, lane_fallbacks) = stepped(&state, h, model, LinearSolver::Structured);
            let (faer, _) = stepped(&state, h, model, LinearSolver::Faer);
            let (scalar, scalar_fallbacks) = scalar_structured(&state, h, model);
            prop_assert!(worst(&lanes, &faer) <= 1e-5, "lanes vs faer: {:e} rad", worst(&lanes, &faer));
            prop_assert!(worst(&lanes, &scalar) <= 1e-5, "lanes vs scalar: {:e} rad", worst(&lanes, &scalar));
            // Gentle cases never decline, in either path.
            prop_assert_eq!((lane_fallbacks, scalar_fallbacks), (0, 0));
        }
    }

    /// Air and force fields are loads the lanes sample per node and lane: in a gusting,
    /// turbulent wind with a dryer's cone and a uniform field over the strands, the lane step
    /// gives the scalar structured step's angles to 1e-5 rad, and the wind moves them (so the
    /// comparison covers the drag, not just gravity).
    #[test]
    fn the_lane_step_agrees_with_the_scalar_step_in_wind_and_force_fields() {
        use crate::{ForceField, Wind};
        let h = 1.0 / 60.0;
        let mut env = Environment {
            wind: Wind {
                direction: Vector::new(0.3, 0.1, -1.0),
                speed: 4.0,
                gust: 0.3,
                turbulence: 0.4,
                drag: 2e-3,
                ..Wind::default()
            },
            fields: vec![
                ForceField::Cone {
                    apex: Point::new(0.05, 0.0, 0.2),
                    direction: Vector::new(0.0, 0.0, -1.0),
                    reach: 0.5,
                    half_angle: 0.8,
                    strength: 5e-4,
                },
                ForceField::Uniform {
                    acceleration: Vector::new(1.0, 0.0, 0.0),
                },
            ],
            time: 0.3,
            ..Environment::default()
        };
        for seed in 0..4u64 {
            let state = strands(11, 17, seed, 0.6, 1.0, 1e-4, 0.0);
            for model in [TorqueModel::Chain, TorqueModel::Local] {
                let (lanes, fallbacks) =
                    stepped_in(&env, &state, h, model, LinearSolver::Structured);
                let (scalar, _) = scalar_structured_in(&env, &state, h, model);
                let gap = worst(&lanes, &scalar.angles);
                assert!(
                    gap <= 1e-5,
                    "seed {seed}, {model:?}: lanes vs scalar {gap:e} rad"
                );
                assert_eq!(fallbacks, 0, "seed {seed}, {model:?}");
                let (still, _) = stepped(&state, h, model, LinearSolver::Structured);
                let moved = worst(&lanes, &still);
                assert!(
                    moved > 1e-4,
                    "seed {seed}, {model:?}: the air moved {moved:e} rad"
                );
            }
            env.time += 0.1;
        }
    }

    /// BDF2 in the lanes: over three steps (the first backward Euler, the next two reading the
    /// history the lanes kept), the same angles as the scalar BDF2 step (taken here with the
    /// dense solve, which the lanes do not cover) to 1e-5 rad; the first step is the lanes'
    /// coupled step, and the third is not (the history is read).
    #[test]
    fn bdf2_in_lanes_agrees_with_the_scalar_bdf2_step() {
        let h = 1.0 / 60.0;
        for seed in 0..4u64 {
            // Gentle enough that BDF2's error estimate never sends a strand back to the coupled
            // step.
            let state = strands(11, 17, seed, 0.2, 0.0, 1e-4, 0.0);
            let three_steps = |integrator, solver| {
                let mut s = state.clone();
                let set = StepSettings {
                    integrator,
                    ..settings(h, TorqueModel::Chain, solver)
                };
                (0..3)
                    .map(|_| {
                        s.step(&Environment::default(), &set)
                            .expect("a finite step");
                        s.theta.iter().chain(&s.phi).copied().collect::<Vec<Real>>()
                    })
                    .collect::<Vec<_>>()
            };
            let lanes = three_steps(Integrator::ImplicitBdf2, LinearSolver::Structured);
            let scalar = three_steps(Integrator::ImplicitBdf2, LinearSolver::Faer);
            let coupled = three_steps(Integrator::ImplicitCoupled, LinearSolver::Structured);
            for k in 0..3 {
                let gap = worst(&lanes[k], &scalar[k]);
                assert!(
                    gap <= 1e-5,
                    "seed {seed}, step {k}: lanes vs scalar {gap:e} rad"
                );
            }
            assert!(
                worst(&lanes[0], &coupled[0]) <= 1e-7,
                "seed {seed}: first step"
            );
            let apart = worst(&lanes[2], &coupled[2]);
            assert!(
                apart > 1e-4,
                "seed {seed}: BDF2 {apart:e} rad from the coupled step"
            );
        }
    }

    /// Hair resting on a moving surface, as the body stage leaves it before a step: strands
    /// stepped a while, then the nodes below a floor lifted onto it (`apply_corrections`), their
    /// rates rewritten by the floor's constraint while the floor slides and rises
    /// (`apply_velocity_constraints_on_surfaces`, friction 0.8), segments shorter or longer than
    /// their rest (as contacts and stretch springs leave them; half the strands with stretch
    /// springs), a load on every node. One more step by the lanes and by the scalar structured
    /// step: the same angles (1e-5 rad), rates (1e-4 of the largest rate) and lengths (1e-6 m).
    #[test]
    fn the_lane_step_agrees_with_the_scalar_step_on_hair_resting_on_a_moving_surface() {
        use crate::{NodeCorrection, VelocityConstraint};
        let h = 1.0 / 60.0;
        let floor = -0.03;
        let surface = Vector::new(0.2, 0.05, -0.1);
        let mut constrained = 0;
        for seed in 0..6u64 {
            let model = if seed % 2 == 0 {
                TorqueModel::Chain
            } else {
                TorqueModel::Local
            };
            let mut state = strands(19, 12, seed, 0.5, 1.0, 1e-4, 0.01);
            for s in (0..state.skeleton_count()).step_by(2) {
                for i in state.nodes(crate::SkeletonId(s as u32)) {
                    state.k_stretch_mut()[i] = 50.0;
                }
            }
            let steady = settings(h, model, LinearSolver::Structured);
            for _ in 0..5 {
                state
                    .step(&Environment::default(), &steady)
                    .expect("a finite step");
            }
            let mut rng = Rng(seed ^ 0x5EED);
            for len in state.length_mut() {
                *len *= 1.0 + 0.05 * rng.signed();
            }
            for s in 0..state.skeleton_count() {
                state.refresh_positions(crate::SkeletonId(s as u32));
            }
            let below: Vec<u32> = (0..state.node_count())
                .filter(|&i| state.positions()[i].y < floor)
                .map(|i| i as u32)
                .collect();
            let lift: Vec<NodeCorrection> = below
                .iter()
                .map(|&node| NodeCorrection {
                    node,
                    delta: Vector::y() * (floor - state.positions()[node as usize].y),
                })
                .collect();
            state.apply_corrections(&lift).expect("finite corrections");
            let contacts: Vec<VelocityConstraint> = below
                .iter()
                .map(|&node| VelocityConstraint {
                    node,
                    normal: Vector::y(),
                    friction: 0.8,
                })
                .collect();
            let moving = vec![surface; contacts.len()];
            state
                .apply_velocity_constraints_on_surfaces(&contacts, &moving)
                .expect("finite constraints");
            constrained += contacts.len();

            let mut lanes = state.clone();
            let report = lanes
                .step(&Environment::default(), &steady)
                .expect("a finite step");
            let (scalar, scalar_fallbacks) = scalar_structured_coordinates(&state, h, model);
            assert_eq!(
                report.dense_fallbacks, scalar_fallbacks,
                "seed {seed}: fallbacks"
            );
            let angles: Vec<Real> = lanes.theta.iter().chain(&lanes.phi).copied().collect();
            let rates: Vec<Real> = lanes
                .omega_theta
                .iter()
                .chain(&lanes.omega_phi)
                .copied()
                .collect();
            let fastest = scalar.rates.iter().fold(1.0, |m: Real, w| m.max(w.abs()));
            assert!(
                worst(&angles, &scalar.angles) <= 1e-5,
                "seed {seed}: angles differ by {:e} rad",
                worst(&angles, &scalar.angles)
            );
            assert!(
                worst(&rates, &scalar.rates) <= 1e-4 * fastest,
                "seed {seed}: rates differ by {:e} rad/s (largest {fastest} rad/s)",
                worst(&rates, &scalar.rates)
            );
            assert!(
                worst(&lanes.length, &scalar.lengths) <= 1e-6,
                "seed {seed}: lengths differ by {:e} m",
                worst(&lanes.length, &scalar.lengths)
            );
            // The positions and velocities the lanes publish are the scalar coordinates'.
            let mut reference = state.clone();
            let m = reference.node_count();
            reference.theta.copy_from_slice(&scalar.angles[..m]);
            reference.phi.copy_from_slice(&scalar.angles[m..]);
            reference.omega_theta.copy_from_slice(&scalar.rates[..m]);
            reference.omega_phi.copy_from_slice(&scalar.rates[m..]);
            reference.length.copy_from_slice(&scalar.lengths);
            for s in 0..reference.skeleton_count() {
                reference.refresh_positions(crate::SkeletonId(s as u32));
            }
            let apart = |a: &[Vector], b: &[Vector]| {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| (x - y).norm())
                    .fold(0.0, Real::max)
            };
            let moved = apart(
                &lanes.positions.iter().map(|p| p.coords).collect::<Vec<_>>(),
                &reference
                    .positions
                    .iter()
                    .map(|p| p.coords)
                    .collect::<Vec<_>>(),
            );
            let sped = apart(&lanes.velocities, &reference.velocities);
            println!("seed {seed}: positions {moved:e} m, velocities {sped:e} m/s");
            assert!(
                moved <= 1e-5,
                "seed {seed}: positions differ by {moved:e} m"
            );
            assert!(
                sped <= 1e-4 * 0.2 * fastest,
                "seed {seed}: velocities differ by {sped:e} m/s"
            );
        }
        // The floor caught a good share of the 6 x 19 x 12 nodes.
        assert!(constrained > 200, "only {constrained} nodes constrained");
    }

    /// Wildly bent strands under loads of a thousand times their weight: some lanes decline their
    /// check; each is redone densely and counted in the report, about as often as the scalar
    /// structured solve declines on the same strands. (Such systems are too ill-conditioned for
    /// an angle-by-angle comparison between solvers; the proptest above compares the answers.)
    #[test]
    fn declined_lanes_fall_back_to_the_dense_step_and_are_counted() {
        let h = 0.05;
        let model = TorqueModel::Chain;
        let mut declined = 0;
        for seed in 0..8 {
            let state = strands(64, 32, seed, 1.5, 0.0, 1e-4, 0.2);
            let (lanes, fallbacks) = stepped(&state, h, model, LinearSolver::Structured);
            let (_, scalar_fallbacks) = scalar_structured(&state, h, model);
            assert!(
                lanes.iter().all(|x| x.is_finite()),
                "seed {seed}: non-finite angles"
            );
            // The lanes check as the scalar solve does: they decline on the same strands, give
            // or take one at the tolerance's edge.
            assert!(
                fallbacks.abs_diff(scalar_fallbacks) <= 1 + scalar_fallbacks / 4,
                "seed {seed}: lanes {fallbacks}, scalar {scalar_fallbacks}"
            );
            declined += fallbacks;
        }
        println!("{declined} of 512 strands declined");
        assert!(
            declined > 0,
            "no strand declined: the fallback went untested"
        );
    }

    /// The lanes do not depend on their neighbours: a strand stepped alone (seven spare lanes)
    /// and in a full group gives bit-identical angles.
    #[test]
    fn a_strand_gets_the_same_bits_alone_and_in_a_group() {
        let h = 1.0 / 60.0;
        let many = strands(8, 20, 11, 0.8, 1.0, 1e-4, 0.0);
        let (together, _) = stepped(&many, h, TorqueModel::Chain, LinearSolver::Structured);
        let one = strands(1, 20, 11, 0.8, 1.0, 1e-4, 0.0);
        let (alone, _) = stepped(&one, h, TorqueModel::Chain, LinearSolver::Structured);
        let nodes = 20;
        let total = many.node_count();
        for i in 0..nodes {
            assert_eq!(together[i].to_bits(), alone[i].to_bits(), "theta {i}");
            assert_eq!(
                together[total + i].to_bits(),
                alone[nodes + i].to_bits(),
                "phi {i}"
            );
        }
    }
    /// ROS3 where the guard trusts one strand's step in one piece and splits others of its group
    /// (turning faster): the strand's bits do not depend on what its neighbours in the group
    /// needed.
    #[test]
    fn a_strand_gets_the_same_ros3_bits_alone_and_in_a_group_whatever_the_others_split() {
        let set = StepSettings {
            integrator: Integrator::ImplicitRos3,
            ..settings(1.0 / 200.0, TorqueModel::Chain, LinearSolver::Structured)
        };
        let faster = |mut state: StrandState| {
            for s in 0..state.skeleton_count() {
                for i in state.nodes(crate::SkeletonId(s as u32)) {
                    state.omega_theta_mut()[i] *= (1 + 12 * s * s) as Real;
                    state.omega_phi_mut()[i] *= (1 + 12 * s * s) as Real;
                }
            }
            state
        };
        let mut many = faster(strands(8, 20, 5, 0.3, 0.1, 1e-4, 0.0));
        let report = many
            .step(&Environment::default(), &set)
            .expect("a finite step");
        let mut one = faster(strands(1, 20, 5, 0.3, 0.1, 1e-4, 0.0));
        let alone = one
            .step(&Environment::default(), &set)
            .expect("a finite step");
        assert!(
            report.rosenbrock_splits > alone.rosenbrock_splits,
            "the others split no more than the first: {report:?}, {alone:?}"
        );
        for i in 0..20 {
            for (field, a, b) in [
                ("theta", &many.theta, &one.theta),
                ("phi", &many.phi, &one.phi),
                ("omega_theta", &many.omega_theta, &one.omega_theta),
                ("omega_phi", &many.omega_phi, &one.omega_phi),
            ] {
                assert_eq!(a[i].to_bits(), b[i].to_bits(), "{field} {i}");
            }
        }
    }
    /// One ROS3 step of `state` through `StrandState::step` (the lanes) against the scalar ROS3
    /// step, strand by strand.
    struct Ros3Gaps {
        /// The largest differences of the angles (rad) and of the rates (rad/s, over the largest
        /// rate, at least 1 rad/s).
        angles: Real,
        rates: Real,
        /// The steps the guard split (lanes, scalar) and of those the steps taken as the coupled
        /// step (lanes, scalar).
        splits: (usize, usize),
        fallbacks: (usize, usize),
    }

    fn ros3_gaps(env: &Environment, state: &StrandState, h: Real, model: TorqueModel) -> Ros3Gaps {
        let set = StepSettings {
            integrator: Integrator::ImplicitRos3,
            ..settings(h, model, LinearSolver::Structured)
        };
        let mut lanes = state.clone();
        let report = lanes.step(env, &set).expect("a finite step");
        let (scalar, sc) = scalar_in(env, state, &set);
        let angles: Vec<Real> = lanes.theta.iter().chain(&lanes.phi).copied().collect();
        let rates: Vec<Real> = lanes
            .omega_theta
            .iter()
            .chain(&lanes.omega_phi)
            .copied()
            .collect();
        let fastest = scalar.rates.iter().fold(1.0, |m: Real, w| m.max(w.abs()));
        Ros3Gaps {
            angles: worst(&angles, &scalar.angles),
            rates: worst(&rates, &scalar.rates) / fastest,
            splits: (report.rosenbrock_splits, sc.rosenbrock_splits),
            fallbacks: (report.rosenbrock_fallbacks, sc.rosenbrock_fallbacks),
        }
    }

    /// [`ros3_gaps`] in still air within the proptests' bounds: angles to 1e-5 rad, rates to 1e-4
    /// of the largest, the same splits and fallbacks.
    fn ros3_agrees(
        state: &StrandState,
        h: Real,
        model: TorqueModel,
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        let gaps = ros3_gaps(&Environment::default(), state, h, model);
        prop_assert!(
            gaps.angles <= 1e-5,
            "angles differ by {:e} rad",
            gaps.angles
        );
        prop_assert!(
            gaps.rates <= 1e-4,
            "rates differ by {:e} of the largest",
            gaps.rates
        );
        prop_assert_eq!(gaps.splits.0, gaps.splits.1);
        prop_assert_eq!(gaps.fallbacks.0, gaps.fallbacks.1);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64)))]

        /// ROS3 in the lanes gives the scalar ROS3 step's angles to 1e-5 rad and rates to 1e-4
        /// of the largest, on random strands as in the coupled step's proptest (1 to 19 strands,
        /// 2 to 40 nodes, bent or near straight, soft to stiff, both load models, steps from 1 to
        /// 20 ms), and its guard splits exactly the strands the scalar guard splits.
        #[test]
        fn ros3_in_lanes_agrees_with_the_scalar_ros3_step(
            count in 1usize..20, n in 2usize..40, seed in any::<u64>(),
            straight in any::<bool>(), log_k in -6.0f32..0.0, h in 1e-3f32..0.02,
            chain in any::<bool>()) {
            let (state, model) = random_group(count, n, seed, straight, log_k, chain);
            ros3_agrees(&state, h, model)?;
        }

        /// Where the guard splits: soft strands turning at up to 8 rad/s, steps of 1/100 to
        /// 1/25 s, so that most steps go to two or four pieces and some past them to the coupled
        /// step. The lanes' pieces give the scalar guarded step's angles to 1e-5 rad and rates to
        /// 1e-4 of the largest, with the same splits and fallbacks.
        #[test]
        fn ros3_split_in_lanes_agrees_with_the_scalar_guarded_step(
            count in 1usize..20, n in 2usize..30, seed in any::<u64>(),
            log_k in -6.0f32..-2.0, h in 0.01f32..0.04, rate in 0.5f32..8.0,
            chain in any::<bool>()) {
            let state = strands(count, n, seed, 0.6, rate, 10f32.powf(log_k), 0.0);
            let model = if chain { TorqueModel::Chain } else { TorqueModel::Local };
            ros3_agrees(&state, h, model)?;
        }
    }

    /// ROS3 in the lanes where they do the work (gentle strands, short steps: the guard trusts
    /// every step in one piece), under loads, in wind and force fields, with stretch springs:
    /// the scalar ROS3 step's angles to 1e-5 rad and rates to 1e-4 of the largest, and the
    /// step is not the coupled step's.
    #[test]
    fn ros3_in_lanes_agrees_with_the_scalar_ros3_step_in_wind_under_loads() {
        use crate::{ForceField, Wind};
        let env = Environment {
            wind: Wind {
                direction: Vector::new(0.3, 0.1, -1.0),
                speed: 4.0,
                gust: 0.3,
                turbulence: 0.4,
                drag: 2e-3,
                ..Wind::default()
            },
            fields: vec![ForceField::Uniform {
                acceleration: Vector::new(1.0, 0.0, 0.0),
            }],
            time: 0.3,
            ..Environment::default()
        };
        let h = 2e-3;
        for seed in 0..6u64 {
            let model = if seed % 2 == 0 {
                TorqueModel::Chain
            } else {
                TorqueModel::Local
            };
            let mut state = strands(19, 12 + seed as usize, seed, 0.4, 0.5, 1e-4, 0.002);
            for s in (0..state.skeleton_count()).step_by(2) {
                for i in state.nodes(crate::SkeletonId(s as u32)) {
                    state.k_stretch_mut()[i] = 50.0;
                }
            }
            for (env, what) in [(&Environment::default(), "still air"), (&env, "wind")] {
                let gaps = ros3_gaps(env, &state, h, model);
                let (angles, rates) = (gaps.angles, gaps.rates);
                assert!(angles <= 1e-5, "seed {seed}, {what}: angles {angles:e} rad");
                assert!(rates <= 1e-4, "seed {seed}, {what}: rates {rates:e}");
                assert_eq!(gaps.splits, (0, 0), "seed {seed}, {what}: splits");
            }
            let (coupled, _) = stepped(&state, h, model, LinearSolver::Structured);
            let mut ros3 = state.clone();
            ros3.step(
                &Environment::default(),
                &StepSettings {
                    integrator: Integrator::ImplicitRos3,
                    ..settings(h, model, LinearSolver::Structured)
                },
            )
            .expect("a finite step");
            let ros3: Vec<Real> = ros3.theta.iter().chain(&ros3.phi).copied().collect();
            assert!(
                worst(&ros3, &coupled) > 1e-6,
                "seed {seed}: ROS3 is the coupled step"
            );
        }
    }

    /// At the steps of a frame and shorter the guard splits some strands' steps and not others,
    /// in two pieces or four: the lanes split those as the scalar guard would have (the same
    /// count, the same answers), in the wind too, and keep the others' one-piece steps.
    #[test]
    fn ros3_lanes_split_the_steps_their_guard_distrusts_as_the_scalar_step_does() {
        use crate::Wind;
        let wind = Environment {
            wind: Wind {
                direction: Vector::new(0.3, 0.1, -1.0),
                speed: 3.0,
                turbulence: 0.4,
                drag: 2e-3,
                ..Wind::default()
            },
            ..Environment::default()
        };
        let mut split = 0;
        for seed in 0..12u64 {
            let h = 1.0 / (30 << (seed % 4)) as Real;
            let mut state = strands(16, 20, seed, 0.3, 1.0, 1e-4, 0.0);
            // Strand by strand, faster and slower.
            for s in 0..state.skeleton_count() {
                for i in state.nodes(crate::SkeletonId(s as u32)) {
                    state.omega_theta_mut()[i] *= (s % 4) as Real;
                    state.omega_phi_mut()[i] *= (s % 4) as Real;
                }
            }
            let env = if seed % 3 == 2 {
                &wind
            } else {
                &Environment::default()
            };
            let gaps = ros3_gaps(env, &state, h, TorqueModel::Chain);
            let (angles, rates) = (gaps.angles, gaps.rates);
            assert!(angles <= 1e-5, "seed {seed}: angles {angles:e} rad");
            assert!(rates <= 1e-4, "seed {seed}: rates {rates:e}");
            assert_eq!(gaps.splits.0, gaps.splits.1, "seed {seed}: splits");
            assert_eq!(gaps.fallbacks.0, gaps.fallbacks.1, "seed {seed}: fallbacks");
            split += gaps.splits.0;
            println!("seed {seed}, h {h}: {} of 16 split", gaps.splits.0);
        }
        assert!(split > 0 && split < 192, "{split} of 192 strands split");
    }

    /// States stepped in parallel by the workers of one pool, as `hair stability` steps its
    /// cells: each state's first lane step grows the lane buffers, which must not wait for the
    /// pool's other workers from inside one (a waiting worker runs other states' first steps,
    /// whose waits nest on its stack until it overflows, here in 256 KiB).
    #[test]
    fn states_stepped_in_parallel_inside_a_pool_step_without_nesting() {
        use rayon::prelude::*;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .stack_size(256 << 10)
            .build()
            .expect("a pool");
        let set = settings(1e-3, TorqueModel::Chain, LinearSolver::Structured);
        let states: Vec<StrandState> = (0..4000)
            .map(|s| strands(1, 20, s, 0.3, 1.0, 1e-4, 0.0))
            .collect();
        let stepped = pool.install(|| {
            states
                .into_par_iter()
                .map(|mut state| state.step(&Environment::default(), &set).is_ok())
                .filter(|ok| *ok)
                .count()
        });
        assert_eq!(stepped, 4000);
    }
    /// ROS3 on wildly bent strands under loads of a thousand times their weight: some lanes'
    /// residual checks fail; each such strand is redone by the scalar ROS3 step, which takes the
    /// failing stages densely and counts them, about as often as the scalar step alone does on
    /// the same strands, and every strand stays finite.
    #[test]
    fn ros3_lanes_whose_checks_fail_are_redone_by_the_scalar_step_and_counted() {
        // (At 0.05 s the scalar step's one-piece tries, which the lanes take instead, decline
        // twice as often as the lanes': such systems decide their checks by rounding.)
        let h = 0.025;
        let set = StepSettings {
            integrator: Integrator::ImplicitRos3,
            ..settings(h, TorqueModel::Chain, LinearSolver::Structured)
        };
        let mut declined = 0;
        for seed in 0..8 {
            let state = strands(64, 32, seed, 1.5, 0.0, 1e-4, 0.2);
            let mut lanes = state.clone();
            let report = lanes
                .step(&Environment::default(), &set)
                .expect("a finite step");
            let (_, sc) = scalar_in(&Environment::default(), &state, &set);
            assert!(
                lanes.theta.iter().chain(&lanes.phi).all(|x| x.is_finite()),
                "seed {seed}: non-finite angles"
            );
            let (fallbacks, scalar_fallbacks) = (report.dense_fallbacks, sc.dense_fallbacks);
            assert!(
                fallbacks.abs_diff(scalar_fallbacks) <= 1 + scalar_fallbacks / 4,
                "seed {seed}: lanes {fallbacks}, scalar {scalar_fallbacks}"
            );
            declined += fallbacks;
        }
        println!("{declined} dense stage solves on 512 strands");
        assert!(declined > 0, "no check failed: the fallback went untested");
    }
}
