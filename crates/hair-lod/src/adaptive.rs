//! The `adaptive` LOD policy over a strand state (Ward & Lin §6): each step the hierarchy's
//! active front is re-selected from what the camera sees and how fast the hair moves, and the
//! transitions carry the motion between levels.
//!
//! Every hierarchy node is a skeleton of the simulation's [`StrandState`] all the time; only the
//! front is integrated. Before selecting, the front's motion is read into a [`LodState`]
//! (deviations from rest, so a coarse node and its children share one description); after the
//! transitions, every node that became active gets its motion written back from it. Hair hidden
//! from the camera (outside the view, or behind the body: [`BodyDepth`]) for [`HIDDEN_AFTER`]
//! steps asks for the coarsest level and, when all of a tree's hair is hidden, the tree collapses
//! to its root strip.
//! Speeds are held against a decay ([`SPEED_HOLD`]) and merges need a margin
//! ([`crate::MERGE_MARGIN`]): hysteresis, so that the front does not flicker.

use crate::{
    Activity as LodActivity, Front, Hierarchy, LodError, LodState, MergeParams, NodeInputs, Plan,
    SelectParams, TransitionReport,
};
use hair_dynamics::{Point, Real, SkeletonId, StrandState, Vector};

/// What the camera sees, in the head frame.
#[derive(Clone, Copy, Debug)]
pub struct View<'a> {
    /// Eye (m).
    pub eye: Point,
    /// Unit direction the camera looks along.
    pub forward: Vector,
    /// Cosine of the half-angle of the cone that holds the whole image.
    pub cos_half_angle: Real,
    /// The body's depth from this eye, which hides what lies behind it ([`BodyDepth::build`]
    /// for this view; `None`: nothing is hidden but what is outside the cone).
    pub occluder: Option<&'a BodyDepth>,
}

impl View<'_> {
    /// Whether `p` is inside the view cone and not behind the body.
    pub fn sees(&self, p: &Point) -> bool {
        let d = p - self.eye;
        let len = d.norm();
        if len <= 1e-9 {
            return true;
        }
        if d.dot(&self.forward) < self.cos_half_angle * len {
            return false;
        }
        self.occluder.is_none_or(|o| !o.hides(p))
    }
}

/// How far behind the body's surface, along the view, a point must lie to count as hidden (m):
/// hair lies on the body, and a point beside the silhouette, or on the skin seen at a grazing
/// angle, must not be taken for one behind it.
pub const HIDDEN_BEHIND: Real = 0.01;

/// A body mesh as [`BodyDepth`] draws it.
#[derive(Clone, Copy, Debug)]
pub struct OccluderMesh<'a> {
    /// Vertices, in the frame of the view.
    pub vertices: &'a [Point],
    /// Triangles, wound outward for a closed mesh.
    pub triangles: &'a [[u32; 3]],
    /// Whether the mesh is a closed surface (then only the triangles facing the eye are drawn,
    /// if it is wound outward).
    pub closed: bool,
}

/// The body's depth as the camera sees it: a square image over the view cone, each pixel the
/// view depth of the nearest triangle at its centre. It answers "is this point behind the
/// body?" for the `adaptive` policy's visibility, for any body mesh (a head, a bust from an OBJ,
/// the torus), where a point test against the mesh would cost a ray cast per control point.
///
/// The answer errs only toward "seen": a point is hidden when the body covers the centres of
/// its pixel and of the eight around it, each [`HIDDEN_BEHIND`] nearer than the point, so a
/// point near the silhouette, where a pixel is partly body and partly background, stays seen;
/// a triangle that reaches behind the eye is left out (nothing it covers is hidden).
///
/// In the head frame the body does not move, so the image changes only with the view:
/// [`BodyDepth::build`] keeps it when the view is the same to the bit, and a stationary camera
/// draws the body once (its cost: `docs/perf/lod.md`).
#[derive(Clone, Debug, Default)]
pub struct BodyDepth {
    /// The view the image was drawn for: eye, forward and cone cosine, by their bits.
    key: Option<[u32; 7]>,
    right: Vector,
    up: Vector,
    forward: Vector,
    eye: Point,
    /// Tangent of the cone's half-angle: the image spans `[-1, 1]` times it in both directions.
    tan_half: Real,
    /// Per pixel, the depth of the nearest triangle (infinite where there is none).
    nearest: Vec<Real>,
    /// Per pixel, the farthest of `nearest` over the pixel and its eight neighbours.
    covered: Vec<Real>,
    /// The body's vertices in image coordinates and depth (`None` at or behind the near plane),
    /// each projected once for the triangles that share it.
    projected: Vec<Option<(Real, Real, Real)>>,
    /// The farthest of `nearest` over each pixel and its two neighbours in its row.
    row_far: Vec<Real>,
}

/// Pixels along each side of [`BodyDepth`]'s image: at `wardlin`'s camera, 0.6 m from the head
/// with a 40 degree view, one pixel is about 3.5 mm, and the head about 45 pixels across.
pub const BODY_DEPTH_SIZE: usize = 256;

/// Nearest view depth a triangle may reach and still be drawn (m).
const NEAR_PLANE: Real = 1e-3;

impl BodyDepth {
    /// An empty image (hides nothing until built).
    pub fn new() -> Self {
        Self::default()
    }

    /// Draws the body's depth for `view` (its occluder is ignored), unless the image already
    /// holds this view. Returns whether it drew. Takes memory only the first time.
    pub fn build(&mut self, body: OccluderMesh<'_>, view: &View<'_>) -> bool {
        let bits = |v: Real| v.to_bits();
        let key = [
            bits(view.eye.x),
            bits(view.eye.y),
            bits(view.eye.z),
            bits(view.forward.x),
            bits(view.forward.y),
            bits(view.forward.z),
            bits(view.cos_half_angle),
        ];
        if self.key == Some(key) {
            return false;
        }
        self.key = Some(key);
        let forward = view.forward;
        // Any right angle to the view will do; the world's up keeps the image upright.
        let hint = if forward.y.abs() < 0.9 {
            Vector::y()
        } else {
            Vector::x()
        };
        let right = forward.cross(&hint).normalize();
        self.right = right;
        self.up = right.cross(&forward);
        self.forward = forward;
        self.eye = view.eye;
        let c = view.cos_half_angle.clamp(1e-3, 1.0);
        self.tan_half = ((1.0 - c * c).max(0.0).sqrt() / c).max(1e-6);
        let n = BODY_DEPTH_SIZE;
        self.nearest.clear();
        self.nearest.resize(n * n, Real::INFINITY);
        self.covered.clear();
        self.covered.resize(n * n, Real::INFINITY);
        let mut projected = std::mem::take(&mut self.projected);
        projected.clear();
        projected.extend(body.vertices.iter().map(|v| self.project(v)));
        // On a closed, outward-wound surface the nearest triangle along any line of sight
        // faces the eye: the others need not be drawn. (Wound inward, the faces toward the eye
        // would be the far ones: such a mesh is drawn whole.)
        let front_only = body.closed && signed_volume(&body) > 0.0;
        for tri in body.triangles {
            let v = tri.map(|i| projected[i as usize]);
            let [Some(a), Some(b), Some(c)] = v else {
                continue;
            };
            if front_only {
                let [p, q, r] = tri.map(|i| body.vertices[i as usize]);
                if (q - p).cross(&(r - p)).dot(&(p - self.eye)) >= 0.0 {
                    continue;
                }
            }
            self.draw(a, b, c);
        }
        self.projected = projected;
        // The farthest depth around each pixel (a row pass, then a column pass): a point there
        // is hidden only where every neighbouring centre is body in front of it.
        self.row_far.clear();
        self.row_far.resize(n * n, Real::INFINITY);
        for (near, far) in self
            .nearest
            .chunks_exact(n)
            .zip(self.row_far.chunks_exact_mut(n))
        {
            for x in 1..n - 1 {
                far[x] = near[x - 1].max(near[x]).max(near[x + 1]);
            }
        }
        // Pixels on the image's border have neighbours outside it, which are unknown: they
        // stay infinite.
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let i = y * n + x;
                self.covered[i] = self.row_far[i - n]
                    .max(self.row_far[i])
                    .max(self.row_far[i + n]);
            }
        }
        true
    }

    /// Whether `p` lies behind the body as the image's view sees it (false before any build).
    pub fn hides(&self, p: &Point) -> bool {
        let Some((x, y, z)) = self.project(p) else {
            return false;
        };
        let n = BODY_DEPTH_SIZE as Real;
        if !(x >= 0.0 && y >= 0.0 && x < n && y < n) {
            return false;
        }
        let i = y as usize * BODY_DEPTH_SIZE + x as usize;
        self.covered.get(i).is_some_and(|&d| d + HIDDEN_BEHIND < z)
    }

    /// Image coordinates (pixels, the centre of pixel `i` at `i + 0.5`) and view depth of `p`,
    /// or `None` for a point at or behind the near plane (or before any build).
    fn project(&self, p: &Point) -> Option<(Real, Real, Real)> {
        self.key?;
        let d = p - self.eye;
        let z = d.dot(&self.forward);
        if z.is_nan() || z <= NEAR_PLANE {
            return None;
        }
        let half = 0.5 * BODY_DEPTH_SIZE as Real;
        let s = half / (z * self.tan_half);
        Some((half + d.dot(&self.right) * s, half - d.dot(&self.up) * s, z))
    }

    /// Draws one projected triangle into `nearest`: the pixels whose centres it covers, with
    /// the depth interpolated as its reciprocal (linear on the image under a perspective).
    fn draw(&mut self, a: (Real, Real, Real), b: (Real, Real, Real), c: (Real, Real, Real)) {
        let n = BODY_DEPTH_SIZE;
        let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
        if !area.is_finite() || area.abs() < 1e-12 {
            return;
        }
        let lo = |u: Real| (u - 0.5).ceil().max(0.0);
        let hi = |u: Real| (u - 0.5).floor().min(n as Real - 1.0);
        let (x0, x1) = (lo(a.0.min(b.0).min(c.0)), hi(a.0.max(b.0).max(c.0)));
        let (y0, y1) = (lo(a.1.min(b.1).min(c.1)), hi(a.1.max(b.1).max(c.1)));
        if x0 > x1 || y0 > y1 {
            return;
        }
        let inv = 1.0 / area;
        let (ra, rb, rc) = (1.0 / a.2, 1.0 / b.2, 1.0 / c.2);
        for y in y0 as usize..=y1 as usize {
            let py = y as Real + 0.5;
            for x in x0 as usize..=x1 as usize {
                let px = x as Real + 0.5;
                // Barycentric weights from the edge functions, the triangle's winding either way.
                let wa = ((b.0 - px) * (c.1 - py) - (b.1 - py) * (c.0 - px)) * inv;
                let wb = ((c.0 - px) * (a.1 - py) - (c.1 - py) * (a.0 - px)) * inv;
                let wc = 1.0 - wa - wb;
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let depth = 1.0 / (wa * ra + wb * rb + wc * rc);
                let cell = &mut self.nearest[y * n + x];
                *cell = cell.min(depth);
            }
        }
    }
}

/// The volume a closed mesh encloses, positive when its triangles are wound outward.
fn signed_volume(body: &OccluderMesh<'_>) -> f64 {
    body.triangles
        .iter()
        .map(|t| {
            let [p, q, r] = t.map(|i| body.vertices[i as usize].coords.cast::<f64>());
            p.dot(&q.cross(&r)) / 6.0
        })
        .sum()
}

/// When the `adaptive` policy asks for detail (Ward & Lin §6.1): the level a node wants rises
/// as it gets nearer the camera or moves faster; hair the camera cannot see collapses to its
/// root strip and is not drawn.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct AdaptiveSettings {
    /// Nearer than this the finest level (m).
    pub distance_finest: Real,
    /// Farther than this the coarsest level (m).
    pub distance_coarsest: Real,
    /// Slower than this asks for the coarsest level (m/s).
    pub speed_coarsest: Real,
    /// Faster than this asks for the finest level (m/s).
    pub speed_finest: Real,
    /// Children within this distance of their parent merge (m).
    pub merge_distance: Real,
    /// Whether hair hidden from the camera (behind the body or outside the view) collapses.
    pub cull_hidden: bool,
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        let s = SelectParams::default();
        Self {
            distance_finest: s.distance_finest,
            distance_coarsest: s.distance_coarsest,
            speed_coarsest: s.speed_coarsest,
            speed_finest: s.speed_finest,
            merge_distance: MergeParams::default().merge_distance,
            cull_hidden: true,
        }
    }
}

/// The adaptive front and the motion that travels between its levels.
#[derive(Clone, Debug)]
pub struct AdaptiveLod {
    front: Front,
    lod: LodState,
    plan: Plan,
    select: SelectParams,
    merge: MergeParams,
    cull_hidden: bool,
    visible: Vec<bool>,
    distance: Vec<Real>,
    speed: Vec<Real>,
    activity: Vec<LodActivity>,
    was_active: Vec<bool>,
    /// Per node: consecutive steps it has been active and out of sight.
    unseen_for: Vec<u32>,
    /// Per node: the speed it is judged by, its own held against a decay ([`SPEED_HOLD`]).
    held_speed: Vec<Real>,
    last: TransitionReport,
}

/// Steps an active node must stay out of sight before it counts as hidden (asks for the
/// coarsest level, and, with the rest of its tree, lets the tree collapse to its root strip).
/// Hair at the edge of sight goes in and out of it from one step to the next, and a node and
/// its parent are seen differently there (their points differ by up to the merge distance): on
/// the `wardlin` scene, judging each step afresh merged about 60 nodes or collapsed about 60
/// trees on one step and split or restored them on the next, every step, each time carrying the
/// motion across levels (a visible pop, and the work of the transitions). Seen counts at once.
pub const HIDDEN_AFTER: u32 = 15;

/// Fraction of its held speed a node keeps per step when it moves slower (a half-life of about
/// seven steps). Hair fluttering in gusty wind reaches a speed on one step and a third of it a
/// few steps later; judged by the speed of the moment, it split when fast and merged as soon as it
/// slowed. Judged by the held speed, hair gets detail as soon as it is fast and gives it up once
/// it has been slow for a while. (With this, [`HIDDEN_AFTER`] and [`crate::MERGE_MARGIN`], the
/// 240 frames of `hair run zoom` made 8,559 splits and merges instead of 15,329 while hair-hair
/// pushes were summed; with their mean, the default, the hair settles and they make 763.)
pub const SPEED_HOLD: Real = 0.9;

impl AdaptiveLod {
    /// Becomes a copy of `initial`, keeping the plan's lists: the plan is refilled every step,
    /// and its lists keep the room they grew to, so the steps after a reset take no memory
    /// (every other buffer is sized by the hierarchy and comes back at full size).
    pub fn reset_to(&mut self, initial: &Self) {
        let plan = std::mem::take(&mut self.plan);
        *self = initial.clone();
        self.plan = plan;
    }

    /// Starts at the coarsest front (every root strip).
    pub fn new(h: &Hierarchy, spec: &AdaptiveSettings) -> Self {
        let select = SelectParams {
            distance_finest: spec.distance_finest,
            distance_coarsest: spec.distance_coarsest,
            speed_coarsest: spec.speed_coarsest,
            speed_finest: spec.speed_finest,
        };
        let merge = MergeParams {
            merge_distance: spec.merge_distance,
            ..MergeParams::default()
        };
        let n = h.node_count();
        let front = Front::coarsest(h);
        let was_active = (0..n as u32).map(|v| front.is_active(v)).collect();
        Self {
            front,
            lod: LodState::new(h),
            plan: Plan::default(),
            select,
            merge,
            cull_hidden: spec.cull_hidden,
            visible: vec![true; n],
            distance: vec![0.0; n],
            speed: vec![0.0; n],
            activity: vec![LodActivity::Moving; n],
            was_active,
            unseen_for: vec![0; n],
            held_speed: vec![0.0; n],
            last: TransitionReport::default(),
        }
    }

    /// The current front.
    pub fn front(&self) -> &Front {
        &self.front
    }

    /// What the last update did.
    pub fn last_report(&self) -> TransitionReport {
        self.last
    }

    /// Takes the angles in `state` as every node's groom ([`LodState::hold_groom`]).
    pub fn hold_groom(&mut self, h: &Hierarchy, state: &StrandState) -> Result<(), LodError> {
        self.lod.hold_groom(h, state)
    }

    /// The carried per-node state (water, stiffness and the other inherited properties).
    pub fn lod_state(&self) -> &LodState {
        &self.lod
    }

    /// How many trees are collapsed to their root strip because the camera cannot see them.
    pub fn hidden_trees(&self, h: &Hierarchy) -> usize {
        (0..h.tree_count() as u32)
            .filter(|&t| self.front.is_hidden(t))
            .count()
    }

    /// Whether the tree of `node` is collapsed because the camera cannot see it.
    pub fn is_hidden(&self, h: &Hierarchy, node: u32) -> bool {
        self.front.is_hidden(h.tree_of(node))
    }

    /// One LOD stage: reads the front's motion, selects, transitions, writes the motion of every
    /// node that became active and updates the state's active flags. `frozen` marks skeletons
    /// localization froze last step (empty for none). Returns whether the front changed.
    pub fn update(
        &mut self,
        h: &Hierarchy,
        state: &mut StrandState,
        view: &View<'_>,
        frozen: &[bool],
    ) -> Result<bool, LodError> {
        for n in 0..h.node_count() as u32 {
            if self.front.is_active(n) {
                self.lod.read_motion(h, n, state, SkeletonId(n))?;
            }
        }
        let positions = state.positions();
        let velocities = state.velocities();
        for n in 0..h.node_count() {
            let id = SkeletonId(n as u32);
            let r = state.nodes(id);
            // Active nodes are judged by where they are; the others by their root, which
            // does not move in the head frame (their stored points are stale).
            let pts = if self.front.is_active(n as u32) {
                &positions[r.clone()]
            } else {
                &positions[r.start..r.start + 1]
            };
            self.distance[n] = pts
                .iter()
                .map(|p| (p - view.eye).norm())
                .fold(Real::INFINITY, Real::min);
            self.visible[n] = !self.cull_hidden || pts.iter().any(|p| view.sees(p));
            self.speed[n] = if self.front.is_active(n as u32) {
                let now = velocities[r].iter().map(|v| v.norm()).fold(0.0, Real::max);
                let held = &mut self.held_speed[n];
                *held = now.max(*held * SPEED_HOLD);
                *held
            } else {
                0.0
            };
            self.activity[n] = if frozen.get(n).copied().unwrap_or(false) {
                LodActivity::Dormant
            } else {
                LodActivity::Moving
            };
        }
        if self.cull_hidden {
            for n in 0..h.node_count() {
                if self.front.is_active(n as u32) {
                    let unseen = &mut self.unseen_for[n];
                    *unseen = if self.visible[n] {
                        0
                    } else {
                        unseen.saturating_add(1)
                    };
                    self.visible[n] = *unseen < HIDDEN_AFTER;
                }
            }
            // An expanded tree is seen while any of its active nodes is (its root's own point,
            // on the scalp, is often behind the head while the hair hanging from it is in view).
            for t in 0..h.tree_count() as u32 {
                let root = h.tree_root(t);
                if !self.front.is_active(root) {
                    self.visible[root as usize] = h
                        .tree_nodes(t)
                        .any(|n| self.front.is_active(n) && self.visible[n as usize]);
                }
            }
        }
        let inputs = NodeInputs {
            visible: &self.visible,
            distance: &self.distance,
            speed: &self.speed,
            activity: &self.activity,
        };
        crate::select_into(h, &self.front, &inputs, &self.select, &mut self.plan)?;
        self.last = crate::apply(h, &mut self.front, &mut self.lod, &self.plan, &self.merge)?;
        // Children pulled toward their parent's average (not merged yet) carry the pull.
        for i in 0..self.plan.merges.len() {
            let p = self.plan.merges[i];
            if self.front.is_active(p) {
                continue;
            }
            for c in h.children(p) {
                if self.front.is_active(c) && self.was_active[c as usize] {
                    self.lod.write_motion(h, c, state, SkeletonId(c))?;
                }
            }
        }
        // The nodes that became active start out seen, but for a merged parent, which is as
        // unseen as the least unseen of its children, and a collapsed root strip, which is
        // hidden until it is seen. A merged parent holds the highest speed its children held; a
        // node split from its parent, or restored below it, the parent's.
        for n in 0..h.node_count() as u32 {
            let i = n as usize;
            if !self.front.is_active(n) || self.was_active[i] {
                continue;
            }
            let merged = h
                .children(n)
                .filter(|&c| self.was_active[c as usize])
                .map(|c| (self.unseen_for[c as usize], self.held_speed[c as usize]))
                .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)));
            let (unseen, held) = match merged {
                Some(m) => m,
                None => (0, h.parent(n).map_or(0.0, |p| self.held_speed[p as usize])),
            };
            self.unseen_for[i] = if self.front.is_hidden(h.tree_of(n)) {
                HIDDEN_AFTER
            } else {
                unseen
            };
            self.held_speed[i] = held;
        }
        let mut changed = false;
        for n in 0..h.node_count() {
            let now = self.front.is_active(n as u32);
            if now != self.was_active[n] {
                changed = true;
                let id = SkeletonId(n as u32);
                if now {
                    self.lod.write_motion(h, n as u32, state, id)?;
                }
                state.set_active(id, now);
                self.was_active[n] = now;
            }
        }
        Ok(changed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The procedural head and shoulders: vertices, triangles, closed.
    struct Head {
        vertices: Vec<Point>,
        triangles: Vec<[u32; 3]>,
        closed: bool,
    }

    impl Head {
        fn mesh(&self) -> OccluderMesh<'_> {
            OccluderMesh {
                vertices: &self.vertices,
                triangles: &self.triangles,
                closed: self.closed,
            }
        }
    }

    fn head() -> Head {
        let (vertices, triangles) = hair_ssv::head::head_and_shoulders(24);
        Head {
            vertices,
            triangles,
            closed: true,
        }
    }

    fn looking_at(eye: Point, target: Point) -> View<'static> {
        View {
            eye,
            forward: (target - eye).normalize(),
            cos_half_angle: 0.6_f32.cos(),
            occluder: None,
        }
    }

    /// Whether the segment from `a` to `b` crosses any of the body's triangles (Moller and
    /// Trumbore's test, in f64, both windings).
    fn segment_hits(body: &Head, a: &Point, b: &Point) -> bool {
        let (o, d) = (a.coords.cast::<f64>(), (b - a).cast::<f64>());
        body.triangles.iter().any(|t| {
            let [p, q, r] = t.map(|i| body.vertices[i as usize].coords.cast::<f64>());
            let (e1, e2) = (q - p, r - p);
            let h = d.cross(&e2);
            let det = e1.dot(&h);
            if det.abs() < 1e-15 {
                return false;
            }
            let s = o - p;
            let u = s.dot(&h) / det;
            let qv = s.cross(&e1);
            let v = d.dot(&qv) / det;
            let t = e2.dot(&qv) / det;
            (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && (0.0..=1.0).contains(&t)
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Whatever the view, a point the depth image hides is one the body really hides: the
        /// line of sight to it crosses the mesh (the brute-force oracle).
        #[test]
        fn a_hidden_point_is_behind_the_mesh(
            dir in (-1.0f32..1.0, -0.6f32..0.8, -1.0f32..1.0),
            distance in 0.35f32..1.5,
            points in proptest::collection::vec((-0.25f32..0.25, -0.35f32..0.2, -0.25f32..0.25), 150),
        ) {
            let body = head();
            let dir = Vector::new(dir.0, dir.1, dir.2);
            prop_assume!(dir.norm() > 0.2);
            let eye = Point::from(dir.normalize() * distance);
            let view = looking_at(eye, Point::new(0.0, -0.05, 0.0));
            let mut depth = BodyDepth::new();
            prop_assert!(depth.build(body.mesh(), &view));
            for (x, y, z) in points {
                let p = Point::new(x, y, z);
                if depth.hides(&p) {
                    prop_assert!(segment_hits(&body, &eye, &p), "{p:?} hidden from {eye:?}");
                }
            }
        }
    }

    /// From in front of the face, points behind the middle of the head are hidden and points
    /// between the camera and the face are not; so with the mesh wound inward (drawn whole) and
    /// with an open mesh. A view is drawn once: the same view again keeps the image.
    #[test]
    fn the_head_hides_what_is_behind_it_whatever_its_winding() {
        let outward = head();
        let mut inward = head();
        for t in &mut inward.triangles {
            t.swap(1, 2);
        }
        let mut open = head();
        open.closed = false;
        let eye = Point::new(0.0, 0.05, 0.6);
        let view = looking_at(eye, Point::new(0.0, -0.05, 0.0));
        for (name, body) in [("outward", &outward), ("inward", &inward), ("open", &open)] {
            let mut depth = BodyDepth::new();
            assert!(depth.build(body.mesh(), &view), "{name}");
            assert!(
                !depth.build(body.mesh(), &view),
                "{name}: the same view is drawn again"
            );
            let seen = View {
                occluder: Some(&depth),
                ..view
            };
            let mut behind = 0;
            for i in -4..=4 {
                for j in -4..=4 {
                    let (x, y) = (i as Real * 0.01, j as Real * 0.012);
                    for z in [-0.15, -0.2, -0.3] {
                        let p = Point::new(x, y, z);
                        assert!(!seen.sees(&p), "{name}: {p:?} behind the head is seen");
                        behind += 1;
                    }
                    let front = Point::new(x, y, 0.25);
                    assert!(
                        seen.sees(&front),
                        "{name}: {front:?} before the face is hidden"
                    );
                }
            }
            assert_eq!(behind, 243);
        }
        // A different eye draws again; before any build nothing is hidden.
        let mut depth = BodyDepth::new();
        assert!(!depth.hides(&Point::new(0.0, 0.0, -0.3)));
        depth.build(outward.mesh(), &view);
        assert!(depth.build(
            outward.mesh(),
            &looking_at(Point::new(0.0, 0.05, 0.61), Point::origin())
        ));
    }
}
