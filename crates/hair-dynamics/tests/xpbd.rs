//! The XPBD peer: it settles to the elastica's sag when its constraints are resolved, and stays
//! finite on the stiffest springs at the largest step.

mod support;

use hair_dynamics::reference::elastica_tip;
use hair_dynamics::*;
use support::*;

/// A cantilever of `segments` segments clamped along +x with `EI = rho g L^3 / alpha`.
fn cantilever(alpha: f64, segments: usize) -> StrandState {
    let (length, rho) = (0.25f32, 0.02f32);
    let ei = (f64::from(rho) * 9.81 * f64::from(length).powi(3) / alpha) as f32;
    let material = Material {
        linear_density: rho,
        bending_stiffness: ei,
        damping: 0.0,
        ..Material::default()
    };
    one_strand(
        Style::Straight,
        segments + 1,
        length,
        frame_along(Vector::x()),
        material,
    )
    .0
}

#[test]
fn xpbd_settles_to_the_elastica_sag_at_alpha_1() {
    let state = cantilever(1.0, 16);
    let mut x = XpbdStrands::from_state(&state);
    let settings = XpbdSettings {
        substeps: 20,
        iterations: 20,
        damping: 20.0,
        ..XpbdSettings::default()
    };
    let env = Environment::default();
    for _ in 0..300 {
        x.step(&env, 1.0 / 60.0, &settings).unwrap();
    }
    let tip = x.positions().last().unwrap();
    let (rx, ry) = elastica_tip(1.0);
    let err = (f64::from(tip.x) / 0.25 - rx).hypot(-f64::from(tip.y) / 0.25 - ry);
    println!(
        "xpbd tip ({}, {}) / L vs elastica ({rx}, {ry}): error {err:.3e} L",
        tip.x / 0.25,
        -tip.y / 0.25
    );
    assert!(err < 0.02, "tip error {err} L");
}

#[test]
fn xpbd_stays_finite_on_stiff_springs_at_a_tenth_of_a_second() {
    let mut state = cantilever(1.0, 19);
    for k in state.k_theta_mut() {
        *k = 1.0;
    }
    let mut x = XpbdStrands::from_state(&state);
    let env = Environment::default();
    for _ in 0..20 {
        x.step(&env, 0.1, &XpbdSettings::default()).unwrap();
    }
    assert!(
        x.positions()
            .all(|p| p.coords.iter().all(|c| c.is_finite()))
    );
}
