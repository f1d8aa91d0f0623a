//! Criterion benches of one step of 10,000 skeletons x 20 points, per integrator, on one thread
//! and on all threads (the same workload as `hair bench dynamics`); the coupled implicit step also
//! with the dense LU in place of the structured solve (`implicit_coupled_hand`). Also one sweep
//! of `StrandState::sweep_chains` lifting the same strands onto a floor through their lower
//! half (`sweep_10k_x_20_floor`): the hard body constraint's refit with a trivial body.

use std::hint::black_box;
use std::time::Duration;

use criterion::{
    BatchSize, BenchmarkId, Criterion, SamplingMode, Throughput, criterion_group, criterion_main,
};
use hair_dynamics::{
    Environment, Integrator, LinearSolver, Material, Point, Real, Root, SkeletonDesc, StepSettings,
    StrandState, Style, SweepAsk, Vector, style_points,
};
use nalgebra::{Rotation3, Unit};

const SKELETONS: usize = 10_000;
const POINTS: usize = 20;
const LENGTH: Real = 0.25;
const K: Real = 1e-4;
const DT: Real = 1e-3;

/// SplitMix64 in [0, 1): seeded release directions.
fn unit(state: &mut u64) -> Real {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as Real / (1u64 << 24) as Real
}

/// 10,000 straight 25 cm strands on a 1 cm grid, each released 60 degrees from straight down in a
/// seeded direction, joint stiffness `K`, light damping (5 % of each joint's stiffest mode).
fn scene() -> StrandState {
    let mut state = StrandState::new();
    let side = (SKELETONS as f64).sqrt().ceil() as usize;
    let mut seed = 7u64;
    let tilt = 60f32.to_radians();
    let d = LENGTH / (POINTS - 1) as Real;
    for s in 0..SKELETONS {
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

fn bench_step(c: &mut Criterion) {
    let env = Environment::default();
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("a one-thread pool");
    for (group_name, one_thread) in [
        ("step_10k_x_20_1_thread", true),
        ("step_10k_x_20_all_threads", false),
    ] {
        let mut group = c.benchmark_group(group_name);
        group
            .throughput(Throughput::Elements((SKELETONS * POINTS) as u64))
            .sampling_mode(SamplingMode::Flat)
            .sample_size(10)
            .warm_up_time(Duration::from_millis(500))
            .measurement_time(Duration::from_secs(3));
        let variants = Integrator::ALL
            .map(|integrator| (integrator, LinearSolver::default()))
            .into_iter()
            .chain([(Integrator::ImplicitCoupled, LinearSolver::Hand)]);
        for (integrator, solver) in variants {
            let settings = StepSettings {
                dt: DT,
                integrator,
                solver,
                ..StepSettings::default()
            };
            let name = if solver == LinearSolver::default() {
                integrator.name().to_string()
            } else {
                format!("{}_{}", integrator.name(), solver.name())
            };
            let mut state = scene();
            group.bench_function(BenchmarkId::from_parameter(name), |b| {
                let mut run = || {
                    b.iter(|| {
                        // A blown-up skeleton is restored and reported; the cost is still one step.
                        let _ = black_box(state.step(black_box(&env), black_box(&settings)));
                    })
                };
                if one_thread {
                    single.install(run)
                } else {
                    run()
                }
            });
        }
        group.finish();
    }
}

/// Where a node under the floor `y = FLOOR` goes: onto its sphere about its parent at the
/// floor's height, or straight above the parent where the sphere does not reach that high.
fn onto_floor(ask: &SweepAsk<'_>) -> Option<Point> {
    const FLOOR: Real = -0.07;
    if ask.at.y >= FLOOR {
        return None;
    }
    let a = *ask.parent?;
    let len = (ask.at - a).norm();
    let rise = FLOOR - a.y;
    if rise >= len {
        return Some(a + Vector::y() * len);
    }
    let side = Vector::new(ask.at.x - a.x, 0.0, ask.at.z - a.z)
        .try_normalize(1e-9)
        .unwrap_or_else(Vector::x);
    Some(a + side * (len * len - rise * rise).sqrt() + Vector::y() * rise)
}

fn bench_sweep(c: &mut Criterion) {
    let fresh = scene();
    let chains: Vec<[u32; 2]> = (0..SKELETONS as u32).map(|s| [s, 1]).collect();
    let mut group = c.benchmark_group("sweep_10k_x_20_floor");
    group
        .throughput(Throughput::Elements((SKELETONS * POINTS) as u64))
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    group.bench_function("all_threads", |b| {
        b.iter_batched_ref(
            || {
                let state = fresh.clone();
                let out = vec![(); state.node_count()];
                (state, out, vec![0u32; SKELETONS])
            },
            |(state, out, moved)| {
                let _ =
                    black_box(state.sweep_chains(&chains, out, moved, |ask, _| onto_floor(ask)));
            },
            BatchSize::LargeInput,
        )
    });
    group.finish();
}

criterion_group!(benches, bench_step, bench_sweep);
criterion_main!(benches);
