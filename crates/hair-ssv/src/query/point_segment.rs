//! Closest points between a point and a segment.

use super::{Closest, clamp_to};
use crate::Point;

/// Closest points between the point `p` and the segment `a`-`b` (`on_a` is `p`).
///
/// A zero-length segment is treated as the point `a`.
#[inline]
pub fn point_segment(p: &Point, a: &Point, b: &Point) -> Closest {
    let d = b - a;
    let dd = d.norm_squared();
    let t = if dd > 0.0 {
        clamp_to((p - a).dot(&d) / dd, 1.0)
    } else {
        0.0
    };
    Closest::from_points(*p, a + d * t)
}
