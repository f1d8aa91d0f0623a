//! A triangle mesh as a body hair collides with: the signed distance of a point by the exact
//! BVH query (the side decided by angle-weighted pseudo-normals on a closed mesh), by a
//! sampled [`DistanceField`], or by Kurihara's cylinder and sphere tables (§3.1), with a coarse
//! near field that skips queries far from the surface; and [`cap_holes`], which closes the
//! simple holes of a scanned or modelled mesh so that it has an inside.

use crate::distance_field::DistanceField;
use crate::{Body, Bvh, Point, Real, SsvError, Vector};
use std::f32::consts::TAU;
use std::sync::atomic::{AtomicU64, Ordering};

/// Hair within this distance of the body (m) gets an exact query; radii above it are clamped.
pub const NEAR_MARGIN: Real = 0.02;

/// Samples in a body's [`DistanceField`] (about 16 MB of f32).
pub const FIELD_SAMPLES: usize = 4_000_000;

/// How a [`MeshBody`] answers a distance query.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum CollisionMethod {
    /// Signed distances sampled from the exact query on a grid a few millimetres apart and
    /// interpolated trilinearly (the fast default; [`DistanceField::measure_error`] measures its
    /// error).
    Field,
    /// Exact distances through the SSV BVH of the mesh.
    Bvh,
    /// Cylinder and sphere tables (Kurihara et al. §3.1), where the body has them
    /// ([`MeshBody::maps`]); the exact query elsewhere.
    Maps,
}

/// A triangle mesh as a body that hair collides with (m, in the frame the hair is simulated
/// in), with every structure its distance queries use.
#[derive(Clone, Debug)]
pub struct MeshBody {
    /// Vertices (m, head frame).
    pub vertices: Vec<Point>,
    /// Outward-wound triangles.
    pub triangles: Vec<[u32; 3]>,
    /// The SSV BVH over the triangles.
    pub bvh: Bvh,
    /// Cylinder and sphere tables, where the body has them (the procedural head).
    pub maps: Option<Body>,
    /// Coarse voxels around the body: which need an exact query at all.
    pub near: NearField,
    /// Signed distances sampled on a fine grid, filled on first use.
    pub field: DistanceField,
    /// Whether every edge joins exactly two triangles wound opposite ways: a closed surface,
    /// whose signed distance changes no faster than the point moves.
    pub closed: bool,
    /// The pseudo-normals that give the side of a point whose closest surface point is on an
    /// edge or a vertex, for a closed surface (`None` for an open one).
    pub pseudo_normals: Option<PseudoNormals>,
    /// Which [`MeshBody::new`] built it (a clone keeps it): see [`MeshBody::identity`].
    id: u64,
}

/// Ids of the bodies built: a body built later never takes an earlier one's, even once that
/// one is dropped and its storage reused.
static NEXT_BODY_ID: AtomicU64 = AtomicU64::new(0);

/// What a [`MeshBody`]'s distance queries are answered from, cheap to compare: which
/// [`MeshBody::new`] built it (a clone keeps that) and where the structures the queries read are
/// stored, with whether it counts as closed. A body's fields are public, so it can be changed
/// after it was built: a structure replaced by assignment was built while the old one was still
/// stored, so it lies elsewhere and the identity changes. Changing the contents of a structure
/// in place keeps it: of the structures, only the collision tables' parts ([`Body::parts`]) can
/// be changed so.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BodyIdentity {
    id: u64,
    /// The BVH's triangles, the near field's centres, the distance field's samples, the
    /// pseudo-normals and the collision tables' parts (0 where absent).
    storage: [usize; 5],
    closed: bool,
}

/// Angle-weighted pseudo-normals of a closed, consistently wound mesh (Baerentzen and Aanaes,
/// 2005): at a vertex, the incident faces' normals weighted by their angles there; on an edge,
/// the sum of its two faces' normals. For a point whose closest surface point lies on a vertex
/// or an edge, the sign of `(p - q) . n` with that feature's pseudo-normal is the side of the
/// surface the point is on: one dot product, where comparing the faces that share the feature
/// needs a second search of the BVH.
#[derive(Clone, Debug, Default)]
pub struct PseudoNormals {
    /// Per triangle: its vertices' pseudo-normals (in winding order), then its edges' (01, 12, 20).
    per_triangle: Vec<[Vector; 6]>,
}

impl PseudoNormals {
    /// The pseudo-normals of a closed mesh (see [`is_closed`]); `None` if it is not closed.
    pub fn new(vertices: &[Point], triangles: &[[u32; 3]]) -> Option<Self> {
        if !is_closed(triangles) {
            return None;
        }
        let face: Vec<Vector> = triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| vertices[i as usize]);
                (b - a)
                    .cross(&(c - a))
                    .try_normalize(0.0)
                    .unwrap_or_else(Vector::zeros)
            })
            .collect();
        let mut at_vertex = vec![Vector::zeros(); vertices.len()];
        for (t, n) in triangles.iter().zip(&face) {
            for k in 0..3 {
                let o = vertices[t[k] as usize];
                let (u, v) = (
                    vertices[t[(k + 1) % 3] as usize] - o,
                    vertices[t[(k + 2) % 3] as usize] - o,
                );
                at_vertex[t[k] as usize] += n * u.angle(&v);
            }
        }
        // Each undirected edge's two faces, found through the sorted directed edges.
        let mut edges: Vec<((u32, u32), u32)> = triangles
            .iter()
            .enumerate()
            .flat_map(|(i, t)| (0..3).map(move |k| ((t[k], t[(k + 1) % 3]), i as u32)))
            .collect();
        edges.sort_unstable();
        let other_face = |a: u32, b: u32| {
            edges
                .binary_search_by(|probe| probe.0.cmp(&(b, a)))
                .map(|k| edges[k].1 as usize)
                .ok()
        };
        let per_triangle = triangles
            .iter()
            .enumerate()
            .map(|(i, t)| {
                let edge = |k: usize| {
                    let twin = other_face(t[k], t[(k + 1) % 3]).map_or(face[i], |j| face[j]);
                    face[i] + twin
                };
                [
                    at_vertex[t[0] as usize],
                    at_vertex[t[1] as usize],
                    at_vertex[t[2] as usize],
                    edge(0),
                    edge(1),
                    edge(2),
                ]
            })
            .collect();
        Some(Self { per_triangle })
    }
}

/// Whether `triangles` form a closed, consistently wound surface: each directed edge appears
/// once and its reverse once.
pub fn is_closed(triangles: &[[u32; 3]]) -> bool {
    let edges = directed_edges(triangles);
    let unique = edges.windows(2).all(|w| w[0] != w[1]);
    unique
        && edges
            .iter()
            .all(|&(a, b)| edges.binary_search(&(b, a)).is_ok())
}

/// Every triangle's three directed edges in winding order, sorted.
fn directed_edges(triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
    let mut edges: Vec<(u32, u32)> = triangles
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .collect();
    edges.sort_unstable();
    edges
}

/// Caps every hole of a mesh with a fan of triangles around the hole's centroid, wound like the
/// triangles around it, and returns how many holes it capped. A hole is a loop of boundary
/// edges: directed edges whose reverse no triangle has. A mesh with a boundary vertex where two
/// holes meet (more than one boundary edge leaving it), or with a directed edge used twice, is
/// left as it is (0): a fan cannot close it into one surface. A closed mesh has no holes.
///
/// Why: only a closed surface has an inside. Near an open mesh's hole the side of a point is
/// decided by whichever face is closest, so the signed distance flips across the opening with no
/// surface there, and a node pushed out on one side reads as centimetres deep on the other. A
/// fan is exact for a planar convex hole and a fair lid for the rounded openings of scanned and
/// modelled bodies (eye sockets, a neck or arm cut).
pub fn cap_holes(vertices: &mut Vec<Point>, triangles: &mut Vec<[u32; 3]>) -> usize {
    let edges = directed_edges(triangles);
    if edges.windows(2).any(|w| w[0] == w[1]) {
        return 0;
    }
    // Boundary edges in order of their first vertex: the lookup of the edge leaving a vertex.
    let boundary: Vec<(u32, u32)> = edges
        .iter()
        .filter(|&&(a, b)| edges.binary_search(&(b, a)).is_err())
        .copied()
        .collect();
    if boundary.windows(2).any(|w| w[0].0 == w[1].0) {
        return 0;
    }
    let mut used = vec![false; boundary.len()];
    let mut loops: Vec<Vec<u32>> = Vec::new();
    for (k, &(start, _)) in boundary.iter().enumerate() {
        if used[k] {
            continue;
        }
        let mut ring = Vec::new();
        let mut v = start;
        loop {
            let Ok(e) = boundary.binary_search_by_key(&v, |e| e.0) else {
                return 0;
            };
            if used[e] {
                break;
            }
            used[e] = true;
            ring.push(v);
            v = boundary[e].1;
        }
        // The walk must come back to where it started; anything else is not one loop.
        if v != start || ring.len() < 3 {
            return 0;
        }
        loops.push(ring);
    }
    for ring in &loops {
        let centre = ring
            .iter()
            .fold(Vector::zeros(), |s, &v| s + vertices[v as usize].coords)
            / ring.len() as Real;
        let c = vertices.len() as u32;
        vertices.push(Point::from(centre));
        // The mesh holds the boundary edge (a, b); the lid's triangle holds its reverse.
        for (i, &a) in ring.iter().enumerate() {
            let b = ring[(i + 1) % ring.len()];
            triangles.push([b, a, c]);
        }
    }
    loops.len()
}

pub(crate) fn exact_signed_distance(
    bvh: &Bvh,
    pseudo_normals: Option<&PseudoNormals>,
    p: &Point,
) -> Option<(Real, Vector, Point)> {
    thread_local! {
        static TIES: std::cell::RefCell<Vec<crate::MeshContact>> =
            const { std::cell::RefCell::new(Vec::new()) };
    }
    let pss = crate::Ssv::Point(crate::Pss::new(*p, 0.0));
    let hit = bvh.closest(&pss)?;
    let q = hit.closest.on_b;
    let face_of = |t: u32| {
        bvh.triangle(t as usize)
            .map(|tri| (tri[1] - tri[0]).cross(&(tri[2] - tri[0])))
            .and_then(|f| f.try_normalize(1e-30))
    };
    let face = face_of(hit.triangle).unwrap_or_else(Vector::y);
    let d = p - q;
    let dist = d.norm();
    if dist <= 1e-9 {
        return Some((0.0, face, q));
    }
    let dir = d / dist;
    let mut facing = dir.dot(&face);
    // A closest point inside the face is the face's alone, and its normal decides. Where it is
    // on an edge or vertex shared by several triangles, the first one found may face away in a
    // concave crease: a closed surface's pseudo-normal of that feature decides; on an open one,
    // the face most squarely facing the point does (it is the one whose plane the point is
    // farthest from).
    let tri = bvh.triangle(hit.triangle as usize)?;
    let on = |e: usize| {
        let (a, b) = (tri[e], tri[(e + 1) % 3]);
        crate::query::point_segment(&q, &a, &b).dist_sq <= 1e-8 * (b - a).norm_squared()
    };
    let on_edges = [on(0), on(1), on(2)];
    let side = |facing: Real| {
        let outside = facing >= 0.0;
        let normal = if outside { dir } else { -dir };
        Some((if outside { dist } else { -dist }, normal, q))
    };
    if !on_edges.iter().any(|&e| e) {
        return side(facing);
    }
    if let Some(normals) = pseudo_normals.and_then(|n| n.per_triangle.get(hit.triangle as usize)) {
        // On two edges is on the vertex they share: 01 and 12 meet at 1, 12 and 20 at 2, 20 and
        // 01 at 0.
        let feature = match on_edges {
            [true, true, _] => 1,
            [_, true, true] => 2,
            [true, _, true] => 0,
            [true, false, false] => 3,
            [false, true, false] => 4,
            _ => 5,
        };
        return side(dir.dot(&normals[feature]));
    }
    TIES.with(|ties| {
        let mut ties = ties.borrow_mut();
        ties.clear();
        bvh.contacts(&pss, dist * (1.0 + 1e-4) + 1e-7, &mut ties);
        for c in ties.iter() {
            if let Some(f) = face_of(c.triangle) {
                let cos = dir.dot(&f);
                if cos.abs() > facing.abs() {
                    facing = cos;
                }
            }
        }
    });
    let outside = facing >= 0.0;
    let normal = if outside { dir } else { -dir };
    Some((if outside { dist } else { -dist }, normal, q))
}

/// A voxel grid over the body's bounds (grown by a margin) marking the cells whose centre lies
/// within half a diagonal plus the margin of the surface, or inside. A point in any other cell is
/// farther than the margin from the body, so the exact query can be skipped.
#[derive(Clone, Debug, Default)]
pub struct NearField {
    min: Point,
    cell: Real,
    dims: [usize; 3],
    /// Exact signed distance at each cell's centre (`-inf` where the query has no answer).
    centre: Vec<Real>,
    /// Cells whose centre is at most this far out may hold points within the margin.
    reach: Real,
}

/// The spacing and the samples per axis of a lattice over extents `ext` with about `target`
/// samples and never more than twice as many, `pad` more per axis, never finer than
/// `min_spacing`; `None` for non-finite extents. The spacing starts at the cube root of the
/// volume per sample. A flat or needle-thin body has a volume near zero, and that spacing
/// alone would ask for billions of samples along its long sides (a torus placed 1e30 m away
/// collapses flat in `f32`, and asked for 41 GB): the spacing is widened until the count fits.
pub(crate) fn lattice(
    ext: &Vector,
    target: usize,
    min_spacing: Real,
    pad: usize,
) -> Option<(Real, [usize; 3])> {
    if !ext.iter().all(|e| e.is_finite() && *e >= 0.0) {
        return None;
    }
    let dims_at = |h: Real| {
        [ext.x, ext.y, ext.z].map(|e| {
            let d = (e / h).ceil();
            // Saturating: a count beyond `usize` fails the product below.
            if d < usize::MAX as Real {
                d as usize + pad
            } else {
                usize::MAX
            }
        })
    };
    let fits = |dims: &[usize; 3]| {
        dims.iter()
            .try_fold(1usize, |n, &d| n.checked_mul(d))
            .is_some_and(|n| n <= 2 * target)
    };
    let mut h = (ext.x * ext.y * ext.z / target as Real)
        .cbrt()
        .max(min_spacing);
    let mut dims = dims_at(h);
    // Each round cuts every count by a fifth: a few dozen rounds reach any finite extent.
    while !fits(&dims) && h.is_finite() {
        h *= 1.25;
        dims = dims_at(h);
    }
    fits(&dims).then_some((h, dims))
}

impl NearField {
    /// Builds the field for points up to `margin` away from the surface.
    pub fn build(body: &MeshBody, margin: Real) -> Self {
        use rayon::prelude::*;
        let (mut lo, mut hi) = (
            Point::from(Vector::repeat(Real::MAX)),
            Point::from(Vector::repeat(Real::MIN)),
        );
        for v in &body.vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        let pad = Vector::repeat(2.0 * margin);
        lo -= pad;
        hi += pad;
        let ext = hi - lo;
        // About 40,000 cells whatever the body's size. Vertices farther apart than `f32` spans:
        // no near field (every point counts as near).
        let Some((cell, dims)) = lattice(&ext, 40_000, 1e-4, 1) else {
            return Self::default();
        };
        let reach = 0.5 * cell * 3f32.sqrt() + margin;
        let centre = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .map(|k| {
                let (x, y, z) = (
                    k % dims[0],
                    (k / dims[0]) % dims[1],
                    k / (dims[0] * dims[1]),
                );
                let c = lo + Vector::new(x as Real + 0.5, y as Real + 0.5, z as Real + 0.5) * cell;
                body.signed_distance(&c)
                    .map_or(Real::NEG_INFINITY, |(d, _, _)| d)
            })
            .collect();
        Self {
            min: lo,
            cell,
            dims,
            centre,
            reach,
        }
    }

    /// The cell holding `p`: its index and centre, or `None` outside the grid.
    #[inline]
    fn cell_of(&self, p: &Point) -> Option<(usize, Point)> {
        let q = (p - self.min) / self.cell;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
            return None;
        }
        let (x, y, z) = (q.x as usize, q.y as usize, q.z as usize);
        if x >= self.dims[0] || y >= self.dims[1] || z >= self.dims[2] {
            return None;
        }
        let c =
            self.min + Vector::new(x as Real + 0.5, y as Real + 0.5, z as Real + 0.5) * self.cell;
        Some((x + self.dims[0] * (y + self.dims[1] * z), c))
    }

    /// A lower bound of the exact signed distance at `p`: the distance at its cell's centre less
    /// how far `p` is from it (the distance to a closed surface changes no faster than the
    /// point moves). `-inf` where unknown, `+inf` outside the grid (farther than the margin).
    #[inline]
    pub fn lower_bound(&self, p: &Point) -> Real {
        if self.centre.is_empty() {
            return Real::NEG_INFINITY;
        }
        match self.cell_of(p) {
            Some((k, c)) => self.centre[k] - (p - c).norm(),
            None => Real::INFINITY,
        }
    }

    /// Lower and upper bounds of the exact signed distance at `p` (its cell centre's distance
    /// less and plus how far `p` is from that centre); `None` outside the grid or where the
    /// centre has no distance (or no grid was built).
    #[inline]
    pub fn bounds(&self, p: &Point) -> Option<(Real, Real)> {
        let (k, c) = self.cell_of(p)?;
        let d = *self.centre.get(k)?;
        let r = (p - c).norm();
        d.is_finite().then_some((d - r, d + r))
    }

    /// Whether `p` may lie within the margin of the body (or inside it).
    #[inline]
    pub fn is_near(&self, p: &Point) -> bool {
        if self.centre.is_empty() {
            return true;
        }
        self.cell_of(p)
            .is_some_and(|(k, _)| self.centre[k] <= self.reach)
    }
}

impl MeshBody {
    /// The body of a mesh: its BVH (an error for a degenerate triangle or a non-finite
    /// vertex), its distance field (filled on first use), its near field and, for a closed
    /// mesh, its pseudo-normals. No cylinder or sphere tables: set [`MeshBody::maps`] for
    /// [`CollisionMethod::Maps`].
    pub fn new(vertices: Vec<Point>, triangles: Vec<[u32; 3]>) -> Result<Self, SsvError> {
        let bvh = Bvh::new(&vertices, &triangles)?;
        let field = DistanceField::new(&vertices, 2.0 * NEAR_MARGIN, FIELD_SAMPLES);
        // Only a closed surface has pseudo-normals: one closedness test serves both.
        let pseudo_normals = PseudoNormals::new(&vertices, &triangles);
        let closed = pseudo_normals.is_some();
        let mut body = Self {
            vertices,
            triangles,
            bvh,
            maps: None,
            near: NearField::default(),
            field,
            closed,
            pseudo_normals,
            id: NEXT_BODY_ID.fetch_add(1, Ordering::Relaxed),
        };
        body.near = NearField::build(&body, NEAR_MARGIN);
        Ok(body)
    }

    /// Signed distance of a point to the surface (negative inside) with the outward normal and the
    /// closest surface point, by the exact BVH query.
    pub fn signed_distance(&self, p: &Point) -> Option<(Real, Vector, Point)> {
        exact_signed_distance(&self.bvh, self.pseudo_normals.as_ref(), p)
    }

    /// What this body's distance queries are answered from: two bodies (or one body at two
    /// times) with the same identity answer every query alike, so what was learned from the
    /// answers of one holds for the other (unless the tables' parts were changed in place:
    /// see [`BodyIdentity`]).
    pub fn identity(&self) -> BodyIdentity {
        let at = |p: *const u8| p as usize;
        BodyIdentity {
            id: self.id,
            storage: [
                at(self.bvh.tris.as_ptr().cast()),
                at(self.near.centre.as_ptr().cast()),
                at(self.field.samples.as_ptr().cast()),
                self.pseudo_normals
                    .as_ref()
                    .map_or(0, |n| at(n.per_triangle.as_ptr().cast())),
                self.maps
                    .as_ref()
                    .map_or(0, |m| at(m.parts.as_ptr().cast())),
            ],
            closed: self.closed,
        }
    }

    /// [`MeshBody::distance`] where it may be below `reach`, else `None`: points that the
    /// near field's lower bound, less the method's own error, already puts `reach` or farther
    /// away are not queried (and fill no samples of the distance field). The answers below
    /// `reach` are the same as [`MeshBody::distance`]'s. (The bound holds for a closed surface
    /// only: an open mesh, or `Maps`, whose tables have no stated error, is always queried.)
    #[inline]
    pub fn distance_within(
        &self,
        method: CollisionMethod,
        p: &Point,
        reach: Real,
    ) -> Option<(Real, Vector)> {
        self.distance_within_clearance(method, p, reach).0
    }

    /// [`MeshBody::distance_within`] at `p`, and what it tells about the answers near `p`
    /// (see [`Clearance`]): on a closed body, how far from `p` the answer for `reach` (or a
    /// smaller one) stays `None` or at least `reach`; none on an open mesh, by `Maps`, or
    /// outside the near field. Two bounds hold, and the wider is kept:
    /// - the exact distance's: it changes no faster than the point moves, and the method answers
    ///   within `spread` of it (below);
    /// - the method's own: a `Field` value is the trilinear interpolant of exact samples, whose
    ///   slope along an axis is a blend of the slopes of the cell's edges along it (each at most
    ///   one), so it changes at most `sqrt(3)` times as fast as the point moves, with no
    ///   `spread` to give away. Hair resting a millimetre off the body keeps this one.
    ///
    /// Each keeps a margin for rounding (1e-6 m), so asking again within its travel would have
    /// answered `None` or a distance of at least `reach` (for this body: see
    /// [`MeshBody::identity`]).
    #[inline]
    pub fn distance_within_clearance(
        &self,
        method: CollisionMethod,
        p: &Point,
        reach: Real,
    ) -> (Option<(Real, Vector)>, Clearance) {
        // The method's error against the exact distance, and how fast its answer can change
        // with the point; the tables of `Maps` have neither stated, so they keep no clearance.
        let (error, slope) = match method {
            // A field value is a convex combination of exact samples within a cell diagonal.
            CollisionMethod::Field => (self.field.spacing() * 3f32.sqrt() * 1.001, 3f32.sqrt()),
            CollisionMethod::Bvh => (0.0, 1.0),
            CollisionMethod::Maps => return (self.distance(method, p), Clearance::NONE),
        };
        // How far the method's answer can be from the exact distance, for the clearance: a
        // field value is the trilinear mean of exact samples at its cell's corners, and the
        // corners' mean distance from the point is at most half the diagonal (their weighted
        // squared distances add up to at most `3 h^2 / 4`, and the mean of the distances is at
        // most the root of that), so the answer is within half a diagonal of the exact
        // distance; `error`, which the near field's test keeps, takes a whole one.
        let spread = 0.5 * error;
        let mut travel = Real::NEG_INFINITY;
        // One look-up of the near field serves the bound and the margin (`distance`'s own).
        if !self.near.centre.is_empty() {
            let Some((k, c)) = self.near.cell_of(p) else {
                return (None, Clearance::NONE);
            };
            let centre = self.near.centre[k];
            // The exact distance at `p` is at least the centre's less the way to it, and at
            // `q` at least that less `|q - p|` (a closed surface's signed distance changes no
            // faster than the point moves); the method answers within `spread` of it.
            let r = (p - c).norm();
            if self.closed {
                travel = centre - r - spread - 1e-6 - reach;
                if centre - r - error - 1e-6 >= reach {
                    return (None, Clearance::about(*p, reach, travel));
                }
            }
            if centre > self.near.reach {
                return (None, Clearance::about(*p, reach, travel));
            }
        }
        let hit = self.distance_near(method, p);
        if self.closed
            && let Some((d, _)) = hit
        {
            // The answer `d` is within `spread` of the exact distance at `p`, whose value at
            // `q` is at least that less `|q - p|`, and the answer at `q` within `spread` of it;
            // or, by the method's own slope, at least `d` less `slope |q - p|`.
            let exact = d - 2.0 * spread - 1e-6 - reach;
            let own = (d - 1e-6 - reach) / slope;
            travel = travel.max(exact).max(own);
        }
        (hit, Clearance::about(*p, reach, travel))
    }

    /// Signed distance and outward normal by `method`, or `None` when `p` is farther than
    /// the near margin (2 cm) from the body (or the method cannot answer there).
    #[inline]
    pub fn distance(&self, method: CollisionMethod, p: &Point) -> Option<(Real, Vector)> {
        if !self.near.is_near(p) {
            return None;
        }
        self.distance_near(method, p)
    }

    /// [`MeshBody::distance`] at a point the near field puts within the margin.
    #[inline]
    fn distance_near(&self, method: CollisionMethod, p: &Point) -> Option<(Real, Vector)> {
        match (method, &self.maps) {
            (CollisionMethod::Maps, Some(maps)) => {
                use crate::SurfaceMap;
                maps.lookup(p).map(|s| (s.distance, s.normal))
            }
            (CollisionMethod::Field, _) => self.field.query(self, p),
            _ => self.signed_distance(p).map(|(d, n, _)| (d, n)),
        }
    }
}

/// What a distance query tells about the answers near the place it was asked
/// ([`MeshBody::distance_within_clearance`]): within its travel of that place, the method's answer
/// for its reach, or a smaller one, is `None` or at least that reach. A caller that keeps it need
/// not ask again there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearance {
    at: Point,
    reach: Real,
    /// The travel squared; negative when none is known.
    travel_squared: Real,
}

impl Clearance {
    /// Nothing known: no place is kept out of any reach.
    pub const NONE: Self = Self {
        at: Point::new(0.0, 0.0, 0.0),
        reach: Real::NEG_INFINITY,
        travel_squared: -1.0,
    };

    /// Within `travel` of `at`, answers are `None` or at least `reach` (none known when
    /// `travel` is negative or not a number).
    fn about(at: Point, reach: Real, travel: Real) -> Self {
        if travel >= 0.0 {
            Self {
                at,
                reach,
                travel_squared: travel * travel,
            }
        } else {
            Self::NONE
        }
    }

    /// Whether the answer at `q` (the body's frame) is known to be `None` or at least `reach`.
    #[inline]
    pub fn keeps_out(&self, q: &Point, reach: Real) -> bool {
        reach <= self.reach && (q - self.at).norm_squared() <= self.travel_squared
    }

    /// How far from where it was asked the clearance holds (m), if it holds anywhere.
    pub fn travel(&self) -> Option<Real> {
        (self.travel_squared >= 0.0).then(|| self.travel_squared.sqrt())
    }
}

impl Default for Clearance {
    fn default() -> Self {
        Self::NONE
    }
}

/// A torus in the xz plane with `wrinkles` ridges around the ring, `depth` of the tube radius.
pub fn wrinkled_torus(
    center: Point,
    major: Real,
    minor: Real,
    wrinkles: u32,
    depth: Real,
    around: usize,
    tube: usize,
) -> (Vec<Point>, Vec<[u32; 3]>) {
    let mut v = Vec::with_capacity(around * tube);
    for i in 0..around {
        let u = TAU * i as Real / around as Real;
        let r_tube = minor * (1.0 + depth * (wrinkles as Real * u).sin());
        for j in 0..tube {
            let w = TAU * j as Real / tube as Real;
            let ring = major + r_tube * w.cos();
            v.push(center + Vector::new(ring * u.cos(), r_tube * w.sin(), ring * u.sin()));
        }
    }
    let mut t = Vec::with_capacity(2 * around * tube);
    let idx = |i: usize, j: usize| ((i % around) * tube + (j % tube)) as u32;
    for i in 0..around {
        for j in 0..tube {
            // Wound so the normal points out of the tube.
            t.push([idx(i, j), idx(i, j + 1), idx(i + 1, j)]);
            t.push([idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)]);
        }
    }
    (v, t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distance_field::UNKNOWN;
    use crate::head::{HEAD, SHOULDERS, head_and_shoulders};
    use crate::test_meshes::SplitMix;
    use std::sync::atomic::{AtomicU32, Ordering};

    const NECK: Real = crate::head::NECK_RADIUS;

    /// The procedural head and shoulders at `resolution`, as a body.
    fn head(resolution: usize) -> MeshBody {
        let (v, t) = head_and_shoulders(resolution);
        MeshBody::new(v, t).unwrap()
    }

    /// A flat body (zero volume) gets a field and a near grid of about the asked number of
    /// samples, not the billions its volume alone would ask for; non-finite extents get none.
    #[test]
    fn a_flat_body_gets_bounded_lattices() {
        let flat: Vec<Point> = (0..100)
            .map(|k| Point::new((k % 10) as Real * 0.04, 0.0, (k / 10) as Real * 0.04))
            .collect();
        let field = DistanceField::new(&flat, 0.0, 1_000_000);
        let samples: usize = field.dims.iter().product();
        assert!((500_000..=2_000_000).contains(&samples), "{:?}", field.dims);
        for ext in [
            Vector::new(0.4, 0.0, 0.4),
            Vector::new(0.0, 0.0, 0.5),
            Vector::new(1e30, 1e-30, 0.0),
        ] {
            let (h, dims) = lattice(&ext, 40_000, 1e-4, 1).expect("finite extents");
            let n: usize = dims.iter().product();
            assert!(h >= 1e-4 && n <= 80_000, "{ext:?}: {h} {dims:?}");
        }
        assert!(lattice(&Vector::new(Real::INFINITY, 1.0, 1.0), 10, 1e-4, 1).is_none());
        assert!(lattice(&Vector::new(Real::NAN, 1.0, 1.0), 10, 1e-4, 1).is_none());
        // A body too wide for `f32` gets no field, and queries go exact.
        let wide = [Point::new(-3e38, 0.0, 0.0), Point::new(3e38, 0.0, 0.0)];
        assert!(DistanceField::new(&wide, 0.0, 1000).samples.is_empty());
    }

    /// Whether `p` lies inside the ellipsoid `e` shrunk to `scale` of its semi-axes.
    fn in_ellipsoid(e: ([Real; 3], [Real; 3]), scale: Real, p: &Point) -> bool {
        let (c, r) = e;
        (0..3)
            .map(|i| ((p[i] - c[i]) / (r[i] * scale)).powi(2))
            .sum::<Real>()
            < 1.0
    }

    /// The head body joins a head, a neck tube and shoulders. Every point well inside the head,
    /// the neck or the shoulders (the neck's junctions included, where interior walls once made
    /// the signed distance call deep points outside) is inside by the exact distance and by the
    /// distance field; every point well outside all three is outside.
    #[test]
    fn head_body_signed_distance_has_the_right_side_everywhere() {
        let body = head(64);
        let mut rng = SplitMix::new(7);
        let (mut inside, mut outside) = (0, 0);
        while inside < 3000 || outside < 3000 {
            let p = Point::new(
                rng.range(-0.25, 0.25),
                rng.range(-0.35, 0.15),
                rng.range(-0.15, 0.15),
            );
            let neck = (p.x * p.x + p.z * p.z).sqrt();
            let in_neck = neck < 0.9 * NECK && p.y < -0.05 && p.y > SHOULDERS.0[1];
            let deep = in_ellipsoid(HEAD, 0.9, &p) || in_ellipsoid(SHOULDERS, 0.9, &p) || in_neck;
            let near_neck = neck < 1.1 * NECK && p.y < 0.0 && p.y > SHOULDERS.0[1];
            let clear =
                !(in_ellipsoid(HEAD, 1.1, &p) || in_ellipsoid(SHOULDERS, 1.1, &p) || near_neck);
            for method in [CollisionMethod::Bvh, CollisionMethod::Field] {
                let d = body.distance(method, &p).map(|(d, _)| d);
                if deep {
                    assert!(
                        d.is_some_and(|d| d < 0.0),
                        "{p:?} inside, {method:?} gives {d:?}"
                    );
                } else if clear {
                    assert!(
                        d.is_none_or(|d| d > 0.0),
                        "{p:?} outside, {method:?} gives {d:?}"
                    );
                }
            }
            inside += usize::from(deep);
            outside += usize::from(clear);
        }
    }

    /// Filling a band ahead computes exactly the samples a lazy field would compute there, and
    /// only in the band: every query then answers as on a field filled lazily.
    #[test]
    fn a_band_filled_ahead_holds_the_lazy_samples() {
        let (head, torus) = closed_test_bodies();
        for (body, samples) in [(&head, 20_000), (&torus, 3_001)] {
            let ahead = DistanceField::new(&body.vertices, 2.0 * NEAR_MARGIN, samples);
            let lazy = ahead.clone();
            let (inside, outside) = (0.004, 0.01);
            let n = ahead.fill_band(body, inside, outside);
            assert!(n > 0, "nothing filled");
            assert_eq!(ahead.filled(), n);
            assert!(n < ahead.samples.len() * 16 / 2, "{n} samples: not a band");
            // A second call finds them all known.
            assert_eq!(ahead.fill_band(body, inside, outside), 0);
            let [nx, ny, nz] = ahead.dims;
            let mut checked = 0;
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        let bits = ahead.slot(x, y, z).load(Ordering::Relaxed);
                        let c = ahead.min + Vector::new(x as Real, y as Real, z as Real) * ahead.h;
                        let exact = body.signed_distance(&c).map(|(d, _, _)| d);
                        if bits == UNKNOWN {
                            // Left out only where the exact distance is outside the band.
                            if let Some(d) = exact {
                                assert!(d < -inside || d > outside, "{c:?} at {d} left out");
                            }
                            continue;
                        }
                        assert_eq!(bits, lazy.sample(body, x, y, z).to_bits(), "{c:?}");
                        checked += 1;
                    }
                }
            }
            assert_eq!(checked, n);
            // Queries near the surface give the same bits either way.
            for (k, v) in body.vertices.iter().enumerate().step_by(7) {
                let p = v + Vector::new(0.003, -0.002, 0.001) * ((k % 3) as Real - 1.0);
                let (a, b) = (ahead.query(body, &p), lazy.query(body, &p));
                assert_eq!(
                    a.map(|(d, n)| (d.to_bits(), n.map(Real::to_bits))),
                    b.map(|(d, n)| (d.to_bits(), n.map(Real::to_bits))),
                );
            }
        }
    }

    /// A coarse procedural head and a wrinkled torus: two closed bodies.
    fn closed_test_bodies() -> (MeshBody, MeshBody) {
        let (v, t) = wrinkled_torus(Point::origin(), 0.1, 0.03, 8, 0.2, 96, 32);
        (head(32), MeshBody::new(v, t).unwrap())
    }

    /// The distance field keeps every grid vertex in its own slot of the bricks (grids whose
    /// sides are not multiples of the brick), and what it interpolates from those samples stays
    /// within a cell diagonal of the exact distance near the surface.
    #[test]
    fn distance_field_bricks_hold_every_sample_and_agree_with_the_exact_distance() {
        let (head, torus) = closed_test_bodies();
        for (body, samples) in [(&head, 20_000), (&torus, 3_001)] {
            let field = DistanceField::new(&body.vertices, 2.0 * NEAR_MARGIN, samples);
            let [nx, ny, nz] = field.dims;
            assert!(
                nx % 4 != 0 || ny % 4 != 0 || nz % 4 != 0,
                "dims {:?}",
                field.dims
            );
            let base = field.samples.as_ptr() as usize;
            let mut used = vec![false; field.samples.len() * 16];
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        let at = (field.slot(x, y, z) as *const AtomicU32 as usize - base) / 4;
                        assert!(!std::mem::replace(&mut used[at], true), "({x}, {y}, {z})");
                    }
                }
            }
            let error = field.measure_error(body, 4_000, 0.01);
            let bound = field.spacing() * 3f32.sqrt();
            assert!(error > 0.0 && error <= bound, "{error} m against {bound} m");
            // A cell's corners read together are the samples read one by one, whether some
            // were still to compute (the first time) or all were known (the second).
            for z in 0..nz - 1 {
                for y in 0..ny - 1 {
                    for x in 0..nx - 1 {
                        for _ in 0..2 {
                            let together = field.corners(body, x, y, z).map(Real::to_bits);
                            let one_by_one: [u32; 8] = std::array::from_fn(|i| {
                                let (dx, dy, dz) = (i & 1, (i >> 1) & 1, i >> 2);
                                field.sample(body, x + dx, y + dy, z + dz).to_bits()
                            });
                            assert_eq!(together, one_by_one, "cell ({x}, {y}, {z})");
                        }
                    }
                }
            }
        }
    }

    /// On closed bodies the pseudo-normals decide a point's side exactly as comparing the faces
    /// that share its closest edge or vertex does (the second BVH search they replace), on points
    /// near vertices, where closest points on edges and vertices are common.
    #[test]
    fn pseudo_normals_decide_the_side_as_the_faces_do() {
        let (head, torus) = closed_test_bodies();
        let mut rng = SplitMix::new(11);
        for body in [&head, &torus] {
            let normals = body
                .pseudo_normals
                .as_ref()
                .expect("a closed body has them");
            let (mut on_features, mut inside) = (0, 0);
            for k in 0..6000 {
                let v = body.vertices[(k * 7919) % body.vertices.len()];
                let off = Vector::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                );
                let p = v + off * [0.001, 0.01, 0.03][k % 3];
                let with = exact_signed_distance(&body.bvh, Some(normals), &p).unwrap();
                let without = exact_signed_distance(&body.bvh, None, &p).unwrap();
                assert_eq!(with.0, without.0, "{p:?}");
                assert_eq!(with.1, without.1, "{p:?}");
                inside += usize::from(with.0 < 0.0);
                let pss = crate::Ssv::Point(crate::Pss::new(p, 0.0));
                let hit = body.bvh.closest(&pss).unwrap();
                let tri = body.bvh.triangle(hit.triangle as usize).unwrap();
                let q = hit.closest.on_b;
                on_features += usize::from((0..3).any(|e| {
                    let (a, b) = (tri[e], tri[(e + 1) % 3]);
                    crate::query::point_segment(&q, &a, &b).dist_sq <= 1e-8 * (b - a).norm_squared()
                }));
            }
            // Both sides and many edge and vertex cases were exercised.
            assert!(on_features > 500 && inside > 500, "{on_features} {inside}");
        }
        let open = PseudoNormals::new(&head.vertices, &head.triangles[1..]);
        assert!(open.is_none());
        // A cube: sharp edges and corners, where a wrong feature's normal gives the wrong side.
        let (vertices, triangles) = unit_cube();
        let bvh = Bvh::new(&vertices, &triangles).unwrap();
        let normals = PseudoNormals::new(&vertices, &triangles).expect("a cube is closed");
        for k in 0..4000 {
            let c = vertices[k % 8];
            let off = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let p = c + off * 0.2;
            let (d, _, _) = exact_signed_distance(&bvh, Some(&normals), &p).unwrap();
            let inside = p.coords.iter().all(|&x| (0.0..=1.0).contains(&x));
            assert_eq!(d < 0.0, inside, "{p:?} {d}");
        }
    }

    /// The procedural head and the torus are closed surfaces (an open one is not), and on a
    /// closed one the near field's lower bound never exceeds the exact signed distance, so
    /// `distance_within` skips only points the query would put beyond its reach.
    #[test]
    fn near_field_bounds_the_distance_of_closed_bodies() {
        let (head, torus) = closed_test_bodies();
        assert!(head.closed);
        assert!(torus.closed);
        assert!(!is_closed(&head.triangles[1..]));
        let mut rng = SplitMix::new(3);
        let mut skipped = 0;
        for body in [&head, &torus] {
            for _ in 0..4000 {
                let (q, _) = rng.surface_point(body.bvh.triangles(), 0.0);
                let off = Vector::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                );
                let p = q + off * 0.03;
                let exact = body.signed_distance(&p).unwrap().0;
                assert!(body.near.lower_bound(&p) <= exact + 1e-5, "{p:?}");
                for method in [CollisionMethod::Bvh, CollisionMethod::Field] {
                    let reach = 0.004;
                    let within = body.distance_within(method, &p, reach);
                    let full = body.distance(method, &p).filter(|(d, _)| *d < reach);
                    assert_eq!(within.filter(|(d, _)| *d < reach), full, "{p:?} {method:?}");
                    skipped += usize::from(within.is_none() && body.distance(method, &p).is_some());
                }
            }
        }
        assert!(skipped > 1000, "{skipped} queries skipped");
    }

    /// On closed bodies the clearance `distance_within_clearance` finds at a point keeps every
    /// point within its travel out of the reach it was asked for, by both methods, whether the
    /// near field turned the point away or the method answered; points lying within a few
    /// millimetres of the surface keep one by the field's own slope (the exact distance's bound,
    /// less a cell diagonal, gives them none); and a field value is within half a cell diagonal
    /// of the exact distance, which that bound takes.
    #[test]
    fn clearances_keep_the_answers_about_them_out_of_reach() {
        let (head, torus) = closed_test_bodies();
        let mut rng = SplitMix::new(5);
        let reach = 0.004;
        let (mut turned_away, mut answered, mut by_slope, mut kept) = (0, 0, 0, 0);
        for body in [&head, &torus] {
            let diagonal = body.field.spacing() * 3f32.sqrt();
            for k in 0..4000 {
                let (s, _) = rng.surface_point(body.bvh.triangles(), 0.0);
                let direction = |rng: &mut SplitMix| {
                    Vector::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    )
                };
                // Half the points within a few millimetres of the surface, where hair rests.
                let scale = if k % 2 == 0 { 0.03 } else { 0.006 };
                let p = s + direction(&mut rng) * scale;
                if let (Some((f, _)), Some((e, _, _))) = (
                    body.distance(CollisionMethod::Field, &p),
                    body.signed_distance(&p),
                ) {
                    assert!((f - e).abs() <= 0.5 * diagonal, "{p:?}: {f} against {e}");
                }
                let (hit, clearance) =
                    body.distance_within_clearance(CollisionMethod::Maps, &p, 0.0);
                assert_eq!(hit, body.distance(CollisionMethod::Maps, &p));
                assert_eq!(clearance.travel(), None, "Maps at {p:?}");
                for method in [CollisionMethod::Bvh, CollisionMethod::Field] {
                    let (hit, clearance) = body.distance_within_clearance(method, &p, reach);
                    assert_eq!(hit, body.distance_within(method, &p, reach));
                    let Some(travel) = clearance.travel() else {
                        assert!(!clearance.keeps_out(&p, 0.0));
                        continue;
                    };
                    turned_away += usize::from(hit.is_none());
                    answered += usize::from(hit.is_some());
                    if let (CollisionMethod::Field, Some((d, _))) = (method, hit) {
                        by_slope += usize::from(d - diagonal - reach < 0.0);
                    }
                    assert!(!clearance.keeps_out(&p, reach * 1.01), "a wider reach");
                    // Points spread over the ball of its travel, and on its edge.
                    for j in 0..8 {
                        let u = direction(&mut rng)
                            .try_normalize(1e-3)
                            .unwrap_or(Vector::x());
                        let share = if j < 4 { 0.999 } else { rng.range(0.0, 1.0) };
                        let q = p + u * travel * share;
                        if !clearance.keeps_out(&q, reach) {
                            // Only where rounding of `q` alone takes it past the edge.
                            assert!(travel < 1e-5 && j < 4, "{clearance:?} {q:?}");
                            continue;
                        }
                        kept += 1;
                        if let Some((d, _)) = body.distance(method, &q) {
                            assert!(d >= reach, "{method:?} {p:?} {q:?}: {d} within {reach}");
                        }
                    }
                }
            }
        }
        assert!(
            turned_away > 1000 && answered > 1000 && by_slope > 300 && kept > 30_000,
            "{turned_away} {answered} {by_slope} {kept}"
        );
    }

    /// The unit cube `[0, 1]^3`, wound outward; its first two triangles are the bottom (z = 0)
    /// and the next two the top (z = 1).
    fn unit_cube() -> (Vec<Point>, Vec<[u32; 3]>) {
        let vertices = (0..8)
            .map(|i| Point::new((i & 1) as Real, ((i >> 1) & 1) as Real, (i >> 2) as Real))
            .collect();
        let triangles = vec![
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ];
        (vertices, triangles)
    }

    /// A unit cube without its top and bottom faces has two holes; capping them makes a closed
    /// surface whose signed distance gives the right side everywhere, including in the lids'
    /// openings. A closed mesh, and one whose holes meet at a vertex, are left as they are.
    #[test]
    fn capped_holes_close_the_mesh() {
        let (cube, closed) = unit_cube();
        let (mut v, mut t) = (cube.clone(), closed.clone());
        assert_eq!(cap_holes(&mut v, &mut t), 0);
        assert_eq!((v.len(), t.len()), (8, 12));

        let (mut v, mut t) = (cube, closed[4..].to_vec());
        assert!(!is_closed(&t));
        assert_eq!(cap_holes(&mut v, &mut t), 2);
        assert_eq!((v.len(), t.len()), (10, 8 + 8));
        assert!(is_closed(&t));
        let bvh = Bvh::new(&v, &t).unwrap();
        let normals = PseudoNormals::new(&v, &t).expect("capped");
        let mut rng = SplitMix::new(3);
        for _ in 0..2000 {
            let p = Point::new(
                rng.range(-0.5, 1.5),
                rng.range(-0.5, 1.5),
                rng.range(-0.5, 1.5),
            );
            let (d, _, _) = exact_signed_distance(&bvh, Some(&normals), &p).unwrap();
            let inside = p.coords.iter().all(|&x| (0.0..=1.0).contains(&x));
            assert_eq!(d < 0.0, inside, "{p:?} {d}");
        }

        // Two triangles meeting at one vertex: two boundary edges leave it, so no fan closes it.
        let bowtie = vec![
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(1.0, 1.0, 0.0),
            Point::new(-1.0, 0.0, 0.0),
            Point::new(-1.0, -1.0, 0.0),
        ];
        let (mut v, mut t) = (bowtie, vec![[0, 1, 2], [0, 3, 4]]);
        assert_eq!(cap_holes(&mut v, &mut t), 0);
        assert_eq!((v.len(), t.len()), (5, 2));
    }
}
