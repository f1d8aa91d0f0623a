//! Oracles: the pendulum's analytic period and damping, each integrator's order of accuracy, and
//! the cantilever elastica under self-weight.

mod support;

use hair_dynamics::reference::{ReferenceScratch, ReferenceStrand, elastica_tip};
use hair_dynamics::*;
use support::*;

const G: f64 = 9.81;

/// A one-segment pendulum of length `d` hanging along -y, tip mass `m`, damping `gamma`, no spring,
/// released at `theta0`.
fn pendulum(d: f32, m: f32, gamma: f32, theta0: f32) -> ReferenceStrand {
    let frame = frame_along(-Vector::y());
    let (mut state, id) = one_strand(Style::Straight, 2, d, frame, Material::default());
    state.mass_mut()[1] = m;
    state.k_theta_mut()[1] = 0.0;
    state.k_phi_mut()[1] = 0.0;
    state.damping_mut()[1] = gamma;
    state.theta_mut()[1] = theta0;
    ReferenceStrand::from_state(&state, id)
}

fn run_theta(mut s: ReferenceStrand, integrator: Integrator, dt: f32, steps: usize) -> Vec<f64> {
    let env = Environment::default();
    let set = settings(dt, integrator, TorqueModel::Chain);
    let mut scratch = ReferenceScratch::default();
    let mut out = Vec::with_capacity(steps + 1);
    out.push(s.coordinates()[0]);
    for _ in 0..steps {
        assert!(s.step(&env, &set, &mut scratch));
        out.push(s.coordinates()[0]);
    }
    out
}

#[test]
fn pendulum_period_and_damping_ratio_match_the_analytic_values() {
    let (d, m) = (0.1f32, 0.01f32);
    let omega0 = (G / f64::from(d)).sqrt();
    let zeta = 0.05;
    let inertia = f64::from(m) * f64::from(d).powi(2);
    let gamma = (2.0 * zeta * inertia * omega0) as f32;
    let dt = 1e-4f32;
    let theta = run_theta(pendulum(d, m, gamma, 0.01), Integrator::Rk4, dt, 40_000);
    // Period from downward zero crossings, damping from the log decrement of successive peaks.
    let crossings: Vec<f64> = (1..theta.len())
        .filter(|&i| theta[i - 1] > 0.0 && theta[i] <= 0.0)
        .map(|i| (i as f64 - theta[i] / (theta[i] - theta[i - 1])) * f64::from(dt))
        .collect();
    assert!(crossings.len() >= 4, "expected oscillations");
    let period = (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64;
    let expected_period = 2.0 * std::f64::consts::PI / (omega0 * (1.0 - zeta * zeta).sqrt());
    assert!(
        ((period - expected_period) / expected_period).abs() < 1e-3,
        "period {period} vs {expected_period}"
    );
    let peaks: Vec<f64> = (1..theta.len() - 1)
        .filter(|&i| theta[i] > theta[i - 1] && theta[i] >= theta[i + 1] && theta[i] > 0.0)
        .map(|i| theta[i])
        .collect();
    let decrement = (peaks[0] / peaks[3]).ln() / 3.0;
    let measured_zeta =
        decrement / (4.0 * std::f64::consts::PI.powi(2) + decrement * decrement).sqrt();
    assert!(
        ((measured_zeta - zeta) / zeta).abs() < 1e-2,
        "damping ratio {measured_zeta} vs {zeta}"
    );
}

#[test]
fn each_integrator_converges_at_its_order() {
    let (d, m) = (0.1f32, 0.01f32);
    let omega0 = (G / f64::from(d)).sqrt();
    let gamma = (2.0 * 0.05 * f64::from(m) * f64::from(d).powi(2) * omega0) as f32;
    let start = || pendulum(d, m, gamma, 0.5);
    let t_end = 1.0;
    let reference = *run_theta(start(), Integrator::Rk4, 1e-5, 100_000)
        .last()
        .unwrap();
    for integrator in Integrator::ALL {
        let hs: [f32; 3] = if integrator == Integrator::Rk4 {
            [1.0 / 50.0, 1.0 / 100.0, 1.0 / 200.0]
        } else {
            [1.0 / 400.0, 1.0 / 800.0, 1.0 / 1600.0]
        };
        let errors: Vec<f64> = hs
            .iter()
            .map(|&h| {
                let steps = (t_end / f64::from(h)).round() as usize;
                (run_theta(start(), integrator, h, steps).last().unwrap() - reference).abs()
            })
            .collect();
        for pair in errors.windows(2) {
            let order = (pair[0] / pair[1]).log2();
            let expected = f64::from(integrator.order());
            assert!(
                (order - expected).abs() < 0.3,
                "{integrator:?}: errors {errors:?}, order {order} (expected {expected})"
            );
        }
    }
}

/// A strand clamped horizontally, sagging under its own weight, relaxed to equilibrium in f64.
fn cantilever_tip(alpha: f64, segments: usize, torque: TorqueModel) -> (f64, f64) {
    let length = 0.25f32;
    let rho = 0.02f32;
    let ei = (f64::from(rho) * G * f64::from(length).powi(3) / alpha) as f32;
    let material = Material {
        linear_density: rho,
        bending_stiffness: ei,
        damping: 0.0,
        ..Material::default()
    };
    let (state, id) = one_strand(
        Style::Straight,
        segments + 1,
        length,
        frame_along(Vector::x()),
        material,
    );
    let mut s = ReferenceStrand::from_state(&state, id);
    let mut scratch = ReferenceScratch::default();
    let set = settings(1e-3, Integrator::ImplicitCoupled, torque);
    let env = Environment::default();
    let iters = s.relax(&env, &set, 2_000, 1e-12, &mut scratch);
    assert!(
        iters.is_some(),
        "alpha {alpha}, {segments} segments, {torque:?}: did not converge"
    );
    let tip = *s.positions().last().unwrap();
    (tip.x / f64::from(length), -tip.y / f64::from(length))
}

#[test]
fn chain_model_converges_to_the_elastica() {
    for alpha in [1.0, 10.0, 100.0] {
        let (rx, ry) = elastica_tip(alpha);
        let mut last_err = f64::INFINITY;
        for segments in [8, 16, 32, 64] {
            let (x, y) = cantilever_tip(alpha, segments, TorqueModel::Chain);
            let err = (x - rx).hypot(y - ry);
            eprintln!(
                "alpha {alpha} segments {segments}: tip ({x:.6}, {y:.6}) vs ({rx:.6}, {ry:.6}), error {err:.2e}"
            );
            // Second order in the segment length: each halving divides the error by about four.
            assert!(
                last_err / err > 3.5,
                "alpha {alpha}: error {err} at {segments} segments after {last_err}"
            );
            last_err = err;
        }
        assert!(
            last_err < 0.01,
            "alpha {alpha}: tip error {last_err} of L at 64 segments"
        );
    }
}

#[test]
fn local_model_barely_sags() {
    // The papers' local torque: each segment bears only its own weight (docs/dynamics.md).
    let (_, ry) = elastica_tip(10.0);
    let (_, y) = cantilever_tip(10.0, 32, TorqueModel::Local);
    assert!(
        y < 0.5 * ry,
        "local model tip drop {y} should be far below the elastica's {ry}"
    );
}

#[test]
fn elastica_reference_matches_small_deflection_theory() {
    // Linear beam theory: tip drop q L^4 / (8 EI), i.e. alpha / 8 of L.
    let (x, y) = elastica_tip(0.01);
    assert!((y - 0.01 / 8.0).abs() < 1e-6, "{y}");
    assert!((x - 1.0).abs() < 1e-5, "{x}");
}
