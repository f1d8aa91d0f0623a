//! Hairstyles: procedural hair grown on the scalp with Poisson-disc roots, or strands read from a
//! `.tfx` / `.hair` file, as the plain `hair_lod::Hairstyle` every layer starts from.

use crate::HairError;
use crate::scene::{HairstyleSpec, ProceduralHair, StyleSpec};
use hair_dynamics::{Style, style_points};
use hair_lod::{Hairstyle, Strand};
use hair_ssv::{Point, Real, Vector};
use nalgebra::Rotation3;
use std::path::Path;

/// Semi-axes of the scalp ellipsoid of the procedural head (m), centred at the head origin.
pub const SCALP: [Real; 3] = [0.078, 0.115, 0.097];

/// Clearance of draped hair over the procedural head's surface (m), beyond two strand radii:
/// the head mesh's bumps rise up to 3 mm above [`SCALP`].
const DRAPE_CLEARANCE: Real = 0.004;

/// Lays a straight strand (`points`, root first) over the procedural head: root to tip, each
/// segment keeps its length and direction, turned toward straight down by its length over
/// [`DRAPE_TURN`], and a point that would lie within `clearance` of the scalp, the neck or the
/// shoulders is moved out onto that margin along the part's radius, then back to the segment's
/// length (three times).
fn drape(points: &mut [Point], clearance: Real) {
    use hair_ssv::head::{NECK_RADIUS, SHOULDERS};
    let out_of = |q: Point| -> Point {
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
    };
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

/// Length of hair over which a free draped strand turns fully toward straight down (m).
const DRAPE_TURN: Real = 0.05;

/// A deterministic SplitMix64 stream.
#[derive(Clone, Debug)]
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> Real {
        (self.next_u64() >> 40) as Real / (1u64 << 24) as Real
    }
}

/// Builds the hairstyle a scene asks for.
pub fn from_spec(spec: &HairstyleSpec, seed: u64, base_dir: &Path) -> Result<Hairstyle, HairError> {
    match spec {
        HairstyleSpec::Procedural(p) => procedural(p, seed),
        HairstyleSpec::File {
            path,
            scale,
            offset,
            points,
        } => {
            let file = base_dir.join(path);
            let strands = hair_io::read_strands(&file)?;
            let off = Vector::from(*offset);
            let mut out = Vec::with_capacity(strands.strand_count());
            for (strand, s) in strands.iter().enumerate() {
                let pts: Vec<Point> = s
                    .iter()
                    .map(|p| Point::from(Vector::from(*p) * *scale + off))
                    .collect();
                let pts = resample(&pts, *points as usize);
                // The dynamics would reject it too, but could name neither the file nor the
                // strand in it.
                for (segment, w) in pts.windows(2).enumerate() {
                    let length = (w[1] - w[0]).norm();
                    if !(length.is_finite() && length > 0.0) {
                        return Err(HairError::DegenerateStrand {
                            file: file.display().to_string(),
                            strand,
                            segment,
                            length,
                            scale: *scale,
                            points: *points,
                        });
                    }
                }
                let dir = (pts[1] - pts[0])
                    .try_normalize(1e-12)
                    .unwrap_or_else(|| -Vector::y());
                out.push(Strand {
                    root: pts[0],
                    frame: frame_along(&dir),
                    points: pts,
                });
            }
            Ok(Hairstyle { strands: out })
        }
    }
}

/// A root frame whose z axis points along `dir`.
pub fn frame_along(dir: &Vector) -> Rotation3<Real> {
    Rotation3::rotation_between(&Vector::z(), dir)
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector::x_axis(), std::f32::consts::PI))
}

/// Resamples a polyline to `n` points at equal arc length (root and tip kept).
pub fn resample(points: &[Point], n: usize) -> Vec<Point> {
    let mut arc = Vec::with_capacity(points.len());
    let mut total = 0.0;
    arc.push(0.0);
    for w in points.windows(2) {
        total += (w[1] - w[0]).norm();
        arc.push(total);
    }
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for i in 0..n {
        let target = total * i as Real / (n - 1) as Real;
        while j + 2 < points.len() && arc[j + 1] < target {
            j += 1;
        }
        let (a0, a1) = (arc[j], arc[j + 1]);
        let t = if a1 > a0 {
            ((target - a0) / (a1 - a0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(points[j] + (points[j + 1] - points[j]) * t);
    }
    out
}

/// Point on the scalp ellipsoid at spherical angles (polar from +y, azimuth about +y from +x).
fn scalp_point(polar: Real, azimuth: Real) -> (Point, Vector) {
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

/// Procedural hair: Poisson-disc roots on the scalp region, each strand leaving the scalp tilted
/// down along the surface (a tangent line of a convex head stays outside it), then styled.
pub fn procedural(p: &ProceduralHair, seed: u64) -> Result<Hairstyle, HairError> {
    let n = p.strands as usize;
    let mut rng = Rng(seed ^ 0x5CA1_9000);
    // Candidates, uniform in area by rejection against the sphere map's stretch.
    let in_region = |q: &Point| {
        q.y >= p.scalp_min_height
            && q.z <= p.scalp_max_forward
            && !(q.x.abs() < p.parting_width && q.z > -0.05 && q.y > 0.06)
    };
    let mut candidates = Vec::with_capacity(20 * n);
    let mut tries = 0usize;
    while candidates.len() < 20 * n && tries < 400 * n + 10_000 {
        tries += 1;
        let y = 2.0 * rng.unit() - 1.0;
        let polar = y.clamp(-1.0, 1.0).acos();
        let azimuth = std::f32::consts::TAU * rng.unit();
        let (q, _) = scalp_point(polar, azimuth);
        if in_region(&q) {
            candidates.push((polar, azimuth));
        }
    }
    if candidates.is_empty() {
        return Err(HairError::SceneValue {
            file: String::new(),
            field: "hairstyle.scalp_min_height".into(),
            message: "the scalp region holds no roots".into(),
        });
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
    let style = match p.style {
        StyleSpec::Straight | StyleSpec::Draped => Style::Straight,
        StyleSpec::Wavy { amplitude, period } => Style::Wavy { amplitude, period },
        StyleSpec::Curly { radius, pitch } => Style::Curly { radius, pitch },
    };
    let mut strands = Vec::with_capacity(n);
    for (root, normal) in roots {
        // Leave the scalp tilted 70 degrees from the normal toward "down the head"; at the crown,
        // where down is along the normal, comb away from the midline.
        let down = -Vector::y() - normal * (-normal.y);
        let tangent = down.try_normalize(1e-3).unwrap_or_else(|| {
            let side = if root.x >= 0.0 {
                Vector::x()
            } else {
                -Vector::x()
            };
            (side - normal * side.dot(&normal)).normalize()
        });
        let dir = (normal * 0.35 + tangent).normalize();
        let frame = frame_along(&dir);
        let mut points = style_points(root, &frame, &style, p.points as usize, p.length)?;
        if p.style == StyleSpec::Draped {
            drape(&mut points, DRAPE_CLEARANCE + 2.0 * p.strand_radius);
        }
        strands.push(Strand {
            root,
            frame,
            points,
        });
    }
    Ok(Hairstyle { strands })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::BodySpec;

    /// Draped hair keeps the styled segment lengths, and every point past the root lies outside
    /// the head body by at least a strand radius (straight hair from the same roots goes in).
    #[test]
    fn draped_hair_lies_outside_the_head_with_its_lengths() {
        let body = crate::body::from_spec(&BodySpec::Head { resolution: 64 }, Path::new("."))
            .unwrap()
            .unwrap();
        let spec = |style| ProceduralHair {
            strands: 400,
            length: 0.3,
            points: 12,
            style,
            scalp_min_height: -0.02,
            ..ProceduralHair::default()
        };
        let draped = procedural(&spec(StyleSpec::Draped), 5).unwrap();
        let straight = procedural(&spec(StyleSpec::Straight), 5).unwrap();
        let radius = ProceduralHair::default().strand_radius;
        let mut straight_inside = 0;
        for (d, s) in draped.strands.iter().zip(&straight.strands) {
            assert_eq!(d.root, s.root);
            for (wd, ws) in d.points.windows(2).zip(s.points.windows(2)) {
                let (ld, ls) = ((wd[1] - wd[0]).norm(), (ws[1] - ws[0]).norm());
                assert!((ld - ls).abs() < 1e-5 * ls, "segment {ld} instead of {ls}");
            }
            for p in &d.points[1..] {
                let (dist, _, _) = body.signed_distance(p).unwrap();
                assert!(
                    dist > radius,
                    "draped point {p:?} at {dist} m from the body"
                );
            }
            straight_inside += s.points[1..]
                .iter()
                .filter(|p| body.signed_distance(p).is_some_and(|(d, _, _)| d < 0.0))
                .count();
        }
        assert!(
            straight_inside > 0,
            "the straight hair never enters the body"
        );
    }
}
