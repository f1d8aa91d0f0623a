//! Closest points between a point and a rectangle.

use super::{Closest, clamp_to};
use crate::{Point, Rss};

/// Closest points between the point `p` and the core rectangle of `rect` (its radius is ignored).
#[inline]
pub fn point_rectangle(p: &Point, rect: &Rss) -> Closest {
    let d = p - rect.origin;
    let s = clamp_to(d.dot(&rect.axes[0]), rect.extents[0]);
    let t = clamp_to(d.dot(&rect.axes[1]), rect.extents[1]);
    Closest::from_points(*p, rect.origin + rect.axes[0] * s + rect.axes[1] * t)
}
