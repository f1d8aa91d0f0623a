//! Closest points between two segments: the minimum of a convex quadratic over the unit square,
//! found from the infinite lines' solution and two clamped projections.

use super::{Closest, clamp_to};
use crate::{Point, Real, Vector};

/// Closest points between the segments `p0`-`p1` and `q0`-`q1`.
///
/// The lines' solution comes from cross products, so nearly parallel segments keep their
/// accuracy; exactly parallel, zero-length and coincident segments take the clamped projections
/// alone, which are exact for them.
#[inline]
pub fn segment_segment(p0: &Point, p1: &Point, q0: &Point, q1: &Point) -> Closest {
    let (s, t) = segment_segment_params(p0, p1, q0, q1);
    Closest::from_points(p0 + (p1 - p0) * s, q0 + (q1 - q0) * t)
}

/// Squared distance between the segments `p0`-`p1` and `q0`-`q1` (no closest points).
#[inline]
pub fn segment_segment_dist_sq(p0: &Point, p1: &Point, q0: &Point, q1: &Point) -> Real {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let (s, t) = params(&d1, &d2, &r);
    (r + d1 * s - d2 * t).norm_squared()
}

/// Parameters `(s, t)` in `[0, 1]` of the closest points `p0 + s (p1 - p0)`, `q0 + t (q1 - q0)`.
#[inline(always)]
pub(crate) fn segment_segment_params(
    p0: &Point,
    p1: &Point,
    q0: &Point,
    q1: &Point,
) -> (Real, Real) {
    params(&(p1 - p0), &(q1 - q0), &(p0 - q0))
}

/// The parameters from the directions `d1`, `d2` and `r = p0 - q0`.
#[inline(always)]
fn params(d1: &Vector, d2: &Vector, r: &Vector) -> (Real, Real) {
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let b = d1.dot(d2);
    let c = d1.dot(r);
    let f = d2.dot(r);
    // s on the infinite lines. Well away from parallel, `(b f - c e) / (a e - b^2)` is accurate
    // (relative error about eps / sin^2 of the angle). Closer to parallel the same ratio comes
    // from cross products, `((d1 x d2) . (d2 x r)) / |d1 x d2|^2`, which lose only
    // eps / sin(angle) and keep the distance error at a few ulps of the segments' length.
    let denom = a * e - b * b;
    let s0 = if denom > 0.0625 * a * e {
        clamp_to((b * f - c * e) / denom, 1.0)
    } else {
        let n = d1.cross(d2);
        let nn = n.dot(&n);
        if nn > 0.0 {
            clamp_to(n.dot(&d2.cross(r)) / nn, 1.0)
        } else {
            0.0
        }
    };
    let inv_e = if e > 0.0 { 1.0 / e } else { 0.0 };
    let inv_a = if a > 0.0 { 1.0 / a } else { 0.0 };
    let t = clamp_to((b * s0 + f) * inv_e, 1.0);
    let s = clamp_to((b * t - c) * inv_a, 1.0);
    (s, t)
}
