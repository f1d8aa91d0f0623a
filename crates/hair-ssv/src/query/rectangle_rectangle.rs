//! Closest points between two rectangles.
//!
//! Two convex polygons are closest either at a vertex of one against the other, or at a pair of
//! edges; if they intersect, an edge of one pierces the other or two coplanar edges cross.

use super::segment_rectangle::pierce_rectangle;
use super::separation::{
    RectFeature, certified, rect_feature, rect_params, rect_point, rect_support, rect_support_min,
};
use super::{Closest, point_rectangle, segment_segment};
use crate::{Real, Rss};

/// Closest points between the core rectangles of `a` and `b`.
///
/// A fast path alternates projections between the rectangles a few times, reads off the
/// features the projections settle on (corner, edge or face of each), solves that feature pair
/// exactly and keeps the answer when the separation certificate proves it; otherwise (crossing
/// rectangles, unlucky guesses) the full enumeration below decides.
#[inline]
pub fn rectangle_rectangle(a: &Rss, b: &Rss) -> Closest {
    if let Some(c) = rectangle_rectangle_fast(a, b, 2) {
        return c;
    }
    rectangle_rectangle_full(a, b)
}

#[inline(always)]
fn rectangle_rectangle_fast(a: &Rss, b: &Rss, iterations: usize) -> Option<Closest> {
    let mut y = b.center();
    let (mut sa, mut ta) = rect_params(a, &y);
    let mut x = rect_point(a, sa, ta);
    let (mut sb, mut tb) = (0.0, 0.0);
    for _ in 0..iterations {
        (sb, tb) = rect_params(b, &x);
        y = rect_point(b, sb, tb);
        (sa, ta) = rect_params(a, &y);
        x = rect_point(a, sa, ta);
    }
    let cand = match (rect_feature(a, sa, ta), rect_feature(b, sb, tb)) {
        (RectFeature::Vertex(p), _) => point_rectangle(&p, b),
        (_, RectFeature::Vertex(q)) => point_rectangle(&q, a).swapped(),
        (RectFeature::Edge(p0, p1), RectFeature::Edge(q0, q1)) => {
            segment_segment(&p0, &p1, &q0, &q1)
        }
        _ => {
            let (sb, tb) = rect_params(b, &x);
            Closest::from_points(x, rect_point(b, sb, tb))
        }
    };
    let d = cand.on_b - cand.on_a;
    let size = a.extents[0] + a.extents[1] + b.extents[0] + b.extents[1];
    certified(
        &cand,
        rect_support(a, &cand.on_a, &d),
        rect_support_min(b, &cand.on_a, &d),
        size,
    )
    .then_some(cand)
}

/// A lower bound of the distance between two rectangles (one round of projections and the gap
/// of the supports along the resulting direction).
#[inline]
pub(crate) fn rectangle_rectangle_lower_bound(a: &Rss, b: &Rss) -> Real {
    let y = b.center();
    let (sa, ta) = rect_params(a, &y);
    let x = rect_point(a, sa, ta);
    let (sb, tb) = rect_params(b, &x);
    let y = rect_point(b, sb, tb);
    let (sa, ta) = rect_params(a, &y);
    let x = rect_point(a, sa, ta);
    let d = y - x;
    let len = d.norm();
    if len <= 0.0 {
        return 0.0;
    }
    ((rect_support_min(b, &x, &d) - rect_support(a, &x, &d)) / len).max(0.0)
}

/// The exact enumeration: piercing edges, corners against the other rectangle, edge pairs.
#[inline(never)]
fn rectangle_rectangle_full(a: &Rss, b: &Rss) -> Closest {
    let ca = a.corners();
    let cb = b.corners();
    for i in 0..4 {
        if let Some(x) = pierce_rectangle(&ca[i], &ca[(i + 1) & 3], b) {
            return Closest {
                on_a: x,
                on_b: x,
                dist_sq: 0.0,
            };
        }
        if let Some(x) = pierce_rectangle(&cb[i], &cb[(i + 1) & 3], a) {
            return Closest {
                on_a: x,
                on_b: x,
                dist_sq: 0.0,
            };
        }
    }
    // separated: projections converge slowly for some angles; a longer run usually settles
    if let Some(c) = rectangle_rectangle_fast(a, b, 10) {
        return c;
    }
    let mut best = point_rectangle(&ca[0], b);
    for p in &ca[1..] {
        best = best.min(point_rectangle(p, b));
    }
    for p in &cb {
        best = best.min(point_rectangle(p, a).swapped());
    }
    for i in 0..4 {
        for j in 0..4 {
            best = best.min(segment_segment(
                &ca[i],
                &ca[(i + 1) & 3],
                &cb[j],
                &cb[(j + 1) & 3],
            ));
        }
    }
    best
}
