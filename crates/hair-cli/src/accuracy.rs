//! `hair accuracy`: error against cost of every integrator, and the statics of the elastica.
//!
//! Dynamics: the standard strand ([`crate::strand_setup`]) released at 60 degrees is simulated for
//! 2 s by every integrator at time steps from 1/25 s to 1/3200 s, in f32; its tip is compared
//! every 1/25 s with an f64 RK4 reference at 1e-5 s (checked against the same at 2e-5 s). The
//! error is the RMS over those samples of the tip's distance to the reference tip; the cost is the
//! wall time of the f32 run in milliseconds per simulated second (one strand, one thread, best of
//! several repeats). The engines' XPBD ([`crate::xpbd_peer`]) runs the same strand beside them.
//!
//! Statics: a strand clamped horizontally and sagging under its own weight, relaxed to equilibrium
//! in f64 for the chain and the local torque models, and XPBD's rest state at 1/60 s steps, beside
//! the elastica's shooting solution.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use hair::dynamics::reference::{ReferenceScratch, ReferenceStrand, elastica_tip};
use hair::dynamics::{
    DynamicsError, Integrator, LinearSolver, Material, Point, Real, Root, SkeletonDesc,
    StepSettings, StrandState, Style, TorqueModel, Vector, style_points,
};
use nalgebra::{Rotation3, Vector3};
use plotters::prelude::*;
use rayon::prelude::*;
use serde::Serialize;

use crate::strand_setup::{self, Damping};
use crate::xpbd_peer::{self, Method, Stepper};

/// Arguments of `hair accuracy`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Write the results as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Draw error against cost (and against the time step, and the elastica) into this PNG.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// Joint stiffness of the strand (N m / rad, both angles of every joint).
    #[arg(long, default_value_t = 1e-3)]
    pub k: f64,
    /// Damping ratio of each joint's stiffest mode, as in `hair stability`.
    #[arg(long, default_value_t = 0.05)]
    pub damping_ratio: f64,
    /// Time step of the f64 RK4 reference (s); it is checked against twice this step.
    #[arg(long, default_value_t = 1e-5)]
    pub reference_dt: f64,
    /// Timed repeats of each f32 run (the fastest is kept).
    #[arg(long, default_value_t = 5)]
    pub repeat: usize,
    /// Only these time steps, as steps per second (multiples of 25); all eight when not given.
    #[arg(long)]
    pub steps_per_second: Vec<u32>,
    /// Only these segment counts in the elastica table; 8, 16, 32 and 64 when not given.
    #[arg(long)]
    pub segments: Vec<usize>,
}

/// Time steps of the study as steps per second: each divides the sampling interval.
const STEPS_PER_SECOND: [u32; 8] = [25, 50, 100, 200, 400, 800, 1600, 3200];
/// Samples of the tip per second (every 1/25 s).
const SAMPLES_PER_SECOND: u32 = 25;

/// One run of one integrator at one time step.
#[derive(Clone, Debug, Serialize)]
struct Run {
    dt: f64,
    /// RMS distance of the tip to the reference tip over the samples (m); `null` if the run went
    /// non-finite.
    rms_tip_error_m: Option<f64>,
    /// The same over the strand's length.
    rms_tip_error_over_l: Option<f64>,
    /// Largest tip distance at a sample (m).
    max_tip_error_m: Option<f64>,
    /// Wall time per simulated second (ms), one strand, one thread.
    cost_ms_per_sim_s: f64,
    /// Time at which the state went non-finite (s), if it did.
    non_finite_at: Option<f64>,
}

/// All runs of one integrator.
#[derive(Clone, Debug, Serialize)]
struct IntegratorRuns {
    name: &'static str,
    runs: Vec<Run>,
}

/// One static equilibrium of the clamped strand.
#[derive(Clone, Debug, Serialize)]
struct Elastica {
    alpha: f64,
    segments: usize,
    model: &'static str,
    tip_x_over_l: f64,
    tip_y_over_l: f64,
    reference_tip_x_over_l: f64,
    reference_tip_y_over_l: f64,
    /// Distance between the tip and the elastica's tip, over the length.
    tip_error_over_l: f64,
    /// Pseudo-transient Newton iterations over the whole load ramp; `null` if a stage did not
    /// converge.
    iterations: Option<usize>,
}

/// The JSON document.
#[derive(Debug, Serialize)]
struct Report {
    strand: serde_json::Value,
    reference: serde_json::Value,
    integrators: Vec<IntegratorRuns>,
    elastica_method: &'static str,
    elastica: Vec<Elastica>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.k.is_finite() && args.k > 0.0,
        "--k must be positive and finite"
    );
    anyhow::ensure!(
        args.damping_ratio.is_finite() && args.damping_ratio >= 0.0,
        "--damping-ratio must be finite and not negative"
    );
    anyhow::ensure!(
        args.reference_dt.is_finite() && args.reference_dt > 0.0 && args.reference_dt <= 1e-3,
        "--reference-dt must be in (0, 1e-3] s"
    );
    let damping = Damping::Ratio(args.damping_ratio as Real);
    anyhow::ensure!(
        args.steps_per_second
            .iter()
            .all(|s| *s >= SAMPLES_PER_SECOND && s % SAMPLES_PER_SECOND == 0),
        "--steps-per-second must be multiples of {SAMPLES_PER_SECOND}"
    );
    anyhow::ensure!(
        args.segments.iter().all(|s| (1..=1000).contains(s)),
        "--segments must be in 1..=1000"
    );
    let steps_per_second = if args.steps_per_second.is_empty() {
        STEPS_PER_SECOND.to_vec()
    } else {
        args.steps_per_second.clone()
    };
    let segments = if args.segments.is_empty() {
        SEGMENTS.to_vec()
    } else {
        args.segments.clone()
    };
    let started = Instant::now();

    // The elastica runs beside the reference trajectories (both are single-threaded jobs).
    let ((reference, check), elastica) = rayon::join(
        || {
            rayon::join(
                || reference_trajectory(args.k, damping, args.reference_dt),
                || reference_trajectory(args.k, damping, 2.0 * args.reference_dt),
            )
        },
        || elastica_table(&segments),
    );
    let (reference, check) = (reference?, check?);
    let elastica = elastica?;
    let convergence = rms_distance(&reference.samples(), &check.samples());
    println!(
        "reference: f64 RK4 at {:e} s; RMS tip difference to {:e} s: {convergence:.3e} m",
        args.reference_dt,
        2.0 * args.reference_dt
    );

    // Timed f32 runs, one at a time so they do not compete for the cores.
    let mut integrators = Vec::new();
    for method in Method::all() {
        let mut runs = Vec::new();
        for &sps in &steps_per_second {
            runs.push(timed_run(
                method,
                sps,
                args.k,
                damping,
                &reference,
                args.repeat.max(1),
            )?);
        }
        integrators.push(IntegratorRuns {
            name: method.name(),
            runs,
        });
    }

    print_tables(&integrators, &elastica, &steps_per_second);
    println!("accuracy study in {:.1} s", started.elapsed().as_secs_f64());

    if let Some(path) = &args.json {
        let report = Report {
            strand: serde_json::json!({
                "points": strand_setup::POINTS,
                "length_m": strand_setup::LENGTH,
                "linear_density_kg_per_m": strand_setup::LINEAR_DENSITY,
                "release_deg_from_down": strand_setup::RELEASE_DEG,
                "k_n_m_per_rad": args.k,
                "damping": format!(
                    "per joint gamma = 2 * {} * sqrt((k + M g d) * m * d^2), M the mass beyond the joint",
                    args.damping_ratio
                ),
                "torque": "chain",
                "duration_s": strand_setup::DURATION,
                "samples": "tip position every 1/25 s, t = 0.04 .. 2 s",
                "cost": "wall time of one strand on one thread, best of repeats, ms per simulated second",
                "xpbd": "the same strand as XPBD particles (XpbdStrands::from_state): 5 substeps x 5 Gauss-Seidel iterations per step, inextensible, bend compliance 1/k, no damping (the joint damping has no XPBD counterpart)",
            }),
            reference: serde_json::json!({
                "integrator": "rk4",
                "precision": "f64",
                "dt_s": args.reference_dt,
                "rms_tip_difference_to_double_dt_m": convergence,
            }),
            integrators: integrators.clone(),
            elastica_method: "strand of n segments (n + 1 points, trapezoid-lumped masses, 2 EI/d on the root joint and EI/d elsewhere) clamped along +x, gravity -y, EI = rho g L^3 / alpha, rho = 0.02 kg/m, L = 0.25 m; static equilibrium in f64 by ReferenceStrand::relax (pseudo-transient Newton on the coupled implicit step, tolerance 1e-12 rad) with the load ramped through alpha = 1, 2, 5, 10, 20, 50, 100 (relaxing straight to alpha = 100 diverges); model xpbd: the same strand as XPBD particles at 1/60 s steps of 5 substeps x 5 iterations, damped at 20/s until the tip moved under 1e-6 L in each of 30 steps in a row (iterations = those steps; null: not at rest after 60 s); reference: elastica_tip (shooting); y downward",
            elastica: elastica.clone(),
        };
        strand_setup::write_json(path, &report)?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.png {
        draw(path, &integrators, &elastica, args.k)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// The tip of the f64 RK4 reference at every one of its steps, with its velocity, so it can be
/// read at any time by cubic Hermite interpolation (the f32 runs' steps are stored in f32, so
/// their sample times are off the nominal ones by up to about 1e-7 s).
struct Trajectory {
    step: f64,
    position: Vec<Vector3<f64>>,
    velocity: Vec<Vector3<f64>>,
}

impl Trajectory {
    /// The tip at time `t` (s), clamped to the simulated interval.
    fn at(&self, t: f64) -> Vector3<f64> {
        let last = self.position.len() - 1;
        let x = (t / self.step).clamp(0.0, last as f64);
        let i = (x.floor() as usize).min(last.saturating_sub(1));
        let u = x - i as f64;
        let (p0, p1) = (self.position[i], self.position[i + 1]);
        let (m0, m1) = (
            self.velocity[i] * self.step,
            self.velocity[i + 1] * self.step,
        );
        let (u2, u3) = (u * u, u * u * u);
        p0 * (2.0 * u3 - 3.0 * u2 + 1.0)
            + m0 * (u3 - 2.0 * u2 + u)
            + p1 * (-2.0 * u3 + 3.0 * u2)
            + m1 * (u3 - u2)
    }

    /// The tip at the nominal sample times.
    fn samples(&self) -> Vec<Vector3<f64>> {
        sample_times().map(|t| self.at(t)).collect()
    }
}

/// Nominal sample times: every 1/25 s up to the end of the run.
fn sample_times() -> impl Iterator<Item = f64> {
    let count = (strand_setup::DURATION * f64::from(SAMPLES_PER_SECOND)).round() as u32;
    (1..=count).map(|i| f64::from(i) / f64::from(SAMPLES_PER_SECOND))
}

/// The f64 RK4 reference trajectory of the standard strand's tip.
fn reference_trajectory(k: f64, damping: Damping, dt: f64) -> anyhow::Result<Trajectory> {
    let (state, id) = strand_setup::single_strand(k as Real, damping)?;
    let env = strand_setup::environment();
    let mut strand = ReferenceStrand::from_state(&state, id);
    let mut scratch = ReferenceScratch::default();
    let settings = StepSettings {
        dt: dt as Real,
        integrator: Integrator::Rk4,
        torque: TorqueModel::Chain,
        solver: LinearSolver::Structured,
    };
    // The step is stored in f32: time advances by the f32 value actually used.
    let step = f64::from(settings.dt);
    let steps = (strand_setup::DURATION / step).ceil() as usize + 1;
    let mut position = Vec::with_capacity(steps + 1);
    let mut velocity = Vec::with_capacity(steps + 1);
    let mut record = |strand: &ReferenceStrand, scratch: &mut ReferenceScratch| {
        let p = strand.positions();
        let v = strand.velocities(scratch);
        position.push(p[p.len() - 1]);
        velocity.push(v[v.len() - 1]);
    };
    record(&strand, &mut scratch);
    for s in 0..steps {
        anyhow::ensure!(
            strand.step(&env, &settings, &mut scratch),
            "the f64 reference went non-finite at t = {} s",
            s as f64 * step
        );
        record(&strand, &mut scratch);
    }
    Ok(Trajectory {
        step,
        position,
        velocity,
    })
}

fn rms_distance(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(x, y)| (x - y).norm_squared()).sum();
    (sum / a.len().max(1) as f64).sqrt()
}

/// One f32 run of the standard strand, timed; errors against the reference tips.
fn timed_run(
    method: Method,
    steps_per_second: u32,
    k: f64,
    damping: Damping,
    reference: &Trajectory,
    repeat: usize,
) -> anyhow::Result<Run> {
    let env = strand_setup::environment();
    let dt = 1.0 / f64::from(steps_per_second);
    let settings = StepSettings {
        dt: dt as Real,
        integrator: Integrator::ImplicitCoupled,
        torque: TorqueModel::Chain,
        solver: LinearSolver::Structured,
    };
    let per_sample = steps_per_second / SAMPLES_PER_SECOND;
    let samples = sample_times().count();
    let mut best = f64::INFINITY;
    let mut tips = Vec::with_capacity(samples);
    let mut expected = Vec::with_capacity(samples);
    let mut non_finite_at = None;
    for _ in 0..repeat {
        let (state, id) = strand_setup::single_strand(k as Real, damping)?;
        let tip = state.nodes(id).end - 1;
        let mut stepper = Stepper::new(method, state, settings);
        tips.clear();
        expected.clear();
        non_finite_at = None;
        let clock = Instant::now();
        'run: for sample in 0..samples {
            for s in 0..per_sample {
                match stepper.step(&env, settings.dt) {
                    Ok(()) => {}
                    Err(DynamicsError::NonFiniteState { .. }) => {
                        let steps = sample as u32 * per_sample + s + 1;
                        non_finite_at = Some(f64::from(steps) * dt);
                        break 'run;
                    }
                    Err(e) => {
                        return Err(e).with_context(|| format!("{} dt={dt}", method.name()));
                    }
                }
            }
            tips.push(stepper.position(tip));
            // The time actually simulated: whole steps of the f32 step.
            let steps = f64::from((sample as u32 + 1) * per_sample);
            expected.push(reference.at(steps * f64::from(settings.dt)));
        }
        best = best.min(clock.elapsed().as_secs_f64());
        if non_finite_at.is_some() {
            break;
        }
    }
    let finite = non_finite_at.is_none() && tips.iter().all(|t| t.iter().all(|c| c.is_finite()));
    let (rms, max) = if finite {
        let max = tips
            .iter()
            .zip(&expected)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        (Some(rms_distance(&tips, &expected)), Some(max))
    } else {
        (None, None)
    };
    let simulated = match non_finite_at {
        Some(t) => t,
        None => strand_setup::DURATION,
    };
    Ok(Run {
        dt,
        rms_tip_error_m: rms,
        rms_tip_error_over_l: rms.map(|e| e / f64::from(strand_setup::LENGTH)),
        max_tip_error_m: max,
        cost_ms_per_sim_s: 1e3 * best / simulated,
        non_finite_at,
    })
}

/// `alpha = q L^3 / EI` of the elastica table.
const ALPHAS: [f64; 3] = [1.0, 10.0, 100.0];
/// Segment counts of the elastica table.
const SEGMENTS: [usize; 4] = [8, 16, 32, 64];

/// Every (alpha, segments, model) equilibrium, in parallel; `None` is XPBD.
fn elastica_table(segments: &[usize]) -> anyhow::Result<Vec<Elastica>> {
    let mut jobs = Vec::new();
    for alpha in ALPHAS {
        for &segments in segments {
            for model in [Some(TorqueModel::Chain), Some(TorqueModel::Local), None] {
                jobs.push((alpha, segments, model));
            }
        }
    }
    jobs.par_iter()
        .map(|&(a, s, m)| match m {
            Some(m) => elastica(a, s, m),
            None => xpbd_elastica(a, s),
        })
        .collect()
}

/// XPBD's rest state of the clamped strand ([`xpbd_peer::settle`] at 1/60 s, up to 60 s).
fn xpbd_elastica(alpha: f64, segments: usize) -> anyhow::Result<Elastica> {
    let length = f64::from(strand_setup::LENGTH);
    let (state, _) = clamped_strand(alpha, segments)?;
    let env = strand_setup::environment();
    let (tip, steps) = xpbd_peer::settle(&state, &env, 1.0 / 60.0, 3600, 1e-6 * length)
        .with_context(|| format!("xpbd cantilever alpha {alpha}, {segments} segments"))?;
    let (rx, ry) = elastica_tip(alpha);
    let (x, y) = (tip.x / length, -tip.y / length);
    Ok(Elastica {
        alpha,
        segments,
        model: xpbd_peer::NAME,
        tip_x_over_l: x,
        tip_y_over_l: y,
        reference_tip_x_over_l: rx,
        reference_tip_y_over_l: ry,
        tip_error_over_l: (x - rx).hypot(y - ry),
        iterations: steps,
    })
}

/// A strand of `segments` segments clamped along +x at the origin, gravity -y, relaxed to rest.
///
/// [`ReferenceStrand::relax`] started from the straight strand diverges at alpha = 100 (its
/// pseudo-time step grows without a check on the residual), so the load is ramped: the strand is
/// relaxed at alpha = 1, 2, 5, 10, ... up to `alpha`, each stage starting from the previous
/// equilibrium (carried through the f32 state's angles; the f64 relaxation then converges from
/// there to its own tolerance).
fn elastica(alpha: f64, segments: usize, model: TorqueModel) -> anyhow::Result<Elastica> {
    let length = f64::from(strand_setup::LENGTH);
    let env = strand_setup::environment();
    let mut stages: Vec<f64> = [1.0, 2.0, 5.0]
        .iter()
        .flat_map(|m| (0..6).map(move |e| m * 10f64.powi(e)))
        .filter(|a| *a < alpha)
        .collect();
    stages.sort_by(f64::total_cmp);
    stages.push(alpha);
    let mut previous: Option<Vec<f64>> = None;
    let mut iterations = Some(0);
    let mut tip = Vector3::zeros();
    for stage in stages {
        let (mut state, id) = clamped_strand(stage, segments)?;
        if let Some(q) = &previous {
            let range = state.nodes(id);
            for (j, i) in (range.start + 1..range.end).enumerate() {
                state.theta_mut()[i] = q[2 * j] as Real;
                state.phi_mut()[i] = q[2 * j + 1] as Real;
            }
        }
        let mut strand = ReferenceStrand::from_state(&state, id);
        let mut scratch = ReferenceScratch::default();
        let settings = StepSettings {
            dt: 0.1,
            integrator: Integrator::ImplicitCoupled,
            torque: model,
            solver: LinearSolver::Structured,
        };
        let used = strand.relax(&env, &settings, 500, 1e-12, &mut scratch);
        iterations = iterations.zip(used).map(|(a, b)| a + b);
        let p = strand.positions();
        tip = p[p.len() - 1];
        anyhow::ensure!(
            tip.iter().all(|c| c.is_finite()) && strand.coordinates().iter().all(|c| c.is_finite()),
            "the clamped strand (alpha {stage}, {segments} segments, {}) went non-finite",
            model.name()
        );
        previous = Some(strand.coordinates().to_vec());
    }
    let (rx, ry) = elastica_tip(alpha);
    let (x, y) = (tip.x / length, -tip.y / length);
    Ok(Elastica {
        alpha,
        segments,
        model: model.name(),
        tip_x_over_l: x,
        tip_y_over_l: y,
        reference_tip_x_over_l: rx,
        reference_tip_y_over_l: ry,
        tip_error_over_l: (x - rx).hypot(y - ry),
        iterations,
    })
}

/// A straight strand of `segments` segments clamped along +x with `EI = rho g L^3 / alpha`.
fn clamped_strand(
    alpha: f64,
    segments: usize,
) -> anyhow::Result<(StrandState, hair::dynamics::SkeletonId)> {
    let length = f64::from(strand_setup::LENGTH);
    let rho = f64::from(strand_setup::LINEAR_DENSITY);
    let g = f64::from(strand_setup::GRAVITY);
    let frame = Rotation3::from_axis_angle(&Vector::y_axis(), core::f32::consts::FRAC_PI_2);
    let points = style_points(
        Point::origin(),
        &frame,
        &Style::Straight,
        segments + 1,
        length as Real,
    )
    .context("building the clamped strand")?;
    let mut state = StrandState::new();
    let id = state
        .add_skeleton(&SkeletonDesc {
            root: Root::Attached {
                position: Point::origin(),
                frame,
            },
            points,
            material: Material {
                linear_density: rho as Real,
                bending_stiffness: (rho * g * length.powi(3) / alpha) as Real,
                tip_stiffness_ratio: 1.0,
                damping: 0.0,
                tip_damping_ratio: 1.0,
                ..Material::default()
            },
        })
        .context("adding the clamped strand")?;
    Ok((state, id))
}

fn print_tables(integrators: &[IntegratorRuns], elastica: &[Elastica], steps_per_second: &[u32]) {
    println!("\nRMS tip error (m) / cost (ms per simulated second)");
    print!("{:>18}", "dt (s)");
    for sps in steps_per_second {
        print!(" {:>17}", format!("1/{sps}"));
    }
    println!();
    for i in integrators {
        print!("{:>18}", i.name);
        for r in &i.runs {
            let e = r
                .rms_tip_error_m
                .map_or("blew up".to_string(), |e| format!("{e:.2e}"));
            print!(" {:>17}", format!("{e}/{:.2}", r.cost_ms_per_sim_s));
        }
        println!();
    }
    println!("\nelastica: tip (x/L, y/L) of the clamped strand against the shooting solution");
    println!(
        "{:>6} {:>4} {:>6} {:>9} {:>9} {:>9} {:>9} {:>10} {:>5}",
        "alpha", "seg", "model", "x/L", "y/L", "ref x/L", "ref y/L", "err/L", "iters"
    );
    for e in elastica {
        println!(
            "{:>6} {:>4} {:>6} {:>9.5} {:>9.5} {:>9.5} {:>9.5} {:>10.2e} {:>5}",
            e.alpha,
            e.segments,
            e.model,
            e.tip_x_over_l,
            e.tip_y_over_l,
            e.reference_tip_x_over_l,
            e.reference_tip_y_over_l,
            e.tip_error_over_l,
            e.iterations.map_or("no".to_string(), |i| i.to_string())
        );
    }
}

/// Distinct colours of the methods, in [`Method::all`] order (XPBD last, in black).
const COLOURS: [RGBColor; 9] = [
    RGBColor(214, 39, 40),
    RGBColor(255, 127, 14),
    RGBColor(31, 119, 180),
    RGBColor(148, 103, 189),
    RGBColor(44, 160, 44),
    RGBColor(140, 86, 75),
    RGBColor(23, 190, 207),
    RGBColor(227, 119, 194),
    RGBColor(0, 0, 0),
];

fn err(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("{e}")
}

/// Bounds of the positive values `v` widened to whole decades.
fn decades(v: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = v
        .filter(|x| x.is_finite() && *x > 0.0)
        .fold((f64::MAX, f64::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)));
    if lo > hi {
        return 1e-3..1.0;
    }
    10f64.powf(lo.log10().floor())..10f64.powf(hi.log10().ceil().max(lo.log10().floor() + 1.0))
}

/// Three panels: error against cost, error against time step, elastica tip error.
fn draw(
    path: &Path,
    integrators: &[IntegratorRuns],
    elastica: &[Elastica],
    k: f64,
) -> anyhow::Result<()> {
    crate::chart::register_font();
    strand_setup::create_parent(path)?;
    let root = BitMapBackend::new(path, (1800, 650)).into_drawing_area();
    root.fill(&WHITE).map_err(err)?;
    let panels = root.split_evenly((1, 3));
    let points = |r: &Run, x: f64| r.rms_tip_error_m.map(|e| (x, e));
    let y_range = decades(
        integrators
            .iter()
            .flat_map(|i| i.runs.iter().filter_map(|r| r.rms_tip_error_m)),
    );

    // Error against cost, and against the time step.
    for (panel, by_cost) in [(&panels[0], true), (&panels[1], false)] {
        let x_range = if by_cost {
            decades(
                integrators
                    .iter()
                    .flat_map(|i| i.runs.iter().map(|r| r.cost_ms_per_sim_s)),
            )
        } else {
            decades(integrators.iter().flat_map(|i| i.runs.iter().map(|r| r.dt)))
        };
        let caption = if by_cost {
            format!("RMS tip error vs cost (2 s, k = {k:.0e} N m/rad, f64 RK4 ref.)")
        } else {
            "RMS tip error vs time step".to_string()
        };
        let mut chart = ChartBuilder::on(panel)
            .caption(caption, ("sans-serif", 20))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x_range.log_scale(), y_range.clone().log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(if by_cost {
                "cost (ms per simulated second, one strand)"
            } else {
                "dt (s)"
            })
            .y_desc("RMS tip error (m)")
            .label_style(("sans-serif", 14))
            .x_label_formatter(&|v| format!("{v:.0e}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(err)?;
        for (i, colour) in integrators.iter().zip(COLOURS) {
            let xy: Vec<(f64, f64)> = i
                .runs
                .iter()
                .filter_map(|r| points(r, if by_cost { r.cost_ms_per_sim_s } else { r.dt }))
                .collect();
            chart
                .draw_series(LineSeries::new(xy.clone(), colour.stroke_width(2)))
                .map_err(err)?
                .label(i.name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(xy.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .position(if by_cost {
                SeriesLabelPosition::UpperRight
            } else {
                SeriesLabelPosition::LowerRight
            })
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 14))
            .draw()
            .map_err(err)?;
    }

    // Elastica: tip error over length against segments, per alpha and model.
    let e_range = decades(elastica.iter().map(|e| e.tip_error_over_l.max(1e-8)));
    let mut chart = ChartBuilder::on(&panels[2])
        .caption(
            "Cantilever under self-weight: tip error / L (xpbd: triangles)",
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((6.0f64..80.0).log_scale(), e_range.log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("segments")
        .y_desc("|tip - elastica tip| / L")
        .label_style(("sans-serif", 14))
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(err)?;
    let alpha_colours = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
    ];
    for (alpha, colour) in ALPHAS.iter().zip(alpha_colours) {
        for model in ["chain", "local", xpbd_peer::NAME] {
            let xy: Vec<(f64, f64)> = elastica
                .iter()
                .filter(|e| e.alpha == *alpha && e.model == model)
                .map(|e| (e.segments as f64, e.tip_error_over_l.max(1e-8)))
                .collect();
            let style = match model {
                "chain" => colour.stroke_width(2),
                "local" => colour.mix(0.5).stroke_width(1),
                _ => colour.mix(0.8).stroke_width(3),
            };
            chart
                .draw_series(LineSeries::new(xy.clone(), style))
                .map_err(err)?
                .label(format!("alpha {alpha}, {model}"))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
            if model == xpbd_peer::NAME {
                chart
                    .draw_series(
                        xy.iter()
                            .map(|&p| TriangleMarker::new(p, 6, colour.filled())),
                    )
                    .map_err(err)?;
            } else {
                chart
                    .draw_series(xy.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                    .map_err(err)?;
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(err)?;
    root.present()
        .map_err(err)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
