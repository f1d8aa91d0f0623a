//! `hair study SCENE`: every LOD policy, each body collision method and each hair-hair model
//! on one scene, each measured for cost, for its distance from the most faithful run, and for
//! what it leaves in the hair — Ward & Lin's Tables 1 and 2 with the error they could not
//! quantify.
//!
//! The reference (`fine+pairs`, named in `study.json`'s `reference`) is the most faithful run:
//! the `fine` policy, the exact hair-hair model (`Pairs`, searching every step), the exact body
//! distances (`bvh`; a scene without a body keeps its own method) and localization off. Every
//! other row changes what its name says from the scene's own setting: `fine` is the finest level
//! with the scene's own models (the `Volume` hair-hair model by default), `fine+bvh` the same with
//! the exact body (so it differs from the reference by the hair-hair model alone), `fine+maps`
//! the cylinder and sphere tables. Localization (the salon paper's dormant cells) is measured on
//! top of `fine` and `adaptive`, whatever the scene asks for. `adaptive` is also run with the
//! scene's LOD distances scaled down ([`DISTANCE_SCALES`]; `adaptive+distance0.5` asks for the
//! finest level only at half the distance, and for the coarsest from half the distance): a
//! policy's cost falls as its error rises, and these rows trace that trade from the scene's own
//! setting toward the clusters. The `+pairs` rows are the reference's models, `fine+pairs4`
//! searching for pairs every fourth step and testing the pairs it found again in between
//! ([`PAIR_SEARCH_INTERVALS`]): what missing the pairs that form between searches costs.
//!
//! Every run starts from the same scene and seed; after every frame the rendered strands'
//! control vertices are compared with the reference's at the same frame, and the RMS and the
//! maximum over all frames and vertices are reported (mm); so is the RMS over the vertices the
//! camera sees in the reference (`visible_rms_error_mm`, by the test the `adaptive` policy
//! selects with), since that policy spends its detail where the camera looks and lets hidden
//! hair coarsen.
//!
//! Every [`measure::SAMPLE_EVERY`]th frame each run also measures its own hair ([`measure`]):
//! `overlap_mm`, the mean depth of the overlapping crossing pairs of its simulated sections
//! (swept-sphere segments at the hair-hair radii the exact model uses, the groom's own packing
//! capped as that model caps it; near-parallel pairs left out, as that model shares their
//! velocity instead of pushing them apart) by the exact SSV contact, pooled over the samples,
//! with `overlap_pairs`, their mean number per sample: how much interpenetration a cheaper model
//! leaves. And `thickness_mm`, the hair layer's mean thickness over the body: the rendered
//! control vertices (in the head frame) binned by their direction from the centre of the hair's
//! roots, each bin's thickness the largest exact signed distance of its vertices from the body's
//! surface, averaged over the bins that hold hair, then over the samples: a layer that collapses
//! onto the head or puffs up shows there (on 512 of the rendered strands at most,
//! [`measure::THICKNESS_STRANDS`]).
//!
//! Hair in wind is chaotic: two runs that differ by rounding drift apart by centimetres within a
//! second. So the study also runs the reference with gravity changed by one part in a million
//! (`fine+pairs+perturbed`, [`GRAVITY_PERTURBATION`]), far below anything that could be measured
//! on real hair; its distance from the reference is the floor under every other row's error
//! (`chaos_floor_rms_mm`): an error near the floor is as close to the reference as the reference
//! is to itself.

mod chart;
pub mod measure;

use anyhow::{Context, Result};
use hair::scene::{BodySpec, CollisionMethod};
use hair::{LodPolicy, Scene, Simulation};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Arguments of `hair study`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A built-in scene name or a scene file (.ron).
    pub scene: String,
    /// Output directory for study.json, study.csv and study.png.
    #[arg(long, default_value = "out/study")]
    pub out: PathBuf,
    /// Frames per run (default: the scene's own).
    #[arg(long)]
    pub frames: Option<u32>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Only redraw study.png from the study.json in the output directory.
    #[arg(long)]
    pub replot: bool,
}

/// Factors on the scene's `adaptive` distances (`distance_finest` and `distance_coarsest`) of the
/// extra `adaptive+distanceF` rows.
pub const DISTANCE_SCALES: [f32; 2] = [0.5, 0.25];

/// `collision.pair_search_interval` of the extra `fine+pairsN` rows (run when the scene searches
/// every step and has hair-hair collision).
pub const PAIR_SEARCH_INTERVALS: [u32; 2] = [2, 4];

/// Relative change of gravity in the `fine+perturbed` run.
pub const GRAVITY_PERTURBATION: f32 = 1e-6;

/// One configuration's measurements.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PolicyResult {
    /// `policy` or `policy+method`.
    pub name: String,
    /// LOD policy.
    pub policy: String,
    /// Body collision method.
    pub collision: String,
    /// Whether localization froze quiet cells.
    pub localization: bool,
    /// Hair-hair model (`pairs`, `volume` or `off`).
    pub hair_hair: String,
    /// Steps from one hair-hair pair search to the next.
    pub pair_search_interval: u32,
    /// Mean milliseconds per frame.
    pub ms_per_frame: f64,
    /// Mean milliseconds per frame integrating.
    pub ms_dynamics: f64,
    /// Mean milliseconds per frame in hair-hair and hair-object collision.
    pub ms_collision: f64,
    /// Mean skeletons on the LOD front per step.
    pub mean_skeletons: f64,
    /// Mean of those frozen by localization per step.
    pub mean_dormant: f64,
    /// RMS distance of the rendered strands' control vertices from the reference (mm).
    pub rms_error_mm: f64,
    /// Largest such distance (mm).
    pub max_error_mm: f64,
    /// RMS distance over the control vertices the camera sees in the reference (mm; 0 when it
    /// sees none).
    pub visible_rms_error_mm: f64,
    /// Deepest node left inside the body after the depenetration ramp (mm).
    pub max_penetration_mm: f64,
    /// Cost relative to the reference.
    pub cost_ratio: f64,
    /// Mean depth of the overlapping crossing pairs of the simulated sections, over the
    /// samples (mm; 0 when none overlaps; the module's doc gives the definition).
    pub overlap_mm: f64,
    /// Mean number of those pairs per sample.
    pub overlap_pairs: f64,
    /// Mean thickness of the hair layer over the body, over the samples (mm; 0 without a
    /// body; the module's doc gives the definition).
    pub thickness_mm: f64,
}

/// What `study.json` holds.
#[derive(Debug, Serialize, Deserialize)]
pub struct Study {
    /// Scene name.
    pub scene: String,
    /// Frames per run.
    pub frames: u32,
    /// Threads.
    pub threads: usize,
    /// Strands rendered.
    pub strands: usize,
    /// The reference's name (the first of `policies`): every error and cost is relative to it.
    pub reference: String,
    /// Frames from one sample of `overlap_mm` and `thickness_mm` to the next.
    pub sample_every: u32,
    /// RMS distance of the reference's perturbed run from the reference (mm): the error of a run
    /// that differs from it by a perturbation far below measurement.
    pub chaos_floor_rms_mm: f64,
    /// Fraction of the reference's control vertices, over all frames, that the camera sees (the
    /// vertices `visible_rms_error_mm` is taken over).
    pub seen_fraction: f64,
    /// One entry per configuration; the first is the reference.
    pub policies: Vec<PolicyResult>,
}

fn method_name(m: CollisionMethod) -> &'static str {
    match m {
        CollisionMethod::Field => "field",
        CollisionMethod::Bvh => "bvh",
        CollisionMethod::Maps => "maps",
    }
}

/// The body collision method with exact distances: the SSV BVH.
const EXACT_METHOD: CollisionMethod = CollisionMethod::Bvh;

/// Control vertices (every `sub`-th rendered vertex) of every strand.
fn snapshot(sim: &Simulation, out: &mut Vec<hair::ssv::Point>) {
    let g = sim.render_geometry();
    let sub = g.subdivisions.max(1);
    out.clear();
    for s in 0..g.strand_count() {
        out.extend(g.strand(s).iter().step_by(sub).copied());
    }
}

/// One configuration of a study.
#[derive(Clone, Copy, Debug)]
struct Config {
    policy: LodPolicy,
    method: CollisionMethod,
    localization: bool,
    /// Relative change of gravity (0: the scene's own).
    perturbation: f32,
    /// Factor on the scene's adaptive LOD distances (1: the scene's own).
    distance_scale: f32,
    /// Steps between searches of the exact hair-hair model (`Pairs`); 0: the scene's own
    /// hair-hair model and interval.
    pair_interval: u32,
}

struct Run {
    result: PolicyResult,
    /// Milliseconds spent measuring overlap and thickness (not in `ms_per_frame`).
    ms_measuring: f64,
    frames: Vec<Vec<hair::ssv::Point>>,
    /// Per frame, whether the camera sees each control vertex.
    seen: Vec<Vec<bool>>,
    /// Strands rendered.
    strands: usize,
}

fn run_one(
    scene: &hair::LoadedScene,
    config: Config,
    frames: u32,
    reference: Option<&Run>,
) -> Result<Run> {
    let Config {
        policy,
        method,
        localization,
        perturbation,
        distance_scale,
        pair_interval,
    } = config;
    let mut loaded = scene.clone();
    if pair_interval > 0 {
        loaded.scene.collision.hair_hair = hair::collide::HairHairModel::Pairs;
        loaded.scene.collision.pair_search_interval = pair_interval;
    }
    loaded.scene.collision.method = method;
    loaded.scene.localization = localization;
    let adaptive = &mut loaded.scene.adaptive;
    adaptive.distance_finest *= distance_scale;
    adaptive.distance_coarsest *= distance_scale;
    for g in &mut loaded.scene.dynamics.gravity {
        *g *= 1.0 + perturbation;
    }
    let mut sim = Simulation::new(&loaded, policy)
        .with_context(|| format!("building {} with {}", policy.name(), method_name(method)))?;
    let mut sampler = measure::Sampler::new(&loaded.scene, &sim)?;
    let ramp = u64::from(loaded.scene.collision.depenetration_steps);
    let (mut total, mut dynamics, mut collision, mut skeletons, mut dormant, mut steps) =
        (0.0, 0.0, 0.0, 0.0, 0.0, 0.0f64);
    let mut max_pen: f64 = 0.0;
    let (mut sum_sq, mut count, mut max_err) = (0.0f64, 0u64, 0.0f64);
    let (mut seen_sq, mut seen_count) = (0.0f64, 0u64);
    let mut kept_seen = Vec::new();
    let mut kept = Vec::new();
    let mut snap = Vec::new();
    for frame in 0..frames {
        for _ in 0..loaded.scene.substeps {
            let s = sim.step()?;
            total += s.ms_total;
            dynamics += s.ms_dynamics;
            collision += s.ms_hair_hair + s.ms_hair_object;
            skeletons += s.skeletons as f64;
            dormant += s.dormant as f64;
            steps += 1.0;
            if s.step >= ramp {
                max_pen = max_pen.max(s.max_penetration_m);
            }
        }
        snapshot(&sim, &mut snap);
        // Every `SAMPLE_EVERY`th frame, and the last (a short run gets one sample).
        if (frame + 1) % measure::SAMPLE_EVERY == 0 || frame + 1 == frames {
            sampler.sample(&sim)?;
        }
        match reference {
            Some(r) => {
                let f = frame as usize;
                for ((a, b), &seen) in snap.iter().zip(&r.frames[f]).zip(&r.seen[f]) {
                    let d = f64::from((a - b).norm());
                    sum_sq += d * d;
                    max_err = max_err.max(d);
                    count += 1;
                    if seen {
                        seen_sq += d * d;
                        seen_count += 1;
                    }
                }
            }
            None => {
                let mut seen = Vec::new();
                sim.seen_by_camera(&snap, &mut seen);
                kept.push(snap.clone());
                kept_seen.push(seen);
            }
        }
    }
    let f = f64::from(frames.max(1));
    let own = scene.scene.collision.method;
    let mut name = policy.name().to_string();
    // `+pairs` names the reference's models, the exact body method with them.
    let exact = pair_interval > 0 && method == exact_method(&scene.scene);
    if method != own && !exact {
        name = format!("{name}+{}", method_name(method));
    }
    if distance_scale != 1.0 {
        name.push_str(&format!("+distance{distance_scale}"));
    }
    match pair_interval {
        0 => {}
        1 => name.push_str("+pairs"),
        n => name.push_str(&format!("+pairs{n}")),
    }
    if localization {
        name.push_str("+localized");
    }
    if perturbation != 0.0 {
        name.push_str("+perturbed");
    }
    let samples = f64::from(sampler.samples.max(1));
    let [setup, overlap, thickness] = sampler.ms.map(|ms| ms * 1e-3);
    eprintln!(
        "  {name}: {:.1} ms a frame; measuring {:.1} s (radius caps {setup:.1} s, overlap \
         {overlap:.1} s, thickness {thickness:.1} s)",
        total / f64::from(frames.max(1)),
        setup + overlap + thickness,
    );
    Ok(Run {
        result: PolicyResult {
            name,
            policy: policy.name().into(),
            collision: method_name(method).into(),
            localization,
            hair_hair: loaded.scene.collision.hair_hair.name().into(),
            pair_search_interval: loaded.scene.collision.pair_search_interval,
            ms_per_frame: total / f,
            ms_dynamics: dynamics / f,
            ms_collision: collision / f,
            mean_skeletons: skeletons / steps.max(1.0),
            mean_dormant: dormant / steps.max(1.0),
            rms_error_mm: if count > 0 {
                (sum_sq / count as f64).sqrt() * 1e3
            } else {
                0.0
            },
            max_error_mm: max_err * 1e3,
            visible_rms_error_mm: if seen_count > 0 {
                (seen_sq / seen_count as f64).sqrt() * 1e3
            } else {
                0.0
            },
            max_penetration_mm: max_pen * 1e3,
            cost_ratio: 1.0,
            overlap_mm: sampler.overlap.mean_depth() * 1e3,
            overlap_pairs: sampler.overlap.pairs as f64 / samples,
            thickness_mm: sampler.thickness_sum / samples * 1e3,
        },
        ms_measuring: sampler.ms.iter().sum(),
        frames: kept,
        seen: kept_seen,
        strands: sim.render_geometry().strand_count(),
    })
}

/// The exact body method, or the scene's own when it has no body (the method does nothing).
fn exact_method(scene: &Scene) -> CollisionMethod {
    if matches!(scene.body, BodySpec::None) {
        scene.collision.method
    } else {
        EXACT_METHOD
    }
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    if args.replot {
        let path = args.out.join("study.json");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let study: Study =
            serde_json::from_str(&text).with_context(|| format!("parsing {}", path.display()))?;
        return chart::chart(&args.out.join("study.png"), &study);
    }
    let loaded = Scene::load(&args.scene)?;
    let frames = args.frames.unwrap_or(loaded.scene.frames).max(1);
    let threads = args
        .threads
        .unwrap_or_else(rayon::current_num_threads)
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let own = loaded.scene.collision.method;
    let config = |policy, method, localization| Config {
        policy,
        method,
        localization,
        perturbation: 0.0,
        distance_scale: 1.0,
        pair_interval: 0,
    };
    // The exact models: pairs searched every step, exact body distances.
    let reference_config = Config {
        pair_interval: 1,
        ..config(LodPolicy::Fine, exact_method(&loaded.scene), false)
    };
    let mut configs: Vec<Config> = vec![
        Config {
            perturbation: GRAVITY_PERTURBATION,
            ..reference_config
        },
        config(LodPolicy::Fine, own, false),
    ];
    configs.extend(
        [
            LodPolicy::Adaptive,
            LodPolicy::CoarseStrands,
            LodPolicy::Clusters,
            LodPolicy::Strips,
        ]
        .into_iter()
        .map(|p| config(p, own, false)),
    );
    configs.extend(DISTANCE_SCALES.map(|distance_scale| Config {
        distance_scale,
        ..config(LodPolicy::Adaptive, own, false)
    }));
    configs.extend(PAIR_SEARCH_INTERVALS.map(|pair_interval| Config {
        pair_interval,
        ..reference_config
    }));
    configs.push(config(LodPolicy::Fine, own, true));
    configs.push(config(LodPolicy::Adaptive, own, true));
    let mut methods = vec![CollisionMethod::Field, CollisionMethod::Bvh];
    if matches!(loaded.scene.body, BodySpec::Head { .. }) {
        methods.push(CollisionMethod::Maps);
    }
    if matches!(loaded.scene.body, BodySpec::None) {
        methods.clear();
    }
    configs.extend(
        methods
            .into_iter()
            .filter(|&m| m != own)
            .map(|m| config(LodPolicy::Fine, m, false)),
    );
    let study = pool.install(|| -> Result<Study> {
        eprintln!(
            "study {}: fine (pairs, {}), the reference ...",
            loaded.scene.name,
            method_name(reference_config.method)
        );
        let clock = std::time::Instant::now();
        let reference = run_one(&loaded, reference_config, frames, None)?;
        let mut measuring = reference.ms_measuring;
        let fine_ms = reference.result.ms_per_frame.max(1e-9);
        let strands = reference.strands;
        let (seen, vertices) = reference.seen.iter().fold((0usize, 0usize), |(s, n), f| {
            (s + f.iter().filter(|&&x| x).count(), n + f.len())
        });
        let seen_fraction = seen as f64 / vertices.max(1) as f64;
        let mut policies = vec![reference.result.clone()];
        for c in configs {
            eprintln!(
                "study {}: {} ({}{}{}{}{}) ...",
                loaded.scene.name,
                c.policy.name(),
                method_name(c.method),
                if c.distance_scale != 1.0 {
                    format!(", distances x{}", c.distance_scale)
                } else {
                    String::new()
                },
                if c.pair_interval > 0 {
                    match c.pair_interval {
                        1 => ", pairs searched every step".to_string(),
                        n => format!(", pairs searched every {n} steps"),
                    }
                } else {
                    format!(", {}", loaded.scene.collision.hair_hair.name())
                },
                if c.localization { ", localized" } else { "" },
                if c.perturbation != 0.0 {
                    ", perturbed"
                } else {
                    ""
                }
            );
            let run = run_one(&loaded, c, frames, Some(&reference))?;
            measuring += run.ms_measuring;
            let mut r = run.result;
            r.cost_ratio = r.ms_per_frame / fine_ms;
            policies.push(r);
        }
        let wall_ms = clock.elapsed().as_secs_f64() * 1e3;
        eprintln!(
            "study {}: {:.1} s, of which {:.1} s measuring overlap and thickness",
            loaded.scene.name,
            wall_ms * 1e-3,
            measuring * 1e-3
        );
        let chaos_floor_rms_mm = policies
            .iter()
            .find(|p| p.name.ends_with("+perturbed"))
            .map_or(0.0, |p| p.rms_error_mm);
        Ok(Study {
            scene: loaded.scene.name.clone(),
            frames,
            threads,
            strands,
            reference: reference.result.name.clone(),
            sample_every: measure::SAMPLE_EVERY,
            chaos_floor_rms_mm,
            seen_fraction,
            policies,
        })
    })?;
    let json = serde_json::to_string_pretty(&study)?;
    write(&args.out.join("study.json"), &json)?;
    let mut csv = String::from(
        "name,policy,collision,localization,hair_hair,pair_search_interval,ms_per_frame,ms_dynamics,ms_collision,mean_skeletons,mean_dormant,rms_error_mm,max_error_mm,visible_rms_error_mm,max_penetration_mm,cost_ratio,overlap_mm,overlap_pairs,thickness_mm\n",
    );
    for p in &study.policies {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{:.3},{:.3},{:.3},{:.1},{:.1},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.1},{:.3}\n",
            p.name,
            p.policy,
            p.collision,
            p.localization,
            p.hair_hair,
            p.pair_search_interval,
            p.ms_per_frame,
            p.ms_dynamics,
            p.ms_collision,
            p.mean_skeletons,
            p.mean_dormant,
            p.rms_error_mm,
            p.max_error_mm,
            p.visible_rms_error_mm,
            p.max_penetration_mm,
            p.cost_ratio,
            p.overlap_mm,
            p.overlap_pairs,
            p.thickness_mm
        ));
    }
    write(&args.out.join("study.csv"), &csv)?;
    chart::chart(&args.out.join("study.png"), &study)?;
    println!("{json}");
    Ok(())
}

fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small scene through the whole study: the reference (the exact models) is at zero error
    /// and cost 1, every configuration is present once with finite figures, overlap and
    /// thickness included, and the reference's perturbed run sets the floor.
    #[test]
    fn a_study_measures_every_configuration_against_the_exact_models_and_the_floor() {
        let dir = std::env::temp_dir().join(format!("hair-study-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let scene = dir.join("tiny.ron");
        std::fs::write(
            &scene,
            "Scene(name: \"tiny\", frames: 6, body: Head(resolution: 24), \
             hairstyle: Procedural((strands: 60, length: 0.12, points: 6, style: Straight)), \
             wind: (direction: (0.0, 0.0, -1.0), speed: 3.0, gust: 0.3, turbulence: 0.2, drag: 2e-4))",
        )
        .unwrap();
        run(Args {
            scene: scene.display().to_string(),
            out: dir.clone(),
            frames: None,
            threads: Some(2),
            replot: false,
        })
        .unwrap();
        let study: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("study.json")).unwrap())
                .unwrap();
        let rows = study["policies"].as_array().unwrap();
        let names: Vec<&str> = rows.iter().map(|r| r["name"].as_str().unwrap()).collect();
        assert_eq!(names[0], "fine+pairs");
        assert_eq!(study["reference"].as_str(), Some("fine+pairs"));
        assert_eq!(rows[0]["hair_hair"].as_str(), Some("pairs"));
        assert_eq!(rows[0]["collision"].as_str(), Some("bvh"));
        assert_eq!(rows[0]["pair_search_interval"].as_u64(), Some(1));
        for expected in [
            "fine",
            "fine+pairs+perturbed",
            "adaptive",
            "adaptive+distance0.5",
            "adaptive+distance0.25",
            "strips",
            "fine+bvh",
            "fine+maps",
            "fine+pairs2",
            "fine+pairs4",
        ] {
            assert_eq!(
                names.iter().filter(|n| **n == expected).count(),
                1,
                "{names:?}"
            );
        }
        assert_eq!(rows[0]["rms_error_mm"].as_f64(), Some(0.0));
        assert_eq!(rows[0]["cost_ratio"].as_f64(), Some(1.0));
        for r in rows {
            for key in [
                "ms_per_frame",
                "rms_error_mm",
                "max_error_mm",
                "visible_rms_error_mm",
                "cost_ratio",
                "overlap_mm",
                "overlap_pairs",
                "thickness_mm",
            ] {
                let v = r[key].as_f64().unwrap();
                assert!(v.is_finite() && v >= 0.0, "{} {key} {v}", r["name"]);
            }
        }
        // Nearer distances for the finest level never ask for more detail: the scaled rows hold
        // no more skeletons than `adaptive`, and the quartered one fewer.
        let skeletons = |name: &str| {
            rows.iter().find(|r| r["name"] == name).unwrap()["mean_skeletons"]
                .as_f64()
                .unwrap()
        };
        let (own, half, quarter) = (
            skeletons("adaptive"),
            skeletons("adaptive+distance0.5"),
            skeletons("adaptive+distance0.25"),
        );
        assert!(
            own >= half && half >= quarter && quarter < own,
            "{own} {half} {quarter}"
        );
        assert_eq!(rows[0]["visible_rms_error_mm"].as_f64(), Some(0.0));
        // `fine` is the scene's own volume model beside the reference's pairs.
        let fine = rows.iter().find(|r| r["name"] == "fine").unwrap();
        assert_eq!(fine["hair_hair"].as_str(), Some("volume"));
        // Hair lies over the whole scalp: every row's layer stands out from the head, less
        // than the strands are long (0.12 m).
        for r in rows {
            let t = r["thickness_mm"].as_f64().unwrap();
            assert!(t > 0.0 && t < 120.0, "{} thickness {t} mm", r["name"]);
        }
        // The camera sees some of the hair: the coarsest policy's error shows there too.
        let strips = rows.iter().find(|r| r["name"] == "strips").unwrap();
        assert!(strips["visible_rms_error_mm"].as_f64().unwrap() > 0.0);
        assert_eq!(study["strands"].as_u64(), Some(60));
        let seen = study["seen_fraction"].as_f64().unwrap();
        assert!(seen > 0.0 && seen <= 1.0, "{seen}");
        let perturbed = rows
            .iter()
            .find(|r| r["name"] == "fine+pairs+perturbed")
            .unwrap();
        assert_eq!(study["chaos_floor_rms_mm"], perturbed["rms_error_mm"]);
        assert!(dir.join("study.csv").exists() && dir.join("study.png").exists());
        // The chart redrawn from study.json alone.
        std::fs::remove_file(dir.join("study.png")).unwrap();
        run(Args {
            scene: "no scene is loaded".into(),
            out: dir.clone(),
            frames: None,
            threads: None,
            replot: true,
        })
        .unwrap();
        assert!(dir.join("study.png").exists());
        std::fs::remove_dir_all(&dir).ok();
    }
}
