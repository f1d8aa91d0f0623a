//! Closest points between a point and a triangle.

use super::{Closest, point_segment};
use crate::{Point, Real};
use wide::f32x4;

/// Closest points between the point `p` and the triangle `tri`.
///
/// The point projects onto the plane when it lies over the triangle (signs of three edge
/// cross products, which stay well conditioned for slivers and at large coordinates); otherwise
/// the closest point is on an edge. A degenerate triangle (collinear or repeated vertices) is
/// handled as its edges.
#[inline]
pub fn point_triangle(p: &Point, tri: &[Point; 3]) -> Closest {
    let [a, b, c] = tri;
    let ab = b - a;
    let ac = c - a;
    let n = ab.cross(&ac);
    let nn = n.norm_squared();
    let ap = p - a;
    if nn > 0.0 {
        let bp = p - b;
        let cp = p - c;
        let over = ab.cross(&ap).dot(&n) >= 0.0
            && (c - b).cross(&bp).dot(&n) >= 0.0
            && (a - c).cross(&cp).dot(&n) >= 0.0;
        if over {
            let q = p - n * (n.dot(&ap) / nn);
            if q.coords.iter().all(|x| x.is_finite()) {
                return Closest::from_points(*p, q);
            }
        }
    }
    point_segment(p, a, b)
        .min(point_segment(p, b, c))
        .min(point_segment(p, c, a))
}

/// Four triangles side by side: `v[i][axis][lane]` is coordinate `axis` of vertex `i` of
/// triangle `lane`.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
pub(crate) struct TriLanes {
    pub v: [[[Real; 4]; 3]; 3],
}

impl TriLanes {
    /// The triangles `tris` (at most four) in lanes; lanes past them repeat the first, so that
    /// every lane computes finite values.
    pub(crate) fn new(tris: &[[Point; 3]]) -> Self {
        let mut out = Self::default();
        for lane in 0..4 {
            let t = tris.get(lane).or(tris.first());
            for (i, vertex) in t.into_iter().flatten().enumerate() {
                for axis in 0..3 {
                    out.v[i][axis][lane] = vertex[axis];
                }
            }
        }
        out
    }
}

/// Three coordinates of four lanes.
type V4 = [f32x4; 3];

#[inline(always)]
fn sub4(a: &V4, b: &V4) -> V4 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// nalgebra's cross product, lane by lane (the same expressions).
#[inline(always)]
fn cross4(a: &V4, b: &V4) -> V4 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// nalgebra's dot product of 3-vectors, lane by lane: `(x x' + y y') + z z'`.
#[inline(always)]
fn dot4(a: &V4, b: &V4) -> f32x4 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Lane-wise choice: `b` where `take` (a mask), else `a`.
#[inline(always)]
fn select4(take: f32x4, a: &V4, b: &V4) -> V4 {
    [
        take.select(b[0], a[0]),
        take.select(b[1], a[1]),
        take.select(b[2], a[2]),
    ]
}

/// [`point_segment`]'s closest point on the segment `a`-`b` and its squared distance from `p`,
/// lane by lane (the same expressions; the clamp as comparisons, which give the same values
/// as `clamp_to` for every quotient, NaN included).
#[inline(always)]
fn point_segment4(p: &V4, a: &V4, b: &V4) -> (V4, f32x4) {
    let (zero, one) = (f32x4::ZERO, f32x4::ONE);
    let d = sub4(b, a);
    let dd = dot4(&d, &d);
    let x = dot4(&sub4(p, a), &d) / dd;
    let x = x.simd_gt(zero).select(x, zero);
    let x = x.simd_lt(one).select(x, one);
    let t = dd.simd_gt(zero).select(x, zero);
    let q = [a[0] + d[0] * t, a[1] + d[1] * t, a[2] + d[2] * t];
    let dq = sub4(&q, p);
    (q, dot4(&dq, &dq))
}

/// [`point_triangle`] of one point and four triangles at once: per lane, the closest point on
/// the triangle and its squared distance from `p`, with the same values as the scalar function
/// (the same expressions in the same order, lane by lane, and the same choices).
#[inline]
pub(crate) fn point_triangle_lanes(p: &Point, t: &TriLanes) -> ([[Real; 4]; 3], [Real; 4]) {
    let zero = f32x4::ZERO;
    let pv: V4 = [f32x4::splat(p.x), f32x4::splat(p.y), f32x4::splat(p.z)];
    let [a, b, c] = t.v.map(|v| v.map(f32x4::new));
    let ab = sub4(&b, &a);
    let ac = sub4(&c, &a);
    let n = cross4(&ab, &ac);
    let nn = dot4(&n, &n);
    let ap = sub4(&pv, &a);
    let bp = sub4(&pv, &b);
    let cp = sub4(&pv, &c);
    let e0 = dot4(&cross4(&ab, &ap), &n);
    let e1 = dot4(&cross4(&sub4(&c, &b), &bp), &n);
    let e2 = dot4(&cross4(&sub4(&a, &c), &cp), &n);
    let s = dot4(&n, &ap) / nn;
    let q = [pv[0] - n[0] * s, pv[1] - n[1] * s, pv[2] - n[2] * s];
    let dq = sub4(&q, &pv);
    let q_sq = dot4(&dq, &dq);
    let finite = q[0].is_finite() & q[1].is_finite() & q[2].is_finite();
    let over = nn.simd_gt(zero) & e0.simd_ge(zero) & e1.simd_ge(zero) & e2.simd_ge(zero) & finite;
    // The edges as `Closest::min` chains them: a later edge only when strictly nearer.
    let (q0, d0) = point_segment4(&pv, &a, &b);
    let (q1, d1) = point_segment4(&pv, &b, &c);
    let (q2, d2) = point_segment4(&pv, &c, &a);
    let take1 = d1.simd_lt(d0);
    let edge = select4(take1, &q0, &q1);
    let edge_sq = take1.select(d1, d0);
    let take2 = d2.simd_lt(edge_sq);
    let edge = select4(take2, &edge, &q2);
    let edge_sq = take2.select(d2, edge_sq);
    let out = select4(over, &edge, &q);
    (
        out.map(f32x4::to_array),
        over.select(q_sq, edge_sq).to_array(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn point() -> impl Strategy<Value = Point> {
        (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0).prop_map(|(x, y, z)| Point::new(x, y, z))
    }

    /// Triangles of every kind the scalar kernel distinguishes: plain, slivers, collinear and
    /// repeated vertices, and far from the origin (large coordinates, small features).
    fn triangle() -> impl Strategy<Value = [Point; 3]> {
        prop_oneof![
            4 => (point(), point(), point()).prop_map(|(a, b, c)| [a, b, c]),
            1 => (point(), point(), 0.0f32..1.0, -1e-6f32..1e-6)
                .prop_map(|(a, b, s, e)| [a, b, a + (b - a) * s + crate::Vector::repeat(e)]),
            1 => (point(), point(), 0.0f32..1.0).prop_map(|(a, b, s)| [a, b, a + (b - a) * s]),
            1 => (point(), point()).prop_map(|(a, b)| [a, b, b]),
            1 => point().prop_map(|a| [a, a, a]),
            1 => (point(), point(), point()).prop_map(|(a, b, c)| {
                let far = crate::Vector::new(1e4, -3e3, 2e4);
                [a + far, a + far + (b - a) * 1e-3, a + far + (c - a) * 1e-3]
            }),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// The four-lane kernel gives the scalar kernel's closest point and squared distance,
        /// bit for bit, for points anywhere and on the triangles' own vertices and edges.
        #[test]
        fn lanes_equal_the_scalar_kernel_bit_for_bit(
            tris in proptest::collection::vec(triangle(), 1..=4),
            free in point(),
            pick in 0usize..4,
            s in 0.0f32..1.0,
        ) {
            let t = &tris[0];
            let p = match pick {
                0 => free,
                1 => t[0],
                2 => t[0] + (t[1] - t[0]) * s,
                _ => free + (t[1] - t[0]).cross(&(t[2] - t[0])),
            };
            let (on_b, dist_sq) = point_triangle_lanes(&p, &TriLanes::new(&tris));
            for (l, t) in tris.iter().enumerate() {
                let c = point_triangle(&p, t);
                prop_assert_eq!(dist_sq[l].to_bits(), c.dist_sq.to_bits(), "lane {}", l);
                for k in 0..3 {
                    prop_assert_eq!(on_b[k][l].to_bits(), c.on_b[k].to_bits(), "lane {} axis {}", l, k);
                }
            }
        }
    }
}
