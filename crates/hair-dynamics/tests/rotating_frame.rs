//! A head that turns fast: strands simulated in its frame feel Coriolis and centrifugal forces.
//! The coupled implicit step must not make energy out of them at a frame-rate step, which it did
//! while the Coriolis force was an explicit (dead) load (the `shake` scene reached 6.6e8 J).

mod support;

use hair_dynamics::*;
use nalgebra::Rotation3;
use support::*;

/// The `shake` scene's head motion: a turn about the vertical of `amplitude` degrees at 1.2 Hz,
/// with its exact angular velocity and acceleration.
fn shaking_head(t: f64, amplitude: f64) -> Environment {
    let a = amplitude.to_radians();
    let w = std::f64::consts::TAU * 1.2;
    let (s, c) = (w * t).sin_cos();
    Environment {
        head: HeadMotion {
            rotation: Rotation3::from_axis_angle(&Vector::y_axis(), (a * s) as Real),
            angular_velocity: Vector::new(0.0, (a * w * c) as Real, 0.0),
            angular_acceleration: Vector::new(0.0, (-a * w * w * s) as Real, 0.0),
            ..HeadMotion::default()
        },
        ..Environment::default()
    }
}

/// The `shake` scene's hair (its default material) rooted on a 10 cm head along `directions`,
/// 12 points over 30 cm, wavy.
fn scalp(directions: &[Vector]) -> StrandState {
    let material = Material {
        linear_density: 0.01,
        bending_stiffness: 2e-6,
        tip_stiffness_ratio: 0.3,
        damping: 2e-6,
        tip_damping_ratio: 0.3,
        radius: 0.002,
        stretch_stiffness: 0.0,
    };
    let style = Style::Wavy {
        amplitude: 0.008,
        period: 0.1,
    };
    let mut state = StrandState::new();
    for dir in directions {
        let root = Point::from(dir.normalize() * 0.1);
        let frame = frame_along(*dir);
        let points = style_points(root, &frame, &style, 12, 0.3).expect("valid style");
        state
            .add_skeleton(&SkeletonDesc {
                root: Root::Attached {
                    position: root,
                    frame,
                },
                points,
                material,
            })
            .expect("valid skeleton");
    }
    state
}

/// The largest kinetic energy (J, head frame) over 3 s of steps of `dt`.
fn peak_energy(integrator: Integrator, dt: f64, amplitude: f64, directions: &[Vector]) -> f64 {
    let mut state = scalp(directions);
    let all: Vec<u32> = (0..directions.len() as u32).collect();
    let set = settings(dt as Real, integrator, TorqueModel::Chain);
    let steps = (3.0 / dt).round() as usize;
    let mut peak = 0.0_f64;
    for k in 0..steps {
        let env = shaking_head(k as f64 * dt, amplitude);
        state
            .step(&env, &set)
            .unwrap_or_else(|e| panic!("{integrator:?} at step {k}: {e}"));
        peak = peak.max(state.kinetic_energy(&all));
    }
    peak
}

/// Strands leaving the head every 30 degrees of azimuth and elevation, crown included.
fn all_around() -> Vec<Vector> {
    let mut out = Vec::new();
    for a in 0..12 {
        for e in 0..7 {
            let (az, el) = ((a * 30) as Real, (e * 30 - 90) as Real);
            let (az, el) = (az.to_radians(), el.to_radians());
            out.push(Vector::new(
                el.cos() * az.cos(),
                el.sin(),
                el.cos() * az.sin(),
            ));
        }
    }
    out
}

/// A 35 degree shake at 1.2 Hz at dt 1/60 s: the coupled step's peak kinetic energy stays within
/// twice what RK4 reaches at dt 1/1200 s (the motion's own energy). Before the Coriolis force was
/// implicit, strands standing up near the crown gained energy every step: about 1e5 times it.
#[test]
fn a_fast_shake_makes_no_energy_in_the_coupled_step() {
    let directions = all_around();
    let reference = peak_energy(Integrator::Rk4, 1.0 / 1200.0, 35.0, &directions);
    let coupled = peak_energy(Integrator::ImplicitCoupled, 1.0 / 60.0, 35.0, &directions);
    println!(
        "peak kinetic energy: RK4 at 1/1200 s {reference:e} J, coupled at 1/60 s {coupled:e} J"
    );
    assert!(reference > 0.0);
    assert!(
        coupled <= 2.0 * reference,
        "coupled {coupled:e} J vs RK4 {reference:e} J"
    );
}

/// The one strand of the set that blew up, alone, pointing up and back near the crown, with the
/// steps that solve the coupled system: all within twice the small-step RK4 energy; and a gentle
/// 10 degree shake for comparison. (The per-angle implicit step, its loads explicit, is bounded
/// here too but overshoots to 2.3 times.)
#[test]
fn a_strand_near_the_crown_stays_bounded_with_every_implicit_step() {
    let crown = [Vector::new(0.25, 0.866, -0.433)];
    for amplitude in [10.0, 35.0] {
        let reference = peak_energy(Integrator::Rk4, 1.0 / 1200.0, amplitude, &crown);
        for integrator in [
            Integrator::ImplicitCoupled,
            Integrator::ImplicitRos2,
            Integrator::ImplicitRos3,
        ] {
            let peak = peak_energy(integrator, 1.0 / 60.0, amplitude, &crown);
            println!("{amplitude} degrees, {integrator:?}: {peak:e} J (RK4 {reference:e} J)");
            assert!(
                peak <= 2.0 * reference,
                "{amplitude} degrees, {integrator:?}: {peak:e} J vs RK4 {reference:e} J"
            );
        }
    }
}
