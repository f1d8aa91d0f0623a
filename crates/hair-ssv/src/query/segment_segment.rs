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

/// [`segment_segment`] of four pairs at once: `p[i]` (`p0`, `p1`) against `q[i]` (`q0`, `q1`) in
/// lane `i`, with the scalar kernel's expressions lane by lane (four-lane SSE on x86-64, NEON on
/// aarch64): the same closest points and squared distances. For callers with many pairs (a hair
/// collision response), where the scalar kernel's branches and divisions dominate.
pub fn segment_segment4(p: &[[Point; 2]; 4], q: &[[Point; 2]; 4]) -> [Closest; 4] {
    use wide::f32x4;
    let lanes = |f: &dyn Fn(usize) -> Real| f32x4::new([f(0), f(1), f(2), f(3)]);
    let coord = |s: &[[Point; 2]; 4], end: usize, k: usize| lanes(&|i| s[i][end][k]);
    let p0 = [0, 1, 2].map(|k| coord(p, 0, k));
    let q0 = [0, 1, 2].map(|k| coord(q, 0, k));
    let d1 = [0, 1, 2].map(|k| coord(p, 1, k) - p0[k]);
    let d2 = [0, 1, 2].map(|k| coord(q, 1, k) - q0[k]);
    let r = [0, 1, 2].map(|k| p0[k] - q0[k]);
    let dot = |a: &[f32x4; 3], b: &[f32x4; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: &[f32x4; 3], b: &[f32x4; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let (zero, one) = (f32x4::ZERO, f32x4::ONE);
    // `clamp_to(x, 1.0)` as comparisons: the same value for every `x`, NaN (to 0) included.
    let clamp01 = |x: f32x4| {
        let x = x.simd_gt(zero).select(x, zero);
        x.simd_lt(one).select(x, one)
    };
    let a = dot(&d1, &d1);
    let e = dot(&d2, &d2);
    let b = dot(&d1, &d2);
    let c = dot(&d1, &r);
    let f = dot(&d2, &r);
    let denom = a * e - b * b;
    let classic = clamp01((b * f - c * e) / denom);
    let n = cross(&d1, &d2);
    let nn = dot(&n, &n);
    let crossed = nn
        .simd_gt(zero)
        .select(clamp01(dot(&n, &cross(&d2, &r)) / nn), zero);
    let s0 = denom
        .simd_gt(f32x4::splat(0.0625) * a * e)
        .select(classic, crossed);
    let inv_e = e.simd_gt(zero).select(one / e, zero);
    let inv_a = a.simd_gt(zero).select(one / a, zero);
    let t = clamp01((b * s0 + f) * inv_e);
    let s = clamp01((b * t - c) * inv_a);
    let on_a = [0, 1, 2].map(|k| (p0[k] + d1[k] * s).to_array());
    let on_b = [0, 1, 2].map(|k| (q0[k] + d2[k] * t).to_array());
    std::array::from_fn(|i| {
        Closest::from_points(
            Point::new(on_a[0][i], on_a[1][i], on_a[2][i]),
            Point::new(on_b[0][i], on_b[1][i], on_b[2][i]),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn point() -> impl Strategy<Value = Point> {
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0).prop_map(|(x, y, z)| Point::new(x, y, z))
    }

    /// Pairs of every kind the scalar kernel distinguishes: general, nearly and exactly
    /// parallel, collinear, crossing, zero-length on either side or both, and far from the
    /// origin.
    fn pair() -> impl Strategy<Value = ([Point; 2], [Point; 2])> {
        prop_oneof![
            4 => (point(), point(), point(), point()).prop_map(|(a, b, c, d)| ([a, b], [c, d])),
            1 => (point(), point(), point(), -1e-4f32..1e-4, 0.1f32..2.0).prop_map(|(a, b, c, e, k)| {
                let d = c + (b - a) * k + Vector::repeat(e);
                ([a, b], [c, d])
            }),
            1 => (point(), point(), -1.0f32..2.0, -1.0f32..2.0)
                .prop_map(|(a, b, s, t)| ([a, b], [a + (b - a) * s, a + (b - a) * t])),
            1 => (point(), point(), point()).prop_map(|(a, b, c)| ([a, b], [c, c])),
            1 => (point(), point(), point()).prop_map(|(a, c, d)| ([a, a], [c, d])),
            1 => (point(), point()).prop_map(|(a, c)| ([a, a], [c, c])),
            1 => (point(), point(), point(), point()).prop_map(|(a, b, c, d)| {
                let far = Vector::new(3e3, -1e4, 2e3);
                ([a + far, b + far], [c + far, d + far])
            }),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// The four-lane kernel gives the scalar kernel's closest points and squared
        /// distances, bit for bit.
        #[test]
        fn four_lanes_equal_the_scalar_kernel_bit_for_bit(
            pairs in proptest::collection::vec(pair(), 4),
        ) {
            let p: [[Point; 2]; 4] = std::array::from_fn(|i| pairs[i].0);
            let q: [[Point; 2]; 4] = std::array::from_fn(|i| pairs[i].1);
            let lanes = segment_segment4(&p, &q);
            for i in 0..4 {
                let c = segment_segment(&p[i][0], &p[i][1], &q[i][0], &q[i][1]);
                prop_assert_eq!(lanes[i].dist_sq.to_bits(), c.dist_sq.to_bits(), "lane {}", i);
                for k in 0..3 {
                    prop_assert_eq!(lanes[i].on_a[k].to_bits(), c.on_a[k].to_bits(), "lane {}", i);
                    prop_assert_eq!(lanes[i].on_b[k].to_bits(), c.on_b[k].to_bits(), "lane {}", i);
                }
            }
        }
    }
}
