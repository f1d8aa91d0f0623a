//! `hair run SCENE`: simulate a scene, write per-frame metrics and a summary.

use anyhow::{Context, Result};
use hair::{LodPolicy, Scene, Simulation, StepStats};
use serde::Serialize;
use std::io::IsTerminal;
use std::path::PathBuf;

/// Arguments of `hair run`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A built-in scene name (`hair scenes` lists them) or a scene file (.ron).
    pub scene: String,
    /// Frames to simulate (default: the scene's own).
    #[arg(long)]
    pub frames: Option<u32>,
    /// Output directory for metrics.json and summary.json.
    #[arg(long, default_value = "out/run")]
    pub out: PathBuf,
    /// LOD policy: fine, adaptive, coarse-strands, clusters, strips (default: the scene's own).
    #[arg(long)]
    pub lod: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed (default: the scene's own).
    #[arg(long)]
    pub seed: Option<u64>,
}

/// Per-frame metrics: the stats of the frame's last step plus the frame's totals.
#[derive(Debug, Serialize)]
pub struct FrameMetrics {
    /// Frame index.
    pub frame: u32,
    /// Milliseconds for the whole frame (all substeps).
    pub ms_frame: f64,
    /// Stats of the frame's last step.
    #[serde(flatten)]
    pub last_step: StepStats,
}

/// What `summary.json` holds.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// Scene name.
    pub scene: String,
    /// LOD policy.
    pub lod: String,
    /// Threads used.
    pub threads: usize,
    /// Frames simulated.
    pub frames: u32,
    /// Steps per frame.
    pub substeps: u32,
    /// Mean milliseconds per frame.
    pub ms_per_frame: f64,
    /// Mean milliseconds per frame in each stage.
    pub ms_per_stage: Stages,
    /// Skeletons simulated at the end.
    pub skeletons: usize,
    /// Rendered strands.
    pub strands: usize,
    /// Rendered vertices per frame.
    pub render_vertices: usize,
    /// Mean active and dormant skeletons per step.
    pub mean_active: f64,
    /// Mean dormant skeletons per step.
    pub mean_dormant: f64,
    /// Largest penetration after the hard constraint over every step after the depenetration ramp (m).
    pub max_penetration_m: f64,
    /// The penetration tolerance of the scene (m).
    pub tolerance_m: f64,
    /// Hash of the final state's float bits (hex).
    pub state_hash: String,
}

/// Mean milliseconds per frame of each stage.
#[derive(Debug, Default, Serialize)]
pub struct Stages {
    /// Drivers.
    pub drivers: f64,
    /// LOD selection and transitions.
    pub lod: f64,
    /// Grid build.
    pub grid: f64,
    /// Hair-hair collision.
    pub hair_hair: f64,
    /// Integration.
    pub dynamics: f64,
    /// Hair-object collision.
    pub hair_object: f64,
    /// Render geometry.
    pub render_geometry: f64,
}

/// Runs a scene and returns its summary and per-frame metrics, without writing anything.
pub fn simulate(args: &Args, progress: bool) -> Result<(Summary, Vec<FrameMetrics>, Simulation)> {
    let mut loaded = Scene::load(&args.scene)?;
    if let Some(seed) = args.seed {
        loaded.scene.seed = seed;
    }
    let policy = match &args.lod {
        Some(name) => LodPolicy::from_name(name).with_context(|| {
            format!(
                "unknown LOD policy `{name}` (fine, adaptive, coarse-strands, clusters, strips)"
            )
        })?,
        None => loaded.scene.lod,
    };
    let frames = args.frames.unwrap_or(loaded.scene.frames);
    let threads = args
        .threads
        .unwrap_or_else(rayon::current_num_threads)
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    pool.install(|| {
        let mut sim = Simulation::new(&loaded, policy)?;
        let substeps = loaded.scene.substeps;
        let ramp = u64::from(loaded.scene.collision.depenetration_steps);
        let bar = progress.then(|| {
            let b = indicatif::ProgressBar::new(u64::from(frames));
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} frames {per_sec} eta {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        });
        let mut metrics = Vec::with_capacity(frames as usize);
        let mut stages = Stages::default();
        let mut total_ms = 0.0;
        let mut max_pen: f64 = 0.0;
        let (mut active, mut dormant, mut steps) = (0.0f64, 0.0f64, 0.0f64);
        let mut last = StepStats::default();
        for frame in 0..frames {
            let mut ms_frame = 0.0;
            for _ in 0..substeps {
                let s = sim.step()?;
                ms_frame += s.ms_total;
                stages.drivers += s.ms_drivers;
                stages.lod += s.ms_lod;
                stages.grid += s.ms_grid;
                stages.hair_hair += s.ms_hair_hair;
                stages.dynamics += s.ms_dynamics;
                stages.hair_object += s.ms_hair_object;
                stages.render_geometry += s.ms_render_geometry;
                if s.step >= ramp {
                    max_pen = max_pen.max(s.max_penetration_m);
                }
                active += s.active as f64;
                dormant += s.dormant as f64;
                steps += 1.0;
                last = s;
            }
            total_ms += ms_frame;
            metrics.push(FrameMetrics {
                frame,
                ms_frame,
                last_step: last,
            });
            if let Some(b) = &bar {
                b.inc(1);
            }
        }
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        let f = f64::from(frames.max(1));
        for v in [
            &mut stages.drivers,
            &mut stages.lod,
            &mut stages.grid,
            &mut stages.hair_hair,
            &mut stages.dynamics,
            &mut stages.hair_object,
            &mut stages.render_geometry,
        ] {
            *v /= f;
        }
        let summary = Summary {
            scene: loaded.scene.name.clone(),
            lod: policy.name().into(),
            threads,
            frames,
            substeps,
            ms_per_frame: total_ms / f,
            ms_per_stage: stages,
            skeletons: sim.front_nodes().len(),
            strands: sim.render_geometry().strand_count(),
            render_vertices: sim.render_geometry().vertex_count(),
            mean_active: active / steps.max(1.0),
            mean_dormant: dormant / steps.max(1.0),
            max_penetration_m: max_pen,
            tolerance_m: f64::from(loaded.scene.collision.tolerance),
            state_hash: format!("{:016x}", sim.state_hash()),
        };
        Ok((summary, metrics, sim))
    })
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    let (summary, metrics, _) = simulate(&args, std::io::stderr().is_terminal())?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let write = |name: &str, text: String| -> Result<()> {
        let path = args.out.join(name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))
    };
    write("metrics.json", serde_json::to_string_pretty(&metrics)?)?;
    write("summary.json", serde_json::to_string_pretty(&summary)?)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}
