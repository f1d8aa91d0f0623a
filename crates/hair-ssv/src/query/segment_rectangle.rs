//! Closest points between a segment and a rectangle.
//!
//! Either the segment pierces the rectangle (distance zero), or the closest pair involves a
//! segment end or a rectangle edge: when both closest points are interior, the segment is
//! parallel to the plane and can slide to one of those without changing the distance.

use super::{Closest, point_rectangle, segment_segment};
use crate::{Point, Rss};

/// Closest points between the segment `p0`-`p1` and the core rectangle of `rect`.
#[inline]
pub fn segment_rectangle(p0: &Point, p1: &Point, rect: &Rss) -> Closest {
    if let Some(x) = pierce_rectangle(p0, p1, rect) {
        return Closest {
            on_a: x,
            on_b: x,
            dist_sq: 0.0,
        };
    }
    let c = rect.corners();
    let mut best = point_rectangle(p0, rect).min(point_rectangle(p1, rect));
    for i in 0..4 {
        best = best.min(segment_segment(p0, p1, &c[i], &c[(i + 1) & 3]));
    }
    best
}

/// The point where the segment crosses the rectangle's plane, if it lies inside the rectangle.
#[inline(always)]
pub(crate) fn pierce_rectangle(p0: &Point, p1: &Point, rect: &Rss) -> Option<Point> {
    let n = rect.normal();
    let da = (p0 - rect.origin).dot(&n);
    let db = (p1 - rect.origin).dot(&n);
    if da * db > 0.0 || da == db {
        return None;
    }
    let x = p0 + (p1 - p0) * (da / (da - db));
    let d = x - rect.origin;
    let s = d.dot(&rect.axes[0]);
    let t = d.dot(&rect.axes[1]);
    (s >= 0.0 && s <= rect.extents[0] && t >= 0.0 && t <= rect.extents[1]).then_some(x)
}
