//! Signed distances of a mesh sampled on a regular grid, computed on first use and
//! interpolated trilinearly.

use crate::mesh_body::{MeshBody, lattice};
use crate::{Point, Real, Vector};
use std::sync::atomic::{AtomicU32, Ordering};

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
    pub(crate) min: Point,
    pub(crate) h: Real,
    pub(crate) dims: [usize; 3],
    /// Bricks along x and y (the grid's dimensions over 4, rounded up).
    bricks: [usize; 2],
    pub(crate) samples: Vec<BrickLayer>,
}

/// One 4 x 4 layer of a brick of samples (f32 bits), aligned to a cache line.
#[derive(Debug)]
#[repr(C, align(64))]
pub(crate) struct BrickLayer([AtomicU32; 16]);

impl BrickLayer {
    fn unknown() -> Self {
        Self(std::array::from_fn(|_| AtomicU32::new(UNKNOWN)))
    }
}

/// Bits of a sample not yet computed (a NaN no distance can produce).
pub(crate) const UNKNOWN: u32 = 0x7fc0_dead;

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
    pub(crate) fn slot(&self, x: usize, y: usize, z: usize) -> &AtomicU32 {
        let brick = (x >> 2) + self.bricks[0] * ((y >> 2) + self.bricks[1] * (z >> 2));
        &self.samples[4 * brick + (z & 3)].0[(x & 3) + 4 * (y & 3)]
    }

    #[inline]
    pub(crate) fn sample(&self, body: &MeshBody, x: usize, y: usize, z: usize) -> Real {
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

    /// The samples at the eight corners of the cell whose lowest corner is `(x, y, z)`, x
    /// fastest, computing those not yet known. A sample's place in the bricks is a sum of
    /// one term per axis, so the eight places take six terms and the known samples are read
    /// without working out a brick each.
    #[inline]
    pub(crate) fn corners(&self, body: &MeshBody, x: usize, y: usize, z: usize) -> [Real; 8] {
        let [bx, by] = self.bricks;
        let along = |v: usize, brick: usize, within: usize| (v >> 2) * brick + (v & 3) * within;
        let ix = [along(x, 64, 1), along(x + 1, 64, 1)];
        let iy = [along(y, 64 * bx, 4), along(y + 1, 64 * bx, 4)];
        let iz = [along(z, 64 * bx * by, 16), along(z + 1, 64 * bx * by, 16)];
        let mut bits = [UNKNOWN; 8];
        for (i, b) in bits.iter_mut().enumerate() {
            let at = ix[i & 1] + iy[(i >> 1) & 1] + iz[i >> 2];
            if let Some(layer) = self.samples.get(at >> 4) {
                *b = layer.0[at & 15].load(Ordering::Relaxed);
            }
        }
        if bits.contains(&UNKNOWN) {
            return std::array::from_fn(|i| {
                self.sample(body, x + (i & 1), y + ((i >> 1) & 1), z + (i >> 2))
            });
        }
        bits.map(Real::from_bits)
    }

    /// Interpolated signed distance (negative inside) and outward normal at `p`; `None` outside
    /// the field (farther than its margin from the body).
    pub fn query(&self, body: &MeshBody, p: &Point) -> Option<(Real, Vector)> {
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
        let c = self.corners(body, x, y, z);
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
    pub fn fill_band(&self, body: &MeshBody, inside: Real, outside: Real) -> usize {
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
    pub fn measure_error(&self, body: &MeshBody, count: usize, band: Real) -> Real {
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
