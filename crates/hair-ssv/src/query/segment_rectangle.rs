//! Closest points between a segment and a rectangle.
//!
//! Either the segment pierces the rectangle (distance zero), or the closest pair involves a
//! segment end or a rectangle edge: when both closest points are interior, the segment is
//! parallel to the plane and can slide to one of those without changing the distance.

use super::separation::{
    RectFeature, certified, rect_feature, rect_params, rect_point, rect_support_min,
};
use super::{Closest, clamp_to, point_rectangle, point_segment, segment_segment};
use crate::{Point, Real, Rss};

/// Closest points between the segment `p0`-`p1` and the core rectangle of `rect`.
///
/// Like [`rectangle_rectangle`](super::rectangle_rectangle), a fast path guesses the closest
/// features by alternating projections, solves them exactly and keeps the answer only when the
/// separation certificate proves it.
#[inline]
pub fn segment_rectangle(p0: &Point, p1: &Point, rect: &Rss) -> Closest {
    if let Some(c) = segment_rectangle_fast(p0, p1, rect) {
        return c;
    }
    segment_rectangle_full(p0, p1, rect)
}

/// Alternating projections between the segment and the rectangle, starting from the segment's
/// midpoint: `(u, x, s, t, y)` with `x = p0 + u (p1 - p0)` and `y` the rectangle's point `(s, t)`.
#[inline(always)]
fn alternate(
    p0: &Point,
    p1: &Point,
    rect: &Rss,
    iterations: usize,
) -> (Real, Point, Real, Real, Point) {
    let d = p1 - p0;
    let dd = d.norm_squared();
    let inv = if dd > 0.0 { 1.0 / dd } else { 0.0 };
    let mut u = 0.5;
    let mut x = p0 + d * u;
    let (mut s, mut t) = rect_params(rect, &x);
    let mut y = rect_point(rect, s, t);
    for _ in 0..iterations {
        u = clamp_to((y - p0).dot(&d) * inv, 1.0);
        x = p0 + d * u;
        (s, t) = rect_params(rect, &x);
        y = rect_point(rect, s, t);
    }
    (u, x, s, t, y)
}

#[inline(always)]
fn segment_rectangle_fast(p0: &Point, p1: &Point, rect: &Rss) -> Option<Closest> {
    let (u, x, s, t, y) = alternate(p0, p1, rect, 2);
    let end = u <= 0.0 || u >= 1.0;
    let cand = match (end, rect_feature(rect, s, t)) {
        (true, _) => point_rectangle(&x, rect),
        (false, RectFeature::Vertex(q)) => point_segment(&q, p0, p1).swapped(),
        (false, RectFeature::Edge(q0, q1)) => segment_segment(p0, p1, &q0, &q1),
        (false, RectFeature::Face) => Closest::from_points(x, y),
    };
    let d = cand.on_b - cand.on_a;
    let max_a = (p0 - cand.on_a).dot(&d).max((p1 - cand.on_a).dot(&d));
    let size = (p1 - p0).norm() + rect.extents[0] + rect.extents[1];
    certified(&cand, max_a, rect_support_min(rect, &cand.on_a, &d), size).then_some(cand)
}

/// A lower bound of the distance between the segment and the rectangle (cheap: one round of
/// projections and the gap of the supports along the resulting direction).
#[inline]
pub(crate) fn segment_rectangle_lower_bound(p0: &Point, p1: &Point, rect: &Rss) -> Real {
    let (_, x, _, _, y) = alternate(p0, p1, rect, 1);
    let d = y - x;
    let len = d.norm();
    if len <= 0.0 {
        return 0.0;
    }
    let max_a = (p0 - x).dot(&d).max((p1 - x).dot(&d));
    ((rect_support_min(rect, &x, &d) - max_a) / len).max(0.0)
}

/// The exact enumeration: piercing point, segment ends against the rectangle, edges.
#[inline(never)]
fn segment_rectangle_full(p0: &Point, p1: &Point, rect: &Rss) -> Closest {
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
