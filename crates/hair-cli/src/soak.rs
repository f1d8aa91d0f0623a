//! `hair soak SCENE`: the whole simulation under random salon tool use, checked at every step.
//!
//! A seeded generator fires live events of every kind the facade takes while running
//! (`Simulation::push_tool_event` for each tool's press, move and release, with and without a
//! path; `Simulation::push_camera_key`) at random poses around the hair and at random times
//! within steps. After each step it checks that every value of the state is finite, takes the
//! step's body penetration, and the hair's mechanical energy. Then it resets the simulation and
//! replays the same session (the script holds every event fired), and the binary's global
//! allocator counts each heap allocation made inside a replayed `step`.

use hair::dynamics::{SkeletonId, StrandState};
use hair::scene::CameraKey;
use hair::{LodPolicy, Pose, PoseKey, Scene, Simulation, Tool, ToolAction, ToolEvent};
use serde::Serialize;
use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};

/// Arguments of `hair soak`.
///
/// What `allocations_after_warmup` counts: heap allocations (alloc, alloc_zeroed, realloc, on
/// any thread) made inside `Simulation::step` calls of the replay, the warm-up being the live
/// pass. The live pass fires the random events and its steps grow the buffers (grid cells,
/// tool hits, bonds, cut pieces) to the session's high-water marks, which the project allows;
/// the replay, after `Simulation::reset`, runs the same steps (same state hash at every step,
/// checked) and must take no memory at all. Firing an event (`push_tool_event`,
/// `push_camera_key`) happens outside any step and is not counted: it appends to the script,
/// whose `Vec` grows now and then (a path is a `Vec` of its own). The events a step applies (a
/// snip, a grab, spray bonds) run inside it and are counted, except in the steps where a snip
/// cuts hair: each piece cut off becomes a new skeleton built from temporary vectors (five
/// allocations a piece in `StrandState::cut`), so those steps are counted apart
/// (`allocations_in_cut_steps`). The live pass's own allocations
/// inside steps after its first `--warmup` steps are reported too (`live_allocations`): growth
/// to new high-water marks as the random tools reach further.
#[derive(Debug, clap::Args)]
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
// Counting allocator: counts only while `COUNTING` is set, so every other command pays one
// relaxed load per allocation and nothing else.

struct CountingAllocator;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

/// Set by `HAIR_TRACE_ALLOCATIONS`: each allocation of a replayed step prints where it was made
/// (the printing allocates too: the counts are then larger).
static TRACING: AtomicBool = AtomicBool::new(false);

thread_local! {
    /// Set while this thread prints a trace, whose own allocations are not traced.
    static PRINTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn note_allocation() {
    if COUNTING.load(Relaxed) {
        ALLOCATIONS.fetch_add(1, Relaxed);
        if TRACING.load(Relaxed) && !PRINTING.with(|p| p.replace(true)) {
            let trace = std::backtrace::Backtrace::force_capture().to_string();
            let ours = trace
                .lines()
                .filter(|l| l.contains("at ./") && !l.contains("soak.rs"));
            let ours: Vec<&str> = ours.take(5).map(str::trim).collect();
            eprintln!("allocation in a step: {}", ours.join(" < "));
            PRINTING.with(|p| p.set(false));
        }
    }
}

// SAFETY: every call is passed to the system allocator unchanged; only a counter is added.
#[expect(
    unsafe_code,
    reason = "a counting global allocator must implement the unsafe GlobalAlloc trait"
)]
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: the caller's contract is the system allocator's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Runs `f` and returns its result with the allocations made meanwhile (on every thread).
fn counting_allocations<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let before = ALLOCATIONS.load(Relaxed);
    COUNTING.store(true, Relaxed);
    let out = f();
    COUNTING.store(false, Relaxed);
    (out, ALLOCATIONS.load(Relaxed) - before)
}

/// [`counting_allocations`] with tracing held off (the live pass's growth is allowed).
fn counting_allocations_untraced<T>(f: impl FnOnce() -> T) -> (T, u64) {
    let tracing = TRACING.swap(false, Relaxed);
    let out = counting_allocations(f);
    TRACING.store(tracing, Relaxed);
    out
}

// ---------------------------------------------------------------------------------------------
// Generator.

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, well-mixed, seedable generator; the soak
/// needs reproducible streams, not cryptographic ones.
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f32 {
        (lo + (hi - lo) * self.unit()) as f32
    }
    fn below(&mut self, n: usize) -> usize {
        (self.unit() * n as f64) as usize % n
    }
    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    /// Uniform on the unit sphere.
    fn direction(&mut self) -> [f32; 3] {
        let z = 2.0 * self.unit() - 1.0;
        let a = std::f64::consts::TAU * self.unit();
        let r = (1.0 - z * z).max(0.0).sqrt();
        [(r * a.cos()) as f32, (r * a.sin()) as f32, z as f32]
    }
}

/// The hair's axis-aligned box at the start (world frame): where the tools aim.
#[derive(Clone, Copy, Debug)]
struct HairBox {
    center: [f32; 3],
    half: [f32; 3],
    radius: f32,
}

impl HairBox {
    fn of(points: &[hair::ssv::Point]) -> Option<Self> {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let half: [f32; 3] = std::array::from_fn(|k| 0.5 * (hi[k] - lo[k]));
        let radius = half.iter().map(|h| h * h).sum::<f32>().sqrt();
        (radius.is_finite() && radius > 0.0).then(|| Self {
            center: std::array::from_fn(|k| 0.5 * (lo[k] + hi[k])),
            half,
            radius,
        })
    }
}

/// Kinds of events the soak fires: each tool's press, move and release, and camera keys.
const KINDS: usize = Tool::ALL.len() + 1;

/// Draws the random events and keeps which tools are pressed, so that every event it makes is
/// one the script accepts (a move or release only of a pressed tool).
struct EventMaker {
    rng: SplitMix64,
    hair: HairBox,
    pressed: [bool; 6],
    /// Per tool, events fired by action (press, move, release); then camera keys.
    counts: [[u64; 3]; 6],
    camera_keys: u64,
    paths: u64,
}

impl EventMaker {
    fn pose(&mut self, tool: Tool) -> Pose {
        let (c, h, r) = (self.hair.center, self.hair.half, self.hair.radius);
        let out = self.rng.direction();
        let dist = self.rng.range(0.5, 1.4) * r;
        let position = std::array::from_fn(|k| c[k] + out[k] * dist);
        // Mostly aimed at a point of the hair's box, now and then anywhere.
        let direction = if self.rng.chance(0.85) {
            let aim: [f32; 3] = std::array::from_fn(|k| c[k] + h[k] * self.rng.range(-1.0, 1.0));
            let d: [f32; 3] = std::array::from_fn(|k| aim[k] - position[k]);
            if d.iter().any(|x| x.abs() > 1e-6) {
                d
            } else {
                self.rng.direction()
            }
        } else {
            self.rng.direction()
        };
        let mut up = self.rng.direction();
        if tool == Tool::Scissors {
            // The blades' plane needs `up` away from the direction.
            let n = |v: &[f32; 3]| v.iter().map(|x| x * x).sum::<f32>().sqrt();
            let cross = [
                up[1] * direction[2] - up[2] * direction[1],
                up[2] * direction[0] - up[0] * direction[2],
                up[0] * direction[1] - up[1] * direction[0],
            ];
            if n(&cross) <= 0.1 * n(&direction) {
                up = [-direction[1], direction[0], 0.0];
                if n(&up) <= 0.1 * n(&direction) {
                    up = [0.0, -direction[2], direction[1]];
                }
            }
        }
        Pose {
            position,
            direction,
            up,
        }
    }

    /// A random event of a random kind at `time`: `Ok` a tool event, `Err` a camera key.
    fn event(&mut self, time: f32) -> Result<ToolEvent, CameraKey> {
        let kind = self.rng.below(KINDS);
        let Some(&tool) = Tool::ALL.get(kind) else {
            let c = self.hair.center;
            let out = self.rng.direction();
            let dist = self.rng.range(2.0, 5.0) * self.hair.radius;
            let jitter = 0.3 * self.hair.radius;
            return Err(CameraKey {
                time,
                eye: std::array::from_fn(|k| c[k] + out[k] * dist),
                target: std::array::from_fn(|k| c[k] + jitter * self.rng.range(-1.0, 1.0)),
            });
        };
        let i = tool as usize;
        let action = match (self.pressed[i], self.rng.chance(0.6)) {
            (false, _) => ToolAction::Press,
            (true, true) => ToolAction::Move,
            (true, false) => ToolAction::Release,
        };
        let pose = self.pose(tool);
        let mut path = Vec::new();
        if action != ToolAction::Release && self.rng.chance(0.3) {
            let mut t = time;
            for _ in 0..1 + self.rng.below(3) {
                t += self.rng.range(0.05, 1.0);
                path.push(PoseKey {
                    time: t,
                    pose: self.pose(tool),
                });
            }
        }
        Ok(ToolEvent {
            time,
            tool,
            action,
            pose,
            path,
            strength: self.rng.range(0.2, 2.0),
            reach: self.rng.range(0.05, 0.5),
            angle: self.rng.range(0.05, 0.7),
        })
    }

    /// Notes an event the simulation took.
    fn took(&mut self, event: &ToolEvent) {
        let i = event.tool as usize;
        let a = match event.action {
            ToolAction::Press => 0,
            ToolAction::Move => 1,
            ToolAction::Release => 2,
        };
        self.pressed[i] = event.action != ToolAction::Release;
        self.counts[i][a] += 1;
        self.paths += u64::from(!event.path.is_empty());
    }
}

// ---------------------------------------------------------------------------------------------
// Checks.

/// A value of the state that is not finite: which field, at which node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct NonFinite {
    /// The field (`positions`, `theta`, ..., `salon.stiffness`).
    pub field: &'static str,
    /// Its node (global index in the state).
    pub node: usize,
}

/// A non-finite value after a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct NonFiniteAt {
    /// The step.
    pub step: u64,
    /// The value.
    #[serde(flatten)]
    pub value: NonFinite,
}

/// The first value of `state` (every node, active or not) or of the salon's per-node factors
/// that is not finite.
pub fn first_non_finite(state: &StrandState, salon: Option<&hair::Salon>) -> Option<NonFinite> {
    fn scan<T: Copy>(
        field: &'static str,
        values: &[T],
        finite: impl Fn(T) -> bool,
    ) -> Option<NonFinite> {
        let node = values.iter().position(|&v| !finite(v))?;
        Some(NonFinite { field, node })
    }
    let scalar = |v: f32| v.is_finite();
    let vector = |v: hair::dynamics::Vector| v.iter().all(|x| x.is_finite());
    let point = |p: hair::ssv::Point| p.iter().all(|x| x.is_finite());
    let s = state;
    scan("positions", s.positions(), point)
        .or_else(|| scan("velocities", s.velocities(), vector))
        .or_else(|| scan("theta", s.theta(), scalar))
        .or_else(|| scan("phi", s.phi(), scalar))
        .or_else(|| scan("omega_theta", s.omega_theta(), scalar))
        .or_else(|| scan("omega_phi", s.omega_phi(), scalar))
        .or_else(|| scan("rest_theta", s.rest_theta(), scalar))
        .or_else(|| scan("rest_phi", s.rest_phi(), scalar))
        .or_else(|| scan("length", s.length(), scalar))
        .or_else(|| scan("rest_length", s.rest_length(), scalar))
        .or_else(|| scan("mass", s.mass(), scalar))
        .or_else(|| scan("wetness", s.wetness(), scalar))
        .or_else(|| scan("k_theta", s.k_theta(), scalar))
        .or_else(|| scan("k_phi", s.k_phi(), scalar))
        .or_else(|| scan("k_stretch", s.k_stretch(), scalar))
        .or_else(|| scan("damping", s.damping(), scalar))
        .or_else(|| scan("radius", s.radius(), scalar))
        .or_else(|| scan("external_force", s.external_force(), vector))
        .or_else(|| {
            scan(
                "salon.stiffness",
                salon.map_or(&[][..], |x| x.stiffness()),
                scalar,
            )
        })
        .or_else(|| {
            scan(
                "salon.thickness",
                salon.map_or(&[][..], |x| x.thickness()),
                scalar,
            )
        })
}

/// Mechanical energy of the simulated hair (J): kinetic plus the potential of gravity above
/// `floor` (m, along `-gravity`), over the front's skeletons and the unswept fallen pieces,
/// each node's mass its dry mass plus its water, times the strands its skeleton stands for.
fn mechanical_energy(sim: &Simulation, gravity: [f32; 3], floor: f64) -> f64 {
    let (state, h) = (sim.state(), sim.hierarchy());
    let g = nalgebra::Vector3::from(gravity).cast::<f64>();
    let g_norm = g.norm();
    let up = if g_norm > 0.0 {
        -g / g_norm
    } else {
        nalgebra::Vector3::zeros()
    };
    let (m, w, x, v) = (
        state.mass(),
        state.wetness(),
        state.positions(),
        state.velocities(),
    );
    let skeleton = |id: SkeletonId, strands: u32| -> f64 {
        let e: f64 = state
            .nodes(id)
            .map(|i| {
                let mass = f64::from(m[i] + w[i]);
                let height = up.dot(&x[i].coords.cast::<f64>()) - floor;
                mass * (0.5 * f64::from(v[i].norm_squared()) + g_norm * height)
            })
            .sum();
        e * f64::from(strands)
    };
    let front: f64 = sim
        .front_nodes()
        .iter()
        .map(|&n| skeleton(SkeletonId(n), h.strand_count(n)))
        .sum();
    let fallen: f64 = sim
        .salon()
        .fallen_pieces()
        .filter(|f| !f.swept)
        .map(|f| skeleton(f.skeleton, h.strand_count(f.source)))
        .sum();
    front + fallen
}

/// The lowest height (m, along `-gravity`) of the front's nodes: the energy's zero.
fn lowest_height(sim: &Simulation, gravity: [f32; 3]) -> f64 {
    let g = nalgebra::Vector3::from(gravity).cast::<f64>();
    let up = g
        .try_normalize(0.0)
        .map_or_else(nalgebra::Vector3::zeros, |g| -g);
    let state = sim.state();
    sim.front_nodes()
        .iter()
        .flat_map(|&n| state.nodes(SkeletonId(n)))
        .map(|i| up.dot(&state.positions()[i].coords.cast::<f64>()))
        .fold(f64::INFINITY, f64::min)
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
    TRACING.store(
        std::env::var_os("HAIR_TRACE_ALLOCATIONS").is_some(),
        Relaxed,
    );
    let started = std::time::Instant::now();
    // Steps run inside the pool, as `hair run` does: rayon takes no memory for them there.
    pool.install(|| {
        let sim = Simulation::new(&loaded, policy).map_err(|e| scene_error(e.into()))?;
        let hair = HairBox::of(&sim.render_geometry().positions)
            .ok_or_else(|| scene_error(anyhow::anyhow!("the hair has no extent to aim at")))?;
        let mut maker = EventMaker {
            rng: SplitMix64(args.seed),
            hair,
            pressed: [false; 6],
            counts: [[0; 3]; 6],
            camera_keys: 0,
            paths: 0,
        };
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

/// An event fired, without its path (a copy that takes no memory).
#[derive(Clone, Copy, Debug)]
#[expect(dead_code, reason = "read only through Debug, in error messages")]
enum Fired {
    /// A tool event.
    Tool {
        time: f32,
        tool: Tool,
        action: ToolAction,
        pose: Pose,
        path_keys: usize,
        strength: f32,
        reach: f32,
        angle: f32,
    },
    /// A camera key.
    Camera(CameraKey),
}

impl Fired {
    fn of(e: &ToolEvent) -> Self {
        Fired::Tool {
            time: e.time,
            tool: e.tool,
            action: e.action,
            pose: e.pose,
            path_keys: e.path.len(),
            strength: e.strength,
            reach: e.reach,
            angle: e.angle,
        }
    }
}

/// The first non-finite value after a step: of the state, the salon's factors or the step's
/// own figures (penetration, kinetic energy).
fn first_non_finite_of(sim: &Simulation, stats: &hair::StepStats) -> Option<NonFinite> {
    first_non_finite(sim.state(), Some(sim.salon())).or_else(|| {
        let figures = [
            ("stats.max_penetration_m", stats.max_penetration_m),
            ("stats.kinetic_energy", stats.kinetic_energy),
        ];
        let (field, _) = figures.into_iter().find(|(_, v)| !v.is_finite())?;
        Some(NonFinite { field, node: 0 })
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
mod tests {
    use super::*;
    use hair::scene::{BodySpec, HairstyleSpec};

    fn small_salon() -> Simulation {
        let mut loaded = Scene::load("salon").expect("built-in salon");
        loaded.scene.tools.events.clear();
        if let HairstyleSpec::Procedural(p) = &mut loaded.scene.hairstyle {
            p.strands = 40;
        }
        loaded.scene.body = BodySpec::Head { resolution: 12 };
        Simulation::new(&loaded, LodPolicy::Fine).expect("the scene builds")
    }

    #[test]
    fn splitmix_gives_the_reference_stream() {
        // The first outputs of SplitMix64 from seed 0 (Vigna's reference `splitmix64.c`).
        let mut rng = SplitMix64(0);
        assert_eq!(rng.next_u64(), 0xe220_a839_7b1d_cdaf);
        assert_eq!(rng.next_u64(), 0x6e78_9e6a_a1b9_65f4);
    }

    #[test]
    fn a_non_finite_value_anywhere_in_the_state_is_found() {
        let sim = small_salon();
        assert_eq!(first_non_finite(sim.state(), Some(sim.salon())), None);
        let n = sim.state().node_count();
        for (node, value) in [
            (0, f32::NAN),
            (n / 2, f32::INFINITY),
            (n - 1, f32::NEG_INFINITY),
        ] {
            let mut state = sim.state().clone();
            state.omega_phi_mut()[node] = value;
            let found = first_non_finite(&state, None);
            assert_eq!(
                found,
                Some(NonFinite {
                    field: "omega_phi",
                    node
                })
            );
            let mut state = sim.state().clone();
            state.external_force_mut()[node].y = value;
            let found = first_non_finite(&state, None).map(|f| f.field);
            assert_eq!(found, Some("external_force"));
        }
    }

    #[test]
    fn every_generated_event_is_one_the_script_accepts() {
        let sim = small_salon();
        let hair = HairBox::of(&sim.render_geometry().positions).expect("hair");
        let mut maker = EventMaker {
            rng: SplitMix64(7),
            hair,
            pressed: [false; 6],
            counts: [[0; 3]; 6],
            camera_keys: 0,
            paths: 0,
        };
        let mut script = hair::ToolScript::default();
        for k in 0..3000 {
            match maker.event(0.01 * k as f32) {
                Ok(event) => {
                    maker.took(&event);
                    script.events.push(event);
                }
                Err(key) => assert!(key.eye.iter().chain(&key.target).all(|x| x.is_finite())),
            }
        }
        script.validate().expect("a valid script");
        // Every kind came up.
        assert!(
            maker.counts.iter().flatten().all(|&c| c > 0),
            "{:?}",
            maker.counts
        );
        assert!(maker.paths > 0);
    }

    #[test]
    fn the_energy_at_rest_is_the_weight_above_the_lowest_node() {
        let sim = small_salon();
        let g = [0.0, -9.81, 0.0];
        let floor = lowest_height(&sim, g);
        // Lifting the floor by 1 m takes 1 m times the hair's weight from the energy.
        let (state, h) = (sim.state(), sim.hierarchy());
        let weight: f64 = sim
            .front_nodes()
            .iter()
            .flat_map(|&n| state.nodes(SkeletonId(n)).map(move |i| (n, i)))
            .map(|(n, i)| {
                f64::from(h.strand_count(n))
                    * 9.81
                    * f64::from(state.mass()[i] + state.wetness()[i])
            })
            .sum();
        let e0 = mechanical_energy(&sim, g, floor);
        let e1 = mechanical_energy(&sim, g, floor + 1.0);
        assert!(e0 > 0.0);
        assert!(
            ((e0 - e1) - weight).abs() <= 1e-9 * weight,
            "{e0} {e1} {weight}"
        );
        // No gravity, at rest: no energy.
        assert_eq!(mechanical_energy(&sim, [0.0; 3], floor), 0.0);
    }
}
