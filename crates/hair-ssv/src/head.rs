//! The procedural head and shoulders: a body for scenes without a mesh of their own, and for
//! tests and benches.
//!
//! [`head_and_shoulders`] joins a bumpy ellipsoid head and a shoulder ellipsoid by a neck tube
//! into one closed surface; [`head_and_shoulders_body`] builds its collision tables. Metres,
//! `+y` up, the face toward `+z`:
//!
//! | part | centre | size |
//! |---|---|---|
//! | head ([`HEAD`]) | origin | semi-axes 78 x 115 x 97 mm (x, y, z), bumps of up to 2.8% of them |
//! | neck ([`NECK_RADIUS`]) | the `y` axis, between the two | radius 55 mm |
//! | shoulders ([`SHOULDERS`]) | 0.25 m below the head's centre | semi-axes 210 x 85 x 120 mm |

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

/// Appends a triangle, wound so its normal points away from `inside`.
fn push_tri(tris: &mut Vec<[u32; 3]>, v: &[Point], t: [u32; 3], inside: &Point) {
    let [a, b, c] = t.map(|i| v[i as usize]);
    let n = (b - a).cross(&(c - a));
    let centroid = Point::from((a.coords + b.coords + c.coords) / 3.0);
    if n.dot(&(centroid - inside)) >= 0.0 {
        tris.push(t);
    } else {
        tris.push([t[0], t[2], t[1]]);
    }
}

/// Appends the triangles between two rings of `nt` consecutive vertices each (from `lower` and
/// `upper`, the same azimuths), wound away from `inside` (given the height of the triangle's
/// first vertex).
fn push_band(
    tris: &mut Vec<[u32; 3]>,
    v: &[Point],
    lower: u32,
    upper: u32,
    nt: u32,
    inside: impl Fn(Real) -> Point,
) {
    let (a, b) = (|i: u32| lower + i % nt, |i: u32| upper + i % nt);
    for i in 0..nt {
        let inside = inside(v[a(i) as usize].y);
        push_tri(tris, v, [a(i), b(i), b(i + 1)], &inside);
        push_tri(tris, v, [a(i), b(i + 1), a(i + 1)], &inside);
    }
}

/// Whether `p` is inside the neck tube between the shoulders and the head (samplers of points
/// near the surface skip it).
pub fn inside_neck(p: &Point) -> bool {
    p.x * p.x + p.z * p.z < NECK_RADIUS * NECK_RADIUS && p.y < HEAD.0[1] && p.y > SHOULDERS.0[1]
}

/// A point of a bumpy ellipsoid at azimuth `theta` and polar angle `phi` (from `+y`).
fn ellipsoid_point(
    (c, r): ([Real; 3], [Real; 3]),
    bump: &impl Fn(Real, Real) -> Real,
    theta: Real,
    phi: Real,
) -> Point {
    let k = bump(theta, phi);
    Point::new(
        c[0] + r[0] * phi.sin() * theta.cos() * k,
        c[1] + r[1] * phi.cos() * k,
        c[2] + r[2] * phi.sin() * theta.sin() * k,
    )
}

/// The polar angle in `[lo, hi]` at which the ellipsoid at azimuth `theta` meets the neck
/// cylinder (`x^2 + z^2 = NECK_RADIUS^2`), by bisection: the distance from the axis grows from
/// `lo` to `hi` when `rising`, else falls.
fn neck_phi(
    e: ([Real; 3], [Real; 3]),
    bump: &impl Fn(Real, Real) -> Real,
    theta: Real,
    (mut lo, mut hi): (Real, Real),
    rising: bool,
) -> Real {
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        let p = ellipsoid_point(e, bump, theta, mid);
        let outside = p.x.hypot(p.z) > NECK_RADIUS;
        if outside == rising {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Appends the part of a bumpy ellipsoid outside the neck cylinder: `rows` rings from the pole
/// (`top`: the `+y` pole, else the `-y` one) to the ring where the surface meets the neck, each
/// of `n_theta` points at the azimuths `2 pi i / n_theta`. Returns the index of the first
/// vertex of the neck ring.
#[allow(clippy::too_many_arguments, reason = "a private generator")]
fn ellipsoid_to_neck(
    e: ([Real; 3], [Real; 3]),
    bump: impl Fn(Real, Real) -> Real,
    n_theta: usize,
    rows: usize,
    top: bool,
    v: &mut Vec<Point>,
    tris: &mut Vec<[u32; 3]>,
) -> u32 {
    let centre = Point::from(e.0);
    let theta = |i: usize| TAU * i as Real / n_theta as Real;
    // The pole, then rings toward the neck; the polar angle of ring `k` runs from the pole to
    // the neck ring at each azimuth. The neck is on the far side from the pole: the distance
    // from the axis falls toward the `-y` pole there and rises away from the `+y` one.
    let (pole_phi, range) = if top {
        (0.0, (0.5 * PI, PI))
    } else {
        (PI, (0.0, 0.5 * PI))
    };
    let neck: Vec<Real> = (0..n_theta)
        .map(|i| neck_phi(e, &bump, theta(i), range, !top))
        .collect();
    let pole = v.len() as u32;
    v.push(ellipsoid_point(e, &bump, 0.0, pole_phi));
    let ring0 = v.len() as u32;
    for k in 1..=rows {
        let f = k as Real / rows as Real;
        for (i, &to) in neck.iter().enumerate() {
            let phi = pole_phi + (to - pole_phi) * f;
            v.push(ellipsoid_point(e, &bump, theta(i), phi));
        }
    }
    let nt = n_theta as u32;
    let idx = |k: u32, i: u32| ring0 + k * nt + (i % nt);
    for i in 0..nt {
        push_tri(tris, v, [pole, idx(0, i), idx(0, i + 1)], &centre);
    }
    for k in 0..rows as u32 - 1 {
        push_band(tris, v, idx(k, 0), idx(k + 1, 0), nt, |_| centre);
    }
    idx(rows as u32 - 1, 0)
}

/// The head-and-shoulders mesh: vertices and counter-clockwise (outward) triangles.
/// `resolution` 96 gives about 53,000 triangles; 24 about 4,000.
///
/// One closed surface: the head and the shoulders stop where they meet the neck cylinder, and
/// the neck tube joins their rings vertex to vertex, so no triangle lies inside the body and the
/// side of a point is that of its closest face everywhere. (Overlapping closed parts, or a tube
/// whose ends poke into them, leave interior walls that call deep points outside.)
pub fn head_and_shoulders(resolution: usize) -> (Vec<Point>, Vec<[u32; 3]>) {
    let res = resolution.max(8);
    let mut v = Vec::new();
    let mut tris = Vec::new();
    let n_theta = 2 * res;
    let head_ring = ellipsoid_to_neck(HEAD, head_bump, n_theta, res, true, &mut v, &mut tris);
    let shoulder_ring = ellipsoid_to_neck(
        SHOULDERS,
        |_, _| 1.0,
        n_theta,
        (res / 3).max(2),
        false,
        &mut v,
        &mut tris,
    );
    // The neck: rings from the shoulders' neck ring up to the head's, the ends shared.
    let rings = 12;
    let nt = n_theta as u32;
    let mut starts = vec![shoulder_ring];
    for k in 1..rings - 1 {
        starts.push(v.len() as u32);
        let f = k as Real / (rings - 1) as Real;
        for i in 0..nt {
            let (a, b) = (v[(shoulder_ring + i) as usize], v[(head_ring + i) as usize]);
            v.push(a + (b - a) * f);
        }
    }
    starts.push(head_ring);
    for k in 0..rings - 1 {
        let (lower, upper) = (starts[k], starts[k + 1]);
        // Wound away from the axis, at each triangle's height.
        push_band(&mut tris, &v, lower, upper, nt, |y| Point::new(0.0, y, 0.0));
    }
    (v, tris)
}

/// The head, neck and shoulders of [`head_and_shoulders`] as three closed meshes (vertices,
/// outward triangles), for bodies whose parts move apart: the whole bumpy head ellipsoid, the
/// neck cylinder capped inside the head and the shoulders (from the shoulders' centre to the
/// head's), and the whole shoulder ellipsoid. They overlap where the one mesh joins them, and
/// together they cover what it covers, up to the tessellation (the same azimuths).
pub fn head_neck_torso(resolution: usize) -> [(Vec<Point>, Vec<[u32; 3]>); 3] {
    let res = resolution.max(8);
    let n_theta = 2 * res;
    let head = closed_ellipsoid(HEAD, head_bump, n_theta, 2 * res);
    let torso = closed_ellipsoid(SHOULDERS, |_, _| 1.0, n_theta, (2 * res / 3).max(4));
    // The neck: a capped tube on the neck cylinder.
    let (rings, nt) = (12, n_theta as u32);
    let (y0, y1) = (SHOULDERS.0[1], HEAD.0[1]);
    let mut v = vec![Point::new(0.0, y0, 0.0)];
    for k in 0..rings {
        let y = y0 + (y1 - y0) * k as Real / (rings - 1) as Real;
        v.extend((0..nt).map(|i| {
            let theta = TAU * i as Real / n_theta as Real;
            Point::new(NECK_RADIUS * theta.cos(), y, NECK_RADIUS * theta.sin())
        }));
    }
    v.push(Point::new(0.0, y1, 0.0));
    let mut tris = Vec::new();
    let top = v.len() as u32 - 1;
    let ring = |k: u32, i: u32| 1 + k * nt + i % nt;
    let axis = |y: Real| Point::new(0.0, y, 0.0);
    for i in 0..nt {
        push_tri(
            &mut tris,
            &v,
            [0, ring(0, i + 1), ring(0, i)],
            &axis(y0 + 0.01),
        );
        let last = rings as u32 - 1;
        push_tri(
            &mut tris,
            &v,
            [top, ring(last, i), ring(last, i + 1)],
            &axis(y1 - 0.01),
        );
    }
    for k in 0..rings as u32 - 1 {
        push_band(&mut tris, &v, ring(k, 0), ring(k + 1, 0), nt, axis);
    }
    [head, (v, tris), torso]
}

/// A closed bumpy ellipsoid: two poles and `rows - 1` rings of `n_theta` points between them.
fn closed_ellipsoid(
    e: ([Real; 3], [Real; 3]),
    bump: impl Fn(Real, Real) -> Real,
    n_theta: usize,
    rows: usize,
) -> (Vec<Point>, Vec<[u32; 3]>) {
    let centre = Point::from(e.0);
    let mut v = vec![ellipsoid_point(e, &bump, 0.0, 0.0)];
    for k in 1..rows {
        let phi = PI * k as Real / rows as Real;
        v.extend((0..n_theta).map(|i| {
            let theta = TAU * i as Real / n_theta as Real;
            ellipsoid_point(e, &bump, theta, phi)
        }));
    }
    v.push(ellipsoid_point(e, &bump, 0.0, PI));
    let (nt, bottom) = (n_theta as u32, v.len() as u32 - 1);
    let ring = |k: u32, i: u32| 1 + k * nt + i % nt;
    let mut tris = Vec::new();
    let last = rows as u32 - 2;
    for i in 0..nt {
        push_tri(&mut tris, &v, [0, ring(0, i), ring(0, i + 1)], &centre);
        push_tri(
            &mut tris,
            &v,
            [bottom, ring(last, i + 1), ring(last, i)],
            &centre,
        );
    }
    for k in 0..last {
        push_band(&mut tris, &v, ring(k, 0), ring(k + 1, 0), nt, |_| centre);
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
