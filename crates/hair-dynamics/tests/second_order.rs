//! The second-order steps on the coupled system (Rosenbrock, BDF2): their order measured on a
//! 20-point strand against an f64 RK4 reference, and their stability over the grid of
//! `hair stability` (every cell stable, no energy made up); ROS3's accuracy at 1/100 s and its
//! guard; BDF2's start and restarts.

mod support;

use hair_dynamics::reference::{ReferenceScratch, ReferenceStrand};
use hair_dynamics::*;
use support::*;

/// The standard strand of the CLI's studies: 20 points, 25 cm, 0.02 kg/m, released 60 degrees
/// from straight down, rest angles zero, joint stiffness `k`, each joint damped at a 5 % ratio of
/// its stiffest mode (`2 zeta sqrt((k + M g d) m d^2)`, `M` the mass beyond it).
fn standard_strand(k: Real) -> (StrandState, SkeletonId) {
    const POINTS: usize = 20;
    const LENGTH: Real = 0.25;
    let a = 60f32.to_radians();
    let frame = frame_along(Vector::new(a.sin(), -a.cos(), 0.0));
    let material = Material {
        linear_density: 0.02,
        ..Material::default()
    };
    let (mut state, id) = one_strand(Style::Straight, POINTS, LENGTH, frame, material);
    let range = state.nodes(id);
    let d = LENGTH / (POINTS - 1) as Real;
    for i in range.start + 1..range.end {
        let m = state.mass()[i];
        let distal: Real = state.mass()[i..range.end].iter().sum();
        state.k_theta_mut()[i] = k;
        state.k_phi_mut()[i] = k;
        state.damping_mut()[i] = 2.0 * 0.05 * ((k + distal * 9.81 * d) * m * d * d).sqrt();
    }
    (state, id)
}

/// The tip after `t_end` seconds of f64 steps of `dt`.
fn tip_after(k: Real, integrator: Integrator, dt: f64, t_end: f64) -> nalgebra::Vector3<f64> {
    let (state, id) = standard_strand(k);
    let mut strand = ReferenceStrand::from_state(&state, id);
    let mut scratch = ReferenceScratch::default();
    let set = settings(dt as Real, integrator, TorqueModel::Chain);
    let steps = (t_end / dt).round() as usize;
    for _ in 0..steps {
        assert!(strand.step(&Environment::default(), &set, &mut scratch));
    }
    if integrator == Integrator::ImplicitBdf2 {
        println!(
            "bdf2 at 1/{} s: {} of {steps} steps redone as backward Euler",
            1.0 / dt,
            scratch.bdf2_fallbacks()
        );
    }
    *strand.positions().last().unwrap()
}

#[test]
fn rosenbrock_steps_converge_at_their_order_on_a_strand() {
    // Time steps are powers of two so the f32 step is exact.
    let t_end = 0.5;
    let k = 1e-3;
    let reference = tip_after(k, Integrator::Rk4, 1.0 / 65536.0, t_end);
    let check = tip_after(k, Integrator::Rk4, 1.0 / 32768.0, t_end);
    assert!(
        (reference - check).norm() < 1e-10,
        "the reference is converged"
    );
    for (integrator, expected) in [
        (Integrator::ImplicitRos2, 2.0),
        (Integrator::ImplicitRos3, 3.0),
        (Integrator::ImplicitBdf2, 2.0),
    ] {
        let errors: Vec<f64> = [1024.0, 2048.0, 4096.0]
            .iter()
            .map(|s| (tip_after(k, integrator, 1.0 / s, t_end) - reference).norm())
            .collect();
        println!("{integrator:?}: tip errors at dt = 1/1024, 1/2048, 1/4096 s: {errors:?}");
        for pair in errors.windows(2) {
            let order = (pair[0] / pair[1]).log2();
            assert!(
                (order - expected).abs() < 0.35,
                "{integrator:?}: errors {errors:?}, order {order} (expected {expected})"
            );
        }
    }
    // The first-order coupled step for comparison: far less accurate at a frame-rate step.
    let coupled =
        (tip_after(k, Integrator::ImplicitCoupled, 1.0 / 128.0, t_end) - reference).norm();
    let ros3 = (tip_after(k, Integrator::ImplicitRos3, 1.0 / 128.0, t_end) - reference).norm();
    let bdf2 = (tip_after(k, Integrator::ImplicitBdf2, 1.0 / 128.0, t_end) - reference).norm();
    println!(
        "tip error at dt = 1/128 s: coupled {coupled:.3e} m, ros3 {ros3:.3e} m, bdf2 {bdf2:.3e} m"
    );
    assert!(ros3 * 5.0 < coupled, "coupled {coupled:e}, ros3 {ros3:e}");
    assert!(bdf2 * 5.0 < coupled, "coupled {coupled:e}, bdf2 {bdf2:e}");
}

/// The tip every 1/25 s over 2 s of f32 steps of `dt` (as `hair accuracy` samples it).
fn tip_samples(k: Real, integrator: Integrator, dt: Real) -> Vec<nalgebra::Vector3<f64>> {
    let (mut state, id) = standard_strand(k);
    let set = settings(dt, integrator, TorqueModel::Chain);
    let per_sample = (0.04 / dt).round() as usize;
    let mut tips = Vec::new();
    for s in 1..=(2.0 / dt).round() as usize {
        state.step(&Environment::default(), &set).unwrap();
        if s % per_sample == 0 {
            tips.push(
                state.positions()[state_tip(&state, id)]
                    .coords
                    .cast::<f64>(),
            );
        }
    }
    tips
}

/// ROS3 meets issue 39's accuracy goal at a frame-rate step: the standard strand (k = 1e-3)
/// over 2 s at 1/100 s, RMS tip error against f64 RK4 at 1/12800 s within 2e-3 m (the goal;
/// the bar is 5e-3 m, and BDF2 has 3.6e-2). The guard's splits are part of it: 1e-3 rad splits
/// a sixth of these steps in two (the old guard's 0.01 rad split none: 2.2e-3 m).
#[test]
fn ros3_is_within_the_accuracy_goal_at_a_hundredth_of_a_second() {
    let (state, id) = standard_strand(1e-3);
    let mut strand = ReferenceStrand::from_state(&state, id);
    let mut scratch = ReferenceScratch::default();
    let fine = settings(1.0 / 12800.0, Integrator::Rk4, TorqueModel::Chain);
    let mut reference = Vec::new();
    for s in 1..=25600 {
        assert!(strand.step(&Environment::default(), &fine, &mut scratch));
        if s % 512 == 0 {
            reference.push(*strand.positions().last().unwrap());
        }
    }
    let rms = |integrator: Integrator| {
        let tips = tip_samples(1e-3, integrator, 0.01);
        assert_eq!(tips.len(), reference.len());
        let sum: f64 = tips
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).norm_squared())
            .sum();
        (sum / tips.len() as f64).sqrt()
    };
    let ros3 = rms(Integrator::ImplicitRos3);
    let coupled = rms(Integrator::ImplicitCoupled);
    println!("RMS tip error over 2 s at 1/100 s: ros3 {ros3:.3e} m, coupled {coupled:.3e} m");
    assert!(ros3 <= 2e-3, "ros3 {ros3:e}");
    assert!(ros3 * 20.0 < coupled, "ros3 {ros3:e}, coupled {coupled:e}");
}

/// ROS3's fallback to backward Euler is for steps it cannot resolve: none at the order test's
/// steps, nor at 1/100 s on the standard strand; some at 1/10 s, where the run stays finite and
/// makes up no energy.
#[test]
fn ros3_falls_back_to_backward_euler_only_on_unresolved_steps() {
    let fallbacks = |k: Real, dt: f64, t_end: f64| {
        let (state, id) = standard_strand(k);
        let mut strand = ReferenceStrand::from_state(&state, id);
        let mut scratch = ReferenceScratch::default();
        let set = settings(dt as Real, Integrator::ImplicitRos3, TorqueModel::Chain);
        for _ in 0..(t_end / dt).round() as usize {
            assert!(strand.step(&Environment::default(), &set, &mut scratch));
        }
        scratch.rosenbrock_fallbacks()
    };
    let fine = fallbacks(1e-3, 1.0 / 1024.0, 0.5);
    let frame_rate = fallbacks(1e-3, 1.0 / 100.0, 2.0);
    let coarse = fallbacks(1e-4, 1.0 / 10.0, 2.0);
    println!("ros3 fallbacks: 1/1024 s {fine}, 1/100 s {frame_rate}, 1/10 s (k = 1e-4) {coarse}");
    assert_eq!(fine, 0);
    assert_eq!(frame_rate, 0);
    assert!(coarse > 0, "{coarse}");
    let (stable, gain) = stability_cell(Integrator::ImplicitRos3, 1e-4, 10);
    assert!(stable && gain <= 0.05, "stable {stable}, gain {gain}");
}

/// One cell of the stability grid: (stable, energy gain over weight x length).
fn stability_cell(integrator: Integrator, k: f64, steps_per_second: u32) -> (bool, f64) {
    let (mut state, _) = standard_strand(k as Real);
    let env = Environment::default();
    let set = settings(
        1.0 / steps_per_second as Real,
        integrator,
        TorqueModel::Chain,
    );
    let e0 = state.model_energy(&env, TorqueModel::Chain);
    let weight_length = 0.02 * 0.25 * 9.81 * 0.25;
    let (mut first, mut last, mut e_max) = (0.0f64, 0.0f64, e0);
    for s in 0..2 * steps_per_second {
        if state.step(&env, &set).is_err() {
            return (false, f64::NAN);
        }
        let speed = state
            .velocities()
            .iter()
            .map(|v| f64::from(v.norm()))
            .fold(0.0, f64::max);
        if !speed.is_finite() {
            return (false, f64::NAN);
        }
        e_max = e_max.max(state.model_energy(&env, TorqueModel::Chain));
        if s < steps_per_second {
            first = first.max(speed);
        } else {
            last = last.max(speed);
        }
    }
    (
        last <= first && first.max(last) <= 50.0,
        (e_max - e0) / weight_length,
    )
}

#[test]
fn rosenbrock_steps_are_stable_on_the_stability_grid_and_make_up_no_energy() {
    // The grid of `hair stability`: k from 1e-6 to 1 N m/rad, three per decade, and 11 steps.
    let ks: Vec<f64> = (0..19).map(|i| 10f64.powf(-6.0 + i as f64 / 3.0)).collect();
    let rates = [1000, 600, 400, 250, 160, 100, 60, 40, 25, 16, 10];
    for integrator in [
        Integrator::ImplicitRos2,
        Integrator::ImplicitRos3,
        Integrator::ImplicitBdf2,
    ] {
        let mut unstable = Vec::new();
        let mut gaining = Vec::new();
        for &k in &ks {
            for &sps in &rates {
                let (stable, gain) = stability_cell(integrator, k, sps);
                if !stable {
                    unstable.push((k, sps));
                }
                if gain.is_nan() || gain > 0.05 {
                    gaining.push((k, sps, gain));
                }
            }
        }
        println!("{integrator:?}: unstable (k, 1/dt) {unstable:?}; gaining energy {gaining:?}");
        assert!(
            gaining.is_empty(),
            "{integrator:?}: cells gaining energy {gaining:?}"
        );
        if integrator == Integrator::ImplicitBdf2 {
            // One known cell short of the goal: at k = 1e-4, 1/400 s the tip cracks in the
            // second second at 1.002 times the first second's peak speed (RK4: 0.71), with no
            // step failing the error estimate (docs/dynamics.md).
            assert!(
                unstable
                    .iter()
                    .all(|&(k, sps)| sps == 400 && (k - 1e-4).abs() < 1e-9),
                "{integrator:?}: unstable cells {unstable:?}"
            );
        } else {
            // ROS3 too since its guard bounds the rates' error and falls back to backward Euler
            // where four pieces do not resolve the motion; with the old guard it grew in five
            // cells (docs/dynamics.md).
            assert!(
                unstable.is_empty(),
                "{integrator:?}: unstable cells {unstable:?}"
            );
        }
    }
}

/// The largest difference between two states' angles (rad) and rates (rad/s). The coupled step
/// of an attached strand in still air runs in SIMD lanes, which round differently from the
/// scalar step BDF2 shares (they agree to about 1e-5 rad), so "the same step" is a gap of that size.
fn gap(a: &StrandState, b: &StrandState) -> f32 {
    coordinates(a)
        .iter()
        .zip(coordinates(b))
        .map(|(x, y)| (f32::from_bits(*x) - f32::from_bits(y)).abs())
        .fold(0.0, f32::max)
}

/// The largest gap two runs of the same step may show: the lanes' rounding, far below what the
/// history changes.
const SAME_STEP: f32 = 1e-5;

/// Angles and rates of every node, bit for bit.
fn coordinates(state: &StrandState) -> Vec<u32> {
    [
        state.theta(),
        state.phi(),
        state.omega_theta(),
        state.omega_phi(),
    ]
    .iter()
    .flat_map(|v| v.iter().map(|x| x.to_bits()))
    .collect()
}

/// BDF2's first step is the coupled step (backward Euler) bit for bit, its second is not; and
/// after anything rewrites a strand's angles or rates, or the step changes, its next step is the
/// coupled step from there again: the history of a rewritten strand is not used.
#[test]
fn bdf2_starts_and_restarts_with_backward_euler() {
    let env = Environment::default();
    // A step at which no BDF2 step of this strand fails its error estimate (at 1/60 s the
    // release's jolt makes some early steps backward Euler).
    let dt = 1.0 / 128.0;
    let bdf2 = settings(dt, Integrator::ImplicitBdf2, TorqueModel::Chain);
    let coupled = settings(dt, Integrator::ImplicitCoupled, TorqueModel::Chain);
    let (start, id) = standard_strand(1e-3);
    let after = |mut s: StrandState, set: &StepSettings| {
        s.step(&env, set).unwrap();
        s
    };
    let (b1, c1) = (after(start.clone(), &bdf2), after(start.clone(), &coupled));
    assert!(
        gap(&b1, &c1) <= SAME_STEP,
        "{}: {}",
        "first step",
        gap(&b1, &c1)
    );
    let (b2, c2) = (after(b1.clone(), &bdf2), after(b1.clone(), &coupled));
    assert!(
        gap(&b2, &c2) > 100.0 * SAME_STEP,
        "{}: {}",
        "the second step uses the history",
        gap(&b2, &c2)
    );

    // A tool (or a collision response) rewrites an angle: the next step is backward Euler.
    let mut edited = b2.clone();
    let tip = state_tip(&edited, id);
    edited.theta_mut()[tip] += 0.01;
    let (b3, c3) = (after(edited.clone(), &bdf2), after(edited, &coupled));
    assert!(
        gap(&b3, &c3) <= SAME_STEP,
        "{}: {}",
        "after an edit of an angle",
        gap(&b3, &c3)
    );
    let mut edited = b2.clone();
    edited.rates_mut().1[tip] *= 0.5;
    let (b3, c3) = (after(edited.clone(), &bdf2), after(edited, &coupled));
    assert!(
        gap(&b3, &c3) <= SAME_STEP,
        "{}: {}",
        "after an edit of a rate",
        gap(&b3, &c3)
    );

    // A new step size: backward Euler again (BDF2's coefficients assume equal steps).
    let half = settings(dt / 2.0, Integrator::ImplicitBdf2, TorqueModel::Chain);
    let half_coupled = settings(dt / 2.0, Integrator::ImplicitCoupled, TorqueModel::Chain);
    let (b3, c3) = (after(b2.clone(), &half), after(b2.clone(), &half_coupled));
    assert!(
        gap(&b3, &c3) <= SAME_STEP,
        "{}: {}",
        "after a change of step",
        gap(&b3, &c3)
    );

    // Steps of another integrator in between: restart as well.
    let c_then_b = after(after(b2.clone(), &coupled), &bdf2);
    let c_then_c = after(after(b2, &coupled), &coupled);
    assert!(
        gap(&c_then_b, &c_then_c) <= SAME_STEP,
        "{}: {}",
        "after a coupled step",
        gap(&c_then_b, &c_then_c)
    );
}

/// Index of the last node of skeleton `id`.
fn state_tip(state: &StrandState, id: SkeletonId) -> usize {
    state.nodes(id).end - 1
}

/// Undamped, BDF2 never makes up energy: the model energy never rises above its value at
/// release, on soft and stiff strands at frame-rate and large steps (symplectic Euler on the
/// same strands rises above it, so the bound is not loose).
#[test]
fn bdf2_makes_up_no_energy_on_an_undamped_strand() {
    let env = Environment::default();
    let peak_gain = |integrator: Integrator, k: Real, steps_per_second: u32| {
        let (mut state, id) = standard_strand(k);
        for i in state.nodes(id) {
            state.damping_mut()[i] = 0.0;
        }
        let set = settings(
            1.0 / steps_per_second as Real,
            integrator,
            TorqueModel::Chain,
        );
        let e0 = state.model_energy(&env, TorqueModel::Chain);
        let mut peak = f64::NEG_INFINITY;
        for _ in 0..3 * steps_per_second {
            if state.step(&env, &set).is_err() {
                return f64::INFINITY;
            }
            peak = peak.max(state.model_energy(&env, TorqueModel::Chain) - e0);
        }
        peak / (0.02 * 0.25 * 9.81 * 0.25)
    };
    for k in [1e-5, 1e-3, 1e-1] {
        for sps in [10, 60, 250] {
            let gain = peak_gain(Integrator::ImplicitBdf2, k, sps);
            println!("bdf2, k {k}, 1/{sps} s: peak energy gain {gain:.2e} weight x length");
            assert!(gain <= 1e-4, "k {k}, 1/{sps} s: gained {gain:e}");
        }
    }
    let symplectic = peak_gain(Integrator::SymplecticEuler, 1e-3, 250);
    assert!(symplectic > 1e-4, "symplectic Euler gained {symplectic:e}");
}
