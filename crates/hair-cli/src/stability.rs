//! `hair stability`: stability map of every integrator over joint stiffness x time step.
//!
//! Each cell simulates the standard strand ([`crate::strand_setup`]: 20 points, 25 cm, released at
//! 60 degrees, light damping) for 2 s. A cell is stable when every value stays finite and the
//! motion does not grow: the peak node speed in the last second is no higher than in the first,
//! and never above 50 m/s. The engines' XPBD ([`crate::xpbd_peer`]) runs the same strand and
//! cells beside our integrators.

use std::path::PathBuf;

use anyhow::Context as _;
use hair::dynamics::{DynamicsError, Integrator, LinearSolver, Real, StepSettings, TorqueModel};

use crate::xpbd_peer::{Method, Stepper};
use plotters::prelude::*;
use rayon::prelude::*;
use serde::Serialize;

use crate::strand_setup::{self, Damping};

/// Arguments of `hair stability`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Write the map as JSON to this file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Draw one stability map per integrator into this PNG.
    #[arg(long)]
    pub png: Option<PathBuf>,
    /// log10 of the softest joint stiffness (N m / rad); the sweep spans 6 decades from it.
    #[arg(long, default_value_t = -6.0, allow_negative_numbers = true)]
    pub k_min_log10: f64,
    /// Stiffness values per decade.
    #[arg(long, default_value_t = 3)]
    pub k_per_decade: usize,
    /// Decades of stiffness the sweep spans.
    #[arg(long, default_value_t = 6)]
    pub decades: usize,
    /// Damping ratio of each joint's stiffest mode, spring and gravity together:
    /// `gamma = 2 zeta sqrt((k + M g d) m d^2)`, `M` the mass beyond the joint.
    #[arg(long, default_value_t = 0.05)]
    pub damping_ratio: f64,
    /// The same damping on every joint instead (N m s / rad).
    #[arg(long)]
    pub damping_fixed: Option<f64>,
}

/// Time steps of the sweep, as steps per second: 1/1000 s to 1/10 s in about fifth-decade steps,
/// each dividing one second so both halves of the run have a whole number of steps.
const STEPS_PER_SECOND: [u32; 11] = [1000, 600, 400, 250, 160, 100, 60, 40, 25, 16, 10];

/// Speed above which a run counts as unstable (m/s).
const SPEED_LIMIT: f64 = 50.0;

/// One cell of the map.
#[derive(Clone, Debug, Serialize)]
pub struct Cell {
    /// Joint stiffness (N m / rad), on both angles of every joint.
    pub k: f64,
    /// Time step (s).
    pub dt: f64,
    /// Finite, not growing, and below the speed limit.
    pub stable: bool,
    /// Peak node speed in the last second over the peak in the first; `null` when the run went
    /// non-finite.
    pub peak_speed_ratio: Option<f64>,
    /// Peak node speed over the whole run (m/s), up to the blow-up if there was one.
    pub peak_speed: f64,
    /// Time at which the state went non-finite (s), if it did.
    pub non_finite_at: Option<f64>,
    /// Largest rise of the model energy ([`StrandState::model_energy`]: kinetic with the model's
    /// inertia, springs, gravity) above its value at release, over the strand's weight times its
    /// length. The damped model only loses energy, so a positive value is energy the integrator
    /// made up.
    ///
    /// [`StrandState::model_energy`]: hair::dynamics::StrandState::model_energy
    pub energy_gain: f64,
    /// Whether `energy_gain` exceeds [`ENERGY_TOLERANCE`].
    pub energy_grew: bool,
}

/// Energy rise (over weight x length) above which a run counts as gaining energy: a fifth of the
/// energy the release makes available (a rigid 60 degree swing down frees `M g L / 4`).
pub const ENERGY_TOLERANCE: f64 = 0.05;

/// All cells of one integrator.
#[derive(Clone, Debug, Serialize)]
pub struct IntegratorMap {
    /// Integrator name (`explicit_euler`, ..., `implicit_ros3`, `implicit_bdf2`, `xpbd`).
    pub name: &'static str,
    /// How many cells are stable.
    pub stable_cells: usize,
    /// How many cells stayed finite but made up energy (`energy_grew`).
    pub energy_gaining_cells: usize,
    /// Every cell, stiffness-major.
    pub cells: Vec<Cell>,
}

/// The JSON document.
#[derive(Debug, Serialize)]
struct Report {
    strand: serde_json::Value,
    sweep: serde_json::Value,
    criterion: &'static str,
    integrators: Vec<IntegratorMap>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(args.k_per_decade >= 1, "--k-per-decade must be at least 1");
    anyhow::ensure!(
        args.damping_ratio.is_finite() && args.damping_ratio >= 0.0,
        "--damping-ratio must be finite and not negative"
    );
    anyhow::ensure!(args.k_min_log10.is_finite(), "--k-min-log10 must be finite");
    let ks = strand_setup::log_space(
        args.k_min_log10,
        args.k_min_log10 + args.decades as f64,
        args.decades * args.k_per_decade + 1,
    );
    let damping = match args.damping_fixed {
        Some(g) => Damping::Fixed(g as Real),
        None => Damping::Ratio(args.damping_ratio as Real),
    };
    let started = std::time::Instant::now();
    let maps = sweep(&ks, damping)?;
    let seconds = started.elapsed().as_secs_f64();

    for m in &maps {
        println!(
            "{:>18}: {:>3} of {} cells stable; {:>3} stayed finite but gained energy",
            m.name,
            m.stable_cells,
            m.cells.len(),
            m.energy_gaining_cells
        );
    }
    println!(
        "{} cells in {seconds:.1} s",
        maps.iter().map(|m| m.cells.len()).sum::<usize>()
    );

    if let Some(path) = &args.json {
        let report = Report {
            strand: serde_json::json!({
                "points": strand_setup::POINTS,
                "length_m": strand_setup::LENGTH,
                "linear_density_kg_per_m": strand_setup::LINEAR_DENSITY,
                "release_deg_from_down": strand_setup::RELEASE_DEG,
                "rest_angles": "zero (straight along the root direction)",
                "duration_s": strand_setup::DURATION,
                "gravity_m_per_s2": [0.0, -9.81, 0.0],
                "torque": "chain",
                "damping": match damping {
                    Damping::Fixed(g) => format!("{g:e} N m s/rad on every joint"),
                    Damping::Ratio(z) => format!(
                        "per joint gamma = 2 * {z} * sqrt((k + M g d) * m * d^2): damping ratio {z} of each joint's stiffest mode, M the mass beyond the joint, m its node's mass, d the segment length"
                    ),
                },
            }),
            sweep: serde_json::json!({
                "k_n_m_per_rad": ks,
                "k_note": "the same k on theta and phi of every joint, root joint included",
                "dt_s": STEPS_PER_SECOND.iter().map(|s| 1.0 / f64::from(*s)).collect::<Vec<_>>(),
            }),
            criterion: "stable = every value finite, peak node speed in the last second <= peak in the first second, and never above 50 m/s; energy_grew (a diagnostic beside it) = the model energy rose more than 0.05 M g L above its value at release",
            integrators: maps.clone(),
        };
        strand_setup::write_json(path, &report)?;
        println!("wrote {}", path.display());
    }
    if let Some(path) = &args.png {
        let note = match damping {
            Damping::Fixed(g) => format!("damping: {g:e} N m s/rad on every joint"),
            Damping::Ratio(z) => format!(
                "damping: {:.0} % of each joint's stiffest mode (spring + gravity)",
                100.0 * z
            ),
        };
        draw(path, &maps, &ks, &note)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Simulates every cell of every method (our integrators and XPBD), in parallel over cells.
pub fn sweep(ks: &[f64], damping: Damping) -> anyhow::Result<Vec<IntegratorMap>> {
    let methods = Method::all();
    let jobs: Vec<(Method, f64, u32)> = methods
        .iter()
        .flat_map(|&m| {
            ks.iter()
                .flat_map(move |&k| STEPS_PER_SECOND.iter().map(move |&s| (m, k, s)))
        })
        .collect();
    let cells: Vec<Cell> = jobs
        .par_iter()
        .map(|&(m, k, sps)| run_cell(m, k, sps, damping))
        .collect::<anyhow::Result<_>>()?;
    let per = ks.len() * STEPS_PER_SECOND.len();
    Ok(methods
        .iter()
        .zip(cells.chunks(per))
        .map(|(method, chunk)| IntegratorMap {
            name: method.name(),
            stable_cells: chunk.iter().filter(|c| c.stable).count(),
            energy_gaining_cells: chunk
                .iter()
                .filter(|c| c.energy_grew && c.non_finite_at.is_none())
                .count(),
            cells: chunk.to_vec(),
        })
        .collect())
}

/// One 2 s run of the standard strand.
fn run_cell(
    method: Method,
    k: f64,
    steps_per_second: u32,
    damping: Damping,
) -> anyhow::Result<Cell> {
    let (state, _) = strand_setup::single_strand(k as Real, damping)?;
    let env = strand_setup::environment();
    let dt = 1.0 / f64::from(steps_per_second);
    let settings = StepSettings {
        dt: dt as Real,
        integrator: Integrator::ImplicitCoupled,
        torque: TorqueModel::Chain,
        solver: LinearSolver::Structured,
    };
    let mut stepper = Stepper::new(method, state, settings);
    let steps = (strand_setup::DURATION * f64::from(steps_per_second)).round() as u32;
    let (mut first, mut last, mut peak) = (0.0f64, 0.0f64, 0.0f64);
    let energy0 = stepper.energy(&env);
    let mut energy_max = energy0;
    let weight_length = f64::from(strand_setup::LINEAR_DENSITY * strand_setup::LENGTH)
        * f64::from(strand_setup::GRAVITY)
        * f64::from(strand_setup::LENGTH);
    let mut non_finite_at = None;
    for s in 0..steps {
        match stepper.step(&env, dt as Real) {
            Ok(()) => {}
            Err(DynamicsError::NonFiniteState { .. }) => {
                non_finite_at = Some(f64::from(s + 1) * dt);
                break;
            }
            Err(e) => {
                return Err(e)
                    .with_context(|| format!("{} k={k} dt={dt}: step {s}", method.name()));
            }
        }
        let (speed, finite) = stepper.peak_speed();
        if !finite {
            non_finite_at = Some(f64::from(s + 1) * dt);
            break;
        }
        peak = peak.max(speed);
        let energy = stepper.energy(&env);
        if energy.is_finite() {
            energy_max = energy_max.max(energy);
        }
        if s < steps_per_second {
            first = first.max(speed);
        } else {
            last = last.max(speed);
        }
    }
    let ratio = non_finite_at.is_none().then(|| {
        if first > 0.0 {
            last / first
        } else {
            f64::INFINITY
        }
    });
    let stable = non_finite_at.is_none() && peak <= SPEED_LIMIT && last <= first;
    Ok(Cell {
        k,
        dt,
        stable,
        peak_speed_ratio: ratio.filter(|r| r.is_finite()),
        peak_speed: peak,
        non_finite_at,
        energy_gain: (energy_max - energy0) / weight_length,
        energy_grew: (energy_max - energy0) / weight_length > ENERGY_TOLERANCE,
    })
}

/// Colour of a cell: greens for stable (darker when the motion decays more), orange for growing
/// or too-fast motion that stayed finite, dark red for runs that went non-finite.
fn cell_colour(c: &Cell) -> RGBColor {
    if c.stable {
        let r = c.peak_speed_ratio.unwrap_or(1.0).clamp(0.0, 1.0);
        // ratio 1 (undamped-looking) light green, ratio 0 (fully decayed) dark green.
        let t = r.powf(0.5);
        RGBColor(
            (40.0 + 110.0 * t) as u8,
            (110.0 + 100.0 * t) as u8,
            (40.0 + 110.0 * t) as u8,
        )
    } else if c.non_finite_at.is_some() {
        RGBColor(150, 20, 20)
    } else {
        RGBColor(235, 120, 40)
    }
}

/// One heat map per integrator, in a 3 x 4 grid, the panel after the last map holding the legend.
fn draw(
    path: &std::path::Path,
    maps: &[IntegratorMap],
    ks: &[f64],
    damping_note: &str,
) -> anyhow::Result<()> {
    crate::chart::register_font();
    strand_setup::create_parent(path)?;
    let root = BitMapBackend::new(path, (2000, 1450)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow::anyhow!("{e}"))?;
    let (title, body) = root.split_vertically(50);
    title
        .titled(
            "Stability: 20-point 25 cm strand released at 60°, 2 s, chain torque",
            ("sans-serif", 26),
        )
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let panels = body.split_evenly((3, 4));
    let dts: Vec<f64> = STEPS_PER_SECOND
        .iter()
        .map(|s| 1.0 / f64::from(*s))
        .collect();
    let edges = |v: &[f64]| -> Vec<(f64, f64)> {
        let l: Vec<f64> = v.iter().map(|x| x.log10()).collect();
        if l.len() == 1 {
            // A single row or column: a decade wide around it.
            return vec![(l[0] - 0.5, l[0] + 0.5)];
        }
        (0..l.len())
            .map(|i| {
                let lo = if i == 0 {
                    l[0] - 0.5 * (l[1] - l[0])
                } else {
                    0.5 * (l[i - 1] + l[i])
                };
                let hi = if i + 1 == l.len() {
                    l[i] + 0.5 * (l[i] - l[i - 1])
                } else {
                    0.5 * (l[i] + l[i + 1])
                };
                (lo.min(hi), lo.max(hi))
            })
            .collect()
    };
    let dt_edges = edges(&dts);
    let k_edges = edges(ks);
    let x_range = dt_edges.iter().map(|e| e.0).fold(f64::MAX, f64::min)
        ..dt_edges.iter().map(|e| e.1).fold(f64::MIN, f64::max);
    let y_range = k_edges.iter().map(|e| e.0).fold(f64::MAX, f64::min)
        ..k_edges.iter().map(|e| e.1).fold(f64::MIN, f64::max);
    for (map, panel) in maps.iter().zip(panels.iter()) {
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!(
                    "{}: {}/{} stable, {} gain energy",
                    map.name,
                    map.stable_cells,
                    map.cells.len(),
                    map.energy_gaining_cells
                ),
                ("sans-serif", 19),
            )
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(50)
            .build_cartesian_2d(x_range.clone(), y_range.clone())
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("log10 dt (s)")
            .y_desc("log10 k (N m/rad)")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        chart
            .draw_series(map.cells.iter().map(|c| {
                let ix = dts
                    .iter()
                    .position(|d| (d - c.dt).abs() < 1e-12)
                    .unwrap_or(0);
                let iy = ks
                    .iter()
                    .position(|k| (k - c.k).abs() <= 1e-9 * k.abs())
                    .unwrap_or(0);
                let (x0, x1) = dt_edges[ix];
                let (y0, y1) = k_edges[iy];
                Rectangle::new([(x0, y0), (x1, y1)], cell_colour(c).filled())
            }))
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        // A cross on every finite cell whose model energy rose: energy the integrator made up.
        chart
            .draw_series(
                map.cells
                    .iter()
                    .filter(|c| c.energy_grew && c.non_finite_at.is_none())
                    .flat_map(|c| {
                        let ix = dts
                            .iter()
                            .position(|d| (d - c.dt).abs() < 1e-12)
                            .unwrap_or(0);
                        let iy = ks
                            .iter()
                            .position(|k| (k - c.k).abs() <= 1e-9 * k.abs())
                            .unwrap_or(0);
                        let (x0, x1) = dt_edges[ix];
                        let (y0, y1) = k_edges[iy];
                        let (mx, my) = (0.25 * (x1 - x0), 0.25 * (y1 - y0));
                        [
                            PathElement::new(
                                vec![(x0 + mx, y0 + my), (x1 - mx, y1 - my)],
                                BLACK.stroke_width(2),
                            ),
                            PathElement::new(
                                vec![(x0 + mx, y1 - my), (x1 - mx, y0 + my)],
                                BLACK.stroke_width(2),
                            ),
                        ]
                    }),
            )
            .map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    if let Some(legend) = panels.get(maps.len()) {
        let entries = [
            (
                RGBColor(40, 110, 40),
                "stable, motion decayed (last/first peak speed ~ 0)",
            ),
            (RGBColor(150, 210, 150), "stable, little decay (ratio ~ 1)"),
            (
                RGBColor(235, 120, 40),
                "finite but growing, or above 50 m/s",
            ),
            (RGBColor(150, 20, 20), "went non-finite"),
        ];
        for (i, (colour, text)) in entries.iter().enumerate() {
            let y = 60 + 40 * i as i32;
            legend
                .draw(&Rectangle::new([(30, y), (60, y + 25)], colour.filled()))
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            legend
                .draw(&Text::new(*text, (70, y + 4), ("sans-serif", 16)))
                .map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        let y = 60 + 40 * entries.len() as i32;
        for (a, b) in [((30, y), (60, y + 25)), ((30, y + 25), (60, y))] {
            legend
                .draw(&PathElement::new(vec![a, b], BLACK.stroke_width(2)))
                .map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        legend
            .draw(&Text::new(
                "finite, but the model energy rose > 0.05 M g L (made up)",
                (70, y + 4),
                ("sans-serif", 16),
            ))
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let notes: [&str; 5] = [
            "stable: finite, peak node speed in the 2nd second <= 1st,",
            "and never above 50 m/s",
            "k on theta and phi of every joint; 20 points, 25 cm, 0.02 kg/m",
            damping_note,
            "released 60° from straight down, rest angles 0, gravity -y",
        ];
        for (i, text) in notes.iter().enumerate() {
            legend
                .draw(&Text::new(
                    *text,
                    (30, 290 + 24 * i as i32),
                    ("sans-serif", 15),
                ))
                .map_err(|e| anyhow::anyhow!("{e}"))?;
        }
    }
    root.present()
        .map_err(|e| anyhow::anyhow!("{e}"))
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
