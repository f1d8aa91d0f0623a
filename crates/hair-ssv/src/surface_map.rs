//! What the collision tables of Kurihara et al. 1993 §3.1 share: a frame, the answer of a
//! lookup, and the bilinear interpolation of eq. 8-10.

use crate::contact::try_unit;
use crate::{Bvh, Point, Real, SsvError, Vector};

/// An orthonormal frame for a map: origin, axis ("up" of a cylinder, pole of a sphere) and the
/// reference direction of azimuth zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapFrame {
    /// Origin: a point of the cylinder's axis, or the sphere's centre.
    pub origin: Point,
    /// Unit axis.
    pub axis: Vector,
    /// Unit direction of azimuth zero, perpendicular to `axis`.
    pub reference: Vector,
}

impl MapFrame {
    /// A frame from an origin, an axis and any direction not parallel to it (made orthonormal).
    pub fn try_new(origin: Point, axis: Vector, reference: Vector) -> Result<Self, SsvError> {
        let bad = |reason: &str| SsvError::InvalidMap {
            map: "MapFrame",
            reason: reason.to_string(),
        };
        if !origin.coords.iter().all(|x| x.is_finite()) {
            return Err(bad("field `origin` is not finite"));
        }
        let axis = try_unit(&axis).ok_or_else(|| bad("field `axis` is zero or not finite"))?;
        let reference = try_unit(&(reference - axis * axis.dot(&reference)))
            .ok_or_else(|| bad("field `reference` is zero, parallel to `axis` or not finite"))?;
        Ok(Self {
            origin,
            axis,
            reference,
        })
    }

    /// The third axis, `axis x reference` (azimuth a quarter turn from `reference`).
    #[inline]
    pub fn side(&self) -> Vector {
        self.axis.cross(&self.reference)
    }

    /// The unit direction at azimuth `theta` in the plane perpendicular to the axis.
    #[inline]
    pub fn radial(&self, theta: Real) -> Vector {
        let (s, c) = theta.sin_cos();
        self.reference * c + self.side() * s
    }
}

/// The answer of a map lookup for a point `P`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapSample {
    /// Whether `P` is inside: its radius is below the interpolated surface radius.
    pub inside: bool,
    /// Signed distance to the surface along the interpolated normal, `(P - Q) . N`: positive
    /// outside, negative inside.
    pub distance: Real,
    /// The nearest surface point `T = P + ((Q - P) . N) N` (eq. 11).
    pub surface: Point,
    /// The interpolated unit surface normal `N`.
    pub normal: Vector,
}

/// A collision table: lookup of points near a body part.
pub trait SurfaceMap {
    /// The sample for `p`, or `None` when `p` is outside the region the map covers.
    fn lookup(&self, p: &Point) -> Option<MapSample>;

    /// Whether `p` is covered by the map and inside the surface.
    fn inside(&self, p: &Point) -> bool {
        self.lookup(p).is_some_and(|s| s.inside)
    }
}

/// A grid sampled on a periodic azimuth (`m` columns over a full turn) times a clamped second
/// coordinate (`n` rows over `[v0, v0 + (n - 1) dv]`), storing radius and normal.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Grid {
    pub(crate) m: usize,
    pub(crate) n: usize,
    pub(crate) v0: Real,
    pub(crate) dv: Real,
    /// `n * m` radii, row-major by the second coordinate.
    pub(crate) radius: Vec<Real>,
    /// `n * m` unit normals.
    pub(crate) normal: Vec<Vector>,
}

impl Grid {
    /// Samples a body part by casting one ray per node, row by row: node `(i, j)` (azimuth `i`
    /// of `m`, row `j` of `n`, rows at `v0 + j dv`) casts from `centre + dir * max_radius`
    /// toward `centre`, with `(centre, dir) = ray(i, j)` and `dir` the unit direction outward.
    /// The node records how far out from `centre` the outermost surface lies, with its normal
    /// turned outward; where the ray misses, radius 0 (nothing there) and normal `dir`.
    pub(crate) fn cast(
        bvh: &Bvh,
        (m, n): (usize, usize),
        (v0, dv): (Real, Real),
        max_radius: Real,
        ray: impl Fn(usize, usize) -> (Point, Vector),
    ) -> Self {
        let mut radius = Vec::with_capacity(m * n);
        let mut normal = Vec::with_capacity(m * n);
        for j in 0..n {
            for i in 0..m {
                let (centre, dir) = ray(i, j);
                let start = centre + dir * max_radius;
                match bvh.cast_ray(&start, &-dir, max_radius) {
                    Some(hit) => {
                        radius.push(max_radius - hit.t);
                        normal.push(if hit.normal.dot(&dir) >= 0.0 {
                            hit.normal
                        } else {
                            -hit.normal
                        });
                    }
                    None => {
                        radius.push(0.0);
                        normal.push(dir);
                    }
                }
            }
        }
        Self {
            m,
            n,
            v0,
            dv,
            radius,
            normal,
        }
    }

    /// Bilinear interpolation (eq. 8-10) at azimuth `theta` (radians, any range) and second
    /// coordinate `v` (clamped to the grid): radius and normalised normal.
    #[inline]
    pub(crate) fn interpolate(&self, theta: Real, v: Real) -> (Real, Vector) {
        let fi = theta * (self.m as Real / std::f32::consts::TAU);
        let fi = fi - (fi / self.m as Real).floor() * self.m as Real;
        let i0 = (fi as usize).min(self.m - 1);
        let s = (fi - i0 as Real).clamp(0.0, 1.0);
        let i1 = if i0 + 1 == self.m { 0 } else { i0 + 1 };
        let fj = ((v - self.v0) / self.dv).max(0.0).min((self.n - 1) as Real);
        let j0 = (fj as usize).min(self.n.saturating_sub(2));
        let t = (fj - j0 as Real).clamp(0.0, 1.0);
        let j1 = (j0 + 1).min(self.n - 1);
        let (a, b, c, d) = (
            j0 * self.m + i0,
            j0 * self.m + i1,
            j1 * self.m + i0,
            j1 * self.m + i1,
        );
        let w = [(1.0 - s) * (1.0 - t), s * (1.0 - t), (1.0 - s) * t, s * t];
        let r = self.radius[a] * w[0]
            + self.radius[b] * w[1]
            + self.radius[c] * w[2]
            + self.radius[d] * w[3];
        let nrm = self.normal[a] * w[0]
            + self.normal[b] * w[1]
            + self.normal[c] * w[2]
            + self.normal[d] * w[3];
        (r, nrm)
    }
}

/// Completes a lookup from `P`, the surface point `Q` on the same ray, the interpolated normal
/// (any length) and the inside test.
#[inline]
pub(crate) fn sample(
    p: &Point,
    q: &Point,
    normal: Vector,
    fallback: Vector,
    inside: bool,
) -> MapSample {
    let nn = normal.norm_squared();
    let n = if nn > 1e-12 {
        normal / nn.sqrt()
    } else {
        fallback
    };
    let distance = (p - q).dot(&n);
    MapSample {
        inside,
        distance,
        surface: p - n * distance,
        normal: n,
    }
}
