//! The LOD stage of the pipeline: a fixed policy's front, or the `adaptive` policy
//! ([`hair_lod::AdaptiveLod`]) re-selected each step from the camera's view in the head frame
//! and the body's depth image.

use crate::HairError;
use crate::drivers;
use crate::scene::Scene;
use hair_dynamics::{HeadPose, SkeletonId, StrandState};
use hair_lod::{AdaptiveLod, BodyDepth, Hierarchy, NodeKind, OccluderMesh, TransitionReport, View};
use hair_ssv::{MeshBody, Point, Real, Vector};
use serde::{Deserialize, Serialize};

/// Level-of-detail policies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum LodPolicy {
    /// The finest skeletons everywhere.
    Fine,
    /// Chosen per node from visibility, distance and motion.
    Adaptive,
    /// Coarse strand groups everywhere.
    CoarseStrands,
    /// Clusters everywhere.
    Clusters,
    /// Strips everywhere.
    Strips,
}

impl LodPolicy {
    /// Every policy, finest first.
    pub const ALL: [LodPolicy; 5] = [
        LodPolicy::Fine,
        LodPolicy::Adaptive,
        LodPolicy::CoarseStrands,
        LodPolicy::Clusters,
        LodPolicy::Strips,
    ];

    /// The CLI name (`fine`, `adaptive`, `coarse-strands`, `clusters`, `strips`).
    pub fn name(self) -> &'static str {
        match self {
            LodPolicy::Fine => "fine",
            LodPolicy::Adaptive => "adaptive",
            LodPolicy::CoarseStrands => "coarse-strands",
            LodPolicy::Clusters => "clusters",
            LodPolicy::Strips => "strips",
        }
    }

    /// Parses a CLI name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// The LOD stage's state: the adaptive policy (if chosen), its starting point for a reset, and
/// the body's depth image from the camera (drawn again only when the view changes).
#[derive(Clone, Debug, Default)]
pub(crate) struct LodStage {
    adaptive: Option<AdaptiveLod>,
    initial: Option<AdaptiveLod>,
    pub(crate) body_depth: BodyDepth,
    last: TransitionReport,
}

/// What the LOD stage did in a step.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct LodReport {
    /// Whether the front changed.
    pub changed: bool,
    pub splits: u32,
    pub merges: u32,
    pub hidden_trees: usize,
}

impl LodStage {
    /// The stage for `policy`; the adaptive one settles its starting front (one level per
    /// selection, from the root strips down) and sets the state's active flags.
    pub(crate) fn new(
        policy: LodPolicy,
        scene: &Scene,
        h: &Hierarchy,
        state: &mut StrandState,
    ) -> Result<Self, HairError> {
        let mut stage = Self::default();
        if policy != LodPolicy::Adaptive {
            return Ok(stage);
        }
        let mut lod = AdaptiveLod::new(h, &scene.adaptive);
        lod.hold_groom(h, state)?;
        for n in 0..h.node_count() as u32 {
            state.set_active(SkeletonId(n), lod.front().is_active(n));
        }
        // Settled without the body's occlusion: hair hidden at rest coarsens only after
        // `HIDDEN_AFTER` steps of wind. Settled with it and counted hidden at once (tried on
        // 5eea007, then dropped), `wardlin`'s visible RMS distance from `fine` went from 1.94 to
        // 3.76 mm: hair hidden at rest that the wind brings into view came back from its root
        // strip.
        let view = view(scene, &drivers::head_pose(&scene.head_motion, 0.0), 0.0);
        for _ in 0..=h.max_level() {
            if !lod.update(h, state, &view, &[])? {
                break;
            }
        }
        stage.initial = Some(lod.clone());
        stage.adaptive = Some(lod);
        Ok(stage)
    }

    /// Whether the adaptive policy runs.
    pub(crate) fn is_adaptive(&self) -> bool {
        self.adaptive.is_some()
    }

    /// The adaptive front as a sorted node list into `front` (unchanged for a fixed policy).
    pub(crate) fn front_into(&self, h: &Hierarchy, front: &mut Vec<u32>) {
        if let Some(lod) = &self.adaptive {
            front.clear();
            front.extend((0..h.node_count() as u32).filter(|&n| lod.front().is_active(n)));
        }
    }

    /// Back to the starting front; true if there is an adaptive front to refresh.
    pub(crate) fn reset(&mut self) -> bool {
        let Some(initial) = &self.initial else {
            return false;
        };
        match &mut self.adaptive {
            Some(current) => current.reset_to(initial),
            None => self.adaptive = Some(initial.clone()),
        }
        true
    }

    /// One selection at time `t` with the head at `head` (fixed policies change nothing): the
    /// camera's view in the head frame, the body's depth image when hidden hair is culled, and the skeletons
    /// localization froze.
    pub(crate) fn select(
        &mut self,
        scene: &Scene,
        body: Option<&MeshBody>,
        h: &Hierarchy,
        state: &mut StrandState,
        (head, t): (&HeadPose, Real),
        frozen: &[bool],
    ) -> Result<LodReport, HairError> {
        let Some(lod) = &mut self.adaptive else {
            return Ok(LodReport::default());
        };
        let mut view = view(scene, head, t);
        if let (Some(body), true) = (body, scene.adaptive.cull_hidden) {
            self.body_depth.build(occluder(body), &view);
            view.occluder = Some(&self.body_depth);
        }
        let result = lod.update(h, state, &view, frozen);
        self.last = lod.last_report();
        Ok(LodReport {
            changed: result?,
            splits: self.last.splits,
            merges: self.last.merges,
            hidden_trees: lod.hidden_trees(h),
        })
    }
}

/// The camera's view cone at time `t` in the frame of the head at `head`, with no occluder yet.
pub(crate) fn view(scene: &Scene, head: &HeadPose, t: Real) -> View<'static> {
    let (eye, target) = drivers::camera(&scene.camera, t);
    let to_head = |p: Point| head.inverse_transform_point(&p);
    let (eye, target) = (to_head(eye), to_head(target));
    let forward = (target - eye)
        .try_normalize(1e-9)
        .unwrap_or_else(|| -Vector::z());
    // The cone around the whole image at a 3:2 aspect ratio, with a little margin.
    let tan_v = (0.5 * scene.camera.fov_degrees.to_radians()).tan();
    let half = (tan_v * (1.0 + 1.5f32 * 1.5).sqrt()).atan() * 1.1;
    View {
        eye,
        forward,
        cos_half_angle: half.min(std::f32::consts::FRAC_PI_2).cos(),
        occluder: None,
    }
}

/// The body as the adaptive policy's depth image draws it.
pub(crate) fn occluder(body: &MeshBody) -> OccluderMesh<'_> {
    OccluderMesh {
        vertices: &body.vertices,
        triangles: &body.triangles,
        closed: body.closed,
    }
}

/// The nodes a fixed policy simulates: for each finest node, its highest ancestor of the
/// policy's kind (or itself where the tree has none).
pub(crate) fn fixed_front(h: &Hierarchy, policy: LodPolicy) -> Vec<u32> {
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
