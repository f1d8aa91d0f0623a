//! Closest points between a segment and a triangle: a piercing point, or a segment end against
//! the triangle, or a segment against a triangle edge (the same argument as for rectangles).

use super::{Closest, point_triangle, segment_segment};
use crate::Point;

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
#[inline(always)]
pub(crate) fn pierce_triangle(p0: &Point, p1: &Point, tri: &[Point; 3]) -> Option<Point> {
    let [a, b, c] = tri;
    let n = (b - a).cross(&(c - a));
    let da = (p0 - a).dot(&n);
    let db = (p1 - a).dot(&n);
    if da * db > 0.0 || da == db {
        return None;
    }
    let x = p0 + (p1 - p0) * (da / (da - db));
    let inside = (b - a).cross(&(x - a)).dot(&n) >= 0.0
        && (c - b).cross(&(x - b)).dot(&n) >= 0.0
        && (a - c).cross(&(x - c)).dot(&n) >= 0.0;
    inside.then_some(x)
}
