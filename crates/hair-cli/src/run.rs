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
    /// Render every frame to DIR/frame_NNNN.png (GPU through wgpu, or the CPU reference).
    #[arg(long)]
    pub render: bool,
    /// Width and height of rendered frames (pixels).
    #[arg(long, default_value_t = 640)]
    pub size: u32,
    /// Compute the body's distance field near its surface before the first frame (its time
    /// goes to `prefill_ms`, not to the frames); without it each sample is computed by the
    /// first step that reads it. The results are the same either way.
    #[arg(long)]
    pub prefill_field: bool,
    /// Hair-hair model: volume (with its default settings), pairs or off (default: the
    /// scene's own `collision.hair_hair`).
    #[arg(long)]
    pub hair_hair: Option<String>,
    /// Write the body and the drawn strands of every frame to this USD stage (`.usda`): one
    /// animated `BasisCurves` prim, time code `k + 1` after frame `k` at the scene's frame rate.
    #[arg(long)]
    pub usd: Option<PathBuf>,
    /// Write the drawn strands' points of every frame to this NumPy file (float32, frames x
    /// points x 3); with `--usd` and without this, beside the stage with its stem.
    #[arg(long)]
    pub positions: Option<PathBuf>,
    /// Let `--usd` and `--positions` write over existing files (they are kept otherwise).
    #[arg(long)]
    pub replace: bool,
    /// The grid's pair-search kernel (from `HAIR_GRID_KERNEL`; every kernel finds the same
    /// pairs, so results do not depend on it).
    #[arg(skip)]
    pub grid_kernel: hair::grid::Kernel,
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
    /// Steps from one hair-hair pair search to the next (the scene's
    /// `collision.pair_search_interval`; 1 searches every step).
    pub pair_search_interval: u32,
    /// The hair-hair model run: `volume`, `pairs` or `off`.
    pub hair_hair: String,
    /// Mean points of the hair-hair volume's dense grid per step (0 unless `volume`).
    pub mean_volume_cells: f64,
    /// Mean hair-hair contacts per step: pairs in contact (`pairs`), or nodes the density
    /// pushed (`volume`).
    pub mean_hair_contacts: f64,
    /// Mean milliseconds per frame.
    pub ms_per_frame: f64,
    /// Median milliseconds per frame: the mean counts the first frames, which fill the body's
    /// distance field where the hair first reaches (up to several times a later frame's time),
    /// the median hardly does.
    pub ms_frame_p50: f64,
    /// 95th percentile of the frames' milliseconds (nearest rank).
    pub ms_frame_p95: f64,
    /// The slowest frame's milliseconds.
    pub ms_frame_max: f64,
    /// Milliseconds spent before the first frame filling the body's distance field
    /// (`--prefill-field`; 0 without it).
    pub prefill_ms: f64,
    /// Samples of the distance field that filling computed (0 without `--prefill-field`).
    pub prefilled_samples: usize,
    /// Mean milliseconds per frame building the render geometry (drawn strands, followers of
    /// guides included): `ms_per_stage.render_geometry`, named as the step's stat.
    pub ms_render_geometry: f64,
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
    /// Structured implicit solves redone by the dense LU, over every step.
    pub dense_fallbacks: usize,
    /// The hard body constraint's node tests by the exact distance, over every step: its late
    /// passes, where the scene's approximate method (field or tables) cannot be trusted.
    pub body_exact_tests: usize,
    /// Nodes the hard body constraint sent out of a thin part of the body, over every step.
    pub body_escapes: usize,
    /// The largest mean distance (mm) of the simulated nodes from where they were at frame 0
    /// (as built), over the steps of the first second in the still part of the scene: the
    /// steps before the head, the wind or a tool first acts. `null` when something acts from
    /// the start (the head moves or the wind blows): nothing is still to measure.
    pub rest_drift_mm: Option<f64>,
    /// Seconds over which `rest_drift_mm` was measured: up to 1 s, cut at the first tool event.
    pub rest_drift_s: f64,
    /// Hash of the final state's float bits (hex).
    pub state_hash: String,
    /// Salon tool counters at the end (water, bonds, cuts, fallen pieces, grabbed points).
    pub salon: hair::SalonStats,
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

/// Frame times in milliseconds, sorted, for their percentiles.
struct FrameTimes(Vec<f64>);

impl FrameTimes {
    fn new(ms: impl Iterator<Item = f64>) -> Self {
        let mut v: Vec<f64> = ms.collect();
        v.sort_by(f64::total_cmp);
        Self(v)
    }

    /// The `p`th percentile by nearest rank (the smallest time that at least `p` percent of
    /// the frames do not exceed; 100 gives the slowest frame); 0 with no frames.
    fn percentile(&self, p: u32) -> f64 {
        let n = self.0.len();
        if n == 0 {
            return 0.0;
        }
        let rank = (p.min(100) as usize * n).div_ceil(100).max(1);
        self.0[rank - 1]
    }
}

/// Runs a scene and returns its summary and per-frame metrics, without writing anything.
pub fn simulate(
    args: &Args,
    progress: bool,
    on_frame: &mut (dyn FnMut(u32, &Simulation) -> Result<()> + Send),
) -> Result<(Summary, Vec<FrameMetrics>, Simulation)> {
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
    if let Some(name) = &args.hair_hair {
        loaded.scene.collision.hair_hair = hair::collide::HairHairModel::from_name(name)
            .with_context(|| format!("unknown hair-hair model `{name}` (volume, pairs, off)"))?;
    }
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
        sim.set_grid_kernel(args.grid_kernel)?;
        let (prefilled_samples, prefill_ms) = if args.prefill_field {
            let t = std::time::Instant::now();
            let n = sim.prefill_body_field();
            (n, t.elapsed().as_secs_f64() * 1e3)
        } else {
            (0, 0.0)
        };
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
        let still_s = still_seconds(&loaded.scene);
        let start = sim.state().positions().to_vec();
        let (mut rest_drift, mut rest_drift_s): (Option<f64>, f64) = (None, 0.0);
        let mut metrics = Vec::with_capacity(frames as usize);
        let mut stages = Stages::default();
        let mut total_ms = 0.0;
        let mut max_pen: f64 = 0.0;
        let (mut active, mut dormant, mut steps) = (0.0f64, 0.0f64, 0.0f64);
        let mut last = StepStats::default();
        let mut dense_fallbacks = 0;
        let (mut body_exact_tests, mut body_escapes) = (0, 0);
        let (mut volume_cells, mut hair_contacts) = (0.0f64, 0.0f64);
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
                dense_fallbacks += s.dense_fallbacks;
                body_exact_tests += s.body_exact_tests;
                body_escapes += s.body_escapes;
                volume_cells += s.volume_cells as f64;
                hair_contacts += s.hair_contacts as f64;
                if s.time <= still_s + 1e-6 {
                    let d = mean_drift_mm(&sim, &start);
                    rest_drift = Some(rest_drift.map_or(d, |w| w.max(d)));
                    rest_drift_s = s.time;
                }
                steps += 1.0;
                last = s;
            }
            total_ms += ms_frame;
            metrics.push(FrameMetrics {
                frame,
                ms_frame,
                last_step: last,
            });
            on_frame(frame, &sim)?;
            if let Some(b) = &bar {
                b.inc(1);
            }
        }
        if let Some(b) = bar {
            b.finish_and_clear();
        }
        let frame_ms = FrameTimes::new(metrics.iter().map(|m| m.ms_frame));
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
            pair_search_interval: loaded.scene.collision.pair_search_interval,
            hair_hair: loaded.scene.collision.hair_hair.name().into(),
            mean_volume_cells: volume_cells / steps.max(1.0),
            mean_hair_contacts: hair_contacts / steps.max(1.0),
            ms_per_frame: total_ms / f,
            ms_frame_p50: frame_ms.percentile(50),
            ms_frame_p95: frame_ms.percentile(95),
            ms_frame_max: frame_ms.percentile(100),
            prefill_ms,
            prefilled_samples,
            ms_render_geometry: stages.render_geometry,
            ms_per_stage: stages,
            skeletons: sim.front_nodes().len(),
            strands: sim.render_geometry().strand_count(),
            render_vertices: sim.render_geometry().vertex_count(),
            mean_active: active / steps.max(1.0),
            mean_dormant: dormant / steps.max(1.0),
            max_penetration_m: max_pen,
            tolerance_m: f64::from(loaded.scene.collision.tolerance),
            dense_fallbacks,
            body_exact_tests,
            body_escapes,
            rest_drift_mm: rest_drift,
            rest_drift_s,
            state_hash: format!("{:016x}", sim.state_hash()),
            salon: last.salon,
        };
        Ok((summary, metrics, sim))
    })
}

/// How long `scene` is still from its start, at most 1 s: 0 when the head moves or the wind
/// blows, else up to its first tool event.
fn still_seconds(scene: &Scene) -> f64 {
    if scene.head_motion != hair::scene::HeadMotionSpec::Still || scene.wind.speed > 0.0 {
        return 0.0;
    }
    let first_tool = scene
        .tools
        .events
        .first()
        .map_or(1.0, |e| f64::from(e.time));
    first_tool.min(1.0)
}

/// The mean distance (mm) of the front's nodes from `start` (every node's position at frame 0).
fn mean_drift_mm(sim: &Simulation, start: &[hair::ssv::Point]) -> f64 {
    let p = sim.state().positions();
    let (mut sum, mut n) = (0.0f64, 0usize);
    for &node in sim.front_nodes() {
        for i in sim.state().nodes(hair::dynamics::SkeletonId(node)) {
            sum += f64::from((p[i] - start[i]).norm());
            n += 1;
        }
    }
    sum / n.max(1) as f64 * 1e3
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    let export_paths =
        crate::export::Paths::new(args.usd.as_deref(), args.positions.as_deref(), args.replace);
    if let Some(paths) = &export_paths {
        paths.prepare()?;
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let mut export: Option<crate::export::Export> = None;
    let renderer = args.render.then(hair_render::Renderer::new);
    if let Some(r) = &renderer {
        eprintln!("rendering with {}", r.describe());
    }
    let mut frame_out = |frame: u32, sim: &Simulation| -> Result<()> {
        if let Some(paths) = &export_paths {
            let writers = match &mut export {
                Some(writers) => writers,
                None => export.insert(crate::export::Export::create(paths, sim)?),
            };
            writers.write(frame, sim)?;
        }
        let Some(r) = &renderer else { return Ok(()) };
        let scene = render_scene(sim);
        let settings = hair_render::RenderSettings {
            width: args.size,
            height: args.size,
            ..hair_render::RenderSettings::default()
        };
        let image = r.render_to_image(&scene, &settings)?;
        hair_render::save_png(&image, args.out.join(format!("frame_{frame:04}.png")))?;
        Ok(())
    };
    let (summary, metrics, _) = simulate(&args, std::io::stderr().is_terminal(), &mut frame_out)?;
    if let Some(paths) = &export_paths {
        let Some(writers) = export else {
            anyhow::bail!("no frame was simulated: --usd and --positions wrote nothing");
        };
        let frames = writers.finish()?;
        for path in paths.usd.iter().chain([&paths.positions]) {
            eprintln!("wrote {} ({frames} frames)", path.display());
        }
    }
    let write = |name: &str, text: String| -> Result<()> {
        let path = args.out.join(name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))
    };
    write("metrics.json", serde_json::to_string_pretty(&metrics)?)?;
    write("summary.json", serde_json::to_string_pretty(&summary)?)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}

/// The renderer's plain-data view of a simulation ([`hair::render::scene_of`]).
pub fn render_scene(sim: &Simulation) -> hair_render::RenderScene {
    hair::render::scene_of(sim)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The summary names the pair search interval the run used: the scene's own.
    #[test]
    fn the_summary_gives_the_pair_search_interval() {
        let dir = std::env::temp_dir().join(format!("hair-run-interval-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for interval in [1, 3] {
            let mut scene = Scene::load("bristles").unwrap().scene;
            scene.collision.pair_search_interval = interval;
            let path = dir.join(format!("bristles-{interval}.ron"));
            std::fs::write(&path, scene.to_ron()).unwrap();
            let args = Args {
                scene: path.display().to_string(),
                frames: Some(4),
                out: dir.clone(),
                lod: None,
                threads: Some(1),
                seed: None,
                render: false,
                size: 64,
                prefill_field: false,
                grid_kernel: hair::grid::Kernel::Auto,
                hair_hair: None,
                usd: None,
                positions: None,
                replace: false,
            };
            let (summary, metrics, _) = simulate(&args, false, &mut |_, _| Ok(())).unwrap();
            assert_eq!(summary.pair_search_interval, interval);
            assert_eq!(metrics.len(), 4);
            // Four frames: the median is the second fastest, the 95th percentile the slowest.
            let mut ms: Vec<f64> = metrics.iter().map(|m| m.ms_frame).collect();
            ms.sort_by(f64::total_cmp);
            assert_eq!(summary.ms_frame_p50, ms[1]);
            assert_eq!(summary.ms_frame_p95, ms[3]);
            assert_eq!(summary.ms_frame_max, ms[3]);
            assert!(summary.ms_frame_max >= summary.ms_per_frame);
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    /// `--hair-hair` replaces the scene's model, and the summary names it with its grid and
    /// contact counts; an unknown name is an error naming the choices.
    #[test]
    fn the_hair_hair_flag_picks_the_model() {
        let args = |model: &str| Args {
            scene: "bristles".into(),
            frames: Some(2),
            out: std::env::temp_dir(),
            lod: None,
            threads: Some(2),
            seed: None,
            render: false,
            size: 64,
            prefill_field: false,
            grid_kernel: hair::grid::Kernel::Auto,
            hair_hair: Some(model.into()),
            usd: None,
            positions: None,
            replace: false,
        };
        let mut hashes = Vec::new();
        for model in ["volume", "pairs", "off"] {
            let (summary, _, _) = simulate(&args(model), false, &mut |_, _| Ok(())).unwrap();
            assert_eq!(summary.hair_hair, model);
            assert_eq!(summary.mean_volume_cells > 0.0, model == "volume");
            if model == "off" {
                assert_eq!(summary.mean_hair_contacts, 0.0);
            }
            hashes.push(summary.state_hash);
        }
        assert!(
            hashes[0] != hashes[1] && hashes[1] != hashes[2],
            "{hashes:?}"
        );
        let err = simulate(&args("grid"), false, &mut |_, _| Ok(()))
            .err()
            .unwrap();
        assert!(format!("{err:#}").contains("volume, pairs, off"), "{err:#}");
    }

    /// `--prefill-field` computes the distance field's band before the first frame and
    /// changes no result: the same final hash as filling it frame by frame.
    #[test]
    fn filling_the_distance_field_ahead_changes_no_result() {
        let run = |prefill_field: bool| {
            let args = Args {
                scene: "bristles".into(),
                frames: Some(2),
                out: std::env::temp_dir(),
                lod: None,
                threads: Some(2),
                seed: None,
                render: false,
                size: 64,
                prefill_field,
                grid_kernel: hair::grid::Kernel::Auto,
                hair_hair: None,
                usd: None,
                positions: None,
                replace: false,
            };
            simulate(&args, false, &mut |_, _| Ok(())).unwrap().0
        };
        let (lazy, ahead) = (run(false), run(true));
        assert_eq!((lazy.prefilled_samples, lazy.prefill_ms), (0, 0.0));
        assert!(
            ahead.prefilled_samples > 100_000,
            "{}",
            ahead.prefilled_samples
        );
        assert!(ahead.prefill_ms > 0.0);
        assert_eq!(ahead.state_hash, lazy.state_hash);
    }

    #[test]
    fn frame_percentiles_are_by_nearest_rank() {
        let times =
            FrameTimes::new([5.0, 1.0, 4.0, 2.0, 3.0, 10.0, 6.0, 9.0, 8.0, 7.0].into_iter());
        assert_eq!(times.percentile(50), 5.0);
        assert_eq!(times.percentile(95), 10.0);
        assert_eq!(times.percentile(90), 9.0);
        assert_eq!(times.percentile(10), 1.0);
        assert_eq!(times.percentile(0), 1.0);
        assert_eq!(times.percentile(100), 10.0);
        assert_eq!(FrameTimes::new(std::iter::empty()).percentile(50), 0.0);
        let twenty = FrameTimes::new((1..=20).map(f64::from));
        assert_eq!(twenty.percentile(95), 19.0);
    }
}
