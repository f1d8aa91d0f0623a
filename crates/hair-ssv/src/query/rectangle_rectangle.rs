//! Closest points between two rectangles.
//!
//! Two convex polygons are closest either at a vertex of one against the other, or at a pair of
//! edges; if they intersect, an edge of one pierces the other or two coplanar edges cross.

use super::segment_rectangle::pierce_rectangle;
use super::{Closest, point_rectangle, segment_segment};
use crate::Rss;

/// Closest points between the core rectangles of `a` and `b`.
#[inline]
pub fn rectangle_rectangle(a: &Rss, b: &Rss) -> Closest {
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
