//! The scalp of the procedural head ([`crate::head`]): roots spread over a region of it by
//! dart throwing, and strands laid over the head, neck and shoulders ([`drape`]) as a groom
//! lies, so that procedural hair starts near where it rests.

use crate::head::{HEAD, NECK_RADIUS, SHOULDERS};
use crate::{Point, Real, Vector};
use nalgebra::Rotation3;
use rand_xoshiro::SplitMix64;
use rand_xoshiro::rand_core::{Rng, SeedableRng};

/// Semi-axes of the scalp ellipsoid (m), centred at the head origin: the head's.
pub const SCALP: [Real; 3] = HEAD.1;

/// The part of the scalp hair grows from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScalpRegion {
    /// Roots at least this high (m, head frame).
    pub min_height: Real,
    /// Roots at most this far forward (m).
    pub max_forward: Real,
    /// Half-width of a bare parting along the top of the head (m; 0 for none).
    pub parting_width: Real,
}

/// Clearance of draped hair over the procedural head's surface (m), beyond two strand radii:
/// the head mesh's bumps rise up to 3 mm above [`SCALP`].
pub const DRAPE_CLEARANCE: Real = 0.004;

/// Lays a straight strand (`points`, root first) over the procedural head: root to tip, each
/// segment keeps its length and direction, turned toward straight down by its length over
/// 5 cm, and a point that would lie within `clearance` of the scalp, the neck or the
/// shoulders is moved out onto that margin along the part's radius, then back to the segment's
/// length (three times).
pub fn drape(points: &mut [Point], clearance: Real) {
    let out_of = |q: Point| out_of_body(q, clearance);
    let styled: Vec<Vector> = points.windows(2).map(|w| w[1] - w[0]).collect();
    let mut dir: Option<Vector> = None;
    for (k, step) in styled.iter().enumerate() {
        let len = step.norm();
        if len <= 0.0 {
            continue;
        }
        let d = dir.unwrap_or(*step / len);
        let d = (d - Vector::y() * (len / DRAPE_TURN))
            .try_normalize(1e-9)
            .unwrap_or(d);
        let from = points[k];
        let mut q = from + d * len;
        for _ in 0..3 {
            q = from + (out_of(q) - from).try_normalize(1e-9).unwrap_or(d) * len;
        }
        dir = (q - from).try_normalize(1e-9);
        points[k + 1] = q;
    }
}

/// `q` moved out onto the margin `clearance` around the scalp, the neck and the shoulders
/// along the part's radius, where it lies within it.
fn out_of_body(q: Point, clearance: Real) -> Point {
    let mut q = q;
    for (c, r) in [([0.0, 0.0, 0.0], SCALP), SHOULDERS] {
        let c = Vector::from(c);
        let d = q.coords - c;
        let f: Real = (0..3).map(|k| (d[k] / (r[k] + clearance)).powi(2)).sum();
        if f < 1.0 && f > 0.0 {
            q = Point::from(c + d / f.sqrt());
        }
    }
    let (rxz, reach) = (q.x.hypot(q.z), NECK_RADIUS + clearance);
    if rxz < reach && rxz > 0.0 && q.y < 0.0 && q.y > SHOULDERS.0[1] {
        let s = reach / rxz;
        q = Point::new(q.x * s, q.y, q.z * s);
    }
    q
}

/// Length of hair over which a free draped strand turns fully toward straight down (m).
const DRAPE_TURN: Real = 0.05;

/// Lays a styled strand combed over the procedural head as a groom lies. `local` is the style
/// in its root frame (root at the origin, the strand along +z, its wave or curl across x and
/// y). The centreline (each point's z, along `frame`'s z axis from `root`) is laid by [`drape`]
/// with `clearance` plus the style's reach toward the head; each point's offset is then carried
/// in a frame that follows the laid centreline: x across the strand and along the surface, y
/// away from it. So waves lie flat along the head and curls wind clear of it.
pub fn lay_styled(
    root: Point,
    frame: &Rotation3<Real>,
    local: &[Point],
    clearance: Real,
) -> Vec<Point> {
    let mut centre: Vec<Point> = local
        .iter()
        .map(|q| root + frame * Vector::new(0.0, 0.0, q.z))
        .collect();
    // A curl reaches toward the head by its y; a wave across a curved head by its sagitta.
    let (mut reach_y, mut across) = (0.0 as Real, 0.0 as Real);
    for q in local {
        reach_y = reach_y.max(-q.y);
        across = across.max(q.x.abs());
    }
    let head_radius = SCALP.iter().copied().fold(Real::INFINITY, Real::min);
    drape(
        &mut centre,
        clearance + reach_y + across * across / head_radius,
    );
    let n = centre.len();
    let mut side = frame * Vector::x();
    let mut out = Vec::with_capacity(n);
    for (i, q) in local.iter().enumerate() {
        let c = centre[i];
        let tangent = (centre[(i + 1).min(n - 1)] - centre[i.saturating_sub(1)])
            .try_normalize(1e-9)
            .unwrap_or_else(|| frame * Vector::z());
        // Away from the head, or from the neck's axis below it.
        let away =
            if c.y > SHOULDERS.0[1] + SHOULDERS.1[1] && c.y < 0.0 && c.x.hypot(c.z) < SCALP[0] {
                Vector::new(c.x, 0.0, c.z)
            } else {
                c.coords
            };
        if let Some(s) = tangent.cross(&away).try_normalize(1e-6) {
            side = s;
        }
        let up = side.cross(&tangent);
        // Across a curved surface a wave dips toward it: kept out at the clearance.
        out.push(if q.x == 0.0 && q.y == 0.0 {
            c
        } else {
            out_of_body(c + side * q.x + up * q.y, clearance)
        });
    }
    out
}

/// Point on the scalp ellipsoid at spherical angles (polar from +y, azimuth about +y from +x).
pub fn scalp_point(polar: Real, azimuth: Real) -> (Point, Vector) {
    let (sp, cp) = polar.sin_cos();
    let (sa, ca) = azimuth.sin_cos();
    let p = Point::new(SCALP[0] * sp * ca, SCALP[1] * cp, SCALP[2] * sp * sa);
    let n = Vector::new(
        p.x / (SCALP[0] * SCALP[0]),
        p.y / (SCALP[1] * SCALP[1]),
        p.z / (SCALP[2] * SCALP[2]),
    )
    .normalize();
    (p, n)
}

/// `n` roots (points on the scalp ellipsoid and their outward normals) spread over `region`
/// by dart throwing: candidates uniform in area, each kept when no root lies nearer than a
/// disc radius from the region's area; when the disc radius leaves too few, the closest-spaced
/// rejects fill in. Deterministic for a seed; empty when the region holds no scalp.
pub fn scalp_roots(n: usize, region: &ScalpRegion, seed: u64) -> Vec<(Point, Vector)> {
    let mut rng = SplitMix64::seed_from_u64(seed);
    let mut unit = move || (rng.next_u64() >> 40) as Real / (1u64 << 24) as Real;
    // Candidates, uniform in area by rejection against the sphere map's stretch.
    let in_region = |q: &Point| {
        q.y >= region.min_height
            && q.z <= region.max_forward
            && !(q.x.abs() < region.parting_width && q.z > -0.05 && q.y > 0.06)
    };
    let mut candidates = Vec::with_capacity(20 * n);
    let mut tries = 0usize;
    while candidates.len() < 20 * n && tries < 400 * n + 10_000 {
        tries += 1;
        let y = 2.0 * unit() - 1.0;
        let polar = y.clamp(-1.0, 1.0).acos();
        let azimuth = std::f32::consts::TAU * unit();
        let (q, _) = scalp_point(polar, azimuth);
        if in_region(&q) {
            candidates.push((polar, azimuth));
        }
    }
    if candidates.is_empty() {
        return Vec::new();
    }
    // Area of the region, from the fraction of candidates kept (ellipsoid area, Thomsen's formula).
    let [a, b, c] = SCALP;
    let pp = 1.6075f32;
    let ellipsoid_area = 4.0
        * std::f32::consts::PI
        * (((a * b).powf(pp) + (a * c).powf(pp) + (b * c).powf(pp)) / 3.0).powf(1.0 / pp);
    let area = ellipsoid_area * candidates.len() as Real / tries as Real;
    // Greedy dart throwing over the candidates with a hash grid of accepted roots.
    let radius = 0.7 * (area / n as Real).sqrt();
    let cell = radius.max(1e-6);
    let mut grid: std::collections::BTreeMap<(i32, i32, i32), Vec<usize>> =
        std::collections::BTreeMap::new();
    let key = |q: &Point| {
        (
            (q.x / cell).floor() as i32,
            (q.y / cell).floor() as i32,
            (q.z / cell).floor() as i32,
        )
    };
    let mut roots: Vec<(Point, Vector)> = Vec::with_capacity(n);
    let mut rejected = Vec::new();
    for &(polar, azimuth) in &candidates {
        if roots.len() == n {
            break;
        }
        let (q, nrm) = scalp_point(polar, azimuth);
        let k = key(&q);
        let mut ok = true;
        'scan: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&(k.0 + dx, k.1 + dy, k.2 + dz))
                        && list.iter().any(|&i| (roots[i].0 - q).norm() < radius)
                    {
                        ok = false;
                        break 'scan;
                    }
                }
            }
        }
        if ok {
            grid.entry(k).or_default().push(roots.len());
            roots.push((q, nrm));
        } else {
            rejected.push((q, nrm));
        }
    }
    // Too dense for the disc radius: fill with the closest-spaced rejects, deterministically.
    roots.extend(rejected.into_iter().take(n - roots.len()));
    roots
}

/// The direction a combed strand leaves the scalp at `root` (outward `normal`): tilted 70
/// degrees from the normal toward "down the head"; at the crown, where down is along the
/// normal, combed away from the midline.
pub fn comb_direction(root: &Point, normal: &Vector) -> Vector {
    let down = -Vector::y() - normal * (-normal.y);
    let tangent = down.try_normalize(1e-3).unwrap_or_else(|| {
        let side = if root.x >= 0.0 {
            Vector::x()
        } else {
            -Vector::x()
        };
        (side - normal * side.dot(normal)).normalize()
    });
    (normal * 0.35 + tangent).normalize()
}
