//! Conservative cell covers of cores grown by an offset (salon paper §4.3.1: the cells that
//! contain the core shape, then the cells reached by the offset).
//!
//! Everything here works in cell units (a point `p` in metres is `p / h`), in `f64`. A cover
//! holds every cell that contains a point of the core grown by a cube of half-side `r`, a
//! superset of the core grown by a ball of radius `r`; the callers add a small slack to `r`
//! against rounding.

/// Inclusive range of cells on each axis that a walk may emit (cells outside are skipped).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct CellBox {
    pub lo: [i64; 3],
    pub hi: [i64; 3],
}

impl CellBox {
    /// Every cell of the lattice.
    pub const ALL: CellBox = CellBox {
        lo: [i64::MIN / 4; 3],
        hi: [i64::MAX / 4; 3],
    };
}

/// The walk emitted more cells than its limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct OverLimit;

/// `floor` as an integer, without a libm call. `as` saturates, and so does the step down: a
/// value far below the lattice gives `i64::MIN`, which the callers' range checks reject (a
/// plain `t - 1` overflowed there, on hair thrown 1e26 m away).
#[inline]
pub(crate) fn floor_i(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// `floor` of a value `|v| < 2^51` (finite), without the saturating float-to-integer conversion:
/// adding 1.5 * 2^52 rounds `v` to the nearest integer `k` exactly (the sum's unit in the last
/// place is 1) and leaves `k` in the low bits of the sum, so that the difference of the bit
/// patterns is `k`; then one less when `k > v`. The same value as [`floor_i`] there.
#[inline]
pub(crate) fn floor_small(v: f64) -> i64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 * 2^52
    let sum = v + MAGIC;
    let k = sum.to_bits() as i64 - MAGIC.to_bits() as i64;
    k - i64::from(sum - MAGIC > v)
}

/// Direction components below this (in cells, over the whole segment) count as zero in the slab
/// tests: the segment then strays from the tested line by at most this, far below the cover
/// slack the callers add (1e-3 cell), and the reciprocal stays finite.
pub(crate) const TINY: f64 = 1e-12;

/// The parameters `t` in `[t0, t1]` where `p + t d` lies in `[lo, hi]`, given `inv = 1 / d` (0
/// when `|d| <= TINY`). A multiplication by the reciprocal instead of two divisions per slab: the
/// rounding differs by an ulp, far below the cover slack.
#[inline]
fn slab(p: f64, inv: f64, lo: f64, hi: f64, t0: f64, t1: f64) -> Option<(f64, f64)> {
    if inv == 0.0 {
        if p >= lo && p <= hi {
            Some((t0, t1))
        } else {
            None
        }
    } else {
        let (mut s0, mut s1) = ((lo - p) * inv, (hi - p) * inv);
        if s0 > s1 {
            std::mem::swap(&mut s0, &mut s1);
        }
        let (s0, s1) = (s0.max(t0), s1.min(t1));
        (s0 <= s1).then_some((s0, s1))
    }
}

#[inline]
fn span(p: f64, d: f64, t0: f64, t1: f64) -> (f64, f64) {
    let (u, v) = (p + t0 * d, p + t1 * d);
    if u <= v { (u, v) } else { (v, u) }
}

/// Emits, in increasing `(x, y, z)` order, every cell within the clip box that meets the segment
/// `a`-`b` grown by a cube of half-side `r`. Returns the number of cells, or `OverLimit` as soon
/// as more than `limit` would be emitted.
pub(crate) fn segment(
    a: [f64; 3],
    b: [f64; 3],
    r: f64,
    clip: &CellBox,
    limit: u64,
    emit: &mut impl FnMut([i64; 3]),
) -> Result<u64, OverLimit> {
    let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let inv = d.map(|v| if v.abs() > TINY { 1.0 / v } else { 0.0 });
    let (x0, x1) = span(a[0], d[0], 0.0, 1.0);
    let i0 = floor_i(x0 - r).max(clip.lo[0]);
    let i1 = floor_i(x1 + r).min(clip.hi[0]);
    let mut count = 0u64;
    for i in i0..=i1 {
        let fi = i as f64;
        let Some((t0, t1)) = slab(a[0], inv[0], fi - r, fi + 1.0 + r, 0.0, 1.0) else {
            continue;
        };
        let (y0, y1) = span(a[1], d[1], t0, t1);
        let j0 = floor_i(y0 - r).max(clip.lo[1]);
        let j1 = floor_i(y1 + r).min(clip.hi[1]);
        for j in j0..=j1 {
            let fj = j as f64;
            let Some((u0, u1)) = slab(a[1], inv[1], fj - r, fj + 1.0 + r, t0, t1) else {
                continue;
            };
            let (z0, z1) = span(a[2], d[2], u0, u1);
            let k0 = floor_i(z0 - r).max(clip.lo[2]);
            let k1 = floor_i(z1 + r).min(clip.hi[2]);
            if k1 >= k0 {
                count += (k1 - k0 + 1) as u64;
                if count > limit {
                    return Err(OverLimit);
                }
                for k in k0..=k1 {
                    emit([i, j, k]);
                }
            }
        }
    }
    Ok(count)
}

/// The cells of the range `lo..=hi` (at most `out.len()` of them) that meet the segment
/// `a`-`b` grown by a cube of half-side `r`, in increasing `(x, y, z)` order; returns their
/// number. `lo..=hi` must be the segment's cell range grown by `r`; see [`short_mask`].
pub(crate) fn short_segment(
    a: [f64; 3],
    b: [f64; 3],
    r: f64,
    lo: [i64; 3],
    hi: [i64; 3],
    out: &mut [[i64; 3]],
) -> usize {
    let n = [0, 1, 2].map(|k| (hi[k] - lo[k] + 1).clamp(0, 4) as usize);
    let mut mask = short_mask(a, b, r, lo, n);
    let mut m = 0;
    while mask != 0 && m < out.len() {
        let t = i64::from(mask.trailing_zeros());
        mask &= mask - 1;
        out[m] = [lo[0] + (t >> 4), lo[1] + ((t >> 2) & 3), lo[2] + (t & 3)];
        m += 1;
    }
    m
}

/// `max` and `min` by plain comparisons rather than `f64::max`: every value in the short covers
/// is finite.
#[inline(always)]
fn mx(a: f64, b: f64) -> f64 {
    if a > b { a } else { b }
}

#[inline(always)]
fn mn(a: f64, b: f64) -> f64 {
    if a < b { a } else { b }
}

/// [`short_mask`] for a range of at most 2 cells per axis (most short covers): the same bounds
/// and tests, unrolled, with the intervals of each axis as `[t0, t1]` of its first cell then of
/// its second (empty for an axis of one cell). Cell `lo + (i, j, k)` is bit `4 i + 2 j + k`.
/// Each `n` is 1 or 2.
#[inline(always)]
pub(crate) fn small_mask(a: [f64; 3], b: [f64; 3], r: f64, lo: [i64; 3], n: [usize; 3]) -> u64 {
    let axis = |k: usize| -> [f64; 4] {
        if n[k] == 1 {
            return [0.0, 1.0, 2.0, -1.0];
        }
        let d = b[k] - a[k];
        if d.abs() > TINY {
            let inv = 1.0 / d;
            let base = lo[k] as f64 - a[k];
            // `base + 0 + 1` is `base + 1`, also for `base = -0`.
            let up = (base + 1.0 + r) * inv;
            let down = (base + 1.0 - r) * inv;
            if d > 0.0 {
                [0.0, mn(up, 1.0), mx(down, 0.0), 1.0]
            } else {
                [mx(up, 0.0), 1.0, 0.0, mn(down, 1.0)]
            }
        } else {
            let upper = |c: i64| {
                let f = (lo[k] + c) as f64;
                if a[k] >= f - r && a[k] <= f + 1.0 + r {
                    1.0
                } else {
                    -1.0
                }
            };
            [0.0, upper(0), 0.0, upper(1)]
        }
    };
    let (x, y, z) = (axis(0), axis(1), axis(2));
    let mut mask = 0u64;
    for i in 0..2 {
        for j in 0..2 {
            let (y0, y1) = (mx(y[2 * j], x[2 * i]), mn(y[2 * j + 1], x[2 * i + 1]));
            for k in 0..2 {
                let keep = mx(z[2 * k], y0) <= mn(z[2 * k + 1], y1);
                mask |= u64::from(keep) << (4 * i + 2 * j + k);
            }
        }
    }
    mask
}

/// The cells `lo + (i, j, k)`, `i < n[0]`, `j < n[1]`, `k < n[2]` (each `n` at most 4) that meet
/// the segment `a`-`b` grown by a cube of half-side `r`, as bit `16 i + 4 j + k` of a mask (bit
/// order is key order). A cell is kept when the parameter intervals of its three slabs, grown by
/// `r`, intersect within `[0, 1]`: the same cells as [`segment`] up to rounding (both hold every
/// cell the grown segment meets), for a segment whose cell range is small. No list is built, so
/// that the caller can derive keys and earlier-cell bit sets from the mask directly. `lo` and
/// `lo + n - 1` must be the segment's cell range grown by `r` (`floor(min - r)`,
/// `floor(max + r)` per axis), as [`crate::grid::cell_range`] gives.
#[inline]
pub(crate) fn short_mask(a: [f64; 3], b: [f64; 3], r: f64, lo: [i64; 3], n: [usize; 3]) -> u64 {
    if n.contains(&0) {
        return 0;
    }
    if n[0] <= 2 && n[1] <= 2 && n[2] <= 2 {
        // Bit 4 i + 2 j + k to bit 16 i + 4 j + k.
        let m = small_mask(a, b, r, lo, n);
        return (m & 0x3) | ((m & 0xc) << 2) | ((m & 0x30) << 12) | ((m & 0xc0) << 14);
    }
    // Per axis and per cell of the range, the parameter interval inside its grown slab (empty
    // when lower > upper), clamped to [0, 1]. Along a segment that is not flat on that axis,
    // the slabs are crossed in order, and the first cell's interval starts at the segment's
    // start and the last one's ends at its end: the range was rounded outwards from the ends
    // grown by `r >= 0.001` cell, so that these bounds are beyond [0, 1] by at least `2 r / |d|`
    // and clamp to exactly 0 and 1. Only the bounds between two cells of the range are
    // computed, by the same expressions as the general test (`f = lo - a + c`, `(f - r) / d`,
    // `(f + 1 + r) / d`): none for an axis of one cell.
    let mut t0 = [[0.0f64; 4]; 3];
    let mut t1 = [[1.0f64; 4]; 3];
    for k in 0..3 {
        if n[k] <= 1 {
            continue;
        }
        let d = b[k] - a[k];
        if d.abs() > TINY {
            let inv = 1.0 / d;
            let base = lo[k] as f64 - a[k];
            for c in 0..n[k] - 1 {
                // Upper slab bound of cell c, lower slab bound of cell c + 1.
                let up = (base + c as f64 + 1.0 + r) * inv;
                let down = (base + (c + 1) as f64 - r) * inv;
                if d > 0.0 {
                    t1[k][c] = mn(up, 1.0);
                    t0[k][c + 1] = mx(down, 0.0);
                } else {
                    t0[k][c] = mx(up, 0.0);
                    t1[k][c + 1] = mn(down, 1.0);
                }
            }
        } else {
            for c in 0..n[k] {
                let f = (lo[k] + c as i64) as f64;
                if !(a[k] >= f - r && a[k] <= f + 1.0 + r) {
                    t1[k][c] = -1.0;
                }
            }
        }
    }
    // A cell is kept when the largest of its three lower bounds is at most the smallest upper
    // bound (an empty interval fails by itself).
    let mut mask = 0u64;
    for i in 0..n[0] {
        for j in 0..n[1] {
            let (y0, y1) = (mx(t0[1][j], t0[0][i]), mn(t1[1][j], t1[0][i]));
            for k in 0..n[2] {
                let keep = mx(t0[2][k], y0) <= mn(t1[2][k], y1);
                mask |= u64::from(keep) << (16 * i + 4 * j + k);
            }
        }
    }
    mask
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Emits, in increasing `(x, y, z)` order, every cell within the clip box that meets the flat
/// convex polygon `verts` (a triangle or a rectangle, in order around it) grown by a cube of
/// half-side `r`. Cells of the polygon's bounding box are kept when they pass the separating-axis
/// tests on the plane normal and the in-plane edge normals (the remaining cross-product axes are
/// skipped, so the cover is conservative). A polygon with no area is covered through its edges.
pub(crate) fn polygon(
    verts: &[[f64; 3]],
    r: f64,
    clip: &CellBox,
    limit: u64,
    scratch: &mut Vec<[i64; 3]>,
    emit: &mut impl FnMut([i64; 3]),
) -> Result<u64, OverLimit> {
    let n = verts.len();
    let mut normal = [0.0; 3];
    for k in 1..n.saturating_sub(1) {
        let c = cross(sub(verts[k], verts[0]), sub(verts[k + 1], verts[0]));
        normal = [normal[0] + c[0], normal[1] + c[1], normal[2] + c[2]];
    }
    let scale = verts
        .iter()
        .flat_map(|v| v.iter())
        .fold(1.0f64, |m, v| m.max(v.abs()));
    let area2 = dot(normal, normal).sqrt();
    if area2 <= 1e-12 * scale * scale {
        // Degenerate: a segment or a point. Cover every edge, then sort and deduplicate.
        scratch.clear();
        for k in 0..n {
            let (p, q) = (verts[k], verts[(k + 1) % n]);
            segment(p, q, r, clip, limit, &mut |c| scratch.push(c))?;
        }
        scratch.sort_unstable();
        scratch.dedup();
        if scratch.len() as u64 > limit {
            return Err(OverLimit);
        }
        for &c in scratch.iter() {
            emit(c);
        }
        return Ok(scratch.len() as u64);
    }
    // Axes: plane normal, then in-plane edge normals.
    let mut axes: [[f64; 3]; 5] = [[0.0; 3]; 5];
    let mut ranges: [(f64, f64); 5] = [(0.0, 0.0); 5];
    axes[0] = normal;
    let n_axes = 1 + n.min(4);
    for k in 0..n.min(4) {
        axes[1 + k] = cross(normal, sub(verts[(k + 1) % n], verts[k]));
    }
    for a in 0..n_axes {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in verts {
            let p = dot(axes[a], *v);
            lo = lo.min(p);
            hi = hi.max(p);
        }
        ranges[a] = (lo, hi);
    }
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for v in verts {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
    let mut cl = [0i64; 3];
    let mut ch = [0i64; 3];
    for k in 0..3 {
        cl[k] = floor_i(lo[k] - r).max(clip.lo[k]);
        ch[k] = floor_i(hi[k] + r).min(clip.hi[k]);
    }
    let half = 0.5 + r;
    let mut count = 0u64;
    for i in cl[0]..=ch[0] {
        for j in cl[1]..=ch[1] {
            for k in cl[2]..=ch[2] {
                let c = [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5];
                let inside = (0..n_axes).all(|a| {
                    let ax = axes[a];
                    let m = dot(ax, c);
                    let e = half * (ax[0].abs() + ax[1].abs() + ax[2].abs());
                    let slack = 1e-9 * (e + m.abs() + 1.0);
                    m + e + slack >= ranges[a].0 && m - e - slack <= ranges[a].1
                });
                if inside {
                    count += 1;
                    if count > limit {
                        return Err(OverLimit);
                    }
                    emit([i, j, k]);
                }
            }
        }
    }
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diagonal_segment_covers_far_fewer_cells_than_its_box() {
        let mut cells = Vec::new();
        segment(
            [0.5; 3],
            [20.5; 3],
            0.05,
            &CellBox::ALL,
            u64::MAX,
            &mut |c| cells.push(c),
        )
        .unwrap();
        assert!(cells.len() < 200, "{}", cells.len());
        assert!(cells.windows(2).all(|w| w[0] < w[1]));
        assert!(cells.contains(&[0, 0, 0]) && cells.contains(&[20, 20, 20]));
    }

    #[test]
    fn floor_small_is_floor() {
        let mut z = 3u64;
        for n in 0..100_000 {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let u = (z >> 11) as f64 / (1u64 << 53) as f64;
            let v = match n % 4 {
                0 => (u - 0.5) * 4.2e6,
                1 => ((u - 0.5) * 64.0).round() + [0.0, -1e-12, 1e-12, 0.5][n % 3],
                2 => (u - 0.5) * 1e-6,
                _ => (u - 0.5) * 2f64.powi(50),
            };
            assert_eq!(floor_small(v), floor_i(v), "{v}");
        }
        for v in [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.5,
            -2.5,
            1048575.999999,
            -1048576.0,
        ] {
            assert_eq!(floor_small(v), floor_i(v), "{v}");
        }
    }

    #[test]
    fn short_segments_cover_the_cells_the_walk_covers() {
        // Seeded segments about one cell long, some along an axis or a plane of the lattice.
        let mut z = 7u64;
        let mut unit = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut tested = 0;
        for n in 0..20_000 {
            let a = [0; 3].map(|_| unit() * 8.0 - 4.0);
            let mut b = [0; 3].map(|_| 0.0);
            for k in 0..3 {
                b[k] = a[k] + unit() * 2.0 - 1.0;
            }
            if n % 7 == 0 {
                b[n % 3] = a[n % 3];
            }
            let r = 0.001 + unit() * 0.3;
            let mut walk = Vec::new();
            segment(a, b, r, &CellBox::ALL, u64::MAX, &mut |c| walk.push(c)).unwrap();
            let lo = [0, 1, 2].map(|k| floor_i(a[k].min(b[k]) - r));
            let hi = [0, 1, 2].map(|k| floor_i(a[k].max(b[k]) + r));
            if (0..3).any(|k| hi[k] - lo[k] >= 4) {
                continue;
            }
            let mut out = [[0i64; 3]; 64];
            let m = short_segment(a, b, r, lo, hi, &mut out);
            assert_eq!(&out[..m], &walk[..], "{a:?} {b:?} {r}");
            tested += 1;
        }
        assert!(tested > 10_000, "{tested}");
    }

    #[test]
    fn limit_stops_a_huge_walk() {
        let r = segment(
            [0.0; 3],
            [1e6, 0.0, 0.0],
            100.0,
            &CellBox::ALL,
            1000,
            &mut |_| {},
        );
        assert_eq!(r, Err(OverLimit));
    }
}
