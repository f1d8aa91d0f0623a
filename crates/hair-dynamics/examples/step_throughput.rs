//! Node-steps per second of the coupled implicit step on the workload of `hair bench dynamics`
//! (straight 25 cm strands of 20 points released 60 degrees from straight down, k = 1e-4,
//! dt = 1 ms), without building the command-line tool: for profiling (`valgrind
//! --tool=callgrind`) and quick before/after figures.
//!
//! `cargo run --release -p hair-dynamics --example step_throughput -- SKELETONS STEPS THREADS
//! [INTEGRATOR [DT]]` (defaults 10000, 200, all, `implicit_coupled`, 0.001 s); prints node-steps
//! per second, the dense fallbacks and the Rosenbrock steps the guard split.

use std::time::Instant;

use hair_dynamics::{
    Environment, Integrator, Material, Point, Real, Root, SkeletonDesc, StepSettings, StrandState,
    Style, Vector, style_points,
};
use nalgebra::{Rotation3, Unit};

const POINTS: usize = 20;
const LENGTH: Real = 0.25;
const K: Real = 1e-4;

/// SplitMix64 in [0, 1): seeded release directions.
fn unit(state: &mut u64) -> Real {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as Real / (1u64 << 24) as Real
}

fn scene(skeletons: usize) -> StrandState {
    let mut state = StrandState::new();
    let side = (skeletons as f64).sqrt().ceil() as usize;
    let mut seed = 7u64;
    let tilt = 60f32.to_radians();
    let d = LENGTH / (POINTS - 1) as Real;
    for s in 0..skeletons {
        let root = Point::new((s % side) as Real * 0.01, 0.0, (s / side) as Real * 0.01);
        let azimuth = core::f32::consts::TAU * unit(&mut seed);
        let dir = Vector::new(
            tilt.sin() * azimuth.cos(),
            -tilt.cos(),
            tilt.sin() * azimuth.sin(),
        );
        let frame = Unit::try_new(Vector::z().cross(&dir), 1e-12)
            .map_or_else(Rotation3::identity, |axis| {
                Rotation3::from_axis_angle(&axis, Vector::z().angle(&dir))
            });
        let points =
            style_points(root, &frame, &Style::Straight, POINTS, LENGTH).expect("valid style");
        let id = state
            .add_skeleton(&SkeletonDesc {
                root: Root::Attached {
                    position: root,
                    frame,
                },
                points,
                material: Material {
                    linear_density: 0.02,
                    ..Material::default()
                },
            })
            .expect("valid skeleton");
        let range = state.nodes(id);
        for i in range.start + 1..range.end {
            let m = state.mass()[i];
            let distal: Real = state.mass()[i..range.end].iter().sum();
            state.k_theta_mut()[i] = K;
            state.k_phi_mut()[i] = K;
            state.damping_mut()[i] = 2.0 * 0.05 * ((K + distal * 9.81 * d) * m * d * d).sqrt();
        }
    }
    state
}

fn main() {
    let words: Vec<String> = std::env::args().skip(1).collect();
    let args: Vec<usize> = words
        .iter()
        .take(3)
        .map(|a| a.parse().expect("SKELETONS STEPS THREADS as integers"))
        .collect();
    let integrator = words.get(3).map_or(Integrator::ImplicitCoupled, |name| {
        Integrator::ALL
            .into_iter()
            .find(|i| i.name() == name)
            .expect("an integrator's name, e.g. implicit_ros3")
    });
    let dt: Real = words
        .get(4)
        .map_or(1e-3, |dt| dt.parse().expect("DT in seconds"));
    let skeletons = args.first().copied().unwrap_or(10_000);
    let steps = args.get(1).copied().unwrap_or(200);
    let threads = args.get(2).copied().unwrap_or(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool");
    let env = Environment::default();
    let settings = StepSettings {
        dt,
        integrator,
        ..StepSettings::default()
    };
    let mut state = scene(skeletons);
    let (best, total, fallbacks, splits, to_coupled) = pool.install(|| {
        let mut fallbacks = 0;
        let mut total = 0.0;
        let (mut splits, mut to_coupled) = (0, 0);
        let mut best = f64::INFINITY;
        for _ in 0..steps {
            let clock = Instant::now();
            let report = state.step(&env, &settings).expect("finite steps");
            let took = clock.elapsed().as_secs_f64();
            best = best.min(took);
            total += took;
            fallbacks += report.dense_fallbacks;
            splits += report.rosenbrock_splits;
            to_coupled += report.rosenbrock_fallbacks;
        }
        (best, total, fallbacks, splits, to_coupled)
    });
    let nodes = state.node_count() as f64;
    let checksum: f64 = state.positions().iter().map(|p| f64::from(p.y)).sum();
    println!(
        "{skeletons} skeletons x {POINTS} points, {steps} steps of {dt} s by {}, {} threads: {:.2} M node-steps/s (best step), {:.2} M (all steps), {fallbacks} dense fallbacks, {splits} Rosenbrock steps split ({to_coupled} of them to the coupled step), checksum {checksum:.6}",
        integrator.name(),
        pool.current_num_threads(),
        nodes / best / 1e6,
        nodes * steps as f64 / total / 1e6
    );
}
