//! The baseline kernel, on every processor: the cell's boxes by column, four per SSE2 compare
//! on x86-64 (SSE2 is part of every x86-64 processor) or eight at a time as bytes in plain Rust
//! elsewhere, the neighbour and owner tests hit by hit; the exact test in plain Rust, eight
//! lanes (hair-ssv's segment-segment kernel lane-wise).

use std::ops::Range;

use super::Isa;
use crate::grid::Covers8;
use crate::pairs::{CellEntries, CellView, CellWork, LANES, Line, PairChunk, Report, RowHead};
use crate::{Grid, Real, Section};

/// The baseline kernel (no token needed: every processor runs it).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Baseline;

impl Isa for Baseline {
    const EXACT_LANES: usize = LANES;

    #[inline]
    fn task(self, grid: &Grid, cells: Range<usize>, chunk: &mut PairChunk, report: Report) {
        grid.task(self, cells, chunk, report);
    }

    #[inline(always)]
    fn cell(self, grid: &Grid, cell: &CellEntries, work: &mut CellWork, report: Report) {
        grid.cell_pairs_columns(self, cell, work, report);
    }

    #[inline(always)]
    fn exact(self, lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32) {
        lanes_decide(lines, block, margin)
    }

    /// None: the scalar path covers every section.
    #[inline(always)]
    fn small_covers(self, _secs: &[Section], _inv: f64, _grow: f64, _out: &mut Covers8) {}
}

/// Multiplier that moves the low bit of each of the eight bytes of a word into its top byte.
#[cfg(any(test, not(target_arch = "x86_64")))]
const GATHER_BYTES: u64 = 0x0102_0408_1020_4080;
/// The exact test on eight candidates (`block`, internal indices) in plain Rust: hair-ssv's
/// segment-segment kernel lane-wise on the packed lines ([`hair_ssv::lss_lss_lanes`]), then
/// `(sure, open)` lane masks: the distance is surely within `margin`, or within a rounding band
/// of it (or NaN: not two LSS) so that the scalar test must decide.
#[inline(always)]
pub(crate) fn lanes_decide(lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32) {
    let mut p = [[0.0f32; LANES]; 8];
    let mut q = [[0.0f32; LANES]; 8];
    for (l, &[a, b]) in block.iter().enumerate().take(LANES) {
        let (la, lb) = (&lines[a as usize], &lines[b as usize]);
        for k in 0..8 {
            p[k][l] = la[k];
            q[k][l] = lb[k];
        }
    }
    let dir = |e: &[[f32; LANES]; 8], k: usize| -> [f32; LANES] {
        std::array::from_fn(|l| e[3 + k][l] - e[k][l])
    };
    let (u, v) = ([0, 1, 2].map(|k| dir(&p, k)), [0, 1, 2].map(|k| dir(&q, k)));
    let r: [[f32; LANES]; 3] = std::array::from_fn(|k| std::array::from_fn(|l| p[k][l] - q[k][l]));
    let radii: [f32; LANES] = std::array::from_fn(|l| p[6][l] + q[6][l]);
    let d = hair_ssv::lss_lss_lanes(&u, &v, &r, &radii);
    let band: [f32; LANES] = std::array::from_fn(|l| 1e-5 * p[7][l].max(q[7][l]));
    let (mut sure, mut open) = (0u32, 0u32);
    for l in 0..LANES {
        let inside = d[l] < margin - band[l];
        let outside = d[l] > margin + band[l];
        sure |= u32::from(inside) << l;
        open |= u32::from(!(inside | outside)) << l;
    }
    (sure, open)
}

/// Box tests of one row: bit `k` is set when the box at `start + k` (`k < len <= 64`) overlaps
/// the head's box.
///
/// On x86-64, four boxes per SSE2 compare and `movemask` (SSE2 is part of the base instruction
/// set): the portable form compiles to byte-wise compares whose conversion to bits took most of
/// the pair search's instructions.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[expect(
    unsafe_code,
    reason = "calls the SSE2 row and loads from column slices; sound: every x86-64 processor has SSE2, and each load reads four floats inside its slice"
)]
pub(crate) fn row_hits(view: &CellView, head: &RowHead, start: usize, len: usize) -> u64 {
    /// The row with SSE2 enabled, as the intrinsics require; inlined into the row's caller.
    #[target_feature(enable = "sse2")]
    #[inline]
    fn sse2(view: &CellView, head: &RowHead, start: usize, len: usize) -> u64 {
        use std::arch::x86_64::{
            __m128, _mm_and_ps, _mm_cmple_ps, _mm_loadu_ps, _mm_movemask_ps, _mm_set1_ps,
        };
        let [lx, ly, lz, hx, hy, hz] = view.cols;
        let end = start + len.div_ceil(4) * 4;
        let (lx, ly, lz) = (&lx[start..end], &ly[start..end], &lz[start..end]);
        let (hx, hy, hz) = (&hx[start..end], &hy[start..end], &hz[start..end]);
        let (lo, hi) = (head.lo, head.hi);
        let (lo_x, lo_y, lo_z) = (_mm_set1_ps(lo[0]), _mm_set1_ps(lo[1]), _mm_set1_ps(lo[2]));
        let (hi_x, hi_y, hi_z) = (_mm_set1_ps(hi[0]), _mm_set1_ps(hi[1]), _mm_set1_ps(hi[2]));
        // Four consecutive floats of a column, quad `q` of the row.
        let quad = |c: &[f32], q: usize| -> __m128 {
            debug_assert!(4 * q + 4 <= c.len());
            // SAFETY: `q < c.len() / 4` at every call below, so the four floats are inside `c`.
            unsafe { _mm_loadu_ps(c.as_ptr().add(4 * q)) }
        };
        let mut bits = 0u64;
        for q in 0..lx.len() / 4 {
            let x = _mm_and_ps(
                _mm_cmple_ps(quad(lx, q), hi_x),
                _mm_cmple_ps(lo_x, quad(hx, q)),
            );
            let y = _mm_and_ps(
                _mm_cmple_ps(quad(ly, q), hi_y),
                _mm_cmple_ps(lo_y, quad(hy, q)),
            );
            let z = _mm_and_ps(
                _mm_cmple_ps(quad(lz, q), hi_z),
                _mm_cmple_ps(lo_z, quad(hz, q)),
            );
            let hit = _mm_movemask_ps(_mm_and_ps(_mm_and_ps(x, y), z)) as u64;
            bits |= hit << (4 * q);
        }
        bits
    }
    // SAFETY: SSE2 is part of the x86-64 baseline, so every x86-64 processor has it (the
    // compiler enables it for this target by default).
    unsafe { sse2(view, head, start, len) }
}

/// Box tests of one row (see the x86-64 version): eight boxes at a time as bytes, gathered into
/// bits.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub(crate) fn row_hits(view: &CellView, head: &RowHead, start: usize, len: usize) -> u64 {
    row_hits_portable(view, head, start, len)
}

/// The box tests of one row in plain Rust (the kernel off x86-64; on x86-64, the tests' oracle).
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline(always)]
pub(crate) fn row_hits_portable(view: &CellView, head: &RowHead, start: usize, len: usize) -> u64 {
    let [lx, ly, lz, hx, hy, hz] = view.cols;
    let (lo, hi) = (head.lo, head.hi);
    let end = start + len.div_ceil(8) * 8;
    let mut bits = 0u64;
    for (w, b) in (start..end).step_by(8).enumerate() {
        let mut row = [0u8; 8];
        for k in 0..8 {
            row[k] = u8::from(
                (lx[b + k] <= hi[0])
                    & (hx[b + k] >= lo[0])
                    & (ly[b + k] <= hi[1])
                    & (hy[b + k] >= lo[1])
                    & (lz[b + k] <= hi[2])
                    & (hz[b + k] >= lo[2]),
            );
        }
        // Each byte is 0 or 1: the product gathers the eight low bits into the top byte.
        bits |= (u64::from_le_bytes(row).wrapping_mul(GATHER_BYTES) >> 56) << (8 * w);
    }
    bits
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::lcg;
    use crate::pairs::{CellCols, PAD};

    /// Empty columns for a cell of `m` sections (NaN boxes, no earlier cells).
    fn cell_cols(m: usize) -> CellCols {
        let mut cols = CellCols::default();
        for col in cols.boxes.iter_mut() {
            col.resize(m + PAD, f32::NAN);
        }
        cols.earlier.resize(m + PAD, 0);
        cols
    }

    #[test]
    fn row_kernels_agree_with_the_plain_box_test() {
        let mut z = 3u64;
        for m in [2usize, 5, 8, 9, 31, 64, 65, 130] {
            let mut cols = cell_cols(m);
            // Coordinates on a coarse lattice, so that boxes often touch exactly.
            for e in 0..m {
                for k in 0..3 {
                    let lo = (lcg(&mut z) * 16.0).floor() / 16.0;
                    cols.boxes[k][e] = lo;
                    cols.boxes[k + 3][e] = lo + (lcg(&mut z) * 5.0).floor() / 16.0;
                }
            }
            let view = CellView::new(&cols, m + PAD);
            for a in 0..m - 1 {
                let head = RowHead {
                    lo: [0, 1, 2].map(|k| cols.boxes[k][a]),
                    hi: [3, 4, 5].map(|k| cols.boxes[k][a]),
                    earlier: 0,
                };
                let n = m - a - 1;
                for g in 0..n.div_ceil(64) {
                    let (start, len) = (a + 1 + 64 * g, (n - 64 * g).min(64));
                    let expect: u64 = (0..len)
                        .filter(|&k| {
                            let b = start + k;
                            (0..3).all(|d| {
                                cols.boxes[d][b] <= head.hi[d] && cols.boxes[d + 3][b] >= head.lo[d]
                            })
                        })
                        .map(|k| 1u64 << k)
                        .sum();
                    assert_eq!(row_hits_portable(&view, &head, start, len), expect);
                    assert_eq!(row_hits(&view, &head, start, len), expect);
                }
            }
        }
    }
}
