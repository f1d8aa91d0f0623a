//! Bodies the hair grows on and collides with: the procedural head and shoulders, a wrinkled
//! torus (Ward & Lin's brushing scene), or an OBJ file; each with its SSV BVH and, for the
//! procedural head, Kurihara's cylinder and sphere tables.

use crate::HairError;
use crate::scene::BodySpec;
use hair_ssv::{Bvh, Point, Real, Vector};
use std::f32::consts::TAU;
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering};

/// Hair within this distance of the body (m) gets an exact query; radii above it are clamped.
pub const NEAR_MARGIN: Real = 0.02;

/// Samples in a body's [`DistanceField`] (about 16 MB of f32).
pub const FIELD_SAMPLES: usize = 4_000_000;

/// A body mesh in the head frame (m) with its collision structures.
#[derive(Clone, Debug)]
pub struct BodyModel {
    /// Vertices (m, head frame).
    pub vertices: Vec<Point>,
    /// Outward-wound triangles.
    pub triangles: Vec<[u32; 3]>,
    /// The SSV BVH over the triangles.
    pub bvh: Bvh,
    /// Cylinder and sphere tables, where the body has them (the procedural head).
    pub maps: Option<hair_ssv::Body>,
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

/// Samples of the body's signed distance at the vertices of a regular grid (about 4 million
/// vertices over the body's bounds, so a few millimetres apart on a head), each computed by the
/// exact BVH query the first time a query needs it and kept. A query interpolates the eight
/// samples around the point trilinearly and takes the normal from the interpolant's gradient: a
/// few dozen nanoseconds instead of a BVH traversal. The true distance is 1-Lipschitz, so the
/// interpolated value is within `h * sqrt(3)` of it anywhere and within `O(h^2 * curvature)` on
/// smooth surfaces; [`DistanceField::measure_error`] measures it against the exact query.
///
/// Samples are filled lazily from parallel queries through atomics: every sample is a pure
/// function of the mesh, so the order in which threads fill them cannot change a result.
///
/// The samples are stored in bricks of 4 x 4 x 4, each 4 x 4 layer one cache line: the eight
/// samples a query reads then lie in two neighbouring lines of one brick, most of the time,
/// instead of four lines on two pages (x rows, then y, then z over the whole grid).
#[derive(Debug, Default)]
pub struct DistanceField {
    min: Point,
    h: Real,
    dims: [usize; 3],
    /// Bricks along x and y (the grid's dimensions over 4, rounded up).
    bricks: [usize; 2],
    samples: Vec<BrickLayer>,
}

/// One 4 x 4 layer of a brick of samples (f32 bits), aligned to a cache line.
#[derive(Debug)]
#[repr(C, align(64))]
struct BrickLayer([AtomicU32; 16]);

impl BrickLayer {
    fn unknown() -> Self {
        Self(std::array::from_fn(|_| AtomicU32::new(UNKNOWN)))
    }
}

/// Bits of a sample not yet computed (a NaN no distance can produce).
const UNKNOWN: u32 = 0x7fc0_dead;

impl Clone for DistanceField {
    fn clone(&self) -> Self {
        Self {
            min: self.min,
            h: self.h,
            dims: self.dims,
            bricks: self.bricks,
            samples: self
                .samples
                .iter()
                .map(|l| {
                    BrickLayer(
                        l.0.each_ref()
                            .map(|a| AtomicU32::new(a.load(Ordering::Relaxed))),
                    )
                })
                .collect(),
        }
    }
}

impl DistanceField {
    /// A field over the body's bounds grown by `margin`, with about `vertices` samples.
    pub fn new(body_vertices: &[Point], margin: Real, vertices: usize) -> Self {
        let (mut lo, mut hi) = (
            Point::from(Vector::repeat(Real::MAX)),
            Point::from(Vector::repeat(Real::MIN)),
        );
        for v in body_vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        if body_vertices.is_empty() {
            return Self::default();
        }
        let pad = Vector::repeat(margin);
        lo -= pad;
        hi += pad;
        let ext = hi - lo;
        // Vertices farther apart than `f32` spans: no field ([`DistanceField::query`] then
        // answers by the exact query).
        let Some((h, dims)) = lattice(&ext, vertices.max(8), 1e-5, 2) else {
            return Self::default();
        };
        let [bx, by, bz] = dims.map(|d| d.div_ceil(4));
        let samples = (0..bx * by * bz * 4)
            .map(|_| BrickLayer::unknown())
            .collect();
        Self {
            min: lo,
            h,
            dims,
            bricks: [bx, by],
            samples,
        }
    }

    /// Spacing of the samples (m).
    pub fn spacing(&self) -> Real {
        self.h
    }

    /// Samples computed so far.
    pub fn filled(&self) -> usize {
        self.samples
            .iter()
            .flat_map(|l| &l.0)
            .filter(|a| a.load(Ordering::Relaxed) != UNKNOWN)
            .count()
    }

    /// The sample at grid vertex `(x, y, z)`.
    #[inline(always)]
    fn slot(&self, x: usize, y: usize, z: usize) -> &AtomicU32 {
        let brick = (x >> 2) + self.bricks[0] * ((y >> 2) + self.bricks[1] * (z >> 2));
        &self.samples[4 * brick + (z & 3)].0[(x & 3) + 4 * (y & 3)]
    }

    #[inline]
    fn sample(&self, body: &BodyModel, x: usize, y: usize, z: usize) -> Real {
        let slot = self.slot(x, y, z);
        let bits = slot.load(Ordering::Relaxed);
        if bits != UNKNOWN {
            return Real::from_bits(bits);
        }
        let c = self.min + Vector::new(x as Real, y as Real, z as Real) * self.h;
        let d = body.signed_distance(&c).map_or(Real::MAX, |(d, _, _)| d);
        slot.store(d.to_bits(), Ordering::Relaxed);
        d
    }

    /// Interpolated signed distance (negative inside) and outward normal at `p`; `None` outside
    /// the field (farther than its margin from the body).
    pub fn query(&self, body: &BodyModel, p: &Point) -> Option<(Real, Vector)> {
        if self.samples.is_empty() {
            // No field (an empty body, or one too large for `f32`): the exact query.
            return body.signed_distance(p).map(|(d, n, _)| (d, n));
        }
        let q = (p - self.min) / self.h;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
            return None;
        }
        let (x, y, z) = (q.x as usize, q.y as usize, q.z as usize);
        if x + 1 >= self.dims[0] || y + 1 >= self.dims[1] || z + 1 >= self.dims[2] {
            return None;
        }
        let (tx, ty, tz) = (q.x - x as Real, q.y - y as Real, q.z - z as Real);
        let mut c = [0.0 as Real; 8];
        for (i, v) in c.iter_mut().enumerate() {
            *v = self.sample(body, x + (i & 1), y + ((i >> 1) & 1), z + (i >> 2));
        }
        if c.contains(&Real::MAX) {
            return None;
        }
        let lerp = |a: Real, b: Real, t: Real| a + (b - a) * t;
        // Along x first, then y, then z; the gradient from the same bilinear faces.
        let x00 = lerp(c[0], c[1], tx);
        let x10 = lerp(c[2], c[3], tx);
        let x01 = lerp(c[4], c[5], tx);
        let x11 = lerp(c[6], c[7], tx);
        let y0 = lerp(x00, x10, ty);
        let y1 = lerp(x01, x11, ty);
        let d = lerp(y0, y1, tz);
        let dx = lerp(
            lerp(c[1] - c[0], c[3] - c[2], ty),
            lerp(c[5] - c[4], c[7] - c[6], ty),
            tz,
        );
        let dy = lerp(x10 - x00, x11 - x01, tz);
        let dz = y1 - y0;
        let g = Vector::new(dx, dy, dz);
        let n = g
            .try_normalize(1e-12)
            .or_else(|| body.signed_distance(p).map(|(_, n, _)| n))?;
        Some((d, n))
    }

    /// Computes now, in parallel, every sample not yet known whose signed distance may lie
    /// within `[-inside, outside]` by the near field's bound, so that the steps that later
    /// query there find it known; returns how many it computed. The values are those a query
    /// would have computed (each sample is a pure function of the mesh), so a simulation gives
    /// the same results with or without it: the exact queries only move from the first frames
    /// that reach each place to this call.
    pub fn fill_band(&self, body: &BodyModel, inside: Real, outside: Real) -> usize {
        use rayon::prelude::*;
        let [nx, ny, nz] = self.dims;
        (0..nz)
            .into_par_iter()
            .map(|z| {
                let mut filled = 0;
                for y in 0..ny {
                    for x in 0..nx {
                        let slot = self.slot(x, y, z);
                        if slot.load(Ordering::Relaxed) != UNKNOWN {
                            continue;
                        }
                        let c = self.min + Vector::new(x as Real, y as Real, z as Real) * self.h;
                        let Some((low, high)) = body.near.bounds(&c) else {
                            continue;
                        };
                        if high < -inside || low > outside {
                            continue;
                        }
                        self.sample(body, x, y, z);
                        filled += 1;
                    }
                }
                filled
            })
            .sum()
    }

    /// Largest difference between the field and the exact signed distance over `count`
    /// deterministic points within `band` of the body's surface vertices (m).
    pub fn measure_error(&self, body: &BodyModel, count: usize, band: Real) -> Real {
        use rayon::prelude::*;
        if body.vertices.is_empty() {
            return 0.0;
        }
        (0..count)
            .into_par_iter()
            .map(|k| {
                // A low-discrepancy walk over the vertices and offsets (no RNG state to share).
                let v = body.vertices[(k * 7919) % body.vertices.len()];
                let f = |a: usize| ((a as f64 * 0.618_033_988_7).fract() as Real) * 2.0 - 1.0;
                let off = Vector::new(f(3 * k + 1), f(3 * k + 2), f(3 * k + 3)) * band;
                let p = v + off;
                match (self.query(body, &p), body.signed_distance(&p)) {
                    (Some((a, _)), Some((b, _, _))) => (a - b).abs(),
                    _ => 0.0,
                }
            })
            .reduce(|| 0.0, Real::max)
    }
}

fn exact_signed_distance(
    bvh: &Bvh,
    pseudo_normals: Option<&PseudoNormals>,
    p: &Point,
) -> Option<(Real, Vector, Point)> {
    thread_local! {
        static TIES: std::cell::RefCell<Vec<hair_ssv::MeshContact>> =
            const { std::cell::RefCell::new(Vec::new()) };
    }
    let pss = hair_ssv::Ssv::Point(hair_ssv::Pss::new(*p, 0.0));
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
        hair_ssv::query::point_segment(&q, &a, &b).dist_sq <= 1e-8 * (b - a).norm_squared()
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
fn lattice(
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
    pub fn build(body: &BodyModel, margin: Real) -> Self {
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

impl BodyModel {
    /// Builds the body a scene asks for; `None` for `BodySpec::None`.
    pub fn from_spec(spec: &BodySpec, base_dir: &Path) -> Result<Option<Self>, HairError> {
        let (vertices, triangles, maps_wanted) = match spec {
            BodySpec::None => return Ok(None),
            BodySpec::Head { resolution } => {
                let (v, t) = hair_ssv::test_meshes::head_and_shoulders(*resolution as usize);
                (v, t, true)
            }
            BodySpec::Torus {
                center,
                major,
                minor,
                wrinkles,
                depth,
            } => {
                let (v, t) = wrinkled_torus(
                    Point::from(*center),
                    *major,
                    *minor,
                    *wrinkles,
                    *depth,
                    96,
                    32,
                );
                (v, t, false)
            }
            BodySpec::Obj {
                path,
                scale,
                offset,
                close_holes,
            } => {
                let mesh = hair_io::obj::read(&base_dir.join(path))?;
                let off = Vector::from(*offset);
                let mut v = mesh
                    .vertices
                    .iter()
                    .map(|p| Point::from(Vector::from(*p) * *scale + off))
                    .collect();
                let mut t = mesh.triangles;
                if *close_holes {
                    cap_holes(&mut v, &mut t);
                }
                (v, t, false)
            }
        };
        let bvh = Bvh::new(&vertices, &triangles).map_err(|source| match spec {
            BodySpec::Obj { path, scale, .. } => HairError::BodyMesh {
                file: base_dir.join(path).display().to_string(),
                scale: *scale,
                source,
            },
            _ => HairError::Ssv(source),
        })?;
        let maps = if maps_wanted {
            Some(hair_ssv::test_meshes::head_and_shoulders_body(&bvh, 64)?)
        } else {
            None
        };
        let field = DistanceField::new(&vertices, 2.0 * NEAR_MARGIN, FIELD_SAMPLES);
        // Only a closed surface has pseudo-normals: one closedness test serves both.
        let pseudo_normals = PseudoNormals::new(&vertices, &triangles);
        let closed = pseudo_normals.is_some();
        let mut body = Self {
            vertices,
            triangles,
            bvh,
            maps,
            near: NearField::default(),
            field,
            closed,
            pseudo_normals,
        };
        body.near = NearField::build(&body, NEAR_MARGIN);
        Ok(Some(body))
    }

    /// Signed distance of a point to the surface (negative inside) with the outward normal and the
    /// closest surface point, by the exact BVH query.
    pub fn signed_distance(&self, p: &Point) -> Option<(Real, Vector, Point)> {
        exact_signed_distance(&self.bvh, self.pseudo_normals.as_ref(), p)
    }

    /// [`BodyModel::distance`] where it may be below `reach`, else `None`: points that the
    /// near field's lower bound, less the method's own error, already puts `reach` or farther
    /// away are not queried (and fill no samples of the distance field). The answers below
    /// `reach` are the same as [`BodyModel::distance`]'s. (The bound holds for a closed surface
    /// only: an open mesh, or `Maps`, whose tables have no stated error, is always queried.)
    #[inline]
    pub fn distance_within(
        &self,
        method: crate::scene::CollisionMethod,
        p: &Point,
        reach: Real,
    ) -> Option<(Real, Vector)> {
        use crate::scene::CollisionMethod;
        let error = match method {
            // A field value is a convex combination of exact samples within a cell diagonal.
            CollisionMethod::Field => self.field.spacing() * 3f32.sqrt() * 1.001,
            CollisionMethod::Bvh => 0.0,
            CollisionMethod::Maps => Real::INFINITY,
        };
        if self.closed && self.near.lower_bound(p) - error - 1e-6 >= reach {
            return None;
        }
        self.distance(method, p)
    }

    /// Signed distance and outward normal by `method`, or `None` when `p` is farther than
    /// the near margin (2 cm) from the body (or the method cannot answer there).
    #[inline]
    pub fn distance(
        &self,
        method: crate::scene::CollisionMethod,
        p: &Point,
    ) -> Option<(Real, Vector)> {
        use crate::scene::CollisionMethod;
        if !self.near.is_near(p) {
            return None;
        }
        match (method, &self.maps) {
            (CollisionMethod::Maps, Some(maps)) => {
                use hair_ssv::SurfaceMap;
                maps.lookup(p).map(|s| (s.distance, s.normal))
            }
            (CollisionMethod::Field, _) => self.field.query(self, p),
            _ => self.signed_distance(p).map(|(d, n, _)| (d, n)),
        }
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
    use crate::scene::CollisionMethod;
    use hair_ssv::test_meshes::{HEAD, SHOULDERS, SplitMix};

    const NECK: Real = hair_ssv::test_meshes::NECK_RADIUS;

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

    /// An OBJ body with a degenerate triangle is an error naming the file and the triangle.
    #[test]
    fn a_degenerate_obj_names_its_file_and_triangle() {
        let dir = std::env::temp_dir().join(format!("hair-body-obj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
        std::fs::write(dir.join("tet.obj"), tet).unwrap();
        // The fourth face repeats an edge's vertex: zero area.
        std::fs::write(dir.join("flat.obj"), tet.replace("f 2 3 4", "f 2 3 3")).unwrap();
        let spec = |path: &str| BodySpec::Obj {
            path: path.into(),
            scale: 0.1,
            offset: [0.0; 3],
            close_holes: false,
        };
        assert!(
            BodyModel::from_spec(&spec("tet.obj"), &dir)
                .unwrap()
                .is_some()
        );
        match BodyModel::from_spec(&spec("flat.obj"), &dir) {
            Err(HairError::BodyMesh {
                file,
                source: hair_ssv::SsvError::DegenerateTriangle { triangle: 3, .. },
                ..
            }) => assert!(file.ends_with("flat.obj"), "{file}"),
            other => panic!("expected a BodyMesh error, got {:?}", other.err()),
        }
        let _ = std::fs::remove_dir_all(&dir);
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
        let body = BodyModel::from_spec(&BodySpec::Head { resolution: 64 }, Path::new("."))
            .unwrap()
            .unwrap();
        let mut rng = SplitMix(7);
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
    fn closed_test_bodies() -> (BodyModel, BodyModel) {
        let head = BodyModel::from_spec(&BodySpec::Head { resolution: 32 }, Path::new("."))
            .unwrap()
            .unwrap();
        let torus = BodyModel::from_spec(
            &BodySpec::Torus {
                center: [0.0, 0.0, 0.0],
                major: 0.1,
                minor: 0.03,
                wrinkles: 8,
                depth: 0.2,
            },
            Path::new("."),
        )
        .unwrap()
        .unwrap();
        (head, torus)
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
        }
    }

    /// On closed bodies the pseudo-normals decide a point's side exactly as comparing the faces
    /// that share its closest edge or vertex does (the second BVH search they replace), on points
    /// near vertices, where closest points on edges and vertices are common.
    #[test]
    fn pseudo_normals_decide_the_side_as_the_faces_do() {
        let (head, torus) = closed_test_bodies();
        let mut rng = SplitMix(11);
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
                let pss = hair_ssv::Ssv::Point(hair_ssv::Pss::new(p, 0.0));
                let hit = body.bvh.closest(&pss).unwrap();
                let tri = body.bvh.triangle(hit.triangle as usize).unwrap();
                let q = hit.closest.on_b;
                on_features += usize::from((0..3).any(|e| {
                    let (a, b) = (tri[e], tri[(e + 1) % 3]);
                    hair_ssv::query::point_segment(&q, &a, &b).dist_sq
                        <= 1e-8 * (b - a).norm_squared()
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
        let mut rng = SplitMix(3);
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
        let mut rng = SplitMix(3);
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
