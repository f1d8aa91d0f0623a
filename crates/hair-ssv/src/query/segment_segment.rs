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

/// Lanes of [`segment_segment_gaps`]: eight pairs at a time.
pub const GAP_LANES: usize = 8;

/// [`segment_segment`] on eight pairs of segments at once, in structure-of-arrays lanes: for
/// lane `i` the first segment runs from `p0[k][i]` to `p1[k][i]` and the second from `q0[k][i]`
/// to `q1[k][i]` (`k` the axis). Returns, per axis, `on_b - on_a` of [`segment_segment`]'s
/// closest points, bit for bit: the same operations in the same order, with both branches of
/// the scalar kernel computed and one selected per lane, so that the compiler runs the lanes in
/// SIMD registers (a contact solver gathers the crossing pairs it must push apart eight at a
/// time).
#[inline]
pub fn segment_segment_gaps(
    p0: &[[Real; GAP_LANES]; 3],
    p1: &[[Real; GAP_LANES]; 3],
    q0: &[[Real; GAP_LANES]; 3],
    q1: &[[Real; GAP_LANES]; 3],
) -> [[Real; GAP_LANES]; 3] {
    let mut gap = [[0.0; GAP_LANES]; 3];
    for i in 0..GAP_LANES {
        let (ux, uy, uz) = (
            p1[0][i] - p0[0][i],
            p1[1][i] - p0[1][i],
            p1[2][i] - p0[2][i],
        );
        let (vx, vy, vz) = (
            q1[0][i] - q0[0][i],
            q1[1][i] - q0[1][i],
            q1[2][i] - q0[2][i],
        );
        let (rx, ry, rz) = (
            p0[0][i] - q0[0][i],
            p0[1][i] - q0[1][i],
            p0[2][i] - q0[2][i],
        );
        let a = ux * ux + uy * uy + uz * uz;
        let e = vx * vx + vy * vy + vz * vz;
        let b = ux * vx + uy * vy + uz * vz;
        let c = ux * rx + uy * ry + uz * rz;
        let f = vx * rx + vy * ry + vz * rz;
        let denom = a * e - b * b;
        let classic = clamp_to((b * f - c * e) / denom, 1.0);
        let (nx, ny, nz) = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx);
        let (mx, my, mz) = (vy * rz - vz * ry, vz * rx - vx * rz, vx * ry - vy * rx);
        let nn = nx * nx + ny * ny + nz * nz;
        let crossed = clamp_to((nx * mx + ny * my + nz * mz) / nn, 1.0);
        let s0 = if denom > 0.0625 * a * e {
            classic
        } else if nn > 0.0 {
            crossed
        } else {
            0.0
        };
        let inv_e = if e > 0.0 { 1.0 / e } else { 0.0 };
        let inv_a = if a > 0.0 { 1.0 / a } else { 0.0 };
        let t = clamp_to((b * s0 + f) * inv_e, 1.0);
        let s = clamp_to((b * t - c) * inv_a, 1.0);
        gap[0][i] = (q0[0][i] + vx * t) - (p0[0][i] + ux * s);
        gap[1][i] = (q0[1][i] + vy * t) - (p0[1][i] + uy * s);
        gap[2][i] = (q0[2][i] + vz * t) - (p0[2][i] + uz * s);
    }
    gap
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn point() -> impl Strategy<Value = Point> {
        // Small integers make exact parallels, coincident and zero-length segments common.
        prop_oneof![
            (-3i32..=3, -3i32..=3, -3i32..=3)
                .prop_map(|(x, y, z)| Point::new(x as Real, y as Real, z as Real)),
            (-2.0..2.0f32, -2.0..2.0f32, -2.0..2.0f32).prop_map(|(x, y, z)| Point::new(x, y, z)),
        ]
    }

    proptest! {
        #[test]
        fn the_lanes_give_the_scalar_gaps_bit_for_bit(
            segs in proptest::collection::vec((point(), point(), point(), point()), GAP_LANES)
        ) {
            let mut lanes = [[[0.0; GAP_LANES]; 3]; 4];
            for (i, (p0, p1, q0, q1)) in segs.iter().enumerate() {
                for k in 0..3 {
                    lanes[0][k][i] = p0[k];
                    lanes[1][k][i] = p1[k];
                    lanes[2][k][i] = q0[k];
                    lanes[3][k][i] = q1[k];
                }
            }
            let gap = segment_segment_gaps(&lanes[0], &lanes[1], &lanes[2], &lanes[3]);
            for (i, (p0, p1, q0, q1)) in segs.iter().enumerate() {
                let c = segment_segment(p0, p1, q0, q1);
                let d = c.on_b - c.on_a;
                for k in 0..3 {
                    prop_assert_eq!(gap[k][i].to_bits(), d[k].to_bits(), "lane {} axis {}", i, k);
                }
            }
        }
    }
}
