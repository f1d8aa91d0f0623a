//! `hair soak SCENE`: the whole simulation under random salon tool use, checked at every step.
//!
//! A seeded generator fires live events of every kind the facade takes while running
//! (`Simulation::push_tool_event` for each tool's press, move and release, with and without a
//! path; `Simulation::push_camera_key`) at random poses around the hair and at random times
//! within steps. After each step it checks that every value of the state is finite, takes the
//! step's body penetration, and the hair's mechanical energy. Then it resets the simulation and
//! replays the same session (the script holds every event fired), and the binary's global
//! allocator counts each heap allocation made inside a replayed `step`.

mod alloc_count;
mod checks;
mod events;

use alloc_count::{counting_allocations, counting_allocations_untraced};
use checks::{NonFiniteAt, first_non_finite_of, lowest_height, mechanical_energy};
use events::{EventMaker, Fired, HairBox};
use hair::{LodPolicy, Scene, Simulation, Tool};
use serde::Serialize;
use std::collections::BTreeMap;

/// What `allocations_after_warmup` counts, printed by `hair soak --help`.
const ALLOCATIONS_HELP: &str = "\
    What allocations_after_warmup counts: heap allocations (alloc, alloc_zeroed, realloc, on \
    any thread) made inside `Simulation::step` calls of the replay, the warm-up being the live pass. \
    The live pass fires the random events and its steps grow the buffers (grid cells, tool hits, \
    bonds, cut pieces) to the session's high-water marks, which the project allows; the replay, \
    after `Simulation::reset`, runs the same steps (same state hash at every step, checked) and \
    must take no memory at all. Firing an event (`push_tool_event`, `push_camera_key`) happens \
    outside any step and is not counted: it appends to the script, whose `Vec` grows now and \
    then (a path is a `Vec` of its own). The events a step applies (a snip, a grab, spray bonds) \
    run inside it and are counted, except in the steps where a snip cuts hair: each piece cut \
    off becomes a new skeleton built from temporary vectors (five allocations a piece in \
    `StrandState::cut`), so those steps are counted apart (`allocations_in_cut_steps`). The live \
    pass's own allocations inside steps after its first `--warmup` steps are reported too \
    (`live_allocations`): growth to new high-water marks as the random tools reach further.";

/// Arguments of `hair soak` (`ALLOCATIONS_HELP` says what is counted as an allocation).
#[derive(Debug, clap::Args)]
#[command(after_long_help = ALLOCATIONS_HELP)]
pub struct Args {
    /// A built-in scene name (`hair scenes` lists them) or a scene file (.ron). Its own tool
    /// script is dropped: the soak's random events replace it.
    pub scene: String,
    /// Steps to simulate.
    #[arg(long, default_value_t = 2000)]
    pub steps: u64,
    /// Seed of the event generator (the scene keeps its own seed for the hairstyle).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Steps of the live pass whose allocations are left out of `live_allocations.later`.
    #[arg(long, default_value_t = 200)]
    pub warmup: u64,
    /// Mean steps between two firings of events (each fires one to three events).
    #[arg(long, default_value_t = 8.0)]
    pub event_interval: f64,
    /// LOD policy: fine, adaptive, coarse-strands, clusters, strips (default: the scene's own).
    #[arg(long)]
    pub lod: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

// ---------------------------------------------------------------------------------------------
// The soak.

/// What stopped a soak: the scene, an event the simulation refused, or a step that failed.
#[derive(Debug, thiserror::Error)]
pub enum SoakError {
    /// The scene did not load or build.
    #[error("scene `{scene}`: {source}")]
    Scene {
        /// The scene.
        scene: String,
        /// Why.
        source: anyhow::Error,
    },
    /// The simulation refused a generated event (the generator makes only valid ones).
    #[error("step {step}: the simulation refused event {event}: {source}")]
    Event {
        /// The step it was fired before.
        step: u64,
        /// The event (debug form).
        event: String,
        /// Why.
        source: hair::HairError,
    },
    /// A step of the replay failed (the live pass took it).
    #[error("replayed step {step} failed: {source}")]
    Replay {
        /// The step.
        step: u64,
        /// Why.
        source: hair::HairError,
    },
    /// A step failed.
    #[error("step {step} failed (events fired before it: {events}): {source}")]
    Step {
        /// The step.
        step: u64,
        /// The events fired just before it (debug form), or `none`.
        events: String,
        /// Why.
        source: hair::HairError,
    },
}

/// Events fired, by tool and action, and camera keys.
#[derive(Debug, Serialize)]
pub struct EventCounts {
    /// Per tool (`water`, `spray`, `mousse`, `dryer`, `grab`, `scissors`): press, move, release.
    pub tools: BTreeMap<&'static str, ActionCounts>,
    /// Camera keys pushed.
    pub camera: u64,
    /// Tool events that carried a path (later poses).
    pub with_path: u64,
    /// Every event.
    pub total: u64,
}

/// Events of one tool by action.
#[derive(Debug, Serialize)]
pub struct ActionCounts {
    /// Presses.
    pub press: u64,
    /// Moves.
    #[serde(rename = "move")]
    pub moves: u64,
    /// Releases.
    pub release: u64,
}

/// Heap allocations inside the live pass's `step` calls.
#[derive(Debug, Serialize)]
pub struct LiveAllocations {
    /// Steps counted as `first`.
    pub first_steps: u64,
    /// In the first steps.
    pub first: u64,
    /// In the steps after them.
    pub later: u64,
    /// Steps after them that allocated, the first few (step, allocations).
    pub later_steps: Vec<(u64, u64)>,
}

/// What `hair soak` reports.
#[derive(Debug, Serialize)]
pub struct SoakReport {
    /// Scene name.
    pub scene: String,
    /// LOD policy.
    pub lod: String,
    /// Steps simulated.
    pub steps: u64,
    /// Seed of the event generator.
    pub seed: u64,
    /// Worker threads.
    pub threads: usize,
    /// Steps after which some value of the state was not finite.
    pub non_finite: u64,
    /// The first of them: its step, and the field and node.
    pub first_non_finite: Option<NonFiniteAt>,
    /// Deepest node inside the body over the steps after the depenetration ramp (m), as
    /// `hair run` reports it.
    pub max_penetration_m: f64,
    /// The scene's penetration tolerance (m).
    pub tolerance_m: f64,
    /// Largest mechanical energy (kinetic plus gravity above the start's lowest node) over the
    /// steps, against the start's. Water, the dryer and grab add energy legitimately.
    pub max_energy_ratio: f64,
    /// The mechanical energy at the start (J).
    pub start_energy_j: f64,
    /// Events fired.
    pub events: EventCounts,
    /// Heap allocations inside the replay's `step` calls (the live pass is the warm-up), but
    /// for the steps that cut hair.
    pub allocations_after_warmup: u64,
    /// Replayed steps in which a snip cut hair (each piece a new skeleton).
    pub cut_steps: u64,
    /// Heap allocations inside those steps.
    pub allocations_in_cut_steps: u64,
    /// Replayed steps that allocated, the first few (step, allocations).
    pub allocating_steps: Vec<(u64, u64)>,
    /// Whether every replayed step reached the live pass's state hash (else the replay is
    /// another run and its count proves nothing).
    pub replay_matches: bool,
    /// Allocations inside the live pass's steps: growth to high-water marks.
    pub live_allocations: LiveAllocations,
    /// Salon counters at the end.
    pub salon: hair::SalonStats,
    /// Hash of the final state (hex).
    pub state_hash: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl SoakReport {
    /// Whether every check held: no non-finite state, penetration within the tolerance, no
    /// allocation in the replay, which matches the live pass.
    pub fn passed(&self) -> bool {
        self.non_finite == 0
            && self.max_penetration_m <= self.tolerance_m
            && self.allocations_after_warmup == 0
            && self.replay_matches
    }
}

/// Most allocating steps listed.
const LISTED: usize = 10;

/// Runs the soak.
pub fn soak(args: &Args) -> Result<SoakReport, SoakError> {
    let scene_error = |source: anyhow::Error| SoakError::Scene {
        scene: args.scene.clone(),
        source,
    };
    let mut loaded = Scene::load(&args.scene).map_err(|e| scene_error(e.into()))?;
    // The soak's events replace the scene's script (they would be out of time order with it).
    loaded.scene.tools.events.clear();
    let policy = match &args.lod {
        Some(name) => LodPolicy::from_name(name)
            .ok_or_else(|| scene_error(anyhow::anyhow!("unknown LOD policy `{name}`")))?,
        None => loaded.scene.lod,
    };
    let threads = args
        .threads
        .unwrap_or_else(rayon::current_num_threads)
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| scene_error(e.into()))?;
    alloc_count::trace_from_env();
    let started = std::time::Instant::now();
    // Steps run inside the pool, as `hair run` does: rayon takes no memory for them there.
    pool.install(|| {
        let sim = Simulation::new(&loaded, policy).map_err(|e| scene_error(e.into()))?;
        let hair = HairBox::of(&sim.render_geometry().positions)
            .ok_or_else(|| scene_error(anyhow::anyhow!("the hair has no extent to aim at")))?;
        let mut maker = EventMaker::new(args.seed, hair);
        run_steps(args, sim, &mut maker, &loaded.scene, started)
    })
    .map(|mut report| {
        report.lod = policy.name().into();
        report.threads = threads;
        report
    })
}

/// The step loop of [`soak`].
fn run_steps(
    args: &Args,
    mut sim: Simulation,
    maker: &mut EventMaker,
    scene: &Scene,
    started: std::time::Instant,
) -> Result<SoakReport, SoakError> {
    let gravity = scene.dynamics.gravity;
    let floor = lowest_height(&sim, gravity);
    let start_energy = mechanical_energy(&sim, gravity, floor);
    let ramp = u64::from(scene.collision.depenetration_steps);
    let fire_chance = 1.0 / args.event_interval.max(1.0);
    let (mut non_finite, mut first_non_finite) = (0u64, None);
    let (mut max_pen, mut max_energy) = (0.0f64, start_energy);
    let (mut after, mut during) = (0u64, 0u64);
    let mut later_steps = Vec::with_capacity(LISTED);
    let mut hashes = Vec::with_capacity(args.steps as usize);

    let mut last_stats = hair::StepStats::default();
    for step in 0..args.steps {
        // What was fired before the step, kept without allocating, written out only on an error.
        let mut fired: [Option<Fired>; 3] = [None; 3];
        if maker.rng.chance(fire_chance) {
            // One to three events at sorted random times within the step, never on its ends.
            let n = 1 + maker.rng.below(3);
            let mut at = [0.0f32; 3];
            for a in &mut at[..n] {
                *a = maker.rng.range(0.1, 0.9);
            }
            at[..n].sort_by(f32::total_cmp);
            for (slot, &fraction) in fired.iter_mut().zip(&at[..n]) {
                let time = sim.time() + fraction * sim.dt();
                let refused = |fired: Fired, source| SoakError::Event {
                    step,
                    event: format!("{fired:?}"),
                    source,
                };
                let this = match maker.event(time) {
                    Ok(event) => {
                        let this = Fired::of(&event);
                        maker.took(&event);
                        sim.push_tool_event(event).map_err(|e| refused(this, e))?;
                        this
                    }
                    Err(key) => {
                        sim.push_camera_key(key)
                            .map_err(|e| refused(Fired::Camera(key), e))?;
                        maker.camera_keys += 1;
                        Fired::Camera(key)
                    }
                };
                *slot = Some(this);
            }
        }
        let (result, allocations) = counting_allocations_untraced(|| sim.step());
        let stats = result.map_err(|source| SoakError::Step {
            step,
            events: if fired[0].is_none() {
                "none".into()
            } else {
                let all = fired.iter().flatten().map(|f| format!("{f:?}"));
                all.collect::<Vec<_>>().join("; ")
            },
            source,
        })?;
        if step < args.warmup {
            during += allocations;
        } else if allocations > 0 {
            after += allocations;
            if later_steps.len() < LISTED {
                later_steps.push((step, allocations));
            }
        }
        if let Some(bad) = first_non_finite_of(&sim, &stats) {
            non_finite += 1;
            first_non_finite.get_or_insert(NonFiniteAt { step, value: bad });
        }
        if step >= ramp {
            max_pen = max_pen.max(stats.max_penetration_m);
        }
        max_energy = max_energy.max(mechanical_energy(&sim, gravity, floor));
        hashes.push(stats.state_hash);
        last_stats = stats;
    }
    let live_hash = sim.state_hash();
    // The replay: the same session from the start, every buffer at its high-water mark.
    sim.reset();
    let (mut replayed, mut allocating_steps) = (0u64, Vec::with_capacity(LISTED));
    let (mut cut_steps, mut in_cut_steps, mut cuts) = (0u64, 0u64, 0u64);
    let mut replay_matches = true;
    for (step, &live) in (0..).zip(&hashes) {
        let (result, allocations) = counting_allocations(|| sim.step());
        let stats = result.map_err(|source| SoakError::Replay { step, source })?;
        replay_matches &= stats.state_hash == live;
        if stats.salon.cuts > cuts {
            cuts = stats.salon.cuts;
            cut_steps += 1;
            in_cut_steps += allocations;
            continue;
        }
        replayed += allocations;
        if allocations > 0 && allocating_steps.len() < LISTED {
            allocating_steps.push((step, allocations));
        }
    }
    replay_matches &= sim.state_hash() == live_hash;
    let counts = &maker.counts;
    let tools = Tool::ALL.iter().map(|&t| {
        let [press, moves, release] = counts[t as usize];
        let c = ActionCounts {
            press,
            moves,
            release,
        };
        (t.name(), c)
    });
    let tool_total: u64 = counts.iter().flatten().sum();
    Ok(SoakReport {
        scene: scene.name.clone(),
        lod: String::new(),
        steps: args.steps,
        seed: args.seed,
        threads: 0,
        non_finite,
        first_non_finite,
        max_penetration_m: max_pen,
        tolerance_m: f64::from(scene.collision.tolerance),
        max_energy_ratio: max_energy / start_energy,
        start_energy_j: start_energy,
        events: EventCounts {
            tools: tools.collect(),
            camera: maker.camera_keys,
            with_path: maker.paths,
            total: tool_total + maker.camera_keys,
        },
        allocations_after_warmup: replayed,
        cut_steps,
        allocations_in_cut_steps: in_cut_steps,
        allocating_steps,
        replay_matches,
        live_allocations: LiveAllocations {
            first_steps: args.warmup.min(args.steps),
            first: during,
            later: after,
            later_steps,
        },
        salon: last_stats.salon,
        state_hash: format!("{live_hash:016x}"),
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Runs the command: the report as JSON or a table; an error when a check failed.
pub fn run(args: Args) -> anyhow::Result<()> {
    let report = soak(&args)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    if !report.passed() {
        anyhow::bail!(
            "soak of `{}` failed its checks: non_finite {}, max_penetration_m {:.3e} (tolerance \
             {:.3e}), allocations_after_warmup {}, replay_matches {}",
            report.scene,
            report.non_finite,
            report.max_penetration_m,
            report.tolerance_m,
            report.allocations_after_warmup,
            report.replay_matches
        );
    }
    Ok(())
}

fn print_table(r: &SoakReport) {
    println!("soak of {} ({} LOD, {} threads)", r.scene, r.lod, r.threads);
    let live = &r.live_allocations;
    let rows: [(&str, String); 12] = [
        ("steps", r.steps.to_string()),
        ("seed", r.seed.to_string()),
        ("non_finite", r.non_finite.to_string()),
        ("max_penetration_m", format!("{:.3e}", r.max_penetration_m)),
        ("tolerance_m", format!("{:.3e}", r.tolerance_m)),
        ("max_energy_ratio", format!("{:.4}", r.max_energy_ratio)),
        ("start_energy_j", format!("{:.4e}", r.start_energy_j)),
        (
            "allocations_after_warmup",
            r.allocations_after_warmup.to_string(),
        ),
        ("replay_matches", r.replay_matches.to_string()),
        (
            "allocations_in_cut_steps",
            format!("{} in {} steps", r.allocations_in_cut_steps, r.cut_steps),
        ),
        (
            "live_allocations",
            format!(
                "{} in the first {} steps, {} later",
                live.first, live.first_steps, live.later
            ),
        ),
        ("seconds", format!("{:.1}", r.seconds)),
    ];
    for (name, value) in rows {
        println!("  {name:26} {value}");
    }
    if let Some(at) = r.first_non_finite {
        let (step, bad) = (at.step, at.value);
        println!(
            "  first non-finite: step {step}, {} of node {}",
            bad.field, bad.node
        );
    }
    println!(
        "  {:10} {:>7} {:>7} {:>7}",
        "events", "press", "move", "release"
    );
    for (tool, c) in &r.events.tools {
        println!("  {tool:10} {:>7} {:>7} {:>7}", c.press, c.moves, c.release);
    }
    println!(
        "  camera keys {}, with a path {}, total {}",
        r.events.camera, r.events.with_path, r.events.total
    );
    let s = &r.salon;
    println!(
        "  salon: cuts {}, snips {}, bonds made {}, fallen {}, swept {}, water {:.3e} kg",
        s.cuts, s.snips, s.bonds_made, s.fallen, s.swept, s.water_kg
    );
}

#[cfg(test)]
mod tests;
