//! Support functions and separation certificates: for any direction `d`, the gap between the
//! supports of two convex features along `d` is a lower bound of their distance. The fast paths
//! of the polygon kernels guess the closest features, solve them exactly, and keep the answer
//! only when this bound proves it; the BVH prunes with the same bound.

use super::{Closest, clamp_to};
use crate::{Point, Real, Rss, Vector};

/// `max over the rectangle of (p - x) . d`.
#[inline(always)]
pub(crate) fn rect_support(r: &Rss, x: &Point, d: &Vector) -> Real {
    (r.origin - x).dot(d)
        + (r.extents[0] * r.axes[0].dot(d)).max(0.0)
        + (r.extents[1] * r.axes[1].dot(d)).max(0.0)
}

/// `min over the rectangle of (p - x) . d`.
#[inline(always)]
pub(crate) fn rect_support_min(r: &Rss, x: &Point, d: &Vector) -> Real {
    (r.origin - x).dot(d)
        + (r.extents[0] * r.axes[0].dot(d)).min(0.0)
        + (r.extents[1] * r.axes[1].dot(d)).min(0.0)
}

/// Local clamped coordinates of the projection of `p` onto the rectangle.
#[inline(always)]
pub(crate) fn rect_params(r: &Rss, p: &Point) -> (Real, Real) {
    let d = p - r.origin;
    (
        clamp_to(d.dot(&r.axes[0]), r.extents[0]),
        clamp_to(d.dot(&r.axes[1]), r.extents[1]),
    )
}

/// The rectangle's point at local coordinates `(s, t)`.
#[inline(always)]
pub(crate) fn rect_point(r: &Rss, s: Real, t: Real) -> Point {
    r.origin + r.axes[0] * s + r.axes[1] * t
}

/// A feature of a rectangle: a corner, an edge, or the face.
#[derive(Clone, Copy)]
pub(crate) enum RectFeature {
    Vertex(Point),
    Edge(Point, Point),
    Face,
}

/// The feature of the rectangle a projection with local coordinates `(s, t)` lies on.
#[inline(always)]
pub(crate) fn rect_feature(r: &Rss, s: Real, t: Real) -> RectFeature {
    let s_end = s <= 0.0 || s >= r.extents[0];
    let t_end = t <= 0.0 || t >= r.extents[1];
    match (s_end, t_end) {
        (true, true) => RectFeature::Vertex(rect_point(r, s, t)),
        (true, false) => {
            let a = rect_point(r, s, 0.0);
            RectFeature::Edge(a, a + r.axes[1] * r.extents[1])
        }
        (false, true) => {
            let a = rect_point(r, 0.0, t);
            RectFeature::Edge(a, a + r.axes[0] * r.extents[0])
        }
        (false, false) => RectFeature::Face,
    }
}

/// Whether `c` is provably the closest pair, given the two features' support functions about
/// `c.on_a` along `d = on_b - on_a`: `gap = min_b - max_a` must reach `|d|^2` up to rounding.
/// `size` is the scale of the features (for the rounding allowance).
#[inline(always)]
pub(crate) fn certified(c: &Closest, max_a: Real, min_b: Real, size: Real) -> bool {
    let dd = c.dist_sq;
    if dd <= 0.0 {
        return false;
    }
    let len = dd.sqrt();
    // gap / len is a lower bound of the distance; accept within a few ulps of the scale
    min_b - max_a >= dd - 1e-6 * len * (len + size)
}
