//! XPBD strands: the position-based method game engines integrate hair with, as the peer our
//! angular integrators are measured against (Macklin, Müller & Chentanez 2016, *XPBD:
//! position-based simulation of compliant constrained dynamics*, §3-4).
//!
//! Each node is a particle; a step of `dt` is `substeps` substeps, each predicting positions
//! under gravity and then running `iterations` Gauss-Seidel sweeps (root to tip) over the
//! constraints with their Lagrange multipliers, velocities being the change of position over the
//! substep. Constraints per strand:
//! - stretch, per segment: `C = |x_i - x_{i-1}| - d_i`, compliance `stretch_compliance` (m/N);
//! - bend, per joint: `C = (x_{i+1} - x_i) / d_{i+1} - (x_i - x_{i-1}) / d_i` (a 3-vector, the
//!   turn of the tangent, `2 sin(theta / 2)` long for a bend `theta`), compliance `1 / k` with
//!   `k` the angular model's joint stiffness (N m / rad), so the two models share one bending
//!   energy `k theta^2 / 2` for small bends; the clamp joint compares the first tangent with the
//!   root frame's z axis at its own stiffness (`2 EI / d`).
//!
//! Rest shapes are straight (rest curvature zero); gravity and the head's linear acceleration are
//! the only loads. That covers the charts' scenarios (the standard strand, the clamped
//! cantilever, the throughput bench).

use crate::{DynamicsError, Environment, Point, Real, SkeletonId, StrandState, Vector};

/// Substeps, iterations and compliances of the XPBD peer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct XpbdSettings {
    /// Substeps per step.
    pub substeps: u32,
    /// Gauss-Seidel sweeps over the constraints per substep.
    pub iterations: u32,
    /// Compliance of the stretch constraints (m/N); 0 is inextensible.
    pub stretch_compliance: Real,
    /// Factor on every bend compliance `1 / k` (1: the angular model's stiffness).
    pub bend_compliance_scale: Real,
    /// Velocity damping rate (1/s), applied each substep as `v /= 1 + rate h`.
    pub damping: Real,
}

impl Default for XpbdSettings {
    fn default() -> Self {
        Self {
            substeps: 5,
            iterations: 5,
            stretch_compliance: 0.0,
            bend_compliance_scale: 1.0,
            damping: 0.0,
        }
    }
}

/// Strands as particles with stretch and bend constraints, built from a [`StrandState`].
#[derive(Clone, Debug, Default)]
pub struct XpbdStrands {
    offsets: Vec<usize>,
    x: Vec<Vector>,
    v: Vec<Vector>,
    prev: Vec<Vector>,
    inv_mass: Vec<Real>,
    mass: Vec<Real>,
    /// `d_i`: length of the segment ending at node `i` (0 at a root).
    rest_length: Vec<Real>,
    /// Bend stiffness of the joint at the start of segment `i` (N m / rad).
    stiffness: Vec<Real>,
    /// Direction of the first segment at rest in the root frame (head frame), per strand.
    root_axis: Vec<Vector>,
    attached: Vec<bool>,
    lambda_stretch: Vec<Real>,
    lambda_bend: Vec<Vector>,
    steps: u64,
}

impl XpbdStrands {
    /// The particles of every skeleton of `state` at its current positions and velocities, with
    /// its masses (wetness included), segment rest lengths and joint stiffnesses (`k_theta`).
    pub fn from_state(state: &StrandState) -> Self {
        let mut s = Self::default();
        for k in 0..state.skeleton_count() {
            let id = SkeletonId(k as u32);
            let r = state.nodes(id);
            s.offsets.push(s.x.len());
            s.root_axis.push(state.root_frame(id) * Vector::z());
            s.attached.push(!state.is_free(id));
            for i in r.clone() {
                let m = state.mass[i] + state.wetness[i];
                let pinned = i == r.start && !state.is_free(id);
                s.x.push(state.positions()[i].coords);
                s.v.push(state.velocities()[i]);
                s.mass.push(m);
                s.inv_mass
                    .push(if pinned || m <= 0.0 { 0.0 } else { 1.0 / m });
                s.rest_length.push(if i == r.start {
                    0.0
                } else {
                    state.rest_length[i]
                });
                s.stiffness.push(state.k_theta[i]);
            }
        }
        s.offsets.push(s.x.len());
        s.prev = s.x.clone();
        s.lambda_stretch = vec![0.0; s.x.len()];
        s.lambda_bend = vec![Vector::zeros(); s.x.len()];
        s
    }

    /// Node positions (head frame).
    pub fn positions(&self) -> impl ExactSizeIterator<Item = Point> + '_ {
        self.x.iter().map(|p| Point::from(*p))
    }

    /// Node velocities (head frame).
    pub fn velocities(&self) -> &[Vector] {
        &self.v
    }

    /// Number of particles.
    pub fn node_count(&self) -> usize {
        self.x.len()
    }

    /// Kinetic energy, gravity's potential (zero at the origin) and the bend constraints'
    /// energy `|C|^2 / (2 alpha)` (J), in f64.
    pub fn energy(&self, env: &Environment, settings: &XpbdSettings) -> f64 {
        let g = gravity(env);
        let mut e = 0.0f64;
        for s in 0..self.offsets.len() - 1 {
            let (a, b) = (self.offsets[s], self.offsets[s + 1]);
            for i in a..b {
                let m = f64::from(self.mass[i]);
                e += 0.5 * m * f64::from(self.v[i].norm_squared());
                e -= m * f64::from(g.dot(&self.x[i]));
                if i > a {
                    let c = self.bend_c(a, i);
                    let k = f64::from(self.stiffness[i] / settings.bend_compliance_scale);
                    e += 0.5 * k * f64::from(c.norm_squared());
                }
            }
        }
        e
    }

    /// The bend constraint at the start of segment `i` of the strand starting at `a`.
    fn bend_c(&self, a: usize, i: usize) -> Vector {
        let t = (self.x[i] - self.x[i - 1]) / self.rest_length[i];
        if i == a + 1 {
            let s = self.strand_of(a);
            t - self.root_axis[s]
        } else {
            t - (self.x[i - 1] - self.x[i - 2]) / self.rest_length[i - 1]
        }
    }

    fn strand_of(&self, first: usize) -> usize {
        self.offsets.partition_point(|&o| o <= first) - 1
    }

    /// Advances every strand by `dt`, in parallel over strands (the same bits on any thread
    /// count: strands are independent). A strand that goes non-finite is reported.
    pub fn step(
        &mut self,
        env: &Environment,
        dt: Real,
        settings: &XpbdSettings,
    ) -> Result<(), DynamicsError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(DynamicsError::InvalidTimeStep { dt: f64::from(dt) });
        }
        let g = gravity(env);
        let step = self.steps;
        self.steps += 1;
        let run = RunMut {
            x: &mut self.x,
            v: &mut self.v,
            prev: &mut self.prev,
            lambda_stretch: &mut self.lambda_stretch,
            lambda_bend: &mut self.lambda_bend,
            first: 0,
            last: self.offsets.len() - 1,
        };
        let shared = Shared {
            offsets: &self.offsets,
            inv_mass: &self.inv_mass,
            rest_length: &self.rest_length,
            stiffness: &self.stiffness,
            root_axis: &self.root_axis,
            attached: &self.attached,
            g,
            dt,
            settings,
        };
        let bad = run_parallel(run, &shared);
        match bad {
            Some((skeleton, node)) => Err(DynamicsError::NonFiniteState {
                step,
                skeleton,
                node,
            }),
            None => Ok(()),
        }
    }
}

fn gravity(env: &Environment) -> Vector {
    env.head.rotation.inverse() * (env.gravity - env.head.linear_acceleration)
}

/// Particles per leaf of the parallel split.
const GRAIN_NODES: usize = 512;

/// Read-only inputs of a step.
struct Shared<'a> {
    offsets: &'a [usize],
    inv_mass: &'a [Real],
    rest_length: &'a [Real],
    stiffness: &'a [Real],
    root_axis: &'a [Vector],
    attached: &'a [bool],
    g: Vector,
    dt: Real,
    settings: &'a XpbdSettings,
}

/// The mutable particles of strands `first..last` (slices starting at strand `first`).
struct RunMut<'a> {
    x: &'a mut [Vector],
    v: &'a mut [Vector],
    prev: &'a mut [Vector],
    lambda_stretch: &'a mut [Real],
    lambda_bend: &'a mut [Vector],
    first: usize,
    last: usize,
}

/// Steps the strands of `run`, splitting the run in halves over rayon; returns the first
/// non-finite (strand, node) in strand order.
fn run_parallel(run: RunMut<'_>, sh: &Shared<'_>) -> Option<(usize, usize)> {
    let count = run.last - run.first;
    if count > 1 && run.x.len() > GRAIN_NODES {
        let mid = run.first + count / 2;
        let at = sh.offsets[mid] - sh.offsets[run.first];
        let (x0, x1) = run.x.split_at_mut(at);
        let (v0, v1) = run.v.split_at_mut(at);
        let (p0, p1) = run.prev.split_at_mut(at);
        let (s0, s1) = run.lambda_stretch.split_at_mut(at);
        let (b0, b1) = run.lambda_bend.split_at_mut(at);
        let a = RunMut {
            x: x0,
            v: v0,
            prev: p0,
            lambda_stretch: s0,
            lambda_bend: b0,
            first: run.first,
            last: mid,
        };
        let b = RunMut {
            x: x1,
            v: v1,
            prev: p1,
            lambda_stretch: s1,
            lambda_bend: b1,
            first: mid,
            last: run.last,
        };
        let (ra, rb) = rayon::join(|| run_parallel(a, sh), || run_parallel(b, sh));
        return ra.or(rb);
    }
    let base = sh.offsets[run.first];
    let mut bad = None;
    for s in run.first..run.last {
        let (a, b) = (sh.offsets[s], sh.offsets[s + 1]);
        let (la, lb) = (a - base, b - base);
        let mut strand = StrandMut {
            x: &mut run.x[la..lb],
            v: &mut run.v[la..lb],
            prev: &mut run.prev[la..lb],
            lambda_stretch: &mut run.lambda_stretch[la..lb],
            lambda_bend: &mut run.lambda_bend[la..lb],
            inv_mass: &sh.inv_mass[a..b],
            rest_length: &sh.rest_length[a..b],
            stiffness: &sh.stiffness[a..b],
            root_axis: sh.root_axis[s],
            attached: sh.attached[s],
        };
        if let Some(node) = strand.step(sh.g, sh.dt, sh.settings) {
            bad = bad.or(Some((s, node)));
        }
    }
    bad
}

/// One strand's slices during a step.
struct StrandMut<'a> {
    x: &'a mut [Vector],
    v: &'a mut [Vector],
    prev: &'a mut [Vector],
    lambda_stretch: &'a mut [Real],
    lambda_bend: &'a mut [Vector],
    inv_mass: &'a [Real],
    rest_length: &'a [Real],
    stiffness: &'a [Real],
    root_axis: Vector,
    attached: bool,
}

impl StrandMut<'_> {
    /// One step; returns the first non-finite node, if any.
    fn step(&mut self, g: Vector, dt: Real, settings: &XpbdSettings) -> Option<usize> {
        let n = self.x.len();
        let substeps = settings.substeps.max(1);
        let h = dt / substeps as Real;
        let h2 = h * h;
        let damp = 1.0 / (1.0 + settings.damping.max(0.0) * h);
        for _ in 0..substeps {
            for i in 0..n {
                self.prev[i] = self.x[i];
                if self.inv_mass[i] > 0.0 {
                    self.v[i] = (self.v[i] + g * h) * damp;
                    self.x[i] += self.v[i] * h;
                }
            }
            self.lambda_stretch.iter_mut().for_each(|l| *l = 0.0);
            self.lambda_bend
                .iter_mut()
                .for_each(|l| *l = Vector::zeros());
            let stretch_alpha = settings.stretch_compliance.max(0.0) / h2;
            for _ in 0..settings.iterations.max(1) {
                for i in 1..n {
                    self.stretch(i, stretch_alpha);
                    let k = self.stiffness[i];
                    if k > 0.0 && (i >= 2 || self.attached) {
                        let alpha = settings.bend_compliance_scale.max(0.0) / (k * h2);
                        self.bend(i, alpha);
                    }
                }
            }
            for i in 0..n {
                if self.inv_mass[i] > 0.0 {
                    self.v[i] = (self.x[i] - self.prev[i]) / h;
                }
            }
        }
        (0..n).find(|&i| {
            !(self.x[i].iter().all(|c| c.is_finite()) && self.v[i].iter().all(|c| c.is_finite()))
        })
    }

    /// The stretch constraint of segment `i` (nodes `i - 1`, `i`).
    fn stretch(&mut self, i: usize, alpha: Real) {
        let (wa, wb) = (self.inv_mass[i - 1], self.inv_mass[i]);
        let denom = wa + wb + alpha;
        let e = self.x[i] - self.x[i - 1];
        let len = e.norm();
        if denom <= 0.0 || len <= 0.0 {
            return;
        }
        let nrm = e / len;
        let c = len - self.rest_length[i];
        let dl = (-c - alpha * self.lambda_stretch[i]) / denom;
        self.lambda_stretch[i] += dl;
        self.x[i - 1] -= nrm * (wa * dl);
        self.x[i] += nrm * (wb * dl);
    }

    /// The bend constraint at the start of segment `i`: linear in the positions, so its three
    /// components share one scalar gradient weight per node.
    fn bend(&mut self, i: usize, alpha: Real) {
        let di = self.rest_length[i];
        let t = (self.x[i] - self.x[i - 1]) / di;
        // (node, gradient weight) pairs.
        let (c, nodes): (Vector, [(usize, Real); 3]) = if i == 1 {
            (
                t - self.root_axis,
                [(1, 1.0 / di), (0, -1.0 / di), (0, 0.0)],
            )
        } else {
            let dp = self.rest_length[i - 1];
            let tp = (self.x[i - 1] - self.x[i - 2]) / dp;
            (
                t - tp,
                [
                    (i, 1.0 / di),
                    (i - 1, -1.0 / di - 1.0 / dp),
                    (i - 2, 1.0 / dp),
                ],
            )
        };
        let denom: Real = nodes
            .iter()
            .map(|&(j, g)| self.inv_mass[j] * g * g)
            .sum::<Real>()
            + alpha;
        if denom <= 0.0 {
            return;
        }
        let dl = (-c - self.lambda_bend[i] * alpha) / denom;
        self.lambda_bend[i] += dl;
        for (j, g) in nodes {
            self.x[j] += dl * (self.inv_mass[j] * g);
        }
    }
}
