//! Shared proptest strategies (with the degenerate cases on purpose) and parry3d-f64 oracles.
#![allow(dead_code, reason = "each test binary uses a different subset")]

use hair_ssv::{Lss, Point, Pss, Real, Rss, Ssv, Vector};
use parry3d_f64::math::{Mat3, Pose, Rot3, Vec3};
use parry3d_f64::shape::{Ball, Capsule, Cuboid, RoundShape, Segment, Shape, Triangle};
use proptest::prelude::*;

/// Converts to parry's f64 vector.
pub fn v64(p: &Point) -> Vec3 {
    Vec3::new(p.x as f64, p.y as f64, p.z as f64)
}

/// Converts a vector to parry's f64 vector.
pub fn d64(v: &Vector) -> Vec3 {
    Vec3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// Scene scales: tiny, unit, huge.
pub fn scale() -> impl Strategy<Value = Real> {
    prop_oneof![Just(1e-3 as Real), Just(1.0), Just(1e3), 0.05f32..20.0]
}

/// A unit-cube coordinate, sometimes exactly 0 or +-1 so features line up.
fn coord() -> impl Strategy<Value = Real> {
    prop_oneof![6 => -1.0f32..1.0, 1 => Just(0.0), 1 => Just(1.0), 1 => Just(-1.0)]
}

/// A point in the unit cube.
pub fn unit_point() -> impl Strategy<Value = Point> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Point::new(x, y, z))
}

/// A unit vector (falls back to +x for the null draw).
pub fn unit_vector() -> impl Strategy<Value = Vector> {
    prop_oneof![
        4 => (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)
            .prop_map(|(x, y, z)| Vector::new(x, y, z).try_normalize(1e-3).unwrap_or(Vector::x())),
        1 => prop_oneof![Just(Vector::x()), Just(Vector::y()), Just(Vector::z()), Just(-Vector::z())],
    ]
}

/// A radius, often zero.
pub fn radius() -> impl Strategy<Value = Real> {
    prop_oneof![3 => 0.0f32..0.3, 1 => Just(0.0)]
}

/// Orthonormal axes from two unit vectors (Gram-Schmidt with a fallback when they are parallel).
pub fn axes() -> impl Strategy<Value = [Vector; 2]> {
    (unit_vector(), unit_vector()).prop_map(|(u, w)| {
        let v = w - u * u.dot(&w);
        let v = v.try_normalize(1e-3).unwrap_or_else(|| {
            let c = if u.x.abs() < 0.9 {
                Vector::x()
            } else {
                Vector::y()
            };
            u.cross(&c).normalize()
        });
        // Re-orthogonalise to f32 precision.
        let v = (v - u * u.dot(&v)).normalize();
        [u, v]
    })
}

/// An extent, sometimes zero (zero-area rectangles).
pub fn extent() -> impl Strategy<Value = Real> {
    prop_oneof![4 => 0.0f32..1.5, 1 => Just(0.0)]
}

/// A PSS in the unit scene.
pub fn pss() -> impl Strategy<Value = Pss> {
    (unit_point(), radius()).prop_map(|(c, r)| Pss::new(c, r))
}

/// An LSS in the unit scene, sometimes of zero length.
pub fn lss() -> impl Strategy<Value = Lss> {
    prop_oneof![
        4 => (unit_point(), unit_point(), radius()).prop_map(|(a, b, r)| Lss::new(a, b, r)),
        1 => (unit_point(), radius()).prop_map(|(a, r)| Lss::new(a, a, r)),
    ]
}

/// Two LSS with the degenerate relations: parallel, collinear, coincident, crossing, touching
/// ends, zero-length.
pub fn lss_pair() -> impl Strategy<Value = (Lss, Lss)> {
    prop_oneof![
        4 => (lss(), lss()),
        2 => (lss(), unit_point(), -2.0f32..2.0, radius()).prop_map(|(a, off, k, r)| {
            // parallel (or anti-parallel) copy, shifted
            let d = a.b - a.a;
            let o = off.coords * 0.5;
            (a, Lss::new(a.a + o, a.a + o + d * k, r))
        }),
        1 => (lss(), -1.0f32..2.0, -1.0f32..2.0, radius()).prop_map(|(a, s, t, r)| {
            // collinear
            let d = a.b - a.a;
            (a, Lss::new(a.a + d * s, a.a + d * t, r))
        }),
        1 => lss().prop_map(|a| (a, Lss::new(a.b, a.a, a.radius * 0.5))),
        1 => (lss(), unit_point(), 0.0f32..1.0, radius()).prop_map(|(a, p, s, r)| {
            // crossing through a point of `a`
            let x = a.a + (a.b - a.a) * s;
            (a, Lss::new(p, x + (x - p), r))
        }),
        1 => (lss(), unit_point(), radius()).prop_map(|(a, p, r)| (a, Lss::new(a.b, p, r))),
        1 => (unit_point(), radius(), radius()).prop_map(|(p, r1, r2)| (Lss::new(p, p, r1), Lss::new(p, p, r2))),
    ]
}

/// An RSS in the unit scene, sometimes with zero extents.
pub fn rss() -> impl Strategy<Value = Rss> {
    (unit_point(), axes(), extent(), extent(), radius())
        .prop_map(|(o, ax, e0, e1, r)| Rss::new(o, ax, [e0, e1], r))
}

/// Two RSS including parallel planes, coplanar overlapping, identical and crossing ones.
pub fn rss_pair() -> impl Strategy<Value = (Rss, Rss)> {
    prop_oneof![
        4 => (rss(), rss()),
        2 => (rss(), -0.5f32..0.5, -0.5f32..0.5, prop_oneof![Just(0.0f32), -0.5f32..0.5], extent(), extent(), radius())
            .prop_map(|(a, s, t, h, e0, e1, r)| {
                // parallel or coplanar copy
                let o = a.origin + a.axes[0] * s + a.axes[1] * t + a.normal() * h;
                (a, Rss::new(o, a.axes, [e0, e1], r))
            }),
        1 => rss().prop_map(|a| (a, a)),
        1 => (rss(), axes(), extent(), extent(), radius()).prop_map(|(a, ax, e0, e1, r)| {
            // centred on a's centre, any orientation: crossing
            let o = a.center() - ax[0] * (0.5 * e0) - ax[1] * (0.5 * e1);
            (a, Rss::new(o, ax, [e0, e1], r))
        }),
    ]
}

/// Any SSV in the unit scene.
pub fn ssv() -> impl Strategy<Value = Ssv> {
    prop_oneof![
        pss().prop_map(Ssv::Point),
        lss().prop_map(Ssv::Line),
        rss().prop_map(Ssv::Rect)
    ]
}

/// A triangle in the unit scene, sometimes degenerate (repeated or collinear vertices).
pub fn triangle() -> impl Strategy<Value = [Point; 3]> {
    prop_oneof![
        5 => (unit_point(), unit_point(), unit_point()).prop_map(|(a, b, c)| [a, b, c]),
        1 => (unit_point(), unit_point(), 0.0f32..1.0).prop_map(|(a, b, s)| [a, b, a + (b - a) * s]),
        1 => (unit_point(), unit_point()).prop_map(|(a, b)| [a, b, b]),
    ]
}

/// Scales a whole scene.
pub fn scale_ssv(s: &Ssv, k: Real) -> Ssv {
    match s {
        Ssv::Point(p) => Ssv::Point(Pss::new(p.center * k, p.radius * k)),
        Ssv::Line(l) => Ssv::Line(Lss::new(l.a * k, l.b * k, l.radius * k)),
        Ssv::Rect(r) => Ssv::Rect(Rss::new(
            r.origin * k,
            r.axes,
            [r.extents[0] * k, r.extents[1] * k],
            r.radius * k,
        )),
    }
}

/// Scales a triangle.
pub fn scale_tri(t: &[Point; 3], k: Real) -> [Point; 3] {
    [t[0] * k, t[1] * k, t[2] * k]
}

/// The shape parry uses as the oracle for an SSV, with its pose.
pub fn parry_shape(s: &Ssv) -> (Pose, Box<dyn Shape>) {
    match s {
        Ssv::Point(p) => (
            Pose::from_translation(v64(&p.center)),
            Box::new(Ball::new(p.radius as f64)),
        ),
        Ssv::Line(l) => (
            Pose::IDENTITY,
            Box::new(Capsule::new(v64(&l.a), v64(&l.b), l.radius as f64)),
        ),
        Ssv::Rect(r) => match rect_as_segment(r) {
            // parry's GJK misreads cuboids flat in two directions: use the equivalent capsule
            Some((a, b)) => (
                Pose::IDENTITY,
                Box::new(Capsule::new(a, b, r.radius as f64)),
            ),
            None => {
                let (pose, cuboid) = parry_rect_core(r);
                (
                    pose,
                    Box::new(RoundShape {
                        inner_shape: cuboid,
                        border_radius: r.radius as f64,
                    }),
                )
            }
        },
    }
}

/// The core (radius zero) of an SSV as a parry shape, for core-distance comparisons.
pub fn parry_core(s: &Ssv) -> (Pose, Box<dyn Shape>) {
    match s {
        Ssv::Point(p) => (
            Pose::from_translation(v64(&p.center)),
            Box::new(Ball::new(0.0)),
        ),
        Ssv::Line(l) => (Pose::IDENTITY, Box::new(Segment::new(v64(&l.a), v64(&l.b)))),
        Ssv::Rect(r) => match rect_as_segment(r) {
            Some((a, b)) => (Pose::IDENTITY, Box::new(Segment::new(a, b))),
            None => {
                let (pose, cuboid) = parry_rect_core(r);
                (pose, Box::new(cuboid))
            }
        },
    }
}

/// A rectangle with a zero extent as its segment (possibly of zero length), in f64.
pub fn rect_as_segment(r: &Rss) -> Option<(Vec3, Vec3)> {
    let o = v64(&r.origin);
    if r.extents[0] == 0.0 {
        Some((o, o + d64(&r.axes[1]) * r.extents[1] as f64))
    } else if r.extents[1] == 0.0 {
        Some((o, o + d64(&r.axes[0]) * r.extents[0] as f64))
    } else {
        None
    }
}

/// A flat cuboid (third half-extent zero) and its pose for an RSS core.
pub fn parry_rect_core(r: &Rss) -> (Pose, Cuboid) {
    let u = d64(&r.axes[0]).normalize();
    let v = (d64(&r.axes[1]) - u * u.dot(d64(&r.axes[1]))).normalize();
    let n = u.cross(v);
    let rot = Rot3::from_mat3(&Mat3::from_cols(u, v, n));
    let half = Vec3::new(r.extents[0] as f64 * 0.5, r.extents[1] as f64 * 0.5, 0.0);
    let c = v64(&r.origin) + u * half.x + v * half.y;
    (Pose::from_parts(c, rot), Cuboid::new(half))
}

/// A parry triangle.
pub fn parry_triangle(t: &[Point; 3]) -> Triangle {
    Triangle::new(v64(&t[0]), v64(&t[1]), v64(&t[2]))
}

/// The f64 core distance between two SSVs according to parry.
pub fn oracle_core_distance(a: &Ssv, b: &Ssv) -> f64 {
    if let (Ssv::Rect(ra), Ssv::Rect(rb)) = (a, b)
        && rect_as_segment(ra).is_none()
        && rect_as_segment(rb).is_none()
    {
        // GJK between two flat cuboids stalls a few percent short (both supports are whole
        // faces). Two disjoint convex polygons are closest at an edge of one, and crossing ones
        // have an edge of one through the other: every edge against the other rectangle.
        let edges = |r: &Rss| {
            let c = r.corners();
            [0, 1, 2, 3].map(|i| Segment::new(v64(&c[i]), v64(&c[(i + 1) % 4])))
        };
        let (pa, ca) = parry_rect_core(ra);
        let (pb, cb) = parry_rect_core(rb);
        let mut best = f64::INFINITY;
        for (edges, (pose, cuboid)) in [(edges(ra), (&pb, &cb)), (edges(rb), (&pa, &ca))] {
            for e in &edges {
                let d = parry3d_f64::query::distance(&Pose::IDENTITY, e, pose, cuboid)
                    .expect("supported")
                    .distance;
                best = best.min(d);
            }
        }
        return best;
    }
    let (pa, sa) = parry_core(a);
    let (pb, sb) = parry_core(b);
    parry3d_f64::query::distance(&pa, sa.as_ref(), &pb, sb.as_ref())
        .expect("supported")
        .distance
}

/// The f64 distance (clamped at zero) between two SSVs according to parry.
pub fn oracle_distance(a: &Ssv, b: &Ssv) -> f64 {
    let (pa, sa) = parry_shape(a);
    let (pb, sb) = parry_shape(b);
    parry3d_f64::query::distance(&pa, sa.as_ref(), &pb, sb.as_ref())
        .expect("supported")
        .distance
}

/// The f64 distance between an SSV core and a triangle according to parry.
pub fn oracle_core_triangle_distance(a: &Ssv, t: &[Point; 3]) -> f64 {
    let (pa, sa) = parry_core(a);
    let tri = parry_triangle(t);
    parry3d_f64::query::distance(&pa, sa.as_ref(), &Pose::IDENTITY, &tri)
        .expect("supported")
        .distance
}

/// Applies a rigid motion (rotation about `axis` by `angle`, then translation) to a point.
pub fn rigid(p: &Point, rot: &nalgebra::UnitQuaternion<Real>, tr: &Vector) -> Point {
    rot * p + tr
}

/// Applies a rigid motion to an SSV.
pub fn rigid_ssv(s: &Ssv, rot: &nalgebra::UnitQuaternion<Real>, tr: &Vector) -> Ssv {
    match s {
        Ssv::Point(p) => Ssv::Point(Pss::new(rigid(&p.center, rot, tr), p.radius)),
        Ssv::Line(l) => Ssv::Line(Lss::new(
            rigid(&l.a, rot, tr),
            rigid(&l.b, rot, tr),
            l.radius,
        )),
        Ssv::Rect(r) => Ssv::Rect(Rss::new(
            rigid(&r.origin, rot, tr),
            [rot * r.axes[0], rot * r.axes[1]],
            r.extents,
            r.radius,
        )),
    }
}

/// A random rotation.
pub fn rotation() -> impl Strategy<Value = nalgebra::UnitQuaternion<Real>> {
    (unit_vector(), -3.2f32..3.2).prop_map(|(axis, angle)| {
        nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle)
    })
}

/// The largest absolute coordinate of a shape (with its radius), for tolerances.
pub fn extent_of(s: &Ssv) -> Real {
    let (lo, hi) = s.aabb();
    lo.coords.abs().max().max(hi.coords.abs().max())
}
