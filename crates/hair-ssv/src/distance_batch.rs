//! Batched LSS-LSS distances: the segment-segment kernel of [`query::segment_segment`] run on
//! eight pairs at a time in structure-of-arrays lanes, branch-free, so the compiler can keep
//! them in SIMD registers.
//!
//! [`query::segment_segment`]: crate::query::segment_segment

use crate::{Lss, Real};

const LANES: usize = 8;

#[inline(always)]
fn clamp01(x: Real) -> Real {
    x.clamp(0.0, 1.0)
}

/// Signed distances of many LSS pairs: `out[i] = distance_lss_lss(&pairs[i].0, &pairs[i].1)` up
/// to rounding, for `i < min(pairs.len(), out.len())`.
pub fn distance_lss_lss_batch(pairs: &[(Lss, Lss)], out: &mut [Real]) {
    let n = pairs.len().min(out.len());
    let (pairs, out) = (&pairs[..n], &mut out[..n]);
    let mut chunks = pairs.chunks_exact(LANES);
    let mut outs = out.chunks_exact_mut(LANES);
    for (pc, oc) in (&mut chunks).zip(&mut outs) {
        lanes(pc, oc);
    }
    let (rest, rest_out) = (chunks.remainder(), outs.into_remainder());
    if !rest.is_empty() {
        let mut buf = [(
            Lss::new(Default::default(), Default::default(), 0.0),
            Lss::new(Default::default(), Default::default(), 0.0),
        ); LANES];
        buf[..rest.len()].copy_from_slice(rest);
        let mut o = [0.0; LANES];
        lanes(&buf, &mut o);
        rest_out.copy_from_slice(&o[..rest.len()]);
    }
}

#[inline(always)]
fn lanes(pairs: &[(Lss, Lss)], out: &mut [Real]) {
    let mut d1 = [[0.0; LANES]; 3];
    let mut d2 = [[0.0; LANES]; 3];
    let mut r = [[0.0; LANES]; 3];
    let mut rad = [0.0; LANES];
    for (i, (p, q)) in pairs.iter().enumerate().take(LANES) {
        for k in 0..3 {
            d1[k][i] = p.b[k] - p.a[k];
            d2[k][i] = q.b[k] - q.a[k];
            r[k][i] = p.a[k] - q.a[k];
        }
        rad[i] = p.radius + q.radius;
    }
    let res = lss_lss_lanes(&d1, &d2, &r, &rad);
    out.copy_from_slice(&res[..out.len()]);
}

/// The segment-segment kernel of [`query::segment_segment`] on eight pairs of LSS in
/// structure-of-arrays lanes, branch-free: for lane `i`, the first core is `a + s u` and the
/// second `a' + t v` (`s`, `t` in `[0, 1]`), with `u[k][i]`, `v[k][i]` and `r[k][i] = a - a'`
/// along axis `k`, and `radii[i]` the sum of the two radii. Returns the signed distances, equal
/// to [`crate::Ssv::distance`]'s up to rounding. For callers that hold their segments in lanes
/// already (a pair search testing eight candidates at once).
///
/// [`query::segment_segment`]: crate::query::segment_segment
#[inline(always)]
pub fn lss_lss_lanes(
    u: &[[Real; LANES]; 3],
    v: &[[Real; LANES]; 3],
    r: &[[Real; LANES]; 3],
    radii: &[Real; LANES],
) -> [Real; LANES] {
    let (s, t) = segment_segment_params_lanes(u, v, r);
    std::array::from_fn(|i| {
        let w = [0, 1, 2].map(|k| r[k][i] + u[k][i] * s[i] - v[k][i] * t[i]);
        (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt() - radii[i]
    })
}

/// The parameters `(s, t)` in `[0, 1]` of the closest points `a + s u` and `a' + t v` of eight
/// pairs of segments in lanes (`u`, `v` and `r = a - a'` as for [`lss_lss_lanes`]): the
/// expressions of [`query::segment_segment`] in the same order, so that for finite segments
/// they are the same values, bit for bit. Branch-free, so the loop compiles to packed
/// instructions.
///
/// [`query::segment_segment`]: crate::query::segment_segment
#[inline(always)]
pub fn segment_segment_params_lanes(
    u: &[[Real; LANES]; 3],
    v: &[[Real; LANES]; 3],
    r: &[[Real; LANES]; 3],
) -> ([Real; LANES], [Real; LANES]) {
    let mut s_out = [0.0; LANES];
    let mut t_out = [0.0; LANES];
    for i in 0..LANES {
        let (ux, uy, uz) = (u[0][i], u[1][i], u[2][i]);
        let (vx, vy, vz) = (v[0][i], v[1][i], v[2][i]);
        let (rx, ry, rz) = (r[0][i], r[1][i], r[2][i]);
        let a = ux * ux + uy * uy + uz * uz;
        let e = vx * vx + vy * vy + vz * vz;
        let b = ux * vx + uy * vy + uz * vz;
        let c = ux * rx + uy * ry + uz * rz;
        let f = vx * rx + vy * ry + vz * rz;
        // the lines' solution as in the scalar kernel: cross products near parallel
        let denom = a * e - b * b;
        let classic = (b * f - c * e) / denom;
        let (nx, ny, nz) = (uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx);
        let (mx, my, mz) = (vy * rz - vz * ry, vz * rx - vx * rz, vx * ry - vy * rx);
        let nn = nx * nx + ny * ny + nz * nz;
        let crossed = (nx * mx + ny * my + nz * mz) / nn;
        let s0 = if denom > 0.0625 * a * e {
            classic
        } else if nn > 0.0 {
            crossed
        } else {
            0.0
        };
        let s0 = clamp01(s0);
        let inv_e = if e > 0.0 { 1.0 / e } else { 0.0 };
        let inv_a = if a > 0.0 { 1.0 / a } else { 0.0 };
        let t = clamp01((b * s0 + f) * inv_e);
        s_out[i] = clamp01((b * t - c) * inv_a);
        t_out[i] = t;
    }
    (s_out, t_out)
}
