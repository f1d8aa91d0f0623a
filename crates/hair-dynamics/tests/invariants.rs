//! Property tests of the strand model's invariants.

mod support;

use hair_dynamics::*;
use proptest::prelude::*;
use support::*;

fn integrator() -> impl Strategy<Value = Integrator> {
    prop::sample::select(Integrator::ALL.to_vec())
}

fn style() -> impl Strategy<Value = Style> {
    prop_oneof![
        Just(Style::Straight),
        (0.0f32..0.03, 0.02f32..0.2)
            .prop_map(|(amplitude, period)| Style::Wavy { amplitude, period }),
        (0.0f32..0.02, 0.005f32..0.1).prop_map(|(radius, pitch)| Style::Curly { radius, pitch }),
    ]
}

/// Styles whose segments bend by less than about 90 degrees, where motion is not chaotic.
fn gentle_style() -> impl Strategy<Value = Style> {
    prop_oneof![
        Just(Style::Straight),
        (0.0f32..0.01, 0.05f32..0.2)
            .prop_map(|(amplitude, period)| Style::Wavy { amplitude, period }),
        (0.01f32..0.02, 0.02f32..0.1).prop_map(|(radius, pitch)| Style::Curly { radius, pitch }),
    ]
}

fn direction() -> impl Strategy<Value = Vector> {
    (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
        .prop_filter("non-zero", |(x, y, z)| x * x + y * y + z * z > 1e-3)
        .prop_map(|(x, y, z)| Vector::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// At the rest pose with no external force nothing moves, bit for bit.
    #[test]
    fn rest_pose_is_exactly_still(style in style(), dir in direction(), n in 2usize..24, integrator in integrator(),
                                  chain in any::<bool>(), dt in 1e-4f32..0.1) {
        let (mut state, _) = one_strand(style, n, 0.25, frame_along(dir), Material::default());
        let before = (state.theta().to_vec(), state.phi().to_vec(), state.positions().to_vec());
        let torque = if chain { TorqueModel::Chain } else { TorqueModel::Local };
        for _ in 0..20 {
            state.step(&no_gravity(), &settings(dt, integrator, torque)).unwrap();
        }
        prop_assert_eq!(&before.0, &state.theta().to_vec());
        prop_assert_eq!(&before.1, &state.phi().to_vec());
        prop_assert!(state.omega_theta().iter().chain(state.omega_phi()).all(|w| *w == 0.0));
        for (a, b) in before.2.iter().zip(state.positions()) {
            prop_assert!((a - b).norm() <= 1e-6, "{a} vs {b}");
        }
    }

    /// No NaN for any finite input in the documented ranges (k up to 1e9, dt up to 0.1 s): the
    /// implicit methods stay finite, and every method either stays finite or reports the strand.
    #[test]
    fn implicit_steps_stay_finite(k in 1e-9f32..1e9, dt in 1e-4f32..0.1, damping in 0.0f32..1.0,
                                  style in style(), dir in direction(), coupled in any::<bool>(),
                                  chain in any::<bool>(), start in -3.0f32..3.0) {
        let (mut state, _) = one_strand(style, 12, 0.25, frame_along(dir), Material::default());
        state.k_theta_mut().iter_mut().for_each(|x| *x = k);
        state.k_phi_mut().iter_mut().for_each(|x| *x = k);
        state.damping_mut().iter_mut().for_each(|x| *x = damping);
        state.theta_mut()[1] += start;
        let integrator = if coupled { Integrator::ImplicitCoupled } else { Integrator::ImplicitAngular };
        let torque = if chain { TorqueModel::Chain } else { TorqueModel::Local };
        let env = Environment { wind: Wind { speed: 5.0, drag: 1e-3, turbulence: 0.3, ..Wind::default() }, ..Environment::default() };
        for _ in 0..50 {
            if let Err(e) = state.step(&env, &settings(dt, integrator, torque)) {
                return Err(TestCaseError::fail(format!("{e}")));
            }
            prop_assert!(state.theta().iter().chain(state.phi()).chain(state.omega_theta()).chain(state.omega_phi()).all(|x| x.is_finite()));
            prop_assert!(state.positions().iter().all(|p| p.coords.iter().all(|c| c.is_finite())));
        }
    }

    /// Rotating the root frame (and gravity with it) rotates the result.
    #[test]
    fn rotating_the_root_frame_rotates_the_result(style in gentle_style(), axis in direction(), angle in -3.0f32..3.0,
                                                   integrator in prop::sample::select(vec![Integrator::ImplicitAngular, Integrator::ImplicitCoupled, Integrator::SymplecticEuler])) {
        let q = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
        let base = frame_along(Vector::new(0.3, -1.0, 0.2));
        let (mut a, _) = one_strand(style, 10, 0.2, base, Material::default());
        let (mut b, _) = one_strand(style, 10, 0.2, q * base, Material::default());
        let env_a = Environment::default();
        let env_b = Environment { gravity: q * env_a.gravity, ..Environment::default() };
        let s = settings(1.0 / 240.0, integrator, TorqueModel::Chain);
        for _ in 0..120 {
            a.step(&env_a, &s).unwrap();
            b.step(&env_b, &s).unwrap();
        }
        for (pa, pb) in a.positions().iter().zip(b.positions()) {
            let expected = q * pa;
            prop_assert!((expected - pb).norm() < 2e-5, "{expected} vs {pb}");
        }
    }
}

/// Rigid segments keep their lengths over 10,000 steps of a swinging, wind-blown strand.
#[test]
fn segment_lengths_hold_over_ten_thousand_steps() {
    for integrator in [Integrator::ImplicitAngular, Integrator::ImplicitCoupled] {
        let (mut state, id) = one_strand(
            Style::Curly {
                radius: 0.01,
                pitch: 0.03,
            },
            20,
            0.25,
            frame_along(Vector::new(1.0, 0.2, 0.0)),
            Material::default(),
        );
        let env = Environment {
            wind: Wind {
                speed: 3.0,
                gust: 0.5,
                turbulence: 0.5,
                drag: 2e-3,
                ..Wind::default()
            },
            ..Environment::default()
        };
        for _ in 0..10_000 {
            state
                .step(&env, &settings(1.0 / 120.0, integrator, TorqueModel::Chain))
                .unwrap();
        }
        let r = state.nodes(id);
        let p = state.positions();
        for i in r.start + 1..r.end {
            let d = (p[i] - p[i - 1]).norm();
            let rest = state.rest_length()[i];
            assert!(
                (d - rest).abs() <= 1e-5 * rest,
                "{integrator:?} node {i}: {d} vs {rest}"
            );
        }
    }
}

/// With damping and no external work, the implicit steps never gain energy: springs alone for the
/// per-angle step (its loads are explicit), springs and gravity for the coupled step with the
/// chain torque (the local torque of the papers is not the gradient of any potential).
#[test]
fn implicit_steps_never_gain_energy() {
    let cases = [
        (Integrator::ImplicitAngular, false),
        (Integrator::ImplicitCoupled, false),
        (Integrator::ImplicitCoupled, true),
    ];
    for (integrator, gravity) in cases {
        for torque in [TorqueModel::Local, TorqueModel::Chain] {
            if gravity && torque == TorqueModel::Local {
                continue;
            }
            let (mut state, _) = one_strand(
                Style::Wavy {
                    amplitude: 0.01,
                    period: 0.08,
                },
                16,
                0.2,
                frame_along(Vector::x()),
                Material::default(),
            );
            // Pluck: bend every joint away from rest, so the springs (and gravity) do the work.
            for (i, t) in state.theta_mut().iter_mut().enumerate().skip(1) {
                *t += 0.3 * ((i as f32) * 0.7).sin();
            }
            let s = settings(1.0 / 60.0, integrator, torque);
            let env = if gravity {
                Environment::default()
            } else {
                no_gravity()
            };
            let first = state.model_energy(&env, torque);
            let mut last = first;
            for step in 0..600 {
                state.step(&env, &s).unwrap();
                let e = state.model_energy(&env, torque);
                // The state is f32: allow its rounding (a few ulps of the energy's magnitude).
                assert!(
                    e <= last + 1e-6 * first.abs().max(e.abs()),
                    "{integrator:?} {torque:?} gravity={gravity} step {step}: {e} > {last}"
                );
                last = e;
            }
            assert!(
                last < first,
                "{integrator:?} {torque:?}: damping must have taken energy out"
            );
        }
    }
}
