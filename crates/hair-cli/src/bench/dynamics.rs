//! `hair bench dynamics`: node-steps per second of every integrator on 10,000 skeletons of 20
//! points, on one thread and on all threads.
//!
//! The skeletons are standard strands ([`crate::strand_setup`]) rooted on a grid, each released
//! at 60 degrees from straight down in a seeded direction, with a moderate joint stiffness and a
//! 1 ms step at which every integrator stays finite for the length of the measurement. After a
//! warm-up, rounds of timed batches visit every integrator in turn and the fastest batch of each is
//! kept, so load from other processes on the shared machine falls on all integrators alike.
//!
//! The engines' XPBD ([`crate::xpbd_peer`]: 5 substeps x 5 iterations a step) runs on the same
//! strands under the key `xpbd`; a node-step is one particle advanced by one whole step.

use std::time::Instant;

use anyhow::Context as _;
use hair::dynamics::{
    DynamicsError, Environment, Integrator, LinearSolver, Point, Real, StepSettings, StrandState,
    TorqueModel, Vector,
};
use hair_ssv::test_meshes::SplitMix;
use nalgebra::{Rotation3, Unit};
use serde_json::{Map, Value, json};

use crate::strand_setup::{self, Damping};
use crate::xpbd_peer::{Method, Stepper};

/// Arguments of `hair bench dynamics`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Number of skeletons (20 points each).
    #[arg(long, default_value_t = 10_000)]
    pub skeletons: usize,
    /// Wall time of one timed batch (s); four interleaved rounds of batches are timed.
    #[arg(long, default_value_t = 0.25)]
    pub batch_seconds: f64,
    /// Time step (s).
    #[arg(long, default_value_t = 1e-3)]
    pub dt: f64,
    /// Joint stiffness (N m / rad).
    #[arg(long, default_value_t = 1e-4)]
    pub k: f64,
    /// Measure only these integrators (by name, e.g. `implicit_angular`, `xpbd`); all when not
    /// given.
    #[arg(long)]
    pub only: Vec<String>,
}

/// Throughput of one integrator.
struct Throughput {
    one_thread: f64,
    all_threads: f64,
    non_finite_steps: usize,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.skeletons >= 1, "--skeletons must be at least 1");
    anyhow::ensure!(
        args.batch_seconds.is_finite() && args.batch_seconds > 0.0,
        "--batch-seconds must be positive"
    );
    anyhow::ensure!(
        args.dt.is_finite() && args.dt > 0.0,
        "--dt must be positive and finite"
    );
    anyhow::ensure!(
        args.k.is_finite() && args.k > 0.0,
        "--k must be positive and finite"
    );
    let threads = rayon::current_num_threads();
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .context("building a one-thread pool")?;
    let env = strand_setup::environment();
    let methods = Method::all();
    for name in &args.only {
        anyhow::ensure!(
            methods.iter().any(|m| m.name() == name),
            "unknown integrator `{name}` (expected one of {})",
            methods
                .iter()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let chosen: Vec<Method> = methods
        .into_iter()
        .filter(|m| args.only.is_empty() || args.only.iter().any(|n| n == m.name()))
        .collect();
    let mut benches = Vec::new();
    // The coupled step twice: by its structured solve and by the dense LU it replaced (the peer).
    let variants = chosen.iter().flat_map(|&method| {
        let dense =
            (method == Method::Ours(Integrator::ImplicitCoupled)).then_some(LinearSolver::Hand);
        std::iter::once((method, LinearSolver::Structured))
            .chain(dense.map(|solver| (method, solver)))
    });
    for (method, solver) in variants {
        let settings = StepSettings {
            dt: args.dt as Real,
            integrator: Integrator::ImplicitCoupled,
            torque: TorqueModel::Chain,
            solver,
        };
        benches.push(Bench {
            label: label(method, solver),
            dt: args.dt as Real,
            stepper: Stepper::new(method, build(args.skeletons, args.k)?, settings),
            batch: 1,
            non_finite_steps: 0,
        });
    }
    let one_thread = single.install(|| measure_all(&args, &env, &mut benches))?;
    let all_threads = measure_all(&args, &env, &mut benches)?;
    let results: Vec<(String, Throughput)> = benches
        .iter()
        .zip(one_thread.iter().zip(&all_threads))
        .map(|(b, (&one_thread, &all_threads))| {
            (
                b.label.clone(),
                Throughput {
                    one_thread,
                    all_threads,
                    non_finite_steps: b.non_finite_steps,
                },
            )
        })
        .collect();
    let rate = |label: &str| {
        results
            .iter()
            .find(|(j, _)| j == label)
            .map(|(_, t)| (t.one_thread, t.all_threads))
    };
    let (ia, ee) = (
        rate(Integrator::ImplicitAngular.name()),
        rate(Integrator::ExplicitEuler.name()),
    );
    // Cost per step is the inverse of the throughput.
    let ratio = ia.zip(ee).map(|(a, e)| (e.0 / a.0, e.1 / a.1));
    // How many times faster the structured solve makes the coupled step than the dense LU.
    let speedup = rate(Integrator::ImplicitCoupled.name())
        .zip(rate(&label(
            Method::Ours(Integrator::ImplicitCoupled),
            LinearSolver::Hand,
        )))
        .map(|(s, d)| (s.0 / d.0, s.1 / d.1));

    // The second-order steps' cost per step over the first-order coupled step's (throughputs
    // inverted).
    let cost_over_coupled = |integrator: Integrator| {
        rate(Integrator::ImplicitCoupled.name())
            .zip(rate(integrator.name()))
            .map(|(c, b)| (c.0 / b.0, c.1 / b.1))
    };
    let bdf2_cost = cost_over_coupled(Integrator::ImplicitBdf2);
    let ros3_cost = cost_over_coupled(Integrator::ImplicitRos3);

    if args.json {
        let mut obj = Map::new();
        if let Some((r1, rn)) = bdf2_cost {
            obj.insert("implicit_bdf2_cost_over_implicit_coupled".into(), json!(r1));
            obj.insert(
                "implicit_bdf2_cost_over_implicit_coupled_all_threads".into(),
                json!(rn),
            );
        }
        if let Some((r1, rn)) = ros3_cost {
            obj.insert("implicit_ros3_cost_over_implicit_coupled".into(), json!(r1));
            obj.insert(
                "implicit_ros3_cost_over_implicit_coupled_all_threads".into(),
                json!(rn),
            );
        }
        for (i, t) in &results {
            obj.insert(
                i.clone(),
                json!({
                    "node_steps_per_s_1t": t.one_thread.round(),
                    "node_steps_per_s": t.all_threads.round(),
                    "non_finite_steps": t.non_finite_steps,
                }),
            );
        }
        if let Some((r1, rn)) = speedup {
            obj.insert("implicit_coupled_structured_over_dense".into(), json!(r1));
            obj.insert(
                "implicit_coupled_structured_over_dense_all_threads".into(),
                json!(rn),
            );
        }
        if let Some((r1, rn)) = ratio {
            obj.insert("implicit_angular_over_explicit_euler".into(), json!(r1));
            obj.insert(
                "implicit_angular_over_explicit_euler_all_threads".into(),
                json!(rn),
            );
        }
        obj.insert(
            "config".into(),
            json!({
                "skeletons": args.skeletons,
                "points": strand_setup::POINTS,
                "nodes": args.skeletons * strand_setup::POINTS,
                "threads": threads,
                "dt_s": args.dt,
                "k_n_m_per_rad": args.k,
                "torque": "chain",
                "node_step": "one node of one skeleton advanced by one step; root nodes count",
                "xpbd": "XpbdStrands::from_state of the same strands; one step = 5 substeps x 5 Gauss-Seidel iterations, inextensible, bend compliance 1/k, undamped",
                "timing": "after warm-up, four rounds each timing one batch of about batch_seconds of every integrator in turn; the fastest batch of each is kept",
            }),
        );
        println!(
            "{}",
            serde_json::to_string(&Value::Object(obj)).context("serialising the results")?
        );
    } else {
        println!(
            "{} skeletons x {} points, dt {} s, {} threads",
            args.skeletons,
            strand_setup::POINTS,
            args.dt,
            threads
        );
        println!(
            "{:>24} {:>16} {:>16}",
            "integrator", "1 thread (M/s)", "all threads (M/s)"
        );
        for (i, t) in &results {
            println!(
                "{:>24} {:>16.2} {:>16.2}",
                i,
                t.one_thread / 1e6,
                t.all_threads / 1e6
            );
        }
        if let Some((r1, rn)) = speedup {
            println!(
                "implicit_coupled, structured solve over dense LU: {r1:.2}x as fast (1 thread), {rn:.2}x (all threads)"
            );
        }
        if let Some((r1, rn)) = ratio {
            println!(
                "implicit_angular / explicit_euler cost per step: {r1:.2} (1 thread), {rn:.2} (all threads)"
            );
        }
    }
    Ok(())
}

/// `count` standard strands on a 1 cm grid, each released 60 degrees from straight down towards a
/// seeded azimuth.
fn build(count: usize, k: f64) -> anyhow::Result<StrandState> {
    let mut state = StrandState::new();
    let side = (count as f64).sqrt().ceil() as usize;
    // Seeded release directions.
    let mut rng = SplitMix::new(7);
    let tilt = strand_setup::RELEASE_DEG.to_radians();
    for s in 0..count {
        let root = Point::new((s % side) as Real * 0.01, 0.0, (s / side) as Real * 0.01);
        let azimuth = core::f32::consts::TAU * rng.unit();
        let dir = Vector::new(
            tilt.sin() * azimuth.cos(),
            -tilt.cos(),
            tilt.sin() * azimuth.sin(),
        );
        let frame = match Unit::try_new(Vector::z().cross(&dir), 1e-12) {
            Some(axis) => Rotation3::from_axis_angle(&axis, Vector::z().angle(&dir)),
            None => Rotation3::identity(),
        };
        strand_setup::add_standard_strand(
            &mut state,
            root,
            &frame,
            k as Real,
            Damping::Ratio(0.05),
        )?;
    }
    Ok(state)
}

/// One integrator's state and settings during the measurement.
struct Bench {
    label: String,
    dt: Real,
    stepper: Stepper,
    /// Steps per timed batch.
    batch: usize,
    non_finite_steps: usize,
}

/// A method's name, with the solver's where it is not the default.
fn label(method: Method, solver: LinearSolver) -> String {
    if solver == LinearSolver::default() || method == Method::Xpbd {
        method.name().to_string()
    } else {
        format!("{}_{}", method.name(), solver.name())
    }
}

impl Bench {
    fn step(&mut self, env: &Environment) -> anyhow::Result<()> {
        match self.stepper.step(env, self.dt) {
            Ok(()) => Ok(()),
            Err(DynamicsError::NonFiniteState { .. }) => {
                // The skeleton was restored; the step still cost a step.
                self.non_finite_steps += 1;
                Ok(())
            }
            Err(e) => Err(e).context("stepping the benchmark state"),
        }
    }
}

/// Rounds of timed batches: every round times one batch of every integrator in turn, so load
/// from other processes on the shared machine falls on all of them alike.
const ROUNDS: usize = 4;

/// Node-steps per second of every integrator in the current rayon pool: warm-up, then the
/// fastest batch of [`ROUNDS`] interleaved rounds.
fn measure_all(args: &Args, env: &Environment, benches: &mut [Bench]) -> anyhow::Result<Vec<f64>> {
    for b in benches.iter_mut() {
        // Warm-up: scratch buffers, caches, thread pool; and an estimate of the step's cost.
        let clock = Instant::now();
        let mut warm = 0u32;
        while warm < 2 || clock.elapsed().as_secs_f64() < 0.1 {
            b.step(env)?;
            warm += 1;
        }
        let per_step = clock.elapsed().as_secs_f64() / f64::from(warm);
        b.batch = ((args.batch_seconds / per_step).ceil() as usize).max(1);
    }
    let mut best = vec![f64::INFINITY; benches.len()];
    for _ in 0..ROUNDS {
        for (b, best) in benches.iter_mut().zip(best.iter_mut()) {
            let clock = Instant::now();
            for _ in 0..b.batch {
                b.step(env)?;
            }
            *best = best.min(clock.elapsed().as_secs_f64() / b.batch as f64);
        }
    }
    Ok(benches
        .iter()
        .zip(best)
        .map(|(b, t)| b.stepper.node_count() as f64 / t)
        .collect())
}
