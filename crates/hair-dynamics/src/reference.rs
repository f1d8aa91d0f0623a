//! f64 references: one strand simulated in double precision with the same kernel, and the
//! cantilever elastica under self-weight solved by shooting.

use crate::integrate::{Previous, StepSettings, step_strand};
use crate::strand::{self, RootDyn, Scratch, StrandParams};
use crate::{Environment, SkeletonId, StrandState};
use nalgebra::Vector3;

/// One strand copied out of a [`StrandState`] into f64, stepped with the same kernel.
#[derive(Clone, Debug)]
pub struct ReferenceStrand {
    root: RootDyn<f64>,
    q: Vec<f64>,
    w: Vec<f64>,
    length: Vec<f64>,
    rest_length: Vec<f64>,
    k_stretch: Vec<f64>,
    rest_theta: Vec<f64>,
    rest_phi: Vec<f64>,
    mass: Vec<f64>,
    wetness: Vec<f64>,
    k_theta: Vec<f64>,
    k_phi: Vec<f64>,
    damping: Vec<f64>,
    rest_points: Vec<Vector3<f64>>,
    external: Vec<Vector3<f64>>,
    /// BDF2's previous step: angles, velocities, root position and velocity, and the step it was
    /// taken with (`None`: no previous BDF2 step).
    prev_q: Vec<f64>,
    prev_w: Vec<f64>,
    prev_root: (Vector3<f64>, Vector3<f64>),
    history_dt: Option<f32>,
    /// The coordinates at the start of the step being taken (they become `prev_*`).
    start_q: Vec<f64>,
    start_w: Vec<f64>,
}

fn up(v: &[f32]) -> Vec<f64> {
    v.iter().map(|x| f64::from(*x)).collect()
}

impl ReferenceStrand {
    /// Copies skeleton `id` of `state`.
    pub fn from_state(state: &StrandState, id: SkeletonId) -> Self {
        let r = state.nodes(id);
        let n = r.len();
        let mut q = Vec::with_capacity(2 * n);
        let mut w = Vec::with_capacity(2 * n);
        for i in r.start + 1..r.end {
            q.extend([f64::from(state.theta[i]), f64::from(state.phi[i])]);
            w.extend([
                f64::from(state.omega_theta[i]),
                f64::from(state.omega_phi[i]),
            ]);
        }
        let root = state.root_dyn(id.0 as usize);
        Self {
            root: RootDyn {
                position: root.position.cast(),
                rotation: root.rotation.cast(),
                velocity: root.velocity.cast(),
                free: root.free,
            },
            q,
            w,
            length: up(&state.length[r.clone()]),
            rest_length: up(&state.rest_length[r.clone()]),
            k_stretch: up(&state.k_stretch[r.clone()]),
            rest_theta: up(&state.rest_theta[r.clone()]),
            rest_phi: up(&state.rest_phi[r.clone()]),
            mass: up(&state.mass[r.clone()]),
            wetness: up(&state.wetness[r.clone()]),
            k_theta: up(&state.k_theta[r.clone()]),
            k_phi: up(&state.k_phi[r.clone()]),
            damping: up(&state.damping[r.clone()]),
            rest_points: state.rest_points[r.clone()]
                .iter()
                .map(|v| v.cast())
                .collect(),
            external: state.external_force[r].iter().map(|f| f.cast()).collect(),
            prev_q: Vec::new(),
            prev_w: Vec::new(),
            prev_root: (Vector3::zeros(), Vector3::zeros()),
            history_dt: None,
            start_q: Vec::new(),
            start_w: Vec::new(),
        }
    }

    /// One step in f64. Returns `false` if the strand went non-finite (it is then restored).
    pub fn step(
        &mut self,
        env: &Environment,
        settings: &StepSettings,
        scratch: &mut ReferenceScratch,
    ) -> bool {
        let local = env.local::<f64>();
        let p = StrandParams {
            rest_theta: &self.rest_theta,
            rest_phi: &self.rest_phi,
            mass: &self.mass,
            wetness: &self.wetness,
            k_theta: &self.k_theta,
            k_phi: &self.k_phi,
            damping: &self.damping,
            rest_points: &self.rest_points,
            external: &self.external,
        };
        let bdf2 = settings.integrator == crate::Integrator::ImplicitBdf2;
        // BDF2 reads the previous step if it was a BDF2 step of the same size.
        let previous = (bdf2 && self.history_dt == Some(settings.dt)).then(|| Previous {
            q: &self.prev_q,
            w: &self.prev_w,
            root_position: self.prev_root.0,
            root_velocity: self.prev_root.1,
        });
        self.start_q.clone_from(&self.q);
        self.start_w.clone_from(&self.w);
        let start_root = (self.root.position, self.root.velocity);
        let ok = step_strand(
            &mut self.root,
            &mut self.q,
            &mut self.w,
            &mut self.length,
            &self.rest_length,
            &self.k_stretch,
            &p,
            &local,
            settings,
            previous.as_ref(),
            &mut scratch.0,
        )
        .is_none();
        if !bdf2 {
            self.history_dt = None;
        } else if ok {
            std::mem::swap(&mut self.prev_q, &mut self.start_q);
            std::mem::swap(&mut self.prev_w, &mut self.start_w);
            self.prev_root = start_root;
            self.history_dt = Some(settings.dt);
        }
        ok
    }

    /// Relaxes the strand to static equilibrium by pseudo-transient continuation: coupled implicit
    /// steps with the angular velocities zeroed before each. The step starts at `settings.dt`,
    /// grows by half after every step that succeeds and shrinks fourfold after one that fails, so
    /// it ends as Newton's method on the torque balance. Returns the iterations used when no
    /// angle moved more than `tol` (rad), or `None` if that did not happen within `max_iters`.
    pub fn relax(
        &mut self,
        env: &Environment,
        settings: &StepSettings,
        max_iters: usize,
        tol: f64,
        scratch: &mut ReferenceScratch,
    ) -> Option<usize> {
        let mut s = *settings;
        s.integrator = crate::Integrator::ImplicitCoupled;
        let mut before = self.q.clone();
        for it in 0..max_iters {
            self.w.iter_mut().for_each(|x| *x = 0.0);
            before.copy_from_slice(&self.q);
            if !self.step(env, &s, scratch) {
                s.dt *= 0.25;
                continue;
            }
            let moved = self
                .q
                .iter()
                .zip(&before)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            if moved < tol {
                self.w.iter_mut().for_each(|x| *x = 0.0);
                return Some(it + 1);
            }
            s.dt = (s.dt * 1.5).min(1e3);
        }
        self.w.iter_mut().for_each(|x| *x = 0.0);
        None
    }

    /// Node positions (head frame).
    pub fn positions(&self) -> Vec<Vector3<f64>> {
        let mut out = vec![Vector3::zeros(); self.length.len()];
        strand::positions_only(&self.root, &self.q, &self.length, &mut out);
        out
    }

    /// Node velocities (head frame).
    pub fn velocities(&self, scratch: &mut ReferenceScratch) -> Vec<Vector3<f64>> {
        let n = self.length.len();
        scratch.0.reserve(n, false);
        strand::forward(&self.root, &self.q, &self.w, &self.length, &mut scratch.0);
        scratch.0.vel[..n].to_vec()
    }

    /// Bend coordinates, interleaved `theta_1, phi_1, theta_2, ...`.
    pub fn coordinates(&self) -> &[f64] {
        &self.q
    }
}

/// Reusable scratch memory of [`ReferenceStrand::step`].
#[derive(Default)]
pub struct ReferenceScratch(Scratch<f64>);

impl ReferenceScratch {
    /// [`crate::Integrator::ImplicitBdf2`] steps taken with this scratch whose error estimate
    /// failed, so that they were redone as the coupled step (backward Euler).
    pub fn bdf2_fallbacks(&self) -> usize {
        self.0.bdf2_fallbacks
    }

    /// [`crate::Integrator::ImplicitRos3`] steps taken with this scratch that no split into the
    /// guard's pieces brought within its tolerance, so that they were redone as the coupled step
    /// (backward Euler) in those pieces.
    pub fn rosenbrock_fallbacks(&self) -> usize {
        self.0.rosenbrock_fallbacks
    }
}

/// Tip of a cantilever under its own weight (inextensible elastica), clamped horizontally.
///
/// `alpha = q L^3 / EI`. Returns the tip position over the length, `(x / L, y / L)` with x along
/// the clamp and y downward. Solves `theta'' = -alpha (1 - s) cos(theta)`, `theta(0) = 0`,
/// `theta'(1) = 0` by shooting on `theta'(0)` with bisection and RK4 (2,000 steps), in f64.
pub fn elastica_tip(alpha: f64) -> (f64, f64) {
    let shoot = |k0: f64| -> (f64, f64, f64) {
        let steps = 2000;
        let h = 1.0 / steps as f64;
        // state: theta, theta', x, y
        let f = |s: f64, y: [f64; 4]| -> [f64; 4] {
            [
                y[1],
                -alpha * (1.0 - s) * y[0].cos(),
                y[0].cos(),
                y[0].sin(),
            ]
        };
        let mut y = [0.0, k0, 0.0, 0.0];
        for i in 0..steps {
            let s = i as f64 * h;
            let k1 = f(s, y);
            let a = |k: [f64; 4], c: f64| {
                [
                    y[0] + c * k[0],
                    y[1] + c * k[1],
                    y[2] + c * k[2],
                    y[3] + c * k[3],
                ]
            };
            let k2 = f(s + h / 2.0, a(k1, h / 2.0));
            let k3 = f(s + h / 2.0, a(k2, h / 2.0));
            let k4 = f(s + h, a(k3, h));
            for j in 0..4 {
                y[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
            }
        }
        (y[1], y[2], y[3])
    };
    // theta'(0) = M(0)/EI lies in [0, alpha/2] (the straight beam's root moment is alpha/2).
    let (mut lo, mut hi) = (0.0, alpha.max(1e-12));
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        let (end_slope, _, _) = shoot(mid);
        // Too little root curvature leaves curvature at the free end (end_slope < 0 means overshoot).
        if end_slope > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let (_, x, y) = shoot(0.5 * (lo + hi));
    (x, y)
}
