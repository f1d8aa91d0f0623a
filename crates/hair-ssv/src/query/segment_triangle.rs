//! Closest points between a segment and a triangle: a piercing point, or a segment end against
//! the triangle, or a segment against a triangle edge (the same argument as for rectangles).

use super::point_triangle::{inside_edges, p64};
use super::{Closest, point_triangle, segment_segment};
use crate::{Point, Real};

/// Closest points between the segment `p0`-`p1` and the triangle `tri`.
#[inline]
pub fn segment_triangle(p0: &Point, p1: &Point, tri: &[Point; 3]) -> Closest {
    if let Some(x) = pierce_triangle(p0, p1, tri) {
        return Closest {
            on_a: x,
            on_b: x,
            dist_sq: 0.0,
        };
    }
    point_triangle(p0, tri)
        .min(point_triangle(p1, tri))
        .min(segment_segment(p0, p1, &tri[0], &tri[1]))
        .min(segment_segment(p0, p1, &tri[1], &tri[2]))
        .min(segment_segment(p0, p1, &tri[2], &tri[0]))
}

/// The point where the segment crosses the triangle's plane, if it lies inside the triangle.
///
/// In `f64`, as [`point_triangle`]'s plane tests are: a sliver's `f32` normal cancels, and a
/// segment far from it could then be found to pierce it.
#[inline(always)]
pub(crate) fn pierce_triangle(p0: &Point, p1: &Point, tri: &[Point; 3]) -> Option<Point> {
    let t = tri.map(|v| p64(&v));
    let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
    let (p0, p1) = (p64(p0), p64(p1));
    let da = (p0 - t[0]).dot(&n);
    let db = (p1 - t[0]).dot(&n);
    if da * db > 0.0 || da == db {
        return None;
    }
    let x = p0 + (p1 - p0) * (da / (da - db));
    let x32 = Point::new(x.x as Real, x.y as Real, x.z as Real);
    (inside_edges(&x, &t, &n) && x32.coords.iter().all(|v| v.is_finite())).then_some(x32)
}
