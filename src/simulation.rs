//! The per-step pipeline (`docs/architecture.md`): each stage one call into the layer that
//! owns it.
//!
//! The hard body constraint runs after integration rather than before it, so the state handed
//! to the renderer and to the next step is never inside the body by more than the stated
//! tolerance.

use crate::lod_stage::{self, LodStage};
use crate::scene::{HeadMotionSpec, LodPolicy, Scene};
use crate::{HairError, LoadedScene, drivers, hairstyle};
use hair_collide::{BodyConstraint, HairHairModel as Model, HairHairStage, Localization};
use hair_collide::{Sections, make_groom_rest};
use hair_dynamics::{Environment, HeadPoseTrack, Material, SkeletonId, StepSettings, StrandState};
use hair_grid::{Grid, GridConfig};
use hair_lod::{Hierarchy, NodeKind};
use hair_render::stage::{DrawnStrands, FallenPiece, RenderGeometry};
use hair_salon::{Salon, SalonInput, SalonStats};
use hair_ssv::{MeshBody, Point, Real};
use nalgebra::Isometry3;
use serde::Serialize;
use std::time::Instant;

/// What one step did and cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StepStats {
    /// Step index (0-based).
    pub step: u64,
    /// Simulated time at the end of the step (s).
    pub time: f64,
    /// Milliseconds in the drivers stage.
    pub ms_drivers: f64,
    /// Milliseconds in LOD selection and transitions.
    pub ms_lod: f64,
    /// Milliseconds building the grid.
    pub ms_grid: f64,
    /// Milliseconds in hair-hair collision.
    pub ms_hair_hair: f64,
    /// Milliseconds integrating.
    pub ms_dynamics: f64,
    /// Milliseconds in hair-object collision.
    pub ms_hair_object: f64,
    /// Milliseconds building render geometry.
    pub ms_render_geometry: f64,
    /// Milliseconds for the whole step.
    pub ms_total: f64,
    /// Skeletons in the LOD front.
    pub skeletons: usize,
    /// Splits the adaptive LOD made this step.
    pub lod_splits: u32,
    /// Merges the adaptive LOD made this step.
    pub lod_merges: u32,
    /// Trees the adaptive LOD holds at their root strip because the camera does not see them
    /// (behind the body or outside the view).
    pub lod_hidden_trees: usize,
    /// Skeletons integrated this step.
    pub active: usize,
    /// Skeletons frozen by localization.
    pub dormant: usize,
    /// Hair-hair pairs tested exactly.
    pub pairs_tested: usize,
    /// Hair-hair pairs in contact (`Pairs`), or nodes the density pushed (`Volume`).
    pub hair_contacts: usize,
    /// Points of the hair-hair volume's dense grid (`Volume`; 0 otherwise).
    pub volume_cells: usize,
    /// Nodes in contact with the body.
    pub body_contacts: usize,
    /// Deepest node inside the body after the hard constraint (m).
    pub max_penetration_m: f64,
    /// Node tests by the exact distance where the field or tables could not be trusted.
    pub body_exact_tests: usize,
    /// Nodes sent out of a thin part of the body to the nearest clear place on their sphere.
    pub body_escapes: usize,
    /// Kinetic energy of the simulated nodes (J).
    pub kinetic_energy: f64,
    /// Skeletons whose structured implicit solve failed its residual check and was redone by the
    /// dense LU (`hair_dynamics::StepReport::dense_fallbacks`).
    pub dense_fallbacks: usize,
    /// Rendered vertices.
    pub render_vertices: usize,
    /// Hash of the state's float bits ([`StrandState::state_hash`]).
    pub state_hash: u64,
    // salon (issue 8): tool counters, flattened into the per-frame metrics.
    /// Salon tool counters (water, bonds, cuts, fallen pieces, grabbed points).
    #[serde(flatten)]
    pub salon: hair_salon::SalonStats,
}

/// A scene being simulated.
pub struct Simulation {
    pub(crate) scene: Scene,
    hierarchy: Hierarchy,
    /// The hierarchy nodes simulated (sorted).
    pub(crate) front_nodes: Vec<u32>,
    pub(crate) state: StrandState,
    /// The state as built, for [`Simulation::reset`].
    initial: StrandState,
    pub(crate) body: Option<MeshBody>,
    pub(crate) settings: StepSettings,
    time: Real,
    pub(crate) steps: u64,
    lod: LodStage,
    grid: Grid,
    /// The front's segments as grid sections.
    sections: Sections,
    localization: Localization,
    hair_hair: HairHairStage,
    pub(crate) body_constraint: BodyConstraint,
    /// Rigid body parts the caller poses (`parts.rs`).
    pub(crate) parts: Vec<crate::parts::BodyPart>,
    salon: Salon,
    /// Per skeleton, its collision radius as built (the salon's tools scale it).
    node_radius: Vec<Real>,
    drawn: DrawnStrands,
    /// World from the head track's frame: the accumulated teleports.
    pub(crate) teleport: Isometry3<Real>,
    /// The head's poses and the motion estimated from them (the track's frame).
    pub(crate) head: HeadPoseTrack,
    /// The head track as built, for [`Simulation::reset`].
    initial_head: HeadPoseTrack,
    /// Time carried from one [`Simulation::advance`] to the next (s).
    accumulator: f64,
    previous_render: Vec<Point>,
    frame_render: RenderGeometry,
}

/// Times the stages of a step.
struct StageClock(Instant);

impl StageClock {
    /// Milliseconds since the last lap (or the start).
    fn lap(&mut self) -> f64 {
        let now = Instant::now();
        let ms = (now - self.0).as_secs_f64() * 1e3;
        self.0 = now;
        ms
    }
}

impl Simulation {
    /// Builds the simulation of a loaded scene with a LOD policy.
    pub fn new(loaded: &LoadedScene, policy: LodPolicy) -> Result<Self, HairError> {
        let scene = &loaded.scene;
        let body = crate::body::from_spec(&scene.body, &loaded.base_dir)?;
        let style = hairstyle::from_spec(&scene.hairstyle, scene.seed, &loaded.base_dir)?;
        Self::build(scene.clone(), style, body, &loaded.source, policy)
    }

    /// Builds the simulation of `scene` with the hairstyle and body given (its own
    /// `hairstyle` and `body` unread); `source` names the scene in errors.
    pub(crate) fn build(
        mut scene: Scene,
        style: hair_lod::Hairstyle,
        body: Option<MeshBody>,
        source: &str,
        policy: LodPolicy,
    ) -> Result<Self, HairError> {
        if scene.camera.keys.is_empty() {
            scene
                .camera
                .keys
                .push(fitted_camera(&scene, &style, body.as_ref()));
        }
        let bad_style = |message: String| HairError::SceneValue {
            file: source.into(),
            field: "hairstyle".into(),
            message,
        };
        let hierarchy = Hierarchy::build(&style, &scene.hierarchy.params())
            .map_err(|e| bad_style(e.to_string()))?;
        let per = style.strands[0].points.len();
        if let Some(bad) = style.strands.iter().position(|st| st.points.len() != per) {
            let n = style.strands[bad].points.len();
            return Err(bad_style(format!(
                "strand {bad} has {n} points; every strand needs {per}"
            )));
        }
        let (mut state, node_radius) = skeletons(&scene, &hierarchy)?;
        let front_nodes = lod_stage::fixed_front(&hierarchy, policy);
        let loads = (scene.dynamics.gravity.into(), scene.dynamics.torque);
        let (rest, collision) = (scene.groom_is_its_rest().then_some(loads), &scene.collision);
        let (st, bd) = (&mut state, body.as_ref());
        let (sections, _, constraint) = make_groom_rest(st, bd, &front_nodes, collision, rest)?;
        for s in 0..hierarchy.node_count() as u32 {
            state.set_active(SkeletonId(s), front_nodes.binary_search(&s).is_ok());
        }
        let strand_rest = style
            .strands
            .iter()
            .flat_map(|st| st.points.iter().copied());
        let mut drawn = DrawnStrands::new(strand_rest.collect(), per, 3);
        drawn.prepare(&hierarchy, &state, &front_nodes);
        drawn.set_followers(scene.render_strands as usize, scene.seed);
        let lod = LodStage::new(policy, &scene, &hierarchy, &mut state)?;
        let salon = Salon::new(&scene.tools, &state, &hierarchy, &node_radius);
        let settings = scene
            .dynamics
            .step_settings(scene.frame_rate, scene.substeps);
        // The scene's head path drives the head through the same track a caller's poses do;
        // it was moving a step before the start as the path says.
        let pose = |t: Real| drivers::head_pose(&scene.head_motion, t);
        let head = HeadPoseTrack::with_previous(settings.dt, pose(-settings.dt), pose(0.0))?;
        let localization = Localization::for_model(&scene.collision.hair_hair);
        let mut sim = Self {
            initial: state.clone(),
            scene,
            hierarchy,
            front_nodes,
            state,
            body,
            settings,
            time: 0.0,
            steps: 0,
            lod,
            grid: Grid::new(GridConfig::default()),
            sections,
            localization,
            hair_hair: HairHairStage::new(),
            body_constraint: constraint,
            parts: Vec::new(),
            salon,
            node_radius,
            drawn,
            teleport: Isometry3::identity(),
            initial_head: head.clone(),
            head,
            accumulator: 0.0,
            previous_render: Vec::new(),
            frame_render: RenderGeometry::default(),
        };
        sim.refresh_front();
        if !sim.draw() {
            let strand = sim.drawn.first_undrawable();
            return Err(HairError::NonFiniteRender { step: 0, strand });
        }
        Ok(sim)
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The strand state (every hierarchy node is a skeleton; the LOD front is active).
    pub fn state(&self) -> &StrandState {
        &self.state
    }

    /// The LOD hierarchy.
    pub fn hierarchy(&self) -> &Hierarchy {
        &self.hierarchy
    }

    /// The hierarchy nodes being simulated.
    pub fn front_nodes(&self) -> &[u32] {
        &self.front_nodes
    }

    // salon (issue 8): read access to the tools' state.
    /// The salon tools: pressed tools, grabbed points, fallen pieces, per-node factors.
    pub fn salon(&self) -> &hair_salon::Salon {
        &self.salon
    }

    // view (issue 9): live input for an interactive session, recorded as a replayable script.
    /// A time for a live tool event that the next step applies and a replay of the recorded
    /// script applies at the same step: mid-way through the next step. The salon stage takes
    /// the events before the end of its step, so a time on a step boundary would hang on
    /// rounding; mid-way leaves half a step of margin on both sides.
    pub fn next_event_time(&self) -> Real {
        self.time + 0.5 * self.settings.dt
    }

    /// Appends a live tool event to the running tool script (validated as a script's events
    /// are: in time order, not before the simulated time, moves and releases of pressed tools
    /// only). Use [`Simulation::next_event_time`] for its time; a script of the same events
    /// then replays to the same state.
    pub fn push_tool_event(&mut self, event: hair_salon::ToolEvent) -> Result<(), HairError> {
        self.salon.push_event(event.clone(), self.time)?;
        self.scene.tools.events.push(event);
        Ok(())
    }

    /// Appends a camera keyframe for the adaptive LOD's view (and the scene's camera path):
    /// finite, not before the simulated time nor the last key. Push the held camera at the
    /// current time and the new one at [`Simulation::next_event_time`], and a replay of the
    /// scene's camera path sees exactly the views the live steps saw.
    pub fn push_camera_key(&mut self, key: crate::scene::CameraKey) -> Result<(), HairError> {
        let bad = |message: String| HairError::SceneValue {
            file: "live camera".into(),
            field: "camera.keys".into(),
            message,
        };
        let finite = key.eye.iter().chain(&key.target).all(|x| x.is_finite());
        if !(finite && key.time.is_finite()) {
            return Err(bad("a key must be finite".into()));
        }
        let last = self.scene.camera.keys.last().map_or(0.0, |k| k.time);
        if key.time < self.time || key.time < last {
            return Err(bad(format!(
                "a key at t = {} s is before the simulated time {} s or the last key at {last} s",
                key.time, self.time
            )));
        }
        self.scene.camera.keys.push(key);
        Ok(())
    }

    /// The localization grid as the last step rebuilt it: the front's hair sections (in the
    /// head frame), their cells and the pair search's data. With localization off, the steps
    /// between pair searches (`pair_search_interval` above 1) leave it as the last search built
    /// it, and with `Volume` or `Off` and no tool script, no step builds it.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Runs the grid's pair search with `kernel` (every kernel finds the same pairs in the same
    /// order); an error, and the grid unchanged, when the processor lacks its instructions.
    pub fn set_grid_kernel(&mut self, kernel: hair_grid::Kernel) -> Result<(), HairError> {
        self.grid = Grid::try_new(GridConfig {
            kernel,
            ..GridConfig::default()
        })?;
        Ok(())
    }

    /// Computes ahead the samples of the body's distance field that hair near the surface
    /// reads (`DistanceField::fill_band` on [`MeshBody::field`]): from [`PREFILL_INSIDE`] inside
    /// the surface to the near field's margin outside. The steps otherwise compute each the
    /// first time hair reaches it. Returns how many it computed. For interactive use: it moves
    /// the exact queries out of the first frames, which otherwise run slow. The results are the
    /// same with or without it.
    pub fn prefill_body_field(&self) -> usize {
        let Some(body) = self.body.as_ref() else {
            return 0;
        };
        // Outside, as far as a node is ever queried (the near field's margin); inside, as deep
        // as hair that starts in the body reaches, by and large (deeper samples still come
        // when first read).
        body.field
            .fill_band(body, PREFILL_INSIDE, hair_ssv::NEAR_MARGIN)
    }

    /// The body, if any.
    pub fn body(&self) -> Option<&MeshBody> {
        self.body.as_ref()
    }

    /// The rendered strands (world frame) as of the last step.
    pub fn render_geometry(&self) -> &RenderGeometry {
        self.drawn.output()
    }

    /// The fixed simulation step (s).
    pub fn dt(&self) -> Real {
        self.settings.dt
    }

    /// Simulated time (s).
    pub fn time(&self) -> Real {
        self.time
    }

    /// Advances by a frame of `seconds` (any length: the frame rate is the caller's) in whole
    /// fixed steps, carrying the remainder to the next frame, and pushes each step's stats to
    /// `stats`. [`Simulation::frame_geometry`] then holds the strands blended between the last
    /// two steps by the fraction of a step left over (so drawn motion runs one step behind the
    /// simulation, and stays smooth whatever the ratio of frame to step). Returns the steps
    /// taken.
    pub fn advance(
        &mut self,
        seconds: Real,
        stats: &mut Vec<StepStats>,
    ) -> Result<usize, HairError> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return Err(HairError::SceneValue {
                file: "advance".into(),
                field: "seconds".into(),
                message: format!("a frame must last a finite, non-negative time, got {seconds}"),
            });
        }
        let dt = f64::from(self.settings.dt);
        self.accumulator += f64::from(seconds);
        let mut steps = 0;
        // A frame that is a whole number of steps up to rounding takes them all.
        while self.accumulator >= dt * (1.0 - 1e-6) {
            self.previous_render
                .clone_from(&self.drawn.output().positions);
            stats.push(self.step()?);
            self.accumulator -= dt;
            steps += 1;
        }
        if self.previous_render.len() != self.drawn.output().positions.len() {
            self.previous_render
                .clone_from(&self.drawn.output().positions);
        }
        self.accumulator = self.accumulator.max(0.0);
        let alpha = (self.accumulator / dt).clamp(0.0, 1.0) as Real;
        self.frame_render.subdivisions = self.drawn.output().subdivisions;
        self.frame_render
            .offsets
            .clone_from(&self.drawn.output().offsets);
        self.frame_render.positions.clear();
        // The frame lies `alpha` of a step past the last step: blend from the step before.
        self.frame_render.positions.extend(
            self.previous_render
                .iter()
                .zip(&self.drawn.output().positions)
                .map(|(a, b)| a + (b - a) * alpha),
        );
        Ok(steps)
    }

    /// Which of `points` (world coordinates, as [`Simulation::render_geometry`] gives them) the
    /// camera sees now, by the test the `adaptive` policy selects with: inside the view cone
    /// and not behind the body ([`hair_lod::BodyDepth`]). Written to `out`, one flag per point.
    /// As for that policy, the camera keeps its place relative to the scene's head path, so a
    /// teleport carries what it sees along with the head.
    pub fn seen_by_camera(&self, points: &[Point], out: &mut Vec<bool>) {
        let mut view = lod_stage::view(&self.scene, self.head.current(), self.time);
        // The step's image when it holds this view (`build` then keeps it), else a new one.
        let mut depth = self.lod.body_depth.clone();
        if let Some(body) = &self.body {
            depth.build(lod_stage::occluder(body), &view);
            view.occluder = Some(&depth);
        }
        let head = self.head.motion();
        // The inverse of the render geometry's head-to-world transform.
        let to_head = (self.teleport.rotation.to_rotation_matrix() * head.rotation).inverse();
        let origin = self.teleport * head.position;
        out.clear();
        out.extend(
            points
                .iter()
                .map(|p| view.sees(&Point::from(to_head * (p - origin)))),
        );
    }

    /// The strands at the time of the last [`Simulation::advance`] frame, interpolated between
    /// the two steps around it (the last one's geometry before any `advance`).
    pub fn frame_geometry(&self) -> &RenderGeometry {
        if self.frame_render.positions.is_empty() {
            self.drawn.output()
        } else {
            &self.frame_render
        }
    }

    /// Puts every strand back at rest and the clock at zero. The state is copied into the
    /// buffers already held, so the steps after a reset take no new memory.
    pub fn reset(&mut self) {
        self.state.clone_from(&self.initial);
        self.time = 0.0;
        self.steps = 0;
        self.hair_hair.forget();
        self.localization.clear();
        self.accumulator = 0.0;
        self.head.clone_from(&self.initial_head);
        self.frame_render.positions.clear();
        if self.lod.reset() {
            self.refresh_front();
        }
        self.salon
            .reset(&self.state, &self.hierarchy, &self.node_radius);
        // The initial state, drawn when the simulation was built.
        let _finite = self.draw();
    }

    /// The adaptive policy's front as the sorted node list, and the strands' owners.
    fn refresh_front(&mut self) {
        if !self.lod.is_adaptive() {
            return;
        }
        // Other skeletons, other sections: the kept pairs no longer describe the hair.
        self.hair_hair.forget();
        self.lod.front_into(&self.hierarchy, &mut self.front_nodes);
        self.drawn
            .assign(&self.hierarchy, &self.state, &self.front_nodes);
    }

    /// Simulates one fixed step: the stages in the order they run.
    ///
    /// A step takes no memory once its buffers have grown to what the scene needs (a test
    /// replays each built-in scene after [`Simulation::reset`] and counts every allocation).
    /// That holds when it is called from inside a rayon pool (`ThreadPool::install`, as
    /// `hair run` does); called from any other thread, rayon's queue of outside jobs takes a
    /// small block now and then.
    pub fn step(&mut self) -> Result<StepStats, HairError> {
        let (start, mut clock) = (Instant::now(), StageClock(Instant::now()));
        let mut stats = StepStats {
            step: self.steps,
            ..StepStats::default()
        };
        if self.head.next().is_none() && self.scene.head_motion != HeadMotionSpec::Still {
            let t = self.time + self.settings.dt;
            self.drive_head(drivers::head_pose(&self.scene.head_motion, t))?;
        }
        let env = drivers::environment(&self.scene, self.head.motion(), self.time);
        stats.ms_drivers = clock.lap();
        self.select_lod(&mut stats)?;
        stats.ms_lod = clock.lap();
        self.build_grid()?;
        stats.ms_grid = clock.lap();
        let (state, collision, front) = (&mut self.state, &self.scene.collision, &self.front_nodes);
        let (grid, sections, dt) = (&self.grid, &self.sections, self.settings.dt);
        let r = self
            .hair_hair
            .respond(state, grid, sections, front, collision, dt)?;
        (stats.pairs_tested, stats.hair_contacts) = (r.pairs_tested, r.contacts);
        stats.volume_cells = r.volume_cells;
        stats.ms_hair_hair = clock.lap();
        stats.dense_fallbacks = self.state.step(&env, &self.settings)?.dense_fallbacks;
        self.count_active(&mut stats);
        stats.ms_dynamics = clock.lap();
        stats.salon = self.salon_stage(&env)?;
        stats.salon.ms_salon = clock.lap();
        self.collide_bodies(&mut stats)?;
        stats.ms_hair_object = clock.lap();
        self.time += self.settings.dt;
        self.steps += 1;
        self.head.advance();
        self.draw_step(stats.step)?;
        stats.ms_render_geometry = clock.lap();
        stats.render_vertices = self.drawn.output().vertex_count();
        stats.time = f64::from(self.time);
        stats.kinetic_energy = self.kinetic_energy();
        stats.state_hash = self.state_hash();
        stats.ms_total = (Instant::now() - start).as_secs_f64() * 1e3;
        Ok(stats)
    }

    /// The LOD stage: a fixed front changes nothing; the adaptive one is re-selected.
    fn select_lod(&mut self, stats: &mut StepStats) -> Result<(), HairError> {
        let report = self.lod.select(
            &self.scene,
            self.body.as_ref(),
            &self.hierarchy,
            &mut self.state,
            (self.head.current(), self.time),
            self.localization.frozen(),
        )?;
        if report.changed {
            self.refresh_front();
        }
        stats.lod_splits = report.splits;
        stats.lod_merges = report.merges;
        stats.lod_hidden_trees = report.hidden_trees;
        Ok(())
    }

    /// The grid stage over the front's segments (head frame, where the body is static): the
    /// sections when the pairs, localization or a tool script read them (the volume never
    /// does), the pair grid when the pairs search this step or those two read it, localization.
    fn build_grid(&mut self) -> Result<(), HairError> {
        // The pairs of the last search are tested again while young enough and the hair is the
        // same hair: the same front (a new one drops them) and no tool script (a cut, a bond).
        let reuse_allowed = self.salon.script().events.is_empty();
        let search = self.hair_hair.plan(&self.scene.collision, reuse_allowed);
        let local = self.scene.localization;
        if self.scene.collision.hair_hair == Model::Pairs || local || !reuse_allowed {
            self.sections.build(&self.state, &self.front_nodes);
        }
        if search || local || !reuse_allowed {
            self.grid.rebuild(&self.sections.sections)?;
        }
        if local {
            let (state, touched) = (&mut self.state, self.salon.touched_nodes());
            let (grid, sections, front) = (&self.grid, &self.sections, &self.front_nodes);
            let dt = self.settings.dt;
            self.localization
                .update(state, grid, sections, front, dt, touched)?;
        }
        Ok(())
    }

    /// Counts the front's skeletons, integrated and dormant.
    fn count_active(&self, stats: &mut StepStats) {
        let state = &self.state;
        let active = self.front_nodes.iter();
        let active = active.filter(|&&n| state.is_active(SkeletonId(n))).count();
        stats.skeletons = self.front_nodes.len();
        stats.active = active;
        stats.dormant = self.front_nodes.len() - active;
    }

    /// The salon stage: the tool script's events due and the pressed tools.
    fn salon_stage(&mut self, env: &Environment) -> Result<SalonStats, HairError> {
        let input = SalonInput {
            hierarchy: &self.hierarchy,
            front: &self.front_nodes,
            grid: &self.grid,
            sections: &self.sections.sections,
            body: self.body.as_ref(),
            head: &env.head,
            time: self.time + self.settings.dt,
            dt: self.settings.dt,
            collision: &self.scene.collision,
        };
        Ok(self.salon.step(&mut self.state, &input)?)
    }

    /// The render stage at the end of step `step`: every strand drawn, then the salon's cuts.
    /// A finite state can still be too far out to draw (hair thrown 1e26 m by a huge
    /// gravity): that is an error, not non-finite points handed on.
    fn draw_step(&mut self, step: u64) -> Result<(), HairError> {
        if !self.draw() {
            let strand = self.drawn.first_undrawable();
            return Err(HairError::NonFiniteRender { step, strand });
        }
        let head = self.head.motion();
        let pieces = self.salon.fallen_pieces().filter(|f| !f.swept);
        let fallen = (self.salon.stats().cuts > 0).then_some(pieces.map(|f| FallenPiece {
            skeleton: f.skeleton,
            source: f.source,
            first_source: f.first_source,
        }));
        self.drawn
            .apply_cuts(fallen, &self.state, &self.hierarchy, &head);
        Ok(())
    }

    /// Draws every strand from its front node in world coordinates; false when a control point
    /// is not within drawing range of the origin (non-finite included).
    #[must_use]
    pub(crate) fn draw(&mut self) -> bool {
        let head = self.head.motion();
        // The teleport offset moves the drawn hair with the head, never the dynamics.
        let rot = self.teleport.rotation.to_rotation_matrix() * head.rotation;
        let origin = self.teleport * head.position;
        self.drawn
            .update(&self.hierarchy, &self.state, &rot, &origin)
    }

    /// Kinetic energy of the front's nodes (J, head frame).
    pub fn kinetic_energy(&self) -> f64 {
        self.state.kinetic_energy(&self.front_nodes)
    }

    /// A hash of the state's float bits ([`StrandState::state_hash`]).
    pub fn state_hash(&self) -> u64 {
        self.state.state_hash()
    }
}

/// Every hierarchy node as a skeleton of a new state, with the scene's material and its
/// collision radius (a strand group's size, half a strip's or cluster's width, at least the
/// scene's radius); returns the state and each skeleton's radius.
fn skeletons(scene: &Scene, h: &Hierarchy) -> Result<(StrandState, Vec<Real>), HairError> {
    let d = &scene.dynamics;
    let mut state = StrandState::new();
    let mut node_radius = Vec::with_capacity(h.node_count());
    for node in 0..h.node_count() as u32 {
        let material = Material {
            linear_density: d.linear_density,
            bending_stiffness: d.bending_stiffness,
            tip_stiffness_ratio: d.tip_stiffness_ratio,
            damping: d.damping,
            tip_damping_ratio: d.tip_damping_ratio,
            radius: d.radius,
            stretch_stiffness: 0.0,
        };
        let id = state.add_skeleton(&h.skeleton_desc(node, material))?;
        debug_assert_eq!(id.0, node);
        let r = match h.kind(node) {
            NodeKind::StrandGroup => h.size(node).max(d.radius),
            _ => (0.5 * h.size(node)).max(d.radius),
        };
        node_radius.push(r);
        for i in state.nodes(id) {
            state.radius_mut()[i] = r;
        }
    }
    Ok((state, node_radius))
}

/// How deep inside the body [`Simulation::prefill_body_field`] computes samples (m).
pub const PREFILL_INSIDE: Real = 0.01;

/// The camera a scene without one gets: the hair at time 0 and the body within a quarter of the
/// hair's size around it (a bust's chest is not the subject), framed by [`CameraSpec::fit`].
fn fitted_camera(
    scene: &Scene,
    style: &hair_lod::Hairstyle,
    body: Option<&MeshBody>,
) -> crate::scene::CameraKey {
    let head = drivers::head_pose(&scene.head_motion, 0.0);
    let world = |p: &Point| (head * p).into();
    let hair = style.strands.iter().flat_map(|s| s.points.iter());
    let (mut lo, mut hi) = ([Real::INFINITY; 3], [Real::NEG_INFINITY; 3]);
    for p in hair.clone() {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let margin = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, Real::max) * 0.25;
    let near_hair = |p: &&Point| (0..3).all(|k| p[k] >= lo[k] - margin && p[k] <= hi[k] + margin);
    let body_near = body
        .into_iter()
        .flat_map(|b| b.vertices.iter())
        .filter(near_hair);
    let points = hair.chain(body_near).map(world);
    crate::scene::CameraSpec::fit(points, scene.camera.fov_degrees)
}
