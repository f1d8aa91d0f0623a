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
            let strands = hair_io::read_strands(&base_dir.join(path))?;
            let off = Vector::from(*offset);
            let mut out = Vec::with_capacity(strands.strand_count());
            for s in strands.iter() {
                let pts: Vec<Point> = s
                    .iter()
                    .map(|p| Point::from(Vector::from(*p) * *scale + off))
                    .collect();
                let pts = resample(&pts, *points as usize);
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
        StyleSpec::Straight => Style::Straight,
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
        let points = style_points(root, &frame, &style, p.points as usize, p.length)?;
        strands.push(Strand {
            root,
            frame,
            points,
        });
    }
    Ok(Hairstyle { strands })
}
