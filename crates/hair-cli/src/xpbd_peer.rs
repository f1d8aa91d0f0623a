//! The engines' XPBD strand ([`XpbdStrands`]) as a row of the studies, beside our integrators.
//!
//! Every study builds its strands as a [`StrandState`] and hands them to either our step or
//! [`XpbdStrands::from_state`], so both see the same nodes, masses, rest lengths, joint
//! stiffnesses, roots and release. XPBD runs [`settings`]: 5 substeps of 5 Gauss-Seidel sweeps
//! per step, inextensible segments, bend compliance `1 / k`, no velocity damping (the joints'
//! light damping of the angular model has no XPBD counterpart; XPBD's own dissipation remains).

use hair::dynamics::{DynamicsError, Environment, Integrator, StepSettings, StrandState};
use hair::dynamics::{XpbdSettings, XpbdStrands};

/// Name of the XPBD rows in JSON and on charts.
pub const NAME: &str = "xpbd";

/// The XPBD settings of every study: [`XpbdSettings::default`] (5 substeps x 5 iterations,
/// inextensible, bend compliance `1 / k`), undamped.
pub fn settings() -> XpbdSettings {
    XpbdSettings {
        damping: 0.0,
        ..XpbdSettings::default()
    }
}

/// A method of the studies: one of our integrators, or XPBD.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// One of our angular integrators.
    Ours(Integrator),
    /// The engines' position-based strand.
    Xpbd,
}

impl Method {
    /// Every method, in chart order: [`Integrator::ALL`], then XPBD.
    pub fn all() -> Vec<Method> {
        Integrator::ALL
            .into_iter()
            .map(Method::Ours)
            .chain([Method::Xpbd])
            .collect()
    }

    /// `explicit_euler`, ..., `xpbd`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Ours(i) => i.name(),
            Method::Xpbd => NAME,
        }
    }
}

/// Strands advanced by one method.
pub enum Stepper {
    /// Our angular state and its step.
    Ours(Box<StrandState>, StepSettings),
    /// The XPBD particles built from the same state.
    Xpbd(Box<XpbdStrands>, XpbdSettings),
}

impl Stepper {
    /// `state` advanced by `method`; our integrators use `settings` (XPBD takes its step from it).
    pub fn new(method: Method, state: StrandState, settings: StepSettings) -> Self {
        match method {
            Method::Ours(integrator) => Stepper::Ours(
                Box::new(state),
                StepSettings {
                    integrator,
                    ..settings
                },
            ),
            Method::Xpbd => {
                Stepper::Xpbd(Box::new(XpbdStrands::from_state(&state)), self::settings())
            }
        }
    }

    /// One step of `dt` (our step uses the `dt` of its settings, which is the same).
    pub fn step(&mut self, env: &Environment, dt: f32) -> Result<(), DynamicsError> {
        match self {
            Stepper::Ours(state, settings) => state.step(env, settings).map(|_| ()),
            Stepper::Xpbd(strands, settings) => strands.step(env, dt, settings),
        }
    }

    /// Node `i`'s position (head frame, f64).
    pub fn position(&self, i: usize) -> nalgebra::Vector3<f64> {
        let p = match self {
            Stepper::Ours(state, _) => state.positions()[i].coords,
            Stepper::Xpbd(strands, _) => strands
                .positions()
                .nth(i)
                .map_or_else(|| nalgebra::Vector3::repeat(f32::NAN), |p| p.coords),
        };
        p.map(f64::from)
    }

    /// Largest node speed (m/s), and whether every position and velocity is finite.
    pub fn peak_speed(&self) -> (f64, bool) {
        let (velocities, finite_positions) = match self {
            Stepper::Ours(state, _) => (
                state.velocities(),
                state
                    .positions()
                    .iter()
                    .all(|p| p.coords.iter().all(|c| c.is_finite())),
            ),
            Stepper::Xpbd(strands, _) => (
                strands.velocities(),
                strands
                    .positions()
                    .all(|p| p.coords.iter().all(|c| c.is_finite())),
            ),
        };
        let mut speed = 0.0f64;
        let mut finite = finite_positions;
        for v in velocities {
            let n = f64::from(v.norm());
            finite &= n.is_finite();
            speed = speed.max(n);
        }
        (speed, finite)
    }

    /// The method's own energy (J): our model energy with the chain torque, or XPBD's kinetic,
    /// gravity and bend-constraint energy. Each is compared only with itself at release.
    pub fn energy(&self, env: &Environment) -> f64 {
        match self {
            Stepper::Ours(state, settings) => state.model_energy(env, settings.torque),
            Stepper::Xpbd(strands, settings) => strands.energy(env, settings),
        }
    }

    /// Number of nodes (particles).
    pub fn node_count(&self) -> usize {
        match self {
            Stepper::Ours(state, _) => state.node_count(),
            Stepper::Xpbd(strands, _) => strands.node_count(),
        }
    }
}

/// Velocity damping rate (1/s) with which [`settle`] brings XPBD to rest; it does not move the
/// rest state (velocities are zero there).
pub const SETTLE_DAMPING: f32 = 20.0;

/// XPBD's rest state of `state` under `env`: steps of `dt` with [`settings`] and
/// [`SETTLE_DAMPING`] until the last node moves less than `tolerance` (m) in each of 30 steps in
/// a row, at most `max_steps`. Returns the last node's position and the steps taken (`None`
/// when it never came to rest).
pub fn settle(
    state: &StrandState,
    env: &Environment,
    dt: f32,
    max_steps: usize,
    tolerance: f64,
) -> Result<(nalgebra::Vector3<f64>, Option<usize>), DynamicsError> {
    let mut strands = XpbdStrands::from_state(state);
    let settings = XpbdSettings {
        damping: SETTLE_DAMPING,
        ..self::settings()
    };
    let tip = |s: &XpbdStrands| {
        s.positions()
            .last()
            .map_or_else(nalgebra::Vector3::zeros, |p| p.coords.map(f64::from))
    };
    let mut last = tip(&strands);
    let mut quiet = 0;
    for step in 1..=max_steps {
        strands.step(env, dt, &settings)?;
        let now = tip(&strands);
        quiet = if (now - last).norm() < tolerance {
            quiet + 1
        } else {
            0
        };
        last = now;
        if quiet == 30 {
            return Ok((now, Some(step)));
        }
    }
    Ok((last, None))
}
