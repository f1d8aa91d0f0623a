//! Procedural meshes for tests, benches and reports (not part of the stable API).
//!
//! [`head_and_shoulders`] merges a bumpy ellipsoid head, an open neck tube whose ends sit on
//! the head's and the shoulders' surfaces, and a shoulder ellipsoid; metres, `+y` up, face `+z`.

use std::f32::consts::{PI, TAU};

use crate::{
    Body, BodyPart, Bvh, CylinderMap, CylinderMapConfig, MapFrame, PartMap, Point, Real, SphereMap,
    SphereMapConfig, SsvError, Vector,
};

/// Head centre and semi-axes (x, y, z).
pub const HEAD: ([Real; 3], [Real; 3]) = ([0.0, 0.0, 0.0], [0.078, 0.115, 0.097]);
/// Shoulder centre and semi-axes.
pub const SHOULDERS: ([Real; 3], [Real; 3]) = ([0.0, -0.25, 0.0], [0.21, 0.085, 0.12]);
/// Neck radius.
pub const NECK_RADIUS: Real = 0.055;

fn head_bump(theta: Real, phi: Real) -> Real {
    1.0 + 0.02 * (6.0 * theta).sin() * (5.0 * phi).sin()
        + 0.008 * (13.0 * theta + 1.0).sin() * (11.0 * phi).sin()
}

/// Appends a triangle, wound so its normal points away from `inside`, unless it lies inside
/// the neck (the head's and the shoulders' caps there are interior after the merge).
fn push_tri(tris: &mut Vec<[u32; 3]>, v: &[Point], t: [u32; 3], inside: &Point) {
    if in_neck(v, t) {
        return;
    }
    let [a, b, c] = t.map(|i| v[i as usize]);
    let n = (b - a).cross(&(c - a));
    let centroid = Point::from((a.coords + b.coords + c.coords) / 3.0);
    if n.dot(&(centroid - inside)) >= 0.0 {
        tris.push(t);
    } else {
        tris.push([t[0], t[2], t[1]]);
    }
}

/// Whether `p` is inside the neck tube between the shoulders and the head, where the merge
/// leaves fragments of the caps: samplers of "points near the surface" skip it.
pub fn inside_neck(p: &Point) -> bool {
    p.x * p.x + p.z * p.z < NECK_RADIUS * NECK_RADIUS && p.y < HEAD.0[1] && p.y > SHOULDERS.0[1]
}

/// Whether a triangle lies inside the neck tube (interior geometry the merge removes).
fn in_neck(v: &[Point], t: [u32; 3]) -> bool {
    t.iter().all(|&i| inside_neck(&v[i as usize]))
}

#[allow(clippy::too_many_arguments, reason = "a private generator")]
fn ellipsoid(
    center: [Real; 3],
    radii: [Real; 3],
    n_theta: usize,
    n_phi: usize,
    bump: impl Fn(Real, Real) -> Real,
    v: &mut Vec<Point>,
    tris: &mut Vec<[u32; 3]>,
) {
    let c = Point::from(center);
    let at = |theta: Real, phi: Real| {
        let k = bump(theta, phi);
        c + Vector::new(
            radii[0] * phi.sin() * theta.cos() * k,
            radii[1] * phi.cos() * k,
            radii[2] * phi.sin() * theta.sin() * k,
        )
    };
    let top = v.len() as u32;
    v.push(at(0.0, 0.0));
    let ring0 = v.len() as u32;
    for k in 1..n_phi {
        let phi = PI * k as Real / n_phi as Real;
        for i in 0..n_theta {
            v.push(at(TAU * i as Real / n_theta as Real, phi));
        }
    }
    let bottom = v.len() as u32;
    v.push(at(0.0, PI));
    let nt = n_theta as u32;
    let idx = |k: u32, i: u32| ring0 + k * nt + (i % nt);
    for i in 0..nt {
        push_tri(tris, v, [top, idx(0, i), idx(0, i + 1)], &c);
        push_tri(
            tris,
            v,
            [
                bottom,
                idx(n_phi as u32 - 2, i + 1),
                idx(n_phi as u32 - 2, i),
            ],
            &c,
        );
    }
    for k in 0..n_phi as u32 - 2 {
        for i in 0..nt {
            push_tri(tris, v, [idx(k, i), idx(k + 1, i), idx(k + 1, i + 1)], &c);
            push_tri(tris, v, [idx(k, i), idx(k + 1, i + 1), idx(k, i + 1)], &c);
        }
    }
}

/// Height of the lower half of an ellipsoid (`sign = -1`) or upper half (`+1`) above `(x, z)`.
fn ellipsoid_y(e: ([Real; 3], [Real; 3]), x: Real, z: Real, sign: Real) -> Real {
    let (c, r) = e;
    let q = 1.0 - ((x - c[0]) / r[0]).powi(2) - ((z - c[2]) / r[2]).powi(2);
    c[1] + sign * r[1] * q.max(0.0).sqrt()
}

/// Height of the bumpy head's lower surface above `(x, z)` (inside its outline), by bisection
/// on the radial test `|p / radii| < head_bump(theta, phi)` used to build it.
fn bumpy_head_bottom(x: Real, z: Real) -> Real {
    let (c, r) = HEAD;
    let inside = |y: Real| {
        let u = Vector::new((x - c[0]) / r[0], (y - c[1]) / r[1], (z - c[2]) / r[2]);
        let rho = u.norm();
        let phi = (u.y / rho).clamp(-1.0, 1.0).acos();
        let theta = u.z.atan2(u.x).rem_euclid(TAU);
        rho < head_bump(theta, phi)
    };
    // The centre is inside; a point two semi-axes below it is outside.
    let (mut lo, mut hi) = (c[1] - 2.0 * r[1], c[1]);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if inside(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// The head-and-shoulders mesh: vertices and counter-clockwise (outward) triangles.
/// `resolution` 96 gives about 50,000 triangles; 24 about 3,000.
pub fn head_and_shoulders(resolution: usize) -> (Vec<Point>, Vec<[u32; 3]>) {
    let res = resolution.max(8);
    let mut v = Vec::new();
    let mut tris = Vec::new();
    ellipsoid(HEAD.0, HEAD.1, 2 * res, res, head_bump, &mut v, &mut tris);
    ellipsoid(
        SHOULDERS.0,
        SHOULDERS.1,
        4 * res / 3,
        res / 2,
        |_, _| 1.0,
        &mut v,
        &mut tris,
    );
    // The neck tube ends on the head's and the shoulders' surfaces. Ends pushed inside them
    // would be interior walls: the closest triangle to a point deep in the shoulders is then
    // often the tube's outward-facing stub, and the signed distance calls the point outside.
    let around = (2 * res / 3).max(8);
    let rings = 12;
    let base = v.len() as u32;
    for k in 0..rings {
        let f = k as Real / (rings - 1) as Real;
        for i in 0..around {
            let theta = TAU * i as Real / around as Real;
            let (x, z) = (NECK_RADIUS * theta.cos(), NECK_RADIUS * theta.sin());
            let y_low = ellipsoid_y(SHOULDERS, x, z, 1.0);
            let y_high = bumpy_head_bottom(x, z);
            v.push(Point::new(x, y_low + (y_high - y_low) * f, z));
        }
    }
    let a = around as u32;
    for k in 0..rings as u32 - 1 {
        for i in 0..a {
            let p = |kk: u32, ii: u32| base + kk * a + (ii % a);
            let mid = Point::new(0.0, v[p(k, i) as usize].y, 0.0);
            push_tri(&mut tris, &v, [p(k, i), p(k + 1, i), p(k + 1, i + 1)], &mid);
            push_tri(&mut tris, &v, [p(k, i), p(k + 1, i + 1), p(k, i + 1)], &mid);
        }
    }
    (v, tris)
}

/// The collision tables of the head-and-shoulders body: a head cylinder, a crown sphere cap, a
/// neck cylinder and a shoulder cylinder along `x`, each `samples` x `samples` (Kurihara used 40).
pub fn head_and_shoulders_body(bvh: &Bvh, samples: usize) -> Result<Body, SsvError> {
    let y = Vector::y();
    let x = Vector::x();
    let head = CylinderMap::build(
        bvh,
        MapFrame::try_new(Point::origin(), y, x)?,
        &CylinderMapConfig {
            azimuth_samples: samples,
            height_samples: samples,
            heights: (-0.1, 0.07),
            max_radius: 0.2,
        },
    )?;
    let crown = SphereMap::build(
        bvh,
        MapFrame::try_new(Point::origin(), y, x)?,
        &SphereMapConfig {
            azimuth_samples: samples,
            polar_samples: samples / 2,
            max_polar: 0.9,
            max_radius: 0.2,
        },
    )?;
    let neck = CylinderMap::build(
        bvh,
        MapFrame::try_new(Point::new(0.0, -0.12, 0.0), y, x)?,
        &CylinderMapConfig {
            azimuth_samples: samples,
            height_samples: samples / 2,
            heights: (-0.04, 0.04),
            max_radius: 0.09,
        },
    )?;
    let shoulders = CylinderMap::build(
        bvh,
        MapFrame::try_new(Point::from(SHOULDERS.0), x, y)?,
        &CylinderMapConfig {
            azimuth_samples: samples,
            height_samples: samples,
            heights: (-0.2, 0.2),
            max_radius: 0.15,
        },
    )?;
    Ok(Body {
        parts: vec![
            BodyPart {
                name: "head".into(),
                map: PartMap::Cylinder(head),
            },
            BodyPart {
                name: "crown".into(),
                map: PartMap::Sphere(crown),
            },
            BodyPart {
                name: "neck".into(),
                map: PartMap::Cylinder(neck),
            },
            BodyPart {
                name: "shoulders".into(),
                map: PartMap::Cylinder(shoulders),
            },
        ],
    })
}

/// A small deterministic generator (SplitMix64) so tests and benches need no extra crates.
#[derive(Clone, Debug)]
pub struct SplitMix(pub u64);

impl SplitMix {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: Real, hi: Real) -> Real {
        let u = (self.next_u64() >> 40) as Real / (1u64 << 24) as Real;
        lo + (hi - lo) * u
    }

    /// Uniform point in the box `[-h, h]^3` around `c`.
    pub fn point_near(&mut self, c: &Point, h: Real) -> Point {
        c + Vector::new(self.range(-h, h), self.range(-h, h), self.range(-h, h))
    }

    /// A point on a random triangle of the mesh moved by `offset` along its face normal, with
    /// the triangle's index.
    pub fn surface_point(&mut self, tris: &[[Point; 3]], offset: Real) -> (Point, usize) {
        let k = (self.next_u64() % tris.len() as u64) as usize;
        let t = &tris[k];
        let (mut u, mut w) = (self.range(0.0, 1.0), self.range(0.0, 1.0));
        if u + w > 1.0 {
            (u, w) = (1.0 - u, 1.0 - w);
        }
        let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * w;
        let n = (t[1] - t[0])
            .cross(&(t[2] - t[0]))
            .try_normalize(0.0)
            .unwrap_or_else(Vector::y);
        (p + n * offset, k)
    }
}
