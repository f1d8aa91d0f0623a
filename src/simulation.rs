//! The per-step pipeline (`../DESIGN.md`, "One simulation step"): drivers, LOD selection, grid,
//! hair-hair (soft), dynamics, hair-object (hard), render geometry.
//!
//! The hard constraint runs after integration rather than before it, so the state handed to the
//! renderer and to the next step is never inside the body by more than the stated tolerance.

use crate::render_geometry::{
    CutRender, CutStrands, RenderGeometry, catmull_rom_into, transport_frames,
    transport_frames_into,
};
use crate::scene::{IntegratorSpec, LodPolicy, Scene, TorqueSpec};
use crate::{HairError, LoadedScene, drivers, hairstyle};
use hair_collide::{BodyConstraint, HairPairs, Localization, Sections};
use hair_dynamics::{
    Environment, Integrator, LinearSolver, Material, SkeletonId, StepSettings, StrandState,
    TorqueModel, Wind,
};
use hair_grid::{Grid, GridConfig};
use hair_lod::{
    AdaptiveLod, BodyDepth, Hierarchy, HierarchyParams, NodeKind, OccluderMesh, TransitionReport,
    View,
};
use hair_ssv::{MeshBody, Point, Real, Vector};
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
    pub salon: hair_salon::SalonStats,
}

/// A scene being simulated.
pub struct Simulation {
    scene: Scene,
    hierarchy: Hierarchy,
    front_nodes: Vec<u32>,
    state: StrandState,
    body: Option<MeshBody>,
    settings: StepSettings,
    time: Real,
    steps: u64,
    grid: Grid,
    /// The front's segments as grid sections.
    sections: Sections,
    localization: Localization,
    hair_pairs: HairPairs,
    body_constraint: BodyConstraint,
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
    salon: hair_salon::Salon,
    /// The drawn strands' ends after cuts, and the fallen pieces.
    cut_render: CutRender,
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
        let body = crate::body::from_spec(&scene.body, &loaded.base_dir)?;
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
            sections: Sections::default(),
            localization: Localization::default(),
            hair_pairs: HairPairs::new(),
            body_constraint: BodyConstraint::new(),
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
            salon: hair_salon::Salon::default(),
            cut_render: CutRender::default(),
        };
        // salon (issue 8): tools over the initial state.
        sim.salon = hair_salon::Salon::new(
            &sim.scene.tools,
            &sim.state,
            &sim.hierarchy,
            &sim.node_radius,
        );
        sim.prepare_render();
        if policy == LodPolicy::Adaptive {
            let mut lod = AdaptiveLod::new(&sim.hierarchy, &sim.scene.adaptive);
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
    /// head frame), their cells and the pair search's data. With `pair_search_interval` above
    /// 1 and localization off, the steps between pair searches leave it as the last search
    /// built it.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Computes ahead the samples of the body's distance field that hair near the surface
    /// reads (`DistanceField::fill_band` on [`MeshBody::field`]): from [`PREFILL_INSIDE`] inside
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
            .fill_band(body, PREFILL_INSIDE, hair_ssv::NEAR_MARGIN)
    }

    /// The body, if any.
    pub fn body(&self) -> Option<&MeshBody> {
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
            depth.build(occluder(body), &view);
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
        self.hair_pairs.forget();
        self.localization.clear();
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
        self.hair_pairs.forget();
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
                self.body_depth.build(occluder(body), &view);
                view.occluder = Some(&self.body_depth);
            }
            let result = lod.update(
                &self.hierarchy,
                &mut self.state,
                &view,
                self.localization.frozen(),
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

        // 3. Grid over the front's segments (head frame, where the body is static). The pairs
        // of the last search are tested again while they are young enough and the hair is the
        // same hair: no tool script (a cut, a bond) and the same front.
        self.sections.build(&self.state, &self.front_nodes);
        let collision = &self.scene.collision;
        let search = self
            .hair_pairs
            .plan(collision, self.salon.script().events.is_empty());
        // Between searches nothing else reads the grid unless localization measures activity
        // (the salon's tools would, but a tool script always searches).
        if search || self.scene.localization {
            self.grid.rebuild(&self.sections.sections)?;
        }
        if self.scene.localization {
            self.localization.update(
                &mut self.state,
                &self.grid,
                &self.sections,
                &self.front_nodes,
                self.settings.dt,
                self.salon.volumes(),
            )?;
        }
        let t3 = Instant::now();
        stats.ms_grid = ms(t2, t3);

        // 4. Hair-hair (soft).
        let report = self.hair_pairs.respond(
            &mut self.state,
            &self.grid,
            &self.sections,
            &self.scene.collision,
        )?;
        stats.pairs_tested = report.pairs_tested;
        stats.hair_contacts = report.contacts;
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
            &hair_salon::SalonInput {
                hierarchy: &self.hierarchy,
                front: &self.front_nodes,
                grid: &self.grid,
                sections: &self.sections.sections,
                body: self.body.as_ref(),
                head: &env.head,
                time: self.time + self.settings.dt,
                dt: self.settings.dt,
                collision: &self.scene.collision,
            },
        )?;
        // salon (issue 8) end.
        let t5 = Instant::now();
        stats.ms_dynamics = ms(t4, t5);

        // 6. Hair-object (hard).
        if let Some(body) = &self.body {
            let report = self.body_constraint.apply(
                &mut self.state,
                body,
                &self.front_nodes,
                self.steps,
                &self.scene.collision,
            )?;
            stats.body_contacts = report.contacts;
            stats.max_penetration_m = f64::from(report.max_penetration);
        }
        let t6 = Instant::now();
        stats.ms_hair_object = ms(t5, t6);

        self.time += self.settings.dt;
        self.steps += 1;
        if self.scene.localization {
            self.localization.record_positions(&self.state);
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
        self.cut_render.apply(
            &self.salon,
            &self.state,
            &self.hierarchy,
            &CutStrands {
                strand_node: &self.strand_node,
                node_local_start: &self.node_local_start,
                strand_local: &self.strand_local,
                per: self.points_per_strand,
            },
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

/// How deep inside the body [`Simulation::prefill_body_field`] computes samples (m).
pub const PREFILL_INSIDE: Real = 0.01;

/// The body as the adaptive policy's depth image draws it.
fn occluder(body: &MeshBody) -> OccluderMesh<'_> {
    OccluderMesh {
        vertices: &body.vertices,
        triangles: &body.triangles,
        closed: body.closed,
    }
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
