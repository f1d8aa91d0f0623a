//! The per-step pipeline (`../DESIGN.md`, "One simulation step"): drivers, LOD selection, grid,
//! hair-hair (soft), dynamics, hair-object (hard), render geometry.
//!
//! The hard constraint runs after integration rather than before it, so the state handed to the
//! renderer and to the next step is never inside the body by more than the stated tolerance.

use crate::adaptive::{AdaptiveLod, BodyDepth, View};
use crate::body::BodyModel;
use crate::render_geometry::{
    RenderGeometry, catmull_rom_into, transport_frames, transport_frames_into,
};
use crate::scene::{CollisionMethod, IntegratorSpec, LodPolicy, Scene, TorqueSpec};
use crate::{HairError, LoadedScene, drivers, hairstyle};
use hair_dynamics::{
    Environment, Integrator, LinearSolver, Material, NodeCorrection, SkeletonId, StepSettings,
    StrandState, TorqueModel, VelocityConstraint, Wind,
};
use hair_grid::{Activity, ActivityConfig, ActivityInput, Grid, GridConfig, PairSet, Section};
use hair_lod::{Hierarchy, HierarchyParams, NodeKind, TransitionReport};
use hair_ssv::{Lss, Point, Real, Ssv, Vector};
use nalgebra::{Isometry3, Matrix3};
use rayon::prelude::*;
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
    /// Hair-hair pairs in contact.
    pub hair_contacts: usize,
    /// Nodes in contact with the body.
    pub body_contacts: usize,
    /// Deepest node inside the body after the hard constraint (m).
    pub max_penetration_m: f64,
    /// Kinetic energy of the simulated nodes (J).
    pub kinetic_energy: f64,
    /// Skeletons whose structured implicit solve failed its residual check and was redone by the
    /// dense LU (`hair_dynamics::StepReport::dense_fallbacks`).
    pub dense_fallbacks: usize,
    /// Rendered vertices.
    pub render_vertices: usize,
    /// FNV-1a hash of the state's float bits.
    pub state_hash: u64,
    // salon (issue 8): tool counters, flattened into the per-frame metrics.
    /// Salon tool counters (water, bonds, cuts, fallen pieces, grabbed points).
    #[serde(flatten)]
    pub salon: crate::salon::SalonStats,
}

/// A scene being simulated.
pub struct Simulation {
    scene: Scene,
    hierarchy: Hierarchy,
    front_nodes: Vec<u32>,
    state: StrandState,
    body: Option<BodyModel>,
    settings: StepSettings,
    time: Real,
    steps: u64,
    grid: Grid,
    sections: Vec<Section>,
    section_node: Vec<u32>,
    pairs: PairSet,
    activity: Activity,
    speeds: Vec<Real>,
    /// Node positions at the end of the previous step (localization measures motion by them).
    previous_positions: Vec<Point>,
    frozen_skeleton: Vec<bool>,
    corrections: Vec<NodeCorrection>,
    /// Hair-hair pushes per node: their sum and their number (zero between steps).
    node_push: Vec<(Vector, u32)>,
    constraints: Vec<VelocityConstraint>,
    /// The sections as the hair-hair response reads them, one cache line each.
    contact_sections: Vec<ContactSection>,
    /// The hair-hair narrow phase's decisions, one buffer per chunk of the pair set.
    responses: Vec<ResponseChunk>,
    /// Chunks of `responses` whose `kept` pairs the steps between pair searches test
    /// (`collision.pair_search_interval`), and the steps since they were found; `None` when
    /// there are none to reuse (a new front, a reset, a tool script).
    kept_pairs: Option<(usize, u32)>,
    body_nodes: Vec<BodyNode>,
    /// Per skeleton, the first node the hard constraint moved in this pass (`u32::MAX`: none).
    first_moved: Vec<u32>,
    body_hits: Vec<Option<(Real, Vector)>>,
    /// The hard constraint's sweeps: the chains of this pass and the next (`[skeleton, first
    /// node asked]`, by skeleton), per skeleton its radius, the first node each chain moved,
    /// the chains of the first pass, and per node what its last test found.
    sweep_chains: Vec<[u32; 2]>,
    sweep_next: Vec<[u32; 2]>,
    sweep_radius: Vec<Real>,
    sweep_moved: Vec<u32>,
    swept: Vec<[u32; 2]>,
    sweep_hits: Vec<SweepHit>,
    /// Per node, during the depenetration ramp: how far its sphere may still reach into the
    /// body at the end of this step (m).
    allowance: Vec<Real>,
    render: RenderGeometry,
    strand_node: Vec<u32>,
    /// Transport frames of the front skeletons' nodes, by global node index.
    node_frames: Vec<Matrix3<Real>>,
    /// The front skeletons' node ranges and ids `(start, end, node)`, ascending: the frames are
    /// filled by splitting `node_frames` along them.
    front_ranges: Vec<(usize, usize, u32)>,
    node_radius: Vec<Real>,
    strand_rest: Vec<Point>,
    /// Per node, where its strands' offsets start in `strand_local`.
    node_local_start: Vec<u32>,
    /// Each strand's offset from each node containing it, per control point, in that node's
    /// rest transport frames (so the offset turns with the skeleton).
    strand_local: Vec<Vector>,
    /// Where the offsets of each strand from its current front node start.
    strand_slot: Vec<u32>,
    /// The strands grouped by front node (in the front's order), and each strand's place in
    /// that order: the render pass reads each skeleton's nodes once for all its strands.
    strand_order: Vec<u32>,
    strand_rank: Vec<u32>,
    /// The strands' curves in `strand_order`, before they are copied out in strand order.
    render_scratch: Vec<Point>,
    points_per_strand: usize,
    adaptive: Option<AdaptiveLod>,
    last_lod: TransitionReport,
    /// The body's depth from the camera, for the adaptive policy's visibility (drawn again only
    /// when the view in the head frame changes).
    body_depth: BodyDepth,
    initial_adaptive: Option<AdaptiveLod>,
    teleport: Isometry3<Real>,
    accumulator: f64,
    previous_render: Vec<Point>,
    frame_render: RenderGeometry,
    initial: StrandState,
    // salon (issue 8): the tool script's state.
    salon: crate::salon::Salon,
}

fn integrator(spec: IntegratorSpec) -> Integrator {
    match spec {
        IntegratorSpec::ExplicitEuler => Integrator::ExplicitEuler,
        IntegratorSpec::SymplecticEuler => Integrator::SymplecticEuler,
        IntegratorSpec::Rk4 => Integrator::Rk4,
        IntegratorSpec::ImplicitAngular => Integrator::ImplicitAngular,
        IntegratorSpec::ImplicitCoupled => Integrator::ImplicitCoupled,
    }
}

/// The nodes a fixed policy simulates: for each finest node, its highest ancestor of `kind`
/// (or itself where the tree has none).
fn fixed_front(h: &Hierarchy, policy: LodPolicy) -> Vec<u32> {
    let mut out: Vec<u32> = Vec::new();
    for node in 0..h.node_count() as u32 {
        if !h.is_leaf(node) {
            continue;
        }
        let mut pick = node;
        let mut cur = node;
        while let Some(p) = h.parent(cur) {
            let take = match policy {
                LodPolicy::Fine | LodPolicy::Adaptive => false,
                LodPolicy::CoarseStrands => h.kind(p) == NodeKind::StrandGroup,
                LodPolicy::Clusters => h.kind(p) == NodeKind::Cluster,
                LodPolicy::Strips => true,
            };
            if take {
                pick = p;
            }
            cur = p;
        }
        out.push(pick);
    }
    out.sort_unstable();
    out.dedup();
    out
}

impl Simulation {
    /// Builds the simulation of a loaded scene with a LOD policy.
    pub fn new(loaded: &LoadedScene, policy: LodPolicy) -> Result<Self, HairError> {
        let scene = loaded.scene.clone();
        let body = BodyModel::from_spec(&scene.body, &loaded.base_dir)?;
        let style = hairstyle::from_spec(&scene.hairstyle, scene.seed, &loaded.base_dir)?;
        let params = hierarchy_params(&scene);
        let hierarchy = Hierarchy::build(&style, &params).map_err(|e| HairError::SceneValue {
            file: loaded.source.clone(),
            field: "hairstyle".into(),
            message: e.to_string(),
        })?;
        let d = &scene.dynamics;
        let mut state = StrandState::new();
        let mut node_radius = Vec::with_capacity(hierarchy.node_count());
        for node in 0..hierarchy.node_count() as u32 {
            let material = Material {
                linear_density: d.linear_density,
                bending_stiffness: d.bending_stiffness,
                tip_stiffness_ratio: d.tip_stiffness_ratio,
                damping: d.damping,
                tip_damping_ratio: d.tip_damping_ratio,
                radius: d.radius,
                stretch_stiffness: 0.0,
            };
            let id = state.add_skeleton(&hierarchy.skeleton_desc(node, material))?;
            debug_assert_eq!(id.0, node);
            let r = match hierarchy.kind(node) {
                NodeKind::StrandGroup => hierarchy.size(node).max(d.radius),
                _ => (0.5 * hierarchy.size(node)).max(d.radius),
            };
            node_radius.push(r);
            for i in state.nodes(id) {
                state.radius_mut()[i] = r;
            }
        }
        let front_nodes = fixed_front(&hierarchy, policy);
        let points_per_strand = style.strands[0].points.len();
        if let Some(bad) = style
            .strands
            .iter()
            .position(|st| st.points.len() != points_per_strand)
        {
            return Err(HairError::SceneValue {
                file: loaded.source.clone(),
                field: "hairstyle".into(),
                message: format!(
                    "strand {bad} has {} points; every strand needs {points_per_strand}",
                    style.strands[bad].points.len()
                ),
            });
        }
        let strand_rest: Vec<Point> = style
            .strands
            .iter()
            .flat_map(|st| st.points.iter().copied())
            .collect();
        let mut active = vec![false; hierarchy.node_count()];
        for &n in &front_nodes {
            active[n as usize] = true;
        }
        for s in 0..hierarchy.node_count() {
            state.set_active(SkeletonId(s as u32), active[s]);
        }
        let dt = 1.0 / (scene.frame_rate * scene.substeps as Real);
        let settings = StepSettings {
            dt,
            integrator: integrator(d.integrator),
            torque: match d.torque {
                TorqueSpec::Chain => TorqueModel::Chain,
                TorqueSpec::Local => TorqueModel::Local,
            },
            solver: LinearSolver::Structured,
        };
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
            grid: Grid::new(GridConfig::default()),
            sections: Vec::new(),
            section_node: Vec::new(),
            pairs: PairSet::new(),
            activity: Activity::new(ActivityConfig::default()),
            speeds: Vec::new(),
            previous_positions: Vec::new(),
            frozen_skeleton: Vec::new(),
            corrections: Vec::new(),
            node_push: Vec::new(),
            constraints: Vec::new(),
            contact_sections: Vec::new(),
            responses: Vec::new(),
            kept_pairs: None,
            body_nodes: Vec::new(),
            first_moved: Vec::new(),
            body_hits: Vec::new(),
            sweep_chains: Vec::new(),
            sweep_next: Vec::new(),
            sweep_radius: Vec::new(),
            sweep_moved: Vec::new(),
            swept: Vec::new(),
            sweep_hits: Vec::new(),
            allowance: Vec::new(),
            render: RenderGeometry {
                subdivisions: 3,
                ..RenderGeometry::default()
            },
            strand_node: Vec::new(),
            node_frames: Vec::new(),
            front_ranges: Vec::new(),
            node_radius,
            strand_rest,
            node_local_start: Vec::new(),
            strand_local: Vec::new(),
            strand_slot: Vec::new(),
            strand_order: Vec::new(),
            strand_rank: Vec::new(),
            render_scratch: Vec::new(),
            adaptive: None,
            last_lod: TransitionReport::default(),
            body_depth: BodyDepth::new(),
            initial_adaptive: None,
            teleport: Isometry3::identity(),
            accumulator: 0.0,
            previous_render: Vec::new(),
            frame_render: RenderGeometry::default(),
            points_per_strand,
            salon: crate::salon::Salon::default(),
        };
        // salon (issue 8): tools over the initial state.
        sim.salon = crate::salon::Salon::new(
            &sim.scene.tools,
            &sim.state,
            &sim.hierarchy,
            &sim.node_radius,
        );
        sim.prepare_render();
        if policy == LodPolicy::Adaptive {
            let mut lod = AdaptiveLod::new(&sim.hierarchy, &sim.scene.adaptive)?;
            for n in 0..sim.hierarchy.node_count() as u32 {
                sim.state
                    .set_active(SkeletonId(n), lod.front().is_active(n));
            }
            // Settle the starting front: one level per selection, from the root strips down.
            // Without the body's occlusion: hair hidden at rest coarsens only after
            // `HIDDEN_AFTER` steps of wind. Settled with it and counted hidden at once (tried on
            // 5eea007: this view given the body's depth image and the hidden count, then dropped),
            // `wardlin`'s front started at 2,524 skeletons and averaged 2,596 over 60 frames
            // against 2,919, but the visible RMS distance from `fine` (`hair study wardlin`)
            // went from 1.94 to 3.76 mm: hair hidden at rest that the wind brings into view came
            // back from its root strip.
            let view = sim.view(0.0);
            for _ in 0..=sim.hierarchy.max_level() {
                if !lod.update(&sim.hierarchy, &mut sim.state, &view, &[])? {
                    break;
                }
            }
            sim.initial_adaptive = Some(lod.clone());
            sim.adaptive = Some(lod);
            sim.refresh_front();
        }
        sim.initial = sim.state.clone();
        if !sim.update_render_geometry() {
            return Err(HairError::NonFiniteRender {
                step: 0,
                strand: sim.first_undrawable_strand(),
            });
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
    pub fn salon(&self) -> &crate::salon::Salon {
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
    pub fn push_tool_event(&mut self, event: crate::salon::ToolEvent) -> Result<(), HairError> {
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
    /// head frame), their cells and the pair search's data. With `pair_search_interval` above
    /// 1 and localization off, the steps between pair searches leave it as the last search
    /// built it.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Computes ahead the samples of the body's distance field that hair near the surface
    /// reads (`DistanceField::fill_band` on [`BodyModel::field`]): from [`PREFILL_INSIDE`] inside
    /// the surface to the near field's margin outside. The steps otherwise compute each the
    /// first time hair reaches it. Returns how many it computed. For interactive use: it moves
    /// the exact queries out of the first frames, which otherwise run slow (`hair run wardlin
    /// --prefill-field` on two cores: about 773,000 samples in 0.7 s, its `prefill_ms`; the
    /// first frame's `ms_hair_object` in `metrics.json` then 1.5 ms instead of 23 ms). The
    /// results are the same with or without it.
    pub fn prefill_body_field(&self) -> usize {
        let Some(body) = self.body.as_ref() else {
            return 0;
        };
        // Outside, as far as a node is ever queried (the near field's margin); inside, as deep
        // as hair that starts in the body reaches, by and large (deeper samples still come
        // when first read).
        body.field
            .fill_band(body, PREFILL_INSIDE, crate::body::NEAR_MARGIN)
    }

    /// The body, if any.
    pub fn body(&self) -> Option<&BodyModel> {
        self.body.as_ref()
    }

    /// The rendered strands (world frame) as of the last step.
    pub fn render_geometry(&self) -> &RenderGeometry {
        &self.render
    }

    /// The fixed simulation step (s).
    pub fn dt(&self) -> Real {
        self.settings.dt
    }

    /// Simulated time (s).
    pub fn time(&self) -> Real {
        self.time
    }

    /// Moves the whole head (and the hair with it) by a rigid offset in one jump, as a game
    /// does when a character respawns: the hair's motion relative to the head is untouched, so
    /// nothing whips. Offsets compose; the drawn geometry follows from the next update.
    pub fn teleport(&mut self, offset: Isometry3<Real>) {
        self.teleport = offset * self.teleport;
        // An offset too large to draw is reported by the next step.
        let _finite = self.update_render_geometry();
    }

    /// The accumulated teleport offset (world from the scene's head path).
    pub fn teleport_offset(&self) -> Isometry3<Real> {
        self.teleport
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
            self.previous_render.clone_from(&self.render.positions);
            stats.push(self.step()?);
            self.accumulator -= dt;
            steps += 1;
        }
        if self.previous_render.len() != self.render.positions.len() {
            self.previous_render.clone_from(&self.render.positions);
        }
        self.accumulator = self.accumulator.max(0.0);
        let alpha = (self.accumulator / dt).clamp(0.0, 1.0) as Real;
        self.frame_render.subdivisions = self.render.subdivisions;
        self.frame_render.offsets.clone_from(&self.render.offsets);
        self.frame_render.positions.clear();
        // The frame lies `alpha` of a step past the last step: blend from the step before.
        self.frame_render.positions.extend(
            self.previous_render
                .iter()
                .zip(&self.render.positions)
                .map(|(a, b)| a + (b - a) * alpha),
        );
        Ok(steps)
    }

    /// Which of `points` (world coordinates, as [`Simulation::render_geometry`] gives them) the
    /// camera sees now, by the test the `adaptive` policy selects with: inside the view cone
    /// and not behind the body ([`BodyDepth`]). Written to `out`, one flag per point.
    /// As for that policy, the camera keeps its place relative to the scene's head path, so a
    /// teleport carries what it sees along with the head.
    pub fn seen_by_camera(&self, points: &[Point], out: &mut Vec<bool>) {
        let mut view = self.view(self.time);
        // The step's image when it holds this view (`build` then keeps it), else a new one.
        let mut depth = self.body_depth.clone();
        if let Some(body) = &self.body {
            depth.build(body, &view);
            view.occluder = Some(&depth);
        }
        let head = drivers::head_motion(&self.scene.head_motion, self.time);
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
            &self.render
        } else {
            &self.frame_render
        }
    }

    /// Puts every strand back at rest and the clock at zero. The state is copied into the
    /// buffers already held, so the steps after a reset take no new memory.
    pub fn reset(&mut self) {
        // Copied into the buffers held, which keep the room they grew to.
        self.state.clone_from(&self.initial);
        self.time = 0.0;
        self.steps = 0;
        self.kept_pairs = None;
        self.activity.clear();
        self.frozen_skeleton.clear();
        self.previous_positions.clear();
        self.accumulator = 0.0;
        self.frame_render.positions.clear();
        if let Some(lod) = &self.initial_adaptive {
            match &mut self.adaptive {
                Some(current) => current.reset_to(lod),
                None => self.adaptive = Some(lod.clone()),
            }
            self.refresh_front();
        }
        // salon (issue 8): back to the start of the script.
        self.salon
            .reset(&self.state, &self.hierarchy, &self.node_radius);
        // The initial state, drawn when the simulation was built.
        let _finite = self.update_render_geometry();
    }

    /// Every strand's offsets from every node that contains it, then the assignment of strands
    /// to the current front.
    fn prepare_render(&mut self) {
        let h = &self.hierarchy;
        let per = self.points_per_strand;
        let mut frames = Vec::new();
        let mut rest = Vec::new();
        self.node_local_start.clear();
        self.strand_local.clear();
        for node in 0..h.node_count() as u32 {
            self.node_local_start.push(self.strand_local.len() as u32);
            h.rest_points_into(node, &mut rest);
            let first = self.initial.root_frame(SkeletonId(node));
            transport_frames(&rest, first.matrix(), &mut frames);
            for &s in h.strands(node) {
                let s = s as usize;
                for k in 0..per {
                    let k_node = k.min(rest.len() - 1);
                    let d = self.strand_rest[s * per + k] - rest[k_node];
                    self.strand_local.push(frames[k_node].transpose() * d);
                }
            }
        }
        self.assign_strands();
    }

    /// Which front node draws each strand.
    fn assign_strands(&mut self) {
        let h = &self.hierarchy;
        let per = self.points_per_strand as u32;
        let n_strands = h.strand_total();
        self.strand_node.resize(n_strands, 0);
        self.strand_slot.resize(n_strands, 0);
        self.strand_order.clear();
        for &node in &self.front_nodes {
            let start = self.node_local_start[node as usize];
            for (j, &s) in h.strands(node).iter().enumerate() {
                self.strand_node[s as usize] = node;
                self.strand_slot[s as usize] = start + j as u32 * per;
                self.strand_order.push(s);
            }
        }
        // A front is a cut of the hierarchy, so it holds every strand once; should the count
        // ever differ, the strands are drawn in their own order.
        if self.strand_order.len() != n_strands {
            self.strand_order.clear();
            self.strand_order.extend(0..n_strands as u32);
        }
        self.strand_rank.resize(n_strands, 0);
        for (k, &s) in self.strand_order.iter().enumerate() {
            self.strand_rank[s as usize] = k as u32;
        }
        self.front_ranges.clear();
        let state = &self.state;
        self.front_ranges.extend(self.front_nodes.iter().map(|&n| {
            let r = state.nodes(SkeletonId(n));
            (r.start, r.end, n)
        }));
        self.front_ranges.sort_unstable();
    }

    /// The active front of the adaptive policy as a sorted node list, and the strands' owners.
    fn refresh_front(&mut self) {
        // Other skeletons, other sections: the kept pairs no longer describe the hair.
        self.kept_pairs = None;
        if let Some(lod) = &self.adaptive {
            self.front_nodes.clear();
            self.front_nodes.extend(
                (0..self.hierarchy.node_count() as u32).filter(|&n| lod.front().is_active(n)),
            );
            self.assign_strands();
        }
    }

    /// The camera's view cone at time `t` in the head frame, with no occluder yet.
    fn view(&self, t: Real) -> View<'static> {
        let head = drivers::head_motion(&self.scene.head_motion, t);
        let (eye, target) = drivers::camera(&self.scene.camera, t);
        let to_head = |p: Point| Point::from(head.rotation.inverse() * (p - head.position));
        let (eye, target) = (to_head(eye), to_head(target));
        let forward = (target - eye)
            .try_normalize(1e-9)
            .unwrap_or_else(|| -Vector::z());
        // The cone around the whole image at a 3:2 aspect ratio, with a little margin.
        let tan_v = (0.5 * self.scene.camera.fov_degrees.to_radians()).tan();
        let half = (tan_v * (1.0 + 1.5f32 * 1.5).sqrt()).atan() * 1.1;
        View {
            eye,
            forward,
            cos_half_angle: half.min(std::f32::consts::FRAC_PI_2).cos(),
            occluder: None,
        }
    }

    /// Simulates one fixed step.
    ///
    /// A step takes no memory once its buffers have grown to what the scene needs (a test
    /// replays each built-in scene after [`Simulation::reset`] and counts every allocation).
    /// That holds when it is called from inside a rayon pool (`ThreadPool::install`, as
    /// `hair run` does); called from any other thread, rayon's queue of outside jobs takes a
    /// small block now and then.
    pub fn step(&mut self) -> Result<StepStats, HairError> {
        let t0 = Instant::now();
        let mut stats = StepStats {
            step: self.steps,
            ..StepStats::default()
        };

        // 1. Drivers.
        let head = drivers::head_motion(&self.scene.head_motion, self.time);
        let w = &self.scene.wind;
        let env = Environment {
            gravity: Vector::from(self.scene.dynamics.gravity),
            head,
            wind: Wind {
                direction: Vector::from(w.direction),
                speed: w.speed,
                gust: w.gust,
                gust_frequency: w.gust_frequency,
                turbulence: w.turbulence,
                turbulence_scale: w.turbulence_scale,
                drag: w.drag,
                seed: self.scene.seed,
            },
            fields: Vec::new(),
            time: self.time,
        };
        let t1 = Instant::now();
        stats.ms_drivers = ms(t0, t1);

        // 2. LOD: fixed fronts change nothing; the adaptive one is re-selected.
        if let Some(mut lod) = self.adaptive.take() {
            let mut view = self.view(self.time);
            if let (Some(body), true) = (&self.body, self.scene.adaptive.cull_hidden) {
                self.body_depth.build(body, &view);
                view.occluder = Some(&self.body_depth);
            }
            let result = lod.update(
                &self.hierarchy,
                &mut self.state,
                &view,
                &self.frozen_skeleton,
            );
            self.last_lod = lod.last_report();
            self.adaptive = Some(lod);
            if result? {
                self.refresh_front();
            }
        }
        let t2 = Instant::now();
        stats.ms_lod = ms(t1, t2);
        if let Some(lod) = &self.adaptive {
            stats.lod_splits = self.last_lod.splits;
            stats.lod_merges = self.last_lod.merges;
            stats.lod_hidden_trees = lod.hidden_trees(&self.hierarchy);
        }

        // 3. Grid over the front's segments (head frame, where the body is static).
        self.build_sections();
        // The pairs of the last search, tested again while they are young enough and the hair
        // is the same hair: no tool has acted (a cut, a bond) and the front is the same (a new
        // front drops them above).
        let interval = self.scene.collision.pair_search_interval.max(1);
        let reuse = match self.kept_pairs {
            Some((chunks, age))
                if self.scene.collision.hair_hair
                    && age + 1 < interval
                    && self.salon.script().events.is_empty() =>
            {
                Some((chunks, age + 1))
            }
            _ => None,
        };
        // Between searches nothing else reads the grid unless localization measures activity
        // (the salon's tools would, but a tool script always searches).
        if reuse.is_none() || self.scene.localization {
            self.grid.rebuild(&self.sections)?;
        }
        // Localization: sections frozen when every cell they cover has been quiet.
        if self.scene.localization {
            // Motion is measured by how far nodes moved over the last step, not by their
            // velocity: a node resting on the body keeps a velocity into it that the push-out
            // cancels every step, and hair lying still must not count as moving.
            self.speeds.clear();
            let p = self.state.positions();
            if self.previous_positions.len() == p.len() {
                let (before, inv_dt) = (&self.previous_positions, 1.0 / self.settings.dt);
                self.speeds.extend(self.section_node.iter().map(|&i| {
                    let i = i as usize;
                    (p[i] - before[i])
                        .norm()
                        .max((p[i - 1] - before[i - 1]).norm())
                        * inv_dt
                }));
            } else {
                let v = self.state.velocities();
                self.speeds.extend(
                    self.section_node
                        .iter()
                        .map(|&i| v[i as usize].norm().max(v[i as usize - 1].norm())),
                );
            }
            self.activity.update(
                &self.grid,
                &ActivityInput {
                    dt: self.settings.dt,
                    speeds: &self.speeds,
                    neighbour_forces: &[],
                    // salon (issue 8): the pressed tools' areas wake their cells.
                    tools: self.salon.volumes(),
                },
            )?;
            self.frozen_skeleton.clear();
            self.frozen_skeleton
                .resize(self.hierarchy.node_count(), true);
            for (sec, frozen) in self.activity.frozen().iter().enumerate() {
                if !frozen {
                    self.frozen_skeleton[self.sections[sec].skeleton as usize] = false;
                }
            }
            for &node in &self.front_nodes {
                let id = SkeletonId(node);
                let active = !self.frozen_skeleton[node as usize];
                if !active && self.state.is_active(id) {
                    // Frozen at rest: it wakes with no motion, not with the velocity into
                    // the body it had while resting there.
                    let r = self.state.nodes(id);
                    self.state.omega_theta_mut()[r.clone()].fill(0.0);
                    self.state.omega_phi_mut()[r].fill(0.0);
                    self.state.refresh_positions(id);
                }
                self.state.set_active(id, active);
            }
        }
        let t3 = Instant::now();
        stats.ms_grid = ms(t2, t3);

        // 4. Hair-hair (soft): push overlapping sections apart by half the overlap each; let
        // near-parallel ones share their velocity instead.
        if self.scene.collision.hair_hair {
            let cos_parallel = self.scene.collision.parallel_angle.cos();
            let chunks = if let Some((chunks, age)) = reuse {
                self.kept_pairs = Some((chunks, age));
                let state = &self.state;
                let (p, radius) = (state.positions(), state.radius());
                self.responses[..chunks]
                    .par_iter_mut()
                    .for_each(|out| out.retest(state, p, radius, cos_parallel));
                stats.pairs_tested = self.responses[..chunks].iter().map(|r| r.kept.len()).sum();
                chunks
            } else {
                self.search_hair_pairs(cos_parallel, interval > 1);
                stats.pairs_tested = self.pairs.len();
                let chunks = self.pairs.chunk_count();
                self.kept_pairs = (interval > 1).then_some((chunks, 0));
                chunks
            };
            let responses = &self.responses[..chunks];
            stats.hair_contacts += responses
                .iter()
                .map(|r| r.shares.len() + r.pushes.len())
                .sum::<usize>();
            self.corrections.clear();
            self.node_push
                .resize(self.state.node_count(), (Vector::zeros(), 0));
            // Shares change only the rates and pushes only the push sums: each kind applied in
            // pair order, the two side by side, gives the state of applying them interleaved.
            let (theta, phi) = self.state.rates_mut();
            let node_push = &mut self.node_push;
            rayon::join(
                || {
                    for &[a, b] in responses.iter().flat_map(|r| &r.shares) {
                        // The mean never raises the sum of squared rates: no energy is added.
                        let (a, b) = (a as usize, b as usize);
                        let mean_t = 0.5 * (theta[a] + theta[b]);
                        let mean_p = 0.5 * (phi[a] + phi[b]);
                        theta[a] = mean_t;
                        theta[b] = mean_t;
                        phi[a] = mean_p;
                        phi[b] = mean_p;
                    }
                },
                || {
                    for &(a, b, half) in responses.iter().flat_map(|r| &r.pushes) {
                        let (a, b) = (a as usize, b as usize);
                        node_push[a].0 -= half;
                        node_push[a].1 += 1;
                        node_push[b].0 += half;
                        node_push[b].1 += 1;
                    }
                },
            );
            // One correction per pushed node (a section has dozens of neighbours in dense hair):
            // its pairs' pushes summed in pair order, or their mean (`PushCombine`).
            let mean = self.scene.collision.hair_hair_push == crate::scene::PushCombine::Mean;
            for (node, entry) in self.node_push.iter_mut().enumerate() {
                let (push, pushes) = std::mem::replace(entry, (Vector::zeros(), 0));
                if push != Vector::zeros() {
                    let delta = if mean {
                        push / pushes.max(1) as Real
                    } else {
                        push
                    };
                    self.corrections.push(NodeCorrection {
                        node: node as u32,
                        delta,
                    });
                }
            }
            self.state.apply_corrections(&self.corrections)?;
        }
        let t4 = Instant::now();
        stats.ms_hair_hair = ms(t3, t4);

        // 5. Dynamics.
        let report = self.state.step(&env, &self.settings)?;
        let front_active = self
            .front_nodes
            .iter()
            .filter(|&&n| self.state.is_active(SkeletonId(n)))
            .count();
        stats.skeletons = self.front_nodes.len();
        stats.active = front_active;
        stats.dormant = self.front_nodes.len() - front_active;
        stats.dense_fallbacks = report.dense_fallbacks;
        // salon (issue 8): the tool script's events and the pressed tools, after the dynamics.
        stats.salon = self.salon.step(
            &mut self.state,
            &crate::salon::SalonInput {
                hierarchy: &self.hierarchy,
                front: &self.front_nodes,
                grid: &self.grid,
                sections: &self.sections,
                body: self.body.as_ref(),
                head: &env.head,
                time: self.time + self.settings.dt,
                dt: self.settings.dt,
                friction: self.scene.collision.friction,
            },
        )?;
        // salon (issue 8) end.
        let t5 = Instant::now();
        stats.ms_dynamics = ms(t4, t5);

        // 6. Hair-object (hard).
        let (contacts, depth) = self.collide_body()?;
        stats.body_contacts = contacts;
        stats.max_penetration_m = f64::from(depth);
        let t6 = Instant::now();
        stats.ms_hair_object = ms(t5, t6);

        self.time += self.settings.dt;
        self.steps += 1;
        if self.scene.localization {
            self.previous_positions.clear();
            self.previous_positions
                .extend_from_slice(self.state.positions());
        }

        // 7. Render geometry. A finite state can still be too far out to draw (hair thrown
        // 1e26 m by a huge gravity): that is an error, not non-finite points handed on.
        if !self.update_render_geometry() {
            return Err(HairError::NonFiniteRender {
                step: stats.step,
                strand: self.first_undrawable_strand(),
            });
        }
        // salon (issue 8): cut strands end at the cut; fallen pieces are drawn.
        self.salon.render(
            &self.state,
            &self.hierarchy,
            &self.strand_node,
            &self.node_local_start,
            &self.strand_local,
            self.points_per_strand,
            &drivers::head_motion(&self.scene.head_motion, self.time),
            &mut self.render,
        );
        let t7 = Instant::now();
        stats.ms_render_geometry = ms(t6, t7);
        stats.render_vertices = self.render.vertex_count();
        stats.time = f64::from(self.time);
        stats.kinetic_energy = self.kinetic_energy();
        stats.state_hash = self.state_hash();
        stats.ms_total = ms(t0, Instant::now());
        Ok(stats)
    }

    /// The front's segments as grid sections, each with its end node (`section_node`).
    fn build_sections(&mut self) {
        self.sections.clear();
        self.section_node.clear();
        let (p, radius) = (self.state.positions(), self.state.radius());
        for &node in &self.front_nodes {
            let r = self.state.nodes(SkeletonId(node));
            // salon (issue 8): per-node radius (water thins, mousse thickens).
            for (k, i) in (r.start + 1..r.end).enumerate() {
                self.sections.push(Section {
                    skeleton: node,
                    segment: k as u32,
                    shape: Ssv::Line(Lss::new(p[i - 1], p[i], radius[i].max(radius[i - 1]))),
                });
                self.section_node.push(i as u32);
            }
        }
    }

    /// The hair-hair pair search and narrow phase, into `self.responses` chunk by chunk of the
    /// pair set; with `keep`, each chunk also keeps its pairs of segments (by end node) for
    /// [`ResponseChunk::retest`] on the steps until the next search.
    fn search_hair_pairs(&mut self, cos_parallel: Real, keep: bool) {
        self.grid.overlapping_pairs_by_rank(&mut self.pairs);
        // In the pair search's order, so that the pairs, which come cell by cell, read
        // nearby records.
        let (state, sections, nodes) = (&self.state, &self.sections, &self.section_node);
        self.grid
            .search_order()
            .par_iter()
            .map(|&i| {
                let (s, i) = (&sections[i as usize], i as usize);
                // Every section built above is a segment; any other shape gets no response.
                let (line, segment) = match s.shape {
                    Ssv::Line(l) => (l, true),
                    _ => (Lss::new(Point::origin(), Point::origin(), 0.0), false),
                };
                ContactSection {
                    a: line.a,
                    b: line.b,
                    radius: line.radius,
                    tangent: (line.b - line.a)
                        .try_normalize(0.0)
                        .unwrap_or_else(Vector::zeros),
                    node: nodes[i],
                    active: state.is_active(SkeletonId(s.skeleton)),
                    segment,
                }
            })
            .collect_into_vec(&mut self.contact_sections);
        // The narrow phase, chunk by chunk of the pair set (its chunks do not depend on the
        // thread count), into short records: the shares' two nodes, the pushes' nodes and
        // vector.
        let chunks = self.pairs.chunk_count();
        if self.responses.len() < chunks {
            self.responses.resize_with(chunks, ResponseChunk::default);
        }
        let (pairs, sections) = (&self.pairs, &self.contact_sections);
        self.responses[..chunks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(chunk, out)| {
                out.shares.clear();
                out.pushes.clear();
                out.kept.clear();
                for &[a, b] in pairs.chunk(chunk) {
                    let (sa, sb) = (&sections[a as usize], &sections[b as usize]);
                    if keep && sa.segment && sb.segment {
                        out.kept.push([sa.node, sb.node]);
                    }
                    if !(sa.segment && sb.segment && (sa.active || sb.active)) {
                        continue;
                    }
                    if sa.tangent.dot(&sb.tangent).abs() >= cos_parallel {
                        out.shares.push([sa.node, sb.node]);
                        continue;
                    }
                    let c = hair_ssv::query::segment_segment(&sa.a, &sa.b, &sb.a, &sb.b);
                    let d = c.on_b - c.on_a;
                    let dist = d.norm();
                    let overlap = sa.radius + sb.radius - dist;
                    if overlap > 0.0 && dist > 1e-9 {
                        out.pushes
                            .push((sa.node, sb.node, d * (0.5 * overlap / dist)));
                    }
                }
            });
    }

    /// The hard constraint (Kurihara et al. §4's reaction constraint, made positional): every
    /// front node closer to the body than its radius is moved out along the body's normal and
    /// loses its velocity into the body, with friction. The node stays on the sphere about the
    /// node before it, so a segment hanging straight into a surface swings out of it instead of
    /// being re-aimed along itself ([`body_target`]).
    ///
    /// After the ramp (below) the regular passes are sweeps ([`StrandState::sweep_chains`]):
    /// each skeleton root to tip, in parallel over skeletons, every node tested where the
    /// corrections before it on its skeleton put it, so that one sweep resolves a whole chain
    /// where a pass over every node at once found the nodes after each corrected one pushed in
    /// again by its refit. A corrected node's target is tested and moved again while still
    /// inside, up to [`SWEEP_RETESTS`] times; the skeletons with a corrected node left
    /// unconfirmed are swept again from their first such node, up to [`BODY_PASSES`] sweeps.
    ///
    /// Hair that starts inside the body (at the first step, or the first after a reset) comes
    /// out linearly over the first `depenetration_steps` steps (the ramp): at the end of ramp
    /// step `k` a node may still reach `(ramp - k - 1) / (ramp - k)` of the way it reached at the
    /// start of that step, and never more than it was allowed the step before, so whatever
    /// pushes it back in, it is held to the ramp; a node next to one still allowed inside is
    /// allowed that, less the segment between them. Every other node, including one that
    /// reaches the body during the ramp, is resolved at once. On the ramp the passes test every
    /// node where the last pass left it (the allowances are set on the first), refit the
    /// skeletons they moved, and repeat on them until no node is deeper than the skin
    /// ([`CONTACT_SKIN`] of the tolerance) beyond its allowance, or [`BODY_PASSES`] have run.
    ///
    /// Late passes, from [`BODY_PASSES`] on (on the ramp, or for the skeletons the sweeps left
    /// moving), run until no node is deeper than half the tolerance beyond its allowance or
    /// [`MAX_BODY_PASSES`] have run. They use the exact distance, whatever the scene's method,
    /// once at most [`EXACT_LATE_NODES`] nodes are left; after the ramp they send a node whose
    /// centre is still inside by more than half the tolerance to the nearest point of its
    /// sphere about its parent that clears the body ([`escape`]): lifting along the node's own
    /// normal can land it inside again where the body is thin (an ear) or creased, pass after
    /// pass. The contacts of every pass lose their approach velocity once, after the last pass.
    /// Returns the nodes in contact on the first pass and the deepest node centre left inside
    /// the body (m), each node counted where it was last tested.
    ///
    /// The sweeps replaced passes over every node at once (the queries in parallel, the
    /// corrections gathered in order, the moved skeletons refitted after). With
    /// `--lod fine --prefill-field`, alternated runs of 66cab18 and e682da2 (each built with
    /// `cargo build --release -p hair-cli`), the stage's median frame went from
    /// 80.6-81.0 ms to 54.5-55.8 ms on `scenes/strands10k.ron` (frames 12-29, two rounds) and
    /// from 4.26-4.31 ms to 3.34-3.50 ms on `wardlin` (frames 10-59, three rounds). Measured
    /// and dropped before that: computing the passes' targets ahead in parallel, with the loop
    /// only gathering them (on `strands10k` the first pass took 9.5 ms for both parts against
    /// 8.1 ms for the serial loop alone); the first pass's queries in the grid's search order
    /// (on `wardlin`, 1.28-1.34 ms against 1.20-1.23 ms): the queries wait on arithmetic, not
    /// on memory.
    fn collide_body(&mut self) -> Result<(usize, Real), HairError> {
        let Some(body) = self.body.as_ref() else {
            return Ok((0, 0.0));
        };
        let ramp = self.scene.collision.depenetration_steps as u64;
        // The share of its reach into the body a node that started inside may keep at the end
        // of this ramp step (see above).
        let in_ramp = self.steps < ramp;
        let keep = if in_ramp {
            (ramp - self.steps - 1) as Real / (ramp - self.steps) as Real
        } else {
            0.0
        };
        if self.steps == 0 {
            // The allowances start from the depths read on the first pass below (a root the
            // constraint does not move is allowed nothing).
            self.allowance.clear();
            self.allowance.resize(self.state.positions().len(), 0.0);
        }
        let method = self.scene.collision.method;
        let friction = self.scene.collision.friction;
        let tolerance = 0.5 * self.scene.collision.tolerance;
        // A node the last pass left within rounding of the surface is in contact but needs no
        // refit: without this skin every pass found a few hundred nodes a few nanometres in and
        // ran all its passes to move them by nothing.
        let skin = CONTACT_SKIN * self.scene.collision.tolerance;
        // The passes test positions only, so the velocity constraints of every pass wait for the
        // last one, in pass order: one refresh of each touched skeleton instead of one a pass.
        self.constraints.clear();
        self.body_nodes.clear();
        let mut contacts = 0;
        // The deepest node centre among the nodes the sweeps left (they no longer move).
        let mut swept_depth: Real = 0.0;
        let first_pass = if in_ramp {
            for &n in &self.front_nodes {
                let id = SkeletonId(n);
                if !self.state.is_active(id) {
                    // Frozen by localization: it has not moved since it was last resolved.
                    continue;
                }
                let from = u32::from(!self.state.is_free(id));
                push_body_nodes(&mut self.body_nodes, &self.state, n, from);
            }
            0
        } else {
            // The regular passes as sweeps: each skeleton root to tip, every node tested where
            // the corrections before it put it, in parallel over skeletons. One sweep leaves
            // a skeleton with every node tested where it ends except the corrected ones (the
            // turn onto the sphere about the parent can leave one a little inside), so the next
            // sweep starts at each skeleton's first corrected node.
            self.sweep_chains.clear();
            for &n in &self.front_nodes {
                let id = SkeletonId(n);
                if self.state.is_active(id) {
                    self.sweep_chains
                        .push([n, u32::from(!self.state.is_free(id))]);
                }
            }
            self.sweep_chains.sort_unstable();
            // The sweep holds the state, so the callback reads each skeleton's radius from here.
            let (radius, state) = (&mut self.sweep_radius, &self.state);
            radius.clear();
            radius.extend((0..state.skeleton_count() as u32).map(|n| {
                let r = state.nodes(SkeletonId(n));
                state.radius().get(r.start).copied().unwrap_or(0.0)
            }));
            self.swept.clone_from(&self.sweep_chains);
            self.sweep_hits
                .resize(self.state.node_count(), SweepHit::default());
            for pass in 0..BODY_PASSES {
                if self.sweep_chains.is_empty() {
                    break;
                }
                self.sweep_moved.clear();
                self.sweep_moved.resize(self.sweep_chains.len(), u32::MAX);
                let (chains, skeleton_radius) = (&self.sweep_chains, &self.sweep_radius);
                self.state.sweep_chains(
                    chains,
                    &mut self.sweep_hits,
                    &mut self.sweep_moved,
                    |ask, slot| {
                        // A node a sweep before this one tested where it still is and did not
                        // correct is not tested again.
                        if pass > 0 && !ask.moved && !slot.corrected {
                            slot.tested = false;
                            return None;
                        }
                        let radius = skeleton_radius[chains[ask.chain][0] as usize];
                        let inside = |p: &Point| {
                            body.distance_within(method, p, radius)
                                .filter(|(d, _)| *d < radius)
                        };
                        let hit = inside(&ask.at);
                        *slot = SweepHit {
                            normal: hit.map(|(_, n)| n),
                            depth: hit.map_or(0.0, |(d, _)| -d),
                            tested: true,
                            corrected: false,
                        };
                        let (d, n) = hit?;
                        if radius - d <= skin {
                            return None;
                        }
                        // The target is tested here, and moved again while still inside, a few
                        // times: a query costs a small part of refitting the skeleton again on
                        // the next sweep. Where it ends untested, the next sweep tests it.
                        let mut target =
                            body_target(body, method, ask.at, ask.parent, &n, radius - d, radius);
                        slot.corrected = true;
                        for _ in 0..SWEEP_RETESTS {
                            match inside(&target) {
                                Some((d, n)) if radius - d > skin => {
                                    target = body_target(
                                        body,
                                        method,
                                        target,
                                        ask.parent,
                                        &n,
                                        radius - d,
                                        radius,
                                    );
                                }
                                end => {
                                    slot.depth = end.map_or(0.0, |(d, _)| -d);
                                    slot.corrected = false;
                                    break;
                                }
                            }
                        }
                        Some(target)
                    },
                )?;
                // The contacts in chain order, then the chains to sweep again.
                self.sweep_next.clear();
                for (k, &[n, from]) in self.sweep_chains.iter().enumerate() {
                    let r = self.state.nodes(SkeletonId(n));
                    for node in r.start + from as usize..r.end {
                        let h = &self.sweep_hits[node];
                        if let (true, Some(normal)) = (h.tested, h.normal) {
                            self.constraints.push(VelocityConstraint {
                                node: node as u32,
                                normal,
                                friction,
                            });
                        }
                    }
                    let moved = self.sweep_moved[k];
                    if moved != u32::MAX {
                        self.sweep_next.push([n, moved - r.start as u32]);
                    }
                }
                if pass == 0 {
                    contacts = self.constraints.len();
                }
                std::mem::swap(&mut self.sweep_chains, &mut self.sweep_next);
            }
            // Skeletons still moving after the regular sweeps go on to the late passes below,
            // from their first corrected node.
            for &[n, from] in &self.sweep_chains {
                let r = self.state.nodes(SkeletonId(n));
                for h in &mut self.sweep_hits[r.start + from as usize..r.end] {
                    h.depth = 0.0;
                }
                push_body_nodes(&mut self.body_nodes, &self.state, n, from);
            }
            for &[n, from] in &self.swept {
                let r = self.state.nodes(SkeletonId(n));
                for h in &self.sweep_hits[r.start + from as usize..r.end] {
                    swept_depth = swept_depth.max(h.depth);
                }
            }
            BODY_PASSES
        };
        let mut deepest: Real = 0.0;
        // The deepest node centre among the nodes the passes stopped testing (they no longer
        // move).
        let mut settled: Real = 0.0;
        for pass in first_pass..=MAX_BODY_PASSES {
            if pass > 0 && self.body_nodes.is_empty() {
                break;
            }
            let positions = self.state.positions();
            // The late passes, once few nodes are still moving, query the exact distance: an
            // approximate field or table can be wrong by about its spacing where the body is
            // thinner than that, and there its gradient can send a node back and forth across
            // the surface without ever reaching it. (With many nodes left, as when dense hair
            // starts inside the body, exact queries would cost seconds per step.)
            let method = if pass >= BODY_PASSES && self.body_nodes.len() <= EXACT_LATE_NODES {
                CollisionMethod::Bvh
            } else {
                method
            };
            self.body_nodes
                .par_iter()
                .map(|bn| {
                    body.distance_within(method, &positions[bn.node as usize], bn.radius)
                        .filter(|(d, _)| *d < bn.radius)
                })
                .collect_into_vec(&mut self.body_hits);
            self.corrections.clear();
            deepest = 0.0;
            // The deepest node centre beyond what the ramp allows it: the passes stop when it is
            // out.
            let mut deepest_free: Real = 0.0;
            // Nodes sent to [`escape`] this pass (each costs up to a few hundred exact queries).
            let mut escapes = 0;
            self.first_moved.clear();
            self.first_moved
                .resize(self.state.skeleton_count(), u32::MAX);
            for (bn, hit) in self.body_nodes.iter().zip(&self.body_hits) {
                let node = bn.node as usize;
                if in_ramp && pass == 0 && node < self.allowance.len() {
                    let reach = hit.map_or(0.0, |(d, _)| (bn.radius - d).max(0.0));
                    let before = if self.steps == 0 {
                        reach
                    } else {
                        self.allowance[node].min(reach)
                    };
                    let mut a = before * keep;
                    // A node next to one still allowed inside may be held inside by it, less
                    // the segment between them (its sphere about that node reaches no farther
                    // out). The nodes of a skeleton come root first, so the one before is done.
                    if let Some(&b) = self.allowance.get(bn.prev as usize) {
                        let len = (positions[node] - positions[bn.prev as usize]).norm();
                        a = a.max(b - len);
                    }
                    self.allowance[node] = a;
                }
                let Some((d, n)) = hit else { continue };
                deepest = deepest.max(-d);
                self.constraints.push(VelocityConstraint {
                    node: bn.node,
                    normal: *n,
                    friction,
                });
                let allowed = if in_ramp {
                    self.allowance.get(node).copied().unwrap_or(0.0)
                } else {
                    0.0
                };
                let ramped = allowed > 0.0;
                let lift = bn.radius - d - allowed;
                if lift <= skin {
                    // In contact but out as far as it needs to be: only its approach is
                    // removed.
                    continue;
                }
                deepest_free = deepest_free.max(-d - allowed);
                let p = positions[bn.node as usize];
                let parent = (bn.prev != u32::MAX).then(|| positions[bn.prev as usize]);
                // After the ramp, a node still inside after the regular passes is caught where
                // lifting along its own normal lands in the body again (a thin part such as an
                // ear, or a crease): it goes to the nearest place on its sphere that clears.
                let stuck = parent.is_some_and(|a| (p - a).norm() > 1e-9)
                    && !ramped
                    && pass >= BODY_PASSES
                    && -d > tolerance
                    && escapes < EXACT_LATE_NODES;
                escapes += usize::from(stuck);
                let target = match parent {
                    Some(a) if stuck => {
                        let len = (p - a).norm();
                        escape(body, a, (p - a) / len, len, bn.radius, -d).unwrap_or(p + n * lift)
                    }
                    _ => body_target(body, method, p, parent.as_ref(), n, lift, bn.radius),
                };
                self.corrections.push(NodeCorrection {
                    node: bn.node,
                    delta: target - p,
                });
                let first = &mut self.first_moved[bn.skeleton as usize];
                *first = (*first).min(bn.node);
            }
            if pass == 0 {
                contacts = self.constraints.len();
            }
            let done = self.corrections.is_empty()
                || pass == MAX_BODY_PASSES
                || (pass >= BODY_PASSES && deepest_free <= tolerance);
            if done {
                break;
            }
            self.state.apply_corrections(&self.corrections)?;
            // The refit moves a skeleton's nodes from its first corrected one on; the nodes
            // before it stay where this pass found them: out of the body, or (on the ramp)
            // within their allowance, which the depth reported at the end still counts.
            let (first_moved, mut hits) = (&self.first_moved, self.body_hits.iter());
            self.body_nodes.retain(|bn| {
                let moved = bn.node >= first_moved[bn.skeleton as usize];
                if let (false, Some(Some((d, _)))) = (moved, hits.next()) {
                    settled = settled.max(-d);
                }
                moved
            });
        }
        if !self.constraints.is_empty() {
            self.state.apply_velocity_constraints(&self.constraints)?;
        }
        Ok((contacts, deepest.max(settled).max(swept_depth).max(0.0)))
    }

    /// Kinetic energy of the front's nodes (J, head frame).
    pub fn kinetic_energy(&self) -> f64 {
        let (m, w, v) = (
            self.state.mass(),
            self.state.wetness(),
            self.state.velocities(),
        );
        self.front_nodes
            .iter()
            .flat_map(|&n| self.state.nodes(SkeletonId(n)))
            .map(|i| 0.5 * f64::from(m[i] + w[i]) * f64::from(v[i].norm_squared()))
            .sum()
    }

    /// A hash of the float bits of every angle, angular velocity and position: two chains of
    /// 64-bit words (the angles and rates, two floats a word; the positions), each step an xor,
    /// a multiplication by an odd constant and a rotation, then folded together. Every step is
    /// invertible, so two states that differ in one float always differ in the hash. Word-wise
    /// and in two independent chains it is about nine times cheaper than the byte-wise FNV-1a it
    /// replaced (perf over 60 `wardlin` frames: 1.88% of the samples, then 0.21%).
    pub fn state_hash(&self) -> u64 {
        const K: u64 = 0x9e37_79b9_7f4a_7c15;
        #[inline(always)]
        fn mix(h: u64, w: u64) -> u64 {
            (h ^ w).wrapping_mul(K).rotate_left(29)
        }
        let pair = |a: f32, b: f32| u64::from(a.to_bits()) | u64::from(b.to_bits()) << 32;
        let s = &self.state;
        let (mut angles, mut points) = (0xcbf2_9ce4_8422_2325_u64, 0x8422_2325_cbf2_9ce4_u64);
        let rows = s
            .theta()
            .iter()
            .zip(s.phi())
            .zip(s.omega_theta().iter().zip(s.omega_phi()))
            .zip(s.positions());
        for (((&t, &f), (&wt, &wf)), p) in rows {
            angles = mix(mix(angles, pair(t, f)), pair(wt, wf));
            points = mix(mix(points, pair(p.x, p.y)), u64::from(p.z.to_bits()));
        }
        let h = mix(mix(angles, points), s.node_count() as u64);
        h ^ (h >> 31)
    }

    /// The first drawn strand with a point not within [`DRAWABLE`] of the origin (0 if none).
    fn first_undrawable_strand(&self) -> usize {
        let verts = self.render.offsets.get(1).copied().unwrap_or(1).max(1) as usize;
        self.render
            .positions
            .iter()
            .position(|p| !p.coords.iter().all(|c| c.abs() < DRAWABLE))
            .map_or(0, |i| i / verts)
    }

    /// Rebuilds every rendered strand from its front node, in world coordinates; false when a
    /// control point is not within [`DRAWABLE`] of the origin (non-finite included).
    #[must_use]
    fn update_render_geometry(&mut self) -> bool {
        let h = &self.hierarchy;
        let head = drivers::head_motion(&self.scene.head_motion, self.time);
        let n_strands = h.strand_total();
        let sub = self.render.subdivisions.max(1);
        // Frames of every front node along its current polyline, into disjoint ranges of one
        // buffer (no allocation once it has grown).
        self.node_frames
            .resize(self.state.node_count(), Matrix3::identity());
        let state = &self.state;
        fill_frames(state, &mut self.node_frames, 0, &self.front_ranges);
        let per = self.points_per_strand;
        let verts = sub * (per - 1) + 1;
        self.render.offsets.clear();
        self.render
            .offsets
            .extend((0..=n_strands as u32).map(|s| s * verts as u32));
        self.render
            .positions
            .resize(n_strands * verts, Point::origin());
        let strand_node = &self.strand_node;
        let node_frames = &self.node_frames;
        let local = &self.strand_local;
        let slot = &self.strand_slot;
        // The teleport offset moves the drawn hair with the head, never the dynamics.
        let rot = self.teleport.rotation.to_rotation_matrix() * head.rotation;
        let origin = self.teleport * head.position;
        // Curves in the front's order first: consecutive strands then share their skeleton's
        // nodes and frames, where strand order reads them from all over the state (a strand's
        // neighbours in number almost never share its skeleton). Then copied out in strand
        // order, one contiguous run per strand.
        let order = &self.strand_order;
        self.render_scratch
            .resize(n_strands * verts, Point::origin());
        // Each strand's control points are checked as they are made (in registers, no branch):
        // a curve through points within `DRAWABLE` of the origin stays finite.
        let drawable = self
            .render_scratch
            .par_chunks_mut(verts)
            .zip(order.par_iter())
            .map(|(out, &s)| {
                let s = s as usize;
                let node = strand_node[s];
                let r = state.nodes(SkeletonId(node));
                let p = &state.positions()[r.clone()];
                let frames = &node_frames[r.clone()];
                let mut control = [Point::origin(); 64];
                let count = p.len().min(per).min(64);
                let mut ok = true;
                for k in 0..count {
                    control[k] =
                        origin + rot * (p[k].coords + frames[k] * local[slot[s] as usize + k]);
                    let c = control[k];
                    // False for NaN too.
                    ok &= (c.x.abs() < DRAWABLE) & (c.y.abs() < DRAWABLE) & (c.z.abs() < DRAWABLE);
                }
                catmull_rom_into(&control[..count], sub, out);
                ok
            })
            .reduce(|| true, |a, b| a && b);
        let (scratch, rank) = (&self.render_scratch, &self.strand_rank);
        self.render
            .positions
            .par_chunks_mut(verts)
            .zip(rank.par_iter())
            .for_each(|(out, &k)| {
                let k = k as usize * verts;
                out.copy_from_slice(&scratch[k..k + verts]);
            });
        drawable
    }
}

/// Drawn control points farther than this from the origin (m) stop a step with
/// [`HairError::NonFiniteRender`]: hair there has left any scene, and the curves through such
/// points (sums of a few multiples of them) could overflow `f32`.
const DRAWABLE: Real = 1e36;

/// The transport frames of the skeletons whose node ranges are `ranges` (ascending, disjoint,
/// inside `base..base + frames.len()`) into `frames`, split in halves across threads.
fn fill_frames(
    state: &StrandState,
    frames: &mut [Matrix3<Real>],
    base: usize,
    ranges: &[(usize, usize, u32)],
) {
    if ranges.len() <= 16 {
        for &(start, end, node) in ranges {
            transport_frames_into(
                &state.positions()[start..end],
                state.root_frame(SkeletonId(node)).matrix(),
                &mut frames[start - base..end - base],
            );
        }
        return;
    }
    let mid = ranges.len() / 2;
    let (low, high) = frames.split_at_mut(ranges[mid].0 - base);
    rayon::join(
        || fill_frames(state, low, base, &ranges[..mid]),
        || fill_frames(state, high, ranges[mid].0, &ranges[mid..]),
    );
}

/// The nodes of skeleton `n` from its node `from` on, for the hard constraint's passes, each with
/// the node before it and the skeleton's radius.
fn push_body_nodes(out: &mut Vec<BodyNode>, state: &StrandState, n: u32, from: u32) {
    let r = state.nodes(SkeletonId(n));
    let radius = state.radius()[r.start];
    out.extend((r.start + from as usize..r.end).map(|i| BodyNode {
        node: i as u32,
        prev: if i > r.start { i as u32 - 1 } else { u32::MAX },
        skeleton: n,
        radius,
    }));
}

/// Where the hard constraint sends a node at `p` whose sphere reaches `lift` into the body
/// (`n` the body's normal there): lifted along `n`, then, if it has a parent node, back onto
/// its sphere about the parent at the height the lift asked for, so that a segment hanging
/// straight into a surface swings out of it instead of being re-aimed along itself; where no
/// place on that sphere is high enough, turned out ([`turn_out`]) by `method`.
fn body_target(
    body: &BodyModel,
    method: CollisionMethod,
    p: Point,
    parent: Option<&Point>,
    n: &Vector,
    lift: Real,
    radius: Real,
) -> Point {
    let lifted = p + n * lift;
    let Some(&a) = parent else {
        return lifted;
    };
    let len = (p - a).norm();
    if len <= 1e-9 {
        return lifted;
    }
    let u0 = (p - a) / len;
    let c = (n.dot(&u0) * len + lift) / len;
    if c > 1.0
        && let Some(t) = turn_out(body, method, a, u0, len, radius)
    {
        return t;
    }
    let c = c.clamp(-1.0, 1.0);
    let side = (u0 - n * n.dot(&u0))
        .try_normalize(1e-6)
        .unwrap_or_else(|| any_perpendicular(n));
    a + (side * (1.0 - c * c).max(0.0).sqrt() + n * c) * len
}

/// Where a node at `len` from its parent node `a` (its segment along `u0`) can go outside the
/// body when lifting it along its own surface normal cannot reach the surface: the first of a
/// few directions turned from `u0` toward the body's normal at `a` (back along the segment when
/// `a` is far from the body) that leaves the node's centre `radius` outside, by `method`.
/// A node that swung up into the underside of a part finds its nearest surface on the top, out
/// of reach of its segment; this sends it back out the side it came in by.
fn turn_out(
    body: &BodyModel,
    method: CollisionMethod,
    a: Point,
    u0: Vector,
    len: Real,
    radius: Real,
) -> Option<Point> {
    let away = body.distance(method, &a).map_or(-u0, |(_, n)| n);
    (1..=TURN_OUT_STEPS).find_map(|k| {
        let t = k as Real / TURN_OUT_STEPS as Real;
        let dir = (u0 * (1.0 - t) + away * t).try_normalize(1e-6)?;
        let q = a + dir * len;
        body.distance(method, &q)
            .is_none_or(|(d, _)| d >= radius)
            .then_some(q)
    })
}

/// Where a node caught inside the body can go on its sphere about its parent node `a` (radius
/// `len`, the segment's direction now `u0`): of [`ESCAPE_DIRECTIONS`] directions spread evenly
/// over the sphere, the one nearest `u0` whose point leaves the node's centre `radius` outside by
/// the exact distance; failing that, the one whose point is least deep, if it is less deep than
/// the node (`depth`) now. `None` when no direction improves on where the node is.
fn escape(
    body: &BodyModel,
    a: Point,
    u0: Vector,
    len: Real,
    radius: Real,
    depth: Real,
) -> Option<Point> {
    let mut order: [(Real, u16); ESCAPE_DIRECTIONS] = [(0.0, 0); ESCAPE_DIRECTIONS];
    for (k, slot) in order.iter_mut().enumerate() {
        *slot = (-sphere_direction(k).dot(&u0), k as u16);
    }
    order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let mut best: Option<(Real, Point)> = None;
    for &(_, k) in &order {
        let q = a + sphere_direction(k as usize) * len;
        let d = body
            .distance(CollisionMethod::Bvh, &q)
            .map_or(Real::INFINITY, |(d, _)| d);
        if d >= radius {
            return Some(q);
        }
        if best.is_none_or(|(b, _)| d > b) {
            best = Some((d, q));
        }
    }
    best.filter(|&(d, _)| -d < depth).map(|(_, q)| q)
}

/// Directions [`escape`] tries: enough that neighbours are about 15 degrees apart.
const ESCAPE_DIRECTIONS: usize = 192;

/// The `k`-th of [`ESCAPE_DIRECTIONS`] unit vectors on a Fibonacci sphere (evenly spread).
fn sphere_direction(k: usize) -> Vector {
    let golden = std::f32::consts::PI * (3.0 - 5.0f32.sqrt());
    let y = 1.0 - 2.0 * (k as Real + 0.5) / ESCAPE_DIRECTIONS as Real;
    let r = (1.0 - y * y).max(0.0).sqrt();
    let phi = golden * k as Real;
    Vector::new(r * phi.cos(), y, r * phi.sin())
}

/// Directions [`turn_out`] tries between a segment and the body's normal at its parent node.
const TURN_OUT_STEPS: usize = 8;

/// Detect-and-correct passes of the hard body constraint per step (a final detection follows).
pub const BODY_PASSES: usize = 8;
/// How deep inside the body [`Simulation::prefill_body_field`] computes samples (m).
pub const PREFILL_INSIDE: Real = 0.01;

/// Depth, as a fraction of the scene's penetration tolerance, below which a node in contact with
/// the body is not moved (its approach is still removed).
pub const CONTACT_SKIN: Real = 0.01;

/// Largest number of nodes the late passes of the hard body constraint (from [`BODY_PASSES`] on)
/// query by the exact distance instead of the scene's method.
pub const EXACT_LATE_NODES: usize = 256;

/// How many times a sweep of the hard body constraint tests a corrected node's target, and
/// moves it again while it is still inside, before leaving it to the next sweep.
pub const SWEEP_RETESTS: usize = 2;

/// Most passes of the hard body constraint when nodes stay deeper than the tolerance.
pub const MAX_BODY_PASSES: usize = 32;

/// A node the hard body constraint tests, with the node before it on its skeleton.
/// What the hard constraint's sweeps last found at a node.
#[derive(Clone, Copy, Debug, Default)]
struct SweepHit {
    /// The body's normal where the node's sphere reached the body when last tested (its
    /// velocity constraint).
    normal: Option<Vector>,
    /// How deep its centre is inside the body where it ends, as far as tested (m; negative
    /// outside).
    depth: Real,
    /// Whether the present sweep tested it.
    tested: bool,
    /// Whether the sweep that last tested it moved it to a place it could not confirm clear.
    corrected: bool,
}

#[derive(Clone, Copy, Debug)]
struct BodyNode {
    node: u32,
    /// The previous node of the skeleton, `u32::MAX` for a free root.
    prev: u32,
    skeleton: u32,
    radius: Real,
}

/// One section as the hair-hair response reads it: one cache line, instead of the section, its
/// node, its direction and its skeleton's activity from four arrays.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct ContactSection {
    a: Point,
    b: Point,
    radius: Real,
    /// Unit direction (zero for a degenerate section).
    tangent: Vector,
    /// The section's end node (the one a push moves).
    node: u32,
    /// Whether its skeleton is integrated this step.
    active: bool,
    /// Whether it is a segment (the only shape the response handles).
    segment: bool,
}

/// The hair-hair narrow phase's decisions for one chunk of the pair set, in pair order.
///
/// Measured and dropped (temporary timers, alternated with the code kept): the contact record
/// split into a 16-byte head (direction, node, flags) and the segment read by pushes only (no
/// change on `strands10k`, whose 300,000 records do not fit in the cache); the shares holding
/// the joint that consecutive shares have in common in registers (the accumulation on `wardlin`
/// went from 1.6 to 2.1 ms: slower); the pushes' closest points eight pairs at a time by a lane
/// kernel equal to the scalar one bit for bit (the narrow phase unchanged: 2.4-3.1 ms on
/// `wardlin`, 59-90 ms on `strands10k`, either way; tried again later, medians of 3.86-4.32 ms
/// with it and 3.68-4.78 ms without over four alternated rounds of 60 frames); each node's two
/// rates side by side in a scratch while the shares average them (one load and one store of a
/// pair per node instead of two of each: the shares' loop took 1.76-1.83 ms fastest with it and
/// 1.69-1.91 ms without over three rounds; it waits on the chain of shares, not on memory); the
/// pairs sorted into shares and crossings by a first pass with no branch on the outcome (each
/// written to its list's next slot, the slot kept only if it belongs there), the closest points
/// of the crossings found by a second (near-parallel and crossing pairs come mixed, about one in
/// three crossing): the same records, but the narrow phase took 3.50-5.26 ms on `wardlin` with it
/// and 3.72-4.94 ms without over five alternated rounds of 60 frames, no steadier relative to the
/// pair search's time in the same runs (the outcome's branch is not what the loop waits on).
#[derive(Debug, Default)]
struct ResponseChunk {
    /// Near-parallel sections in contact: their joints share their rates.
    shares: Vec<[u32; 2]>,
    /// Crossing sections overlapping: the second node's push, half the overlap along the line
    /// between the closest points (the first is pushed the opposite way).
    pushes: Vec<(u32, u32, Vector)>,
    /// With `collision.pair_search_interval` above 1: every pair of segments of the chunk, by
    /// their end nodes, in pair order, for the steps until the next search.
    kept: Vec<[u32; 2]>,
}

impl ResponseChunk {
    /// The narrow phase on the kept pairs at the present positions (`p`, per-node `radius`):
    /// the sections rebuilt from their end nodes as the step builds them, a pair now apart
    /// dropped, the others shared or pushed as after a search. Eight pairs at a time, in
    /// lanes with no branch, so that the loops compile to packed instructions: one pair at a
    /// time, with its divisions and branches, the test cost more than the search it replaces
    /// (28.5 ms a step against 23.5 ms on `wardlin`).
    fn retest(&mut self, state: &StrandState, p: &[Point], radius: &[Real], cos_parallel: Real) {
        const L: usize = 8;
        self.shares.clear();
        self.pushes.clear();
        let cos2 = cos_parallel * cos_parallel.abs();
        let active = |i: usize| state.is_active(SkeletonId(state.skeleton_of(i)));
        let mut block = [[0u32; 2]; L];
        for group in self.kept.chunks(L) {
            // The pairs of an active skeleton; padded with the first of them.
            let mut n = 0;
            for &pair in group {
                if active(pair[0] as usize) || active(pair[1] as usize) {
                    block[n] = pair;
                    n += 1;
                }
            }
            if n == 0 {
                continue;
            }
            for k in n..L {
                block[k] = block[0];
            }
            // The sections' ends and radii, lane by lane.
            let (mut a0, mut u, mut b0, mut v) =
                ([[0.0; L]; 3], [[0.0; L]; 3], [[0.0; L]; 3], [[0.0; L]; 3]);
            let mut radii = [0.0; L];
            for (l, &[a, b]) in block.iter().enumerate() {
                let (i, j) = (a as usize, b as usize);
                for k in 0..3 {
                    a0[k][l] = p[i - 1][k];
                    u[k][l] = p[i][k] - p[i - 1][k];
                    b0[k][l] = p[j - 1][k];
                    v[k][l] = p[j][k] - p[j - 1][k];
                }
                radii[l] = radius[i].max(radius[i - 1]) + radius[j].max(radius[j - 1]);
            }
            let mut r = [[0.0; L]; 3];
            for k in 0..3 {
                for l in 0..L {
                    r[k][l] = a0[k][l] - b0[k][l];
                }
            }
            let (s, t) = hair_ssv::segment_segment_params_lanes(&u, &v, &r);
            let (mut d, mut dist, mut parallel) = ([[0.0; L]; 3], [0.0; L], [false; L]);
            for l in 0..L {
                // From the first section's closest point to the second's.
                for k in 0..3 {
                    d[k][l] = (b0[k][l] + v[k][l] * t[l]) - (a0[k][l] + u[k][l] * s[l]);
                }
                dist[l] = (d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l]).sqrt();
                // |cos| of the angle between them at least `cos_parallel`, without the roots; a
                // point section has no direction (its cosine is taken as 0, as the search does).
                let dot = |x: &[[Real; L]; 3], y: &[[Real; L]; 3]| {
                    x[0][l] * y[0][l] + x[1][l] * y[1][l] + x[2][l] * y[2][l]
                };
                let (a, e, b) = (dot(&u, &u), dot(&v, &v), dot(&u, &v));
                parallel[l] = (b * b >= cos2 * a * e && a > 0.0 && e > 0.0) || cos_parallel <= 0.0;
            }
            for l in 0..n {
                let overlap = radii[l] - dist[l];
                // What the search keeps: the segments within the sum of their radii.
                if overlap.is_nan() || overlap < 0.0 {
                    continue;
                }
                let [a, b] = block[l];
                if parallel[l] {
                    self.shares.push([a, b]);
                } else if overlap > 0.0 && dist[l] > 1e-9 {
                    let d = Vector::new(d[0][l], d[1][l], d[2][l]);
                    self.pushes.push((a, b, d * (0.5 * overlap / dist[l])));
                }
            }
        }
    }
}

fn any_perpendicular(n: &Vector) -> Vector {
    let a = if n.x.abs() < 0.9 {
        Vector::x()
    } else {
        Vector::y()
    };
    n.cross(&a).normalize()
}

fn ms(a: Instant, b: Instant) -> f64 {
    (b - a).as_secs_f64() * 1e3
}

/// Hierarchy thresholds for a scene: the defaults, which are sized for a human head.
fn hierarchy_params(scene: &Scene) -> HierarchyParams {
    scene.hierarchy.params()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The camera (the default: in front of the face) sees a point between it and the face, not
    /// one behind the head or far to the side; a teleport carries what it sees with the head
    /// (the camera keeps its place relative to the head path, as for the adaptive policy).
    #[test]
    fn the_camera_sees_in_front_of_the_head_and_follows_a_teleport() {
        let scene = Scene::load("bristles").expect("built-in scene");
        let mut sim = Simulation::new(&scene, LodPolicy::Fine).expect("scene builds");
        let points = [
            Point::new(0.0, 0.0, 0.3),
            Point::new(0.0, 0.0, -0.3),
            Point::new(1.0, 0.0, 0.5),
            Point::new(2.0, 0.0, 0.3),
        ];
        let mut seen = Vec::new();
        sim.seen_by_camera(&points, &mut seen);
        assert_eq!(seen, [true, false, false, false]);
        sim.teleport(Isometry3::translation(2.0, 0.0, 0.0));
        sim.seen_by_camera(&points, &mut seen);
        assert_eq!(seen, [false, false, false, true]);
    }

    /// The kept pairs tested again at the positions the search found them at give what the
    /// search's narrow phase gave: the same shares and the same pushes, bit for bit (the lanes
    /// compute hair-ssv's segment-segment expressions in the same order), save a pair on the
    /// edge of the parallel angle, which the lanes decide on squared cosines.
    #[test]
    fn kept_pairs_retested_where_they_were_found_respond_as_the_search_did() {
        let mut scene = Scene::load("wind").expect("built-in scene");
        scene.scene.collision.pair_search_interval = 3;
        let mut sim = Simulation::new(&scene, LodPolicy::Fine).expect("scene builds");
        let mut compared = (0, 0);
        for _ in 0..12 {
            // The step's sections and the search on them, as `step` runs them (the pairs then
            // meet the dynamics, so they are compared before it).
            sim.build_sections();
            sim.grid.rebuild(&sim.sections).expect("grid");
            let cos = scene.scene.collision.parallel_angle.cos();
            sim.search_hair_pairs(cos, true);
            let chunks = sim.pairs.chunk_count();
            let found: Vec<_> = sim.responses[..chunks]
                .iter()
                .map(|r| (r.shares.clone(), r.pushes.clone()))
                .collect();
            let (p, radius) = (sim.state.positions(), sim.state.radius());
            for (r, (shares, pushes)) in sim.responses[..chunks].iter_mut().zip(&found) {
                r.retest(&sim.state, p, radius, cos);
                let bits = |v: &[(u32, u32, Vector)]| -> Vec<(u32, u32, [u32; 3])> {
                    v.iter()
                        .map(|(a, b, d)| (*a, *b, [d.x, d.y, d.z].map(f32::to_bits)))
                        .collect()
                };
                if r.shares == *shares {
                    assert_eq!(bits(&r.pushes), bits(pushes));
                } else {
                    // Only a pair on the edge of the parallel angle moves between the lists.
                    let moved = r.shares.len().abs_diff(shares.len());
                    assert!(moved <= 2 && moved == r.pushes.len().abs_diff(pushes.len()));
                }
                compared.0 += r.shares.len();
                compared.1 += r.pushes.len();
            }
            sim.step().expect("step");
        }
        assert!(compared.0 > 0 && compared.1 > 0, "{compared:?}");
    }

    /// One float's lowest bit flipped anywhere in the state (an angle or a rate of the first, a
    /// middle or the last node) changes the hash; flipped back, the hash returns.
    #[test]
    fn the_state_hash_sees_every_float() {
        let scene = Scene::load("bristles").expect("built-in scene");
        let mut sim = Simulation::new(&scene, LodPolicy::Fine).expect("scene builds");
        let base = sim.state_hash();
        let n = sim.state.node_count();
        // Flips the lowest bit of one angle or rate of node `i`.
        let flip = |s: &mut StrandState, field: usize, i: usize| {
            let x = match field {
                0 => &mut s.theta_mut()[i],
                1 => &mut s.phi_mut()[i],
                2 => &mut s.omega_theta_mut()[i],
                _ => &mut s.omega_phi_mut()[i],
            };
            *x = f32::from_bits(x.to_bits() ^ 1);
        };
        for i in [0, n / 2, n - 1] {
            for field in 0..4 {
                flip(&mut sim.state, field, i);
                assert_ne!(sim.state_hash(), base, "node {i}, field {field}");
                flip(&mut sim.state, field, i);
                assert_eq!(sim.state_hash(), base);
            }
        }
    }
}
