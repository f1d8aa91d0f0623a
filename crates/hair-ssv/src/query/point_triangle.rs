//! Closest points between a point and a triangle.

use super::{Closest, point_segment};
use crate::{Point, Real};
use std::ops::{Add, Mul, Sub};
use wide::{f32x4, f64x4};

/// Closest points between the point `p` and the triangle `tri`.
///
/// The point projects onto the plane when it lies over the triangle (signs of three edge
/// cross products); otherwise the closest point is on an edge. A degenerate triangle (collinear
/// or repeated vertices) is handled as its edges.
///
/// The plane, the three signs and the projection are computed in `f64`, then the point is
/// rounded to `f32`: in `f32` the normal of a sliver cancels (a triangle 2 km across and
/// 0.5 m thick got the normal `(0, 0, 0.03)`), and a point 374 m off its edge was then found
/// over it, at distance 0.
#[inline]
pub fn point_triangle(p: &Point, tri: &[Point; 3]) -> Closest {
    if let Some(q) = over_triangle(p, tri) {
        return Closest::from_points(*p, q);
    }
    point_segment(p, &tri[0], &tri[1])
        .min(point_segment(p, &tri[1], &tri[2]))
        .min(point_segment(p, &tri[2], &tri[0]))
}

/// A point in `f64`. The difference of two `f32` values is exact in `f64`, and so is the
/// product of two such differences, so the plane tests below round only when products are
/// summed, at `f64` precision.
type P64 = nalgebra::Vector3<f64>;

#[inline(always)]
pub(crate) fn p64(p: &Point) -> P64 {
    P64::new(f64::from(p.x), f64::from(p.y), f64::from(p.z))
}

/// Whether `x` lies over the triangle `a b c` of normal `n` (`n != 0`): on the inner side of
/// all three edges, or on one.
#[inline(always)]
pub(crate) fn inside_edges(x: &P64, [a, b, c]: &[P64; 3], n: &P64) -> bool {
    (b - a).cross(&(x - a)).dot(n) >= 0.0
        && (c - b).cross(&(x - b)).dot(n) >= 0.0
        && (a - c).cross(&(x - c)).dot(n) >= 0.0
}

/// The projection of `p` onto the plane of `tri` when `p` lies over the triangle and the
/// triangle is not degenerate, rounded to `f32` (`None` also when that is not finite).
#[inline(always)]
pub(crate) fn over_triangle(p: &Point, tri: &[Point; 3]) -> Option<Point> {
    let t = tri.map(|v| p64(&v));
    let n = (t[1] - t[0]).cross(&(t[2] - t[0]));
    let nn = n.norm_squared();
    let x = p64(p);
    if !(nn > 0.0 && inside_edges(&x, &t, &n)) {
        return None;
    }
    let q = x - n * (n.dot(&(x - t[0])) / nn);
    let q = Point::new(q.x as Real, q.y as Real, q.z as Real);
    q.coords.iter().all(|v| v.is_finite()).then_some(q)
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

/// Three coordinates of four lanes in `f64`.
type V4d = [f64x4; 3];

#[inline(always)]
fn sub4<T: Copy + Sub<Output = T>>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// nalgebra's cross product, lane by lane (the same expressions).
#[inline(always)]
fn cross4<T: Copy + Sub<Output = T> + Mul<Output = T>>(a: &[T; 3], b: &[T; 3]) -> [T; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// nalgebra's dot product of 3-vectors, lane by lane: `(x x' + y y') + z z'`.
#[inline(always)]
fn dot4<T: Copy + Add<Output = T> + Mul<Output = T>>(a: &[T; 3], b: &[T; 3]) -> T {
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
/// (the same expressions in the same order, lane by lane, and the same choices). Where `AVX`
/// (true only in code compiled for AVX: `Bvh`'s point query on such a processor) the `f64`
/// plane tests run in AVX registers, four lanes per instruction instead of two, with the same
/// operations in the same order, so the same values.
#[inline(always)]
#[cfg_attr(
    target_arch = "x86_64",
    expect(
        unsafe_code,
        reason = "calls the AVX plane tests; sound: `AVX` is true only inside the point search compiled for AVX, run only where the processor has it"
    )
)]
pub(crate) fn point_triangle_lanes_in<const AVX: bool>(
    p: &Point,
    t: &TriLanes,
) -> ([[Real; 4]; 3], [Real; 4]) {
    let pv: V4 = [f32x4::splat(p.x), f32x4::splat(p.y), f32x4::splat(p.z)];
    let [a, b, c] = t.v.map(|v| v.map(f32x4::new));
    #[cfg(target_arch = "x86_64")]
    let (q, inside) = if AVX {
        // SAFETY: `AVX` is true only in code compiled for AVX, which runs only where the
        // processor has it.
        unsafe { plane_lanes_avx(p, t) }
    } else {
        plane_lanes(p, t)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let (q, inside) = plane_lanes(p, t);
    let dq = sub4(&q, &pv);
    let q_sq = dot4(&dq, &dq);
    let finite = q[0].is_finite() & q[1].is_finite() & q[2].is_finite();
    let over = inside & finite;
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

/// The plane tests and the projection of [`point_triangle_lanes_in`], in `f64` as
/// `over_triangle` does them: per lane, the projection of `p` onto the triangle's plane
/// (rounded to `f32`) and whether `p` lies over a triangle that is not degenerate (a mask).
#[inline(always)]
fn plane_lanes(p: &Point, t: &TriLanes) -> (V4, f32x4) {
    let pd: V4d = [p.x, p.y, p.z].map(|x| f64x4::splat(f64::from(x)));
    let [ad, bd, cd]: [V4d; 3] = t.v.map(|v| v.map(|l| f64x4::new(l.map(f64::from))));
    let abd = sub4(&bd, &ad);
    let n = cross4(&abd, &sub4(&cd, &ad));
    let nn = dot4(&n, &n);
    let apd = sub4(&pd, &ad);
    let e0 = dot4(&cross4(&abd, &apd), &n);
    let e1 = dot4(&cross4(&sub4(&cd, &bd), &sub4(&pd, &bd)), &n);
    let e2 = dot4(&cross4(&sub4(&ad, &cd), &sub4(&pd, &cd)), &n);
    let s = dot4(&n, &apd) / nn;
    let q: V4 = [0, 1, 2].map(|k| f32x4::new((pd[k] - n[k] * s).to_array().map(|x| x as Real)));
    let inside = nn.simd_gt(f64x4::ZERO)
        & e0.simd_ge(f64x4::ZERO)
        & e1.simd_ge(f64x4::ZERO)
        & e2.simd_ge(f64x4::ZERO);
    // The f64 lanes' mask as an f32 one (all bits set where inside).
    let inside = f32x4::new(
        inside
            .to_array()
            .map(|m| f32::from_bits(m.to_bits() as u32)),
    );
    (q, inside)
}

/// [`plane_lanes`] with AVX intrinsics: each `f64x4` one register instead of two SSE2 halves
/// (the `wide` crate picks its instructions when it is compiled, for the baseline target). The
/// same operations in the same order; the compares are ordered, false for NaN, as there.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
#[expect(
    unsafe_code,
    reason = "unaligned loads and stores of four floats; sound: each lies inside a four-float array"
)]
fn plane_lanes_avx(p: &Point, t: &TriLanes) -> (V4, f32x4) {
    use std::arch::x86_64::{
        __m256d, _CMP_GE_OQ, _CMP_GT_OQ, _mm_loadu_ps, _mm_storeu_ps, _mm256_add_pd, _mm256_and_pd,
        _mm256_cmp_pd, _mm256_cvtpd_ps, _mm256_cvtps_pd, _mm256_div_pd, _mm256_movemask_pd,
        _mm256_mul_pd, _mm256_set1_pd, _mm256_setzero_pd, _mm256_sub_pd,
    };
    type D3 = [__m256d; 3];
    let load = |l: &[Real; 4]| {
        // SAFETY: four floats.
        _mm256_cvtps_pd(unsafe { _mm_loadu_ps(l.as_ptr()) })
    };
    let sub = |a: &D3, b: &D3| -> D3 { [0, 1, 2].map(|k| _mm256_sub_pd(a[k], b[k])) };
    let cross = |a: &D3, b: &D3| -> D3 {
        [
            _mm256_sub_pd(_mm256_mul_pd(a[1], b[2]), _mm256_mul_pd(a[2], b[1])),
            _mm256_sub_pd(_mm256_mul_pd(a[2], b[0]), _mm256_mul_pd(a[0], b[2])),
            _mm256_sub_pd(_mm256_mul_pd(a[0], b[1]), _mm256_mul_pd(a[1], b[0])),
        ]
    };
    let dot = |a: &D3, b: &D3| {
        _mm256_add_pd(
            _mm256_add_pd(_mm256_mul_pd(a[0], b[0]), _mm256_mul_pd(a[1], b[1])),
            _mm256_mul_pd(a[2], b[2]),
        )
    };
    let pd: D3 = [p.x, p.y, p.z].map(|x| _mm256_set1_pd(f64::from(x)));
    let [ad, bd, cd]: [D3; 3] = t.v.map(|v| v.map(|l| load(&l)));
    let abd = sub(&bd, &ad);
    let n = cross(&abd, &sub(&cd, &ad));
    let nn = dot(&n, &n);
    let apd = sub(&pd, &ad);
    let e0 = dot(&cross(&abd, &apd), &n);
    let e1 = dot(&cross(&sub(&cd, &bd), &sub(&pd, &bd)), &n);
    let e2 = dot(&cross(&sub(&ad, &cd), &sub(&pd, &cd)), &n);
    let s = _mm256_div_pd(dot(&n, &apd), nn);
    let q: V4 = [0, 1, 2].map(|k| {
        let v = _mm256_cvtpd_ps(_mm256_sub_pd(pd[k], _mm256_mul_pd(n[k], s)));
        let mut out = [0.0 as Real; 4];
        // SAFETY: four floats.
        unsafe { _mm_storeu_ps(out.as_mut_ptr(), v) };
        f32x4::new(out)
    });
    let zero = _mm256_setzero_pd();
    let inside = _mm256_and_pd(
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GT_OQ>(nn, zero),
            _mm256_cmp_pd::<_CMP_GE_OQ>(e0, zero),
        ),
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(e1, zero),
            _mm256_cmp_pd::<_CMP_GE_OQ>(e2, zero),
        ),
    );
    let bits = _mm256_movemask_pd(inside);
    let inside = f32x4::new(std::array::from_fn(|l| {
        f32::from_bits(if bits >> l & 1 == 1 { u32::MAX } else { 0 })
    }));
    (q, inside)
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

    /// The AVX instantiation of the four-lane kernel.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn lanes_avx(p: &Point, t: &TriLanes) -> ([[Real; 4]; 3], [Real; 4]) {
        point_triangle_lanes_in::<true>(p, t)
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
            let lanes = TriLanes::new(&tris);
            let (on_b, dist_sq) = point_triangle_lanes_in::<false>(&p, &lanes);
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx") {
                #[expect(
                    unsafe_code,
                    reason = "calls a function compiled for AVX; sound: only after AVX was found"
                )]
                // SAFETY: AVX was found above.
                let avx = unsafe { lanes_avx(&p, &lanes) };
                prop_assert_eq!(avx.0.map(|c| c.map(f32::to_bits)), on_b.map(|c| c.map(f32::to_bits)));
                prop_assert_eq!(avx.1.map(f32::to_bits), dist_sq.map(f32::to_bits));
            }
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
