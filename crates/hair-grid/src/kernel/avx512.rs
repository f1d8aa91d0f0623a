//! The AVX-512 kernel: a cell in blocks of sixteen sections, each block's boxes gathered by
//! one load per box and a transpose in registers, sixteen boxes per compare with the neighbour
//! and owner tests lane-wise and the kept pairs taken by one compress (no loop over the hits);
//! the exact test on sixteen candidates per instruction; eight short covers at once in `f64`
//! lanes.

use std::ops::Range;

use super::{BlockRows, Isa, MAGIC, covers_out, lines8};
use crate::grid::Covers8;
use crate::pairs::{
    Block16, CellEntries, CellWork, LANES, Line, PBox, PairChunk, Report, UNKNOWN, WINDOW,
};
use crate::{Grid, Real, Section};

/// The AVX-512 kernel. A value exists only on a processor with AVX-512F, AVX2, POPCNT and BMI1
/// ([`Avx512::detect`]), which makes its `#[target_feature]` functions sound to call.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx512 {
    _found: (),
}

impl Avx512 {
    /// The kernel, when this processor has AVX-512F, AVX2, POPCNT and BMI1 (asked once, then
    /// cached by the standard library).
    pub(crate) fn detect() -> Option<Self> {
        let found = std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
            && std::arch::is_x86_feature_detected!("avx2");
        found.then_some(Self { _found: () })
    }
}

impl Isa for Avx512 {
    const EXACT_LANES: usize = 2 * LANES;

    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx512` exists only where its instructions were found"
    )]
    fn task(self, grid: &Grid, cells: Range<usize>, chunk: &mut PairChunk, report: Report) {
        /// The task compiled for AVX-512, so that the generic search inlined into it is too.
        #[target_feature(enable = "avx512f,avx2,popcnt,bmi1")]
        fn run(k: Avx512, grid: &Grid, cells: Range<usize>, chunk: &mut PairChunk, report: Report) {
            grid.task(k, cells, chunk, report);
        }
        // SAFETY: `self` exists only when `Avx512::detect` found AVX-512F, AVX2, POPCNT and BMI1
        // on this processor.
        unsafe { run(self, grid, cells, chunk, report) }
    }

    #[inline(always)]
    fn cell(self, grid: &Grid, cell: &CellEntries, work: &mut CellWork, report: Report) {
        grid.cell_pairs_blocks(self, cell, work, report);
    }

    #[inline(always)]
    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx512` exists only where its instructions were found"
    )]
    fn exact(self, lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32) {
        // SAFETY: `self` exists only when `Avx512::detect` found AVX-512F on this processor.
        unsafe { lanes_decide_avx512(lines, block, margin) }
    }

    #[inline(always)]
    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx512` exists only where its instructions were found"
    )]
    fn small_covers(self, secs: &[Section], inv: f64, grow: f64, out: &mut Covers8) {
        // SAFETY: `self` exists only when `Avx512::detect` found AVX-512F on this processor.
        unsafe { small_covers_avx512(secs, inv, grow, out) }
    }
}

impl BlockRows for Avx512 {
    #[inline(always)]
    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx512` exists only where its instructions were found"
    )]
    fn gather(self, boxes: &[PBox], ents: &[u32], earlier: &[u64], blocks: &mut [Block16]) -> u64 {
        // SAFETY: `self` exists only when `Avx512::detect` found AVX-512F on this processor.
        unsafe { gather_avx512(boxes, ents, earlier, blocks) }
    }

    #[inline(always)]
    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx512` exists only where its instructions were found"
    )]
    fn row(
        self,
        blocks: &[Block16],
        m: usize,
        a: usize,
        skip: u32,
        special: bool,
        _unknown: bool,
        row: &mut [[u32; 2]],
    ) -> Option<usize> {
        // SAFETY: `self` exists only when `Avx512::detect` found AVX-512F, POPCNT and BMI1 on
        // this processor.
        unsafe { row_avx512(blocks, m, a, skip, special, row) }
    }
}

/// The 16 x 8 transpose of sixteen rows of eight floats: lane `l` of output `k` is field `k` of
/// row `l`. Register `i` takes rows `i` and `i + 8`, one per 256-bit half, and each half is
/// transposed as eight by eight ([`transpose8`](super::avx2::transpose8)'s steps, the last as a two-register pick).
#[target_feature(enable = "avx512f")]
#[inline]
fn transpose16x8(rows: [std::arch::x86_64::__m256; 16]) -> [std::arch::x86_64::__m512; 8] {
    use std::arch::x86_64::{
        __m512, _mm256_castps_pd, _mm512_castpd_ps, _mm512_castpd256_pd512, _mm512_insertf64x4,
        _mm512_permutex2var_ps, _mm512_setr_epi32, _mm512_shuffle_ps, _mm512_unpackhi_ps,
        _mm512_unpacklo_ps,
    };
    let z: [__m512; 8] = std::array::from_fn(|i| {
        _mm512_castpd_ps(_mm512_insertf64x4::<1>(
            _mm512_castpd256_pd512(_mm256_castps_pd(rows[i])),
            _mm256_castps_pd(rows[i + 8]),
        ))
    });
    let t = [
        _mm512_unpacklo_ps(z[0], z[1]),
        _mm512_unpackhi_ps(z[0], z[1]),
        _mm512_unpacklo_ps(z[2], z[3]),
        _mm512_unpackhi_ps(z[2], z[3]),
        _mm512_unpacklo_ps(z[4], z[5]),
        _mm512_unpackhi_ps(z[4], z[5]),
        _mm512_unpacklo_ps(z[6], z[7]),
        _mm512_unpackhi_ps(z[6], z[7]),
    ];
    let s = [
        _mm512_shuffle_ps::<0x44>(t[0], t[2]),
        _mm512_shuffle_ps::<0xee>(t[0], t[2]),
        _mm512_shuffle_ps::<0x44>(t[1], t[3]),
        _mm512_shuffle_ps::<0xee>(t[1], t[3]),
        _mm512_shuffle_ps::<0x44>(t[4], t[6]),
        _mm512_shuffle_ps::<0xee>(t[4], t[6]),
        _mm512_shuffle_ps::<0x44>(t[5], t[7]),
        _mm512_shuffle_ps::<0xee>(t[5], t[7]),
    ];
    // Lane picks that pair the 128-bit quarters of two registers: the low or the high quarter
    // of each half (what `_mm256_permute2f128_ps` does in the eight-wide transpose).
    let low = _mm512_setr_epi32(0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27);
    let high = _mm512_setr_epi32(4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28, 29, 30, 31);
    std::array::from_fn(|k| {
        let pick = if k < 4 { low } else { high };
        _mm512_permutex2var_ps(s[k % 4], pick, s[k % 4 + 4])
    })
}

/// `lanes_decide_avx2` on sixteen candidates with AVX-512: the same operations in the same
/// order on every lane (`lss_lanes!`), so the same values and decisions.
#[target_feature(enable = "avx512f")]
#[inline]
#[expect(
    unsafe_code,
    reason = "unaligned 256-bit loads of whole `Line`s; sound: a `Line` is eight contiguous floats"
)]
fn lanes_decide_avx512(lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32) {
    use std::arch::x86_64::{
        __m256, __m512, _CMP_GT_OQ, _CMP_LT_OQ, _mm256_loadu_ps, _mm512_add_ps, _mm512_cmp_ps_mask,
        _mm512_div_ps, _mm512_mask_blend_ps, _mm512_max_ps, _mm512_min_ps, _mm512_mul_ps,
        _mm512_set1_ps, _mm512_sqrt_ps, _mm512_sub_ps,
    };
    assert!(block.len() >= 2 * LANES);
    let load = |i: u32| -> __m256 {
        let line: &Line = &lines[i as usize];
        // SAFETY: a `Line` is eight contiguous floats.
        unsafe { _mm256_loadu_ps(line.as_ptr()) }
    };
    let p = transpose16x8(std::array::from_fn(|l| load(block[l][0])));
    let q = transpose16x8(std::array::from_fn(|l| load(block[l][1])));
    let (add, sub) = (_mm512_add_ps, _mm512_sub_ps);
    let (d, band) = lss_lanes!(
        p,
        q,
        __m512,
        add,
        sub,
        _mm512_mul_ps,
        _mm512_div_ps,
        _mm512_min_ps,
        _mm512_max_ps,
        _mm512_sqrt_ps,
        _mm512_set1_ps,
        |a, b| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b),
        // mask_blend(mask, x, y) takes `y` where the mask is set.
        |cond, no, yes| _mm512_mask_blend_ps(cond, no, yes)
    );
    let margin = _mm512_set1_ps(margin);
    let inside = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(d, sub(margin, band));
    let outside = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(d, add(margin, band));
    let sure = u32::from(inside);
    (sure, !(sure | u32::from(outside)) & 0xffff)
}

/// Fills `blocks` with the sections `ents` (internal indices) of a cell and their earlier-cell
/// bit sets, sixteen per block, lanes past the last section with NaN boxes; returns the union
/// of the bit sets. A [`PBox`] is eight 32-bit fields in the order of a block's first eight
/// columns, so each sixteen boxes are loaded whole and transposed in registers, in far fewer
/// instructions than writing them field by field (`docs/perf/grid.md`).
#[target_feature(enable = "avx512f")]
#[inline]
#[expect(
    unsafe_code,
    reason = "loads of whole `PBox`es and masked loads and stores of block fields; sound: indices are asserted in range, `Block16` is `repr(C)` with its columns first, and the masks cover only the cell's sections"
)]
fn gather_avx512(boxes: &[PBox], ents: &[u32], earlier: &[u64], blocks: &mut [Block16]) -> u64 {
    use std::arch::x86_64::{
        __m256, _mm256_loadu_ps, _mm512_mask_blend_ps, _mm512_maskz_loadu_epi32,
        _mm512_maskz_loadu_epi64, _mm512_or_si512, _mm512_reduce_or_epi64, _mm512_set1_ps,
        _mm512_setzero_si512, _mm512_storeu_epi32, _mm512_storeu_epi64, _mm512_storeu_ps,
    };
    let m = ents.len();
    assert!(m > 0 && earlier.len() == m && blocks.len() == m.div_ceil(16));
    assert!(ents.iter().all(|&i| (i as usize) < boxes.len()));
    // One row of eight fields, as floats (the ids' bits are moved unchanged).
    let row = |i: u32| -> __m256 {
        // SAFETY: `i < boxes.len()` (asserted above), and a `PBox` is eight 32-bit fields.
        unsafe { _mm256_loadu_ps(boxes.as_ptr().add(i as usize).cast()) }
    };
    let nan = _mm512_set1_ps(f32::NAN);
    let mut any = _mm512_setzero_si512();
    for (b, blk) in blocks.iter_mut().enumerate() {
        let first = 16 * b;
        let count = (m - first).min(16);
        let valid: u16 = if count == 16 {
            0xffff
        } else {
            (1 << count) - 1
        };
        // Rows past the cell's end repeat its first section; their lanes are masked below.
        let at = |l: usize| if l < count { ents[first + l] } else { ents[0] };
        let z: [__m256; 16] = std::array::from_fn(|i| row(at(i)));
        let cols = transpose16x8(z);
        let base = (blk as *mut Block16).cast::<f32>();
        let ents_at = ents.as_ptr().wrapping_add(first);
        let earlier_at = earlier.as_ptr().wrapping_add(first);
        // SAFETY: a `Block16` starts with its eight columns of sixteen 32-bit fields (`repr(C)`:
        // lo, hi, skel, seg), then `ents` and `earlier`; the masked loads read only the lanes
        // of sections `first..first + count`, inside `ents` and `earlier`.
        unsafe {
            for (k, &col) in cols.iter().enumerate() {
                // The boxes' lanes past the end are NaN, which fails every comparison.
                let col = if k < 6 {
                    _mm512_mask_blend_ps(valid, nan, col)
                } else {
                    col
                };
                _mm512_storeu_ps(base.add(16 * k), col);
            }
            _mm512_storeu_epi32(
                blk.ents.as_mut_ptr().cast(),
                _mm512_maskz_loadu_epi32(valid, ents_at.cast()),
            );
            let e0 = _mm512_maskz_loadu_epi64(valid as u8, earlier_at.cast());
            let e1 =
                _mm512_maskz_loadu_epi64((valid >> 8) as u8, earlier_at.wrapping_add(8).cast());
            _mm512_storeu_epi64(blk.earlier.as_mut_ptr().cast(), e0);
            _mm512_storeu_epi64(blk.earlier.as_mut_ptr().add(8).cast(), e1);
            any = _mm512_or_si512(any, _mm512_or_si512(e0, e1));
        }
    }
    _mm512_reduce_or_epi64(any) as u64
}

/// A row of a cell with AVX-512 (on the cell in blocks of sixteen): the
/// pairs of section `a` with the later sections of the cell that this cell reports, written to
/// the start of `row`, and their count. Sixteen boxes per compare, and the neighbour and owner
/// tests lane-wise too, so that a block's kept pairs come out of one mask and a compress, with
/// no loop over the hits (with AVX2 that loop cost about as much as the box tests). `special`
/// says that the cell holds bit sets with [`OUTSIDE`](crate::pairs::OUTSIDE) or [`UNKNOWN`](crate::pairs::UNKNOWN); then a row with a pair
/// the bit sets cannot tell ([`owner`](crate::pairs::owner)'s `unsure`, rare) gives `None`, for
/// `Grid::row_blocks` to do again with the key lists. (No call inside: around one, every
/// vector register would be spilled.)
#[target_feature(enable = "avx512f,popcnt,bmi1")]
#[inline]
#[expect(
    unsafe_code,
    reason = "unaligned loads of block columns and stores of kept pairs; sound: each load reads one sixteen-lane column, and `row` has room for the stores (asserted)"
)]
fn row_avx512(
    blocks: &[Block16],
    m: usize,
    a: usize,
    skip: u32,
    special: bool,
    row: &mut [[u32; 2]],
) -> Option<usize> {
    use std::arch::x86_64::{
        __m512, __m512i, _CMP_LE_OQ, _mm512_cmp_ps_mask, _mm512_cmpgt_epu32_mask,
        _mm512_cmpneq_epu32_mask, _mm512_loadu_epi32, _mm512_loadu_epi64, _mm512_loadu_ps,
        _mm512_maskz_compress_epi32, _mm512_max_epu32, _mm512_min_epu32, _mm512_permutex2var_epi32,
        _mm512_set1_epi32, _mm512_set1_epi64, _mm512_set1_ps, _mm512_setr_epi32,
        _mm512_storeu_epi32, _mm512_sub_epi32, _mm512_test_epi64_mask, _mm512_testn_epi64_mask,
    };
    // The blocks hold `m` sections; `row` has room for one pair per section after `a` and
    // sixteen more (the last block's stores go past its kept pairs).
    assert!(a + 1 < m && blocks.len() >= m.div_ceil(16) && row.len() >= m - a - 1 + 16);
    let (ba, la) = (&blocks[a / 16], a % 16);
    let (lo, hi) = (
        [0, 1, 2].map(|k| ba.lo[k][la]),
        [0, 1, 2].map(|k| ba.hi[k][la]),
    );
    let lo_a = lo.map(|v| _mm512_set1_ps(v));
    let hi_a = hi.map(|v| _mm512_set1_ps(v));
    let ea = ba.earlier[la];
    let earlier_a = _mm512_set1_epi64(ea as i64);
    let window_a = _mm512_set1_epi64((ea & WINDOW) as i64);
    let unknown = _mm512_set1_epi64(UNKNOWN as i64);
    let unknown_a: u16 = if ea & UNKNOWN != 0 { 0xffff } else { 0 };
    let skel_a = _mm512_set1_epi32(ba.skel[la] as i32);
    let seg_a = _mm512_set1_epi32(ba.seg[la] as i32);
    let skip = _mm512_set1_epi32(skip as i32);
    let ent_a = _mm512_set1_epi32(ba.ents[la] as i32);
    // The pair `[ent_a, b_l]` of lane `l` of the compressed entries: lanes 0-7, then 8-15.
    let first8 = _mm512_setr_epi32(0, 16, 0, 17, 0, 18, 0, 19, 0, 20, 0, 21, 0, 22, 0, 23);
    let last8 = _mm512_setr_epi32(0, 24, 0, 25, 0, 26, 0, 27, 0, 28, 0, 29, 0, 30, 0, 31);
    let ps = |c: &[f32; 16]| -> __m512 {
        // SAFETY: sixteen floats.
        unsafe { _mm512_loadu_ps(c.as_ptr()) }
    };
    let epi32 = |c: &[u32; 16]| -> __m512i {
        // SAFETY: sixteen 32-bit integers.
        unsafe { _mm512_loadu_epi32(c.as_ptr().cast()) }
    };
    let epi64 = |c: &[u64]| -> __m512i {
        // SAFETY: called on halves of sixteen 64-bit integers: eight.
        unsafe { _mm512_loadu_epi64(c.as_ptr().cast()) }
    };
    // Sixteen lanes of a 64-bit test, from its two halves.
    let join = |lo: u8, hi: u8| u16::from(lo) | u16::from(hi) << 8;
    let le = |a: __m512, b: __m512| _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b);
    let out = row.as_mut_ptr().cast::<i32>();
    let mut k = 0usize;
    // The sections after `a`: the rest of its block, then the whole later blocks.
    let mut lanes = 0xffffu16.checked_shl(la as u32 + 1).unwrap_or(0);
    for blk in &blocks[a / 16..m.div_ceil(16)] {
        // Box overlap (ordered compares: false for the NaN padding), each independent of the
        // others: chained through masks they would wait on one another.
        let x = le(ps(&blk.lo[0]), hi_a[0]) & le(lo_a[0], ps(&blk.hi[0]));
        let y = le(ps(&blk.lo[1]), hi_a[1]) & le(lo_a[1], ps(&blk.hi[1]));
        let z = le(ps(&blk.lo[2]), hi_a[2]) & le(lo_a[2], ps(&blk.hi[2]));
        // Not neighbours on one skeleton: another skeleton, or segments more than `skip` apart
        // (|s_a - s_b| as max - min, unsigned).
        let segs = epi32(&blk.seg);
        let gap = _mm512_sub_epi32(_mm512_max_epu32(segs, seg_a), _mm512_min_epu32(segs, seg_a));
        let apart =
            _mm512_cmpneq_epu32_mask(epi32(&blk.skel), skel_a) | _mm512_cmpgt_epu32_mask(gap, skip);
        let hit = x & y & z & apart & lanes;
        lanes = 0xffff;
        // Owner: the bit sets share nothing.
        let (e0, e1) = (epi64(&blk.earlier[..8]), epi64(&blk.earlier[8..]));
        let here = join(
            _mm512_testn_epi64_mask(e0, earlier_a),
            _mm512_testn_epi64_mask(e1, earlier_a),
        );
        if special {
            // Undecided: they share only the outside bit, or one cover is too long to be
            // described.
            let no_window = join(
                _mm512_testn_epi64_mask(e0, window_a),
                _mm512_testn_epi64_mask(e1, window_a),
            );
            let unknown_b = join(
                _mm512_test_epi64_mask(e0, unknown),
                _mm512_test_epi64_mask(e1, unknown),
            );
            if hit & !here & (no_window | unknown_b | unknown_a) != 0 {
                return None;
            }
        }
        let keep = hit & here;
        let n = keep.count_ones() as usize;
        // The kept entries, packed to the low lanes in order, paired with `ent_a`: eight pairs
        // per store, the second store only for more than eight (rare, and well predicted).
        let kept = _mm512_maskz_compress_epi32(keep, epi32(&blk.ents));
        // SAFETY: the `k` pairs kept so far came from the sections between `a` and this block,
        // so `k + 16 <= m - a - 1 + 16 <= row.len()` (asserted above).
        unsafe {
            _mm512_storeu_epi32(
                out.add(2 * k),
                _mm512_permutex2var_epi32(ent_a, first8, kept),
            );
            if n > 8 {
                _mm512_storeu_epi32(
                    out.add(2 * k + 16),
                    _mm512_permutex2var_epi32(ent_a, last8, kept),
                );
            }
        }
        k += n;
    }
    Some(k)
}
/// `short_line` for eight sections at once with AVX-512, for the sections whose cover lies
/// within 2 x 2 x 2 cells (most hair sections): the same expressions, lane by lane
/// (`small_cover_lanes!`), so the same ranges and masks, into `out`. Every other section (not an LSS,
/// outside the lattice, a negative or NaN radius, a longer range) gets `None`, for the scalar
/// path to cover or reject.
#[target_feature(enable = "avx512f")]
#[inline]
#[expect(
    unsafe_code,
    reason = "AVX loads and AVX-512 stores on local arrays; sound: each covers eight floats or eight `i64`s of its array"
)]
pub(super) fn small_covers_avx512(secs: &[Section], inv: f64, grow: f64, out: &mut Covers8) {
    use std::arch::x86_64::{
        __m512d, __m512i, __mmask8, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm512_abs_pd,
        _mm512_add_epi64, _mm512_add_pd, _mm512_castpd_si512, _mm512_cmp_pd_mask,
        _mm512_cmpeq_epi64_mask, _mm512_cmple_epi64_mask, _mm512_cvtps_pd, _mm512_div_pd,
        _mm512_mask_blend_pd, _mm512_mask_or_epi64, _mm512_mask_sub_epi64, _mm512_max_pd,
        _mm512_min_pd, _mm512_mul_pd, _mm512_set1_epi64, _mm512_set1_pd, _mm512_setzero_si512,
        _mm512_storeu_epi64, _mm512_sub_epi64, _mm512_sub_pd,
    };
    *out = [None; 8];
    let mut f = [[0.0f32; 8]; 7];
    let line = lines8(secs, &mut f);
    let wide = |c: &[f32; 8]| -> __m512d {
        // SAFETY: eight floats.
        _mm512_cvtps_pd(unsafe { std::arch::x86_64::_mm256_loadu_ps(c.as_ptr()) })
    };
    let inv_v = _mm512_set1_pd(inv);
    let va: [__m512d; 3] = std::array::from_fn(|k| _mm512_mul_pd(wide(&f[k]), inv_v));
    let vb: [__m512d; 3] = std::array::from_fn(|k| _mm512_mul_pd(wide(&f[3 + k]), inv_v));
    let one = _mm512_set1_pd(1.0);
    let magic = _mm512_set1_pd(MAGIC);
    let magic_bits = _mm512_set1_epi64(MAGIC.to_bits() as i64);
    let one_i = _mm512_set1_epi64(1);
    // `floor_small`: the floor as an integer and as a float (exact: small integers).
    let floor = |v: __m512d| -> (__m512i, __m512d) {
        let sum = _mm512_add_pd(v, magic);
        let back = _mm512_sub_pd(sum, magic);
        let over = _mm512_cmp_pd_mask::<_CMP_GT_OQ>(back, v);
        let k = _mm512_sub_epi64(_mm512_castpd_si512(sum), magic_bits);
        let k = _mm512_mask_sub_epi64(k, over, k, one_i);
        (
            k,
            _mm512_mask_blend_pd(over, back, _mm512_sub_pd(back, one)),
        )
    };
    let (ok, cl, ch, mask) = small_cover_lanes!(
        va, vb, wide(&f[6]), line, inv, grow, __m512d,
        add: _mm512_add_pd,
        sub: _mm512_sub_pd,
        mul: _mm512_mul_pd,
        div: _mm512_div_pd,
        min: _mm512_min_pd,
        max: _mm512_max_pd,
        abs: _mm512_abs_pd,
        splat: _mm512_set1_pd,
        cmp: _mm512_cmp_pd_mask,
        and: |a: __mmask8, b: __mmask8| a & b,
        bits: u32::from,
        blend: |m: __mmask8, no, yes| _mm512_mask_blend_pd(m, no, yes),
        floor: floor,
        int_sub: _mm512_sub_epi64,
        int_one: one_i,
        int_add: _mm512_add_epi64,
        narrow: |n| u32::from(_mm512_cmple_epi64_mask(n, _mm512_set1_epi64(2))),
        single: |n| _mm512_cmpeq_epi64_mask(n, one_i),
        int_zero: _mm512_setzero_si512(),
        set: |mask, keep, bit| _mm512_mask_or_epi64(mask, keep, mask, _mm512_set1_epi64(bit))
    );
    let lanes = |v: __m512i| -> [i64; 8] {
        let mut t = [0i64; 8];
        // SAFETY: eight 64-bit integers.
        unsafe { _mm512_storeu_epi64(t.as_mut_ptr(), v) };
        t
    };
    let (cl, ch, mask) = (cl.map(lanes), ch.map(lanes), lanes(mask));
    covers_out(out, 0, secs.len(), ok, (&cl, &ch, &mask));
}
