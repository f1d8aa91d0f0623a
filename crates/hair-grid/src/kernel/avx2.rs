//! The AVX2 kernel: a cell in blocks of sixteen sections, eight boxes per compare less the hits
//! whose pair an earlier cell surely reports, then the neighbour and owner tests hit by hit; the
//! exact test on eight candidates per instruction; eight short covers at once, in two halves of
//! four `f64` lanes.

use std::ops::Range;

use super::{BlockRows, Isa, MAGIC, covers_out, lines8};
use crate::grid::Covers8;
use crate::pairs::{
    Block16, CellEntries, CellWork, LANES, Line, PBox, PairChunk, Report, UNKNOWN, WINDOW, owner,
};
use crate::{Grid, Real, Section};

/// The AVX2 kernel. A value exists only on a processor with AVX2 ([`Avx2::detect`]), which makes
/// its `#[target_feature(enable = "avx2")]` functions sound to call.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2 {
    _found: (),
}

impl Avx2 {
    /// The kernel, when this processor has AVX2 (asked once, then cached by the standard
    /// library).
    pub(crate) fn detect() -> Option<Self> {
        std::arch::is_x86_feature_detected!("avx2").then_some(Self { _found: () })
    }
}

impl Isa for Avx2 {
    const EXACT_LANES: usize = LANES;

    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx2` exists only where AVX2 was found"
    )]
    fn task(self, grid: &Grid, cells: Range<usize>, chunk: &mut PairChunk, report: Report) {
        /// The task compiled for AVX2, so that the generic search inlined into it is too.
        #[target_feature(enable = "avx2")]
        fn run(k: Avx2, grid: &Grid, cells: Range<usize>, chunk: &mut PairChunk, report: Report) {
            grid.task(k, cells, chunk, report);
        }
        // SAFETY: `self` exists only when `Avx2::detect` found AVX2 on this processor.
        unsafe { run(self, grid, cells, chunk, report) }
    }

    #[inline(always)]
    fn cell(self, grid: &Grid, cell: &CellEntries, work: &mut CellWork, report: Report) {
        grid.cell_pairs_blocks(self, cell, work, report);
    }

    #[inline(always)]
    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx2` exists only where AVX2 was found"
    )]
    fn exact(self, lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32) {
        // SAFETY: `self` exists only when `Avx2::detect` found AVX2 on this processor.
        unsafe { lanes_decide_avx2(lines, block, margin) }
    }

    #[inline(always)]
    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx2` exists only where AVX2 was found"
    )]
    fn small_covers(self, secs: &[Section], inv: f64, grow: f64, out: &mut Covers8) {
        // SAFETY: `self` exists only when `Avx2::detect` found AVX2 on this processor.
        unsafe { small_covers_avx2(secs, inv, grow, out) }
    }
}

impl BlockRows for Avx2 {
    #[inline(always)]
    fn gather(self, boxes: &[PBox], ents: &[u32], earlier: &[u64], blocks: &mut [Block16]) -> u64 {
        gather_blocks(boxes, ents, earlier, blocks)
    }

    #[inline(always)]
    #[expect(
        unsafe_code,
        reason = "calls a `#[target_feature]` function; sound: an `Avx2` exists only where AVX2 was found"
    )]
    fn row(
        self,
        blocks: &[Block16],
        m: usize,
        a: usize,
        skip: u32,
        _special: bool,
        unknown: bool,
        row: &mut [[u32; 2]],
    ) -> Option<usize> {
        // SAFETY: `self` exists only when `Avx2::detect` found AVX2 on this processor.
        unsafe { row_avx2(blocks, m, a, skip, unknown, row) }
    }
}

/// [`lanes_decide`](super::baseline::lanes_decide) with AVX2 intrinsics, the same operations in the same order (so the same
/// values): a core is eight floats, one register, so the eight first cores are loaded whole and
/// transposed in registers (the second ones the same way) instead of 128 single moves, and the
/// lane masks come from compares and `movemask` instead of a loop over the lanes.
#[target_feature(enable = "avx2")]
#[inline]
#[expect(
    unsafe_code,
    reason = "unaligned 256-bit loads of whole `Line`s; sound: a `Line` is eight contiguous floats"
)]
fn lanes_decide_avx2(lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32) {
    use std::arch::x86_64::{
        __m256, _CMP_GT_OQ, _CMP_LT_OQ, _mm256_add_ps, _mm256_blendv_ps, _mm256_cmp_ps,
        _mm256_div_ps, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_movemask_ps,
        _mm256_mul_ps, _mm256_set1_ps, _mm256_sqrt_ps, _mm256_sub_ps,
    };
    assert!(block.len() >= LANES);
    let load = |i: u32| -> __m256 {
        let line: &Line = &lines[i as usize];
        // SAFETY: a `Line` is eight contiguous floats.
        unsafe { _mm256_loadu_ps(line.as_ptr()) }
    };
    let p = transpose8(std::array::from_fn(|l| load(block[l][0])));
    let q = transpose8(std::array::from_fn(|l| load(block[l][1])));
    let (add, sub) = (_mm256_add_ps, _mm256_sub_ps);
    let (d, band) = lss_lanes!(
        p,
        q,
        __m256,
        add,
        sub,
        _mm256_mul_ps,
        _mm256_div_ps,
        _mm256_min_ps,
        _mm256_max_ps,
        _mm256_sqrt_ps,
        _mm256_set1_ps,
        |a, b| _mm256_cmp_ps::<_CMP_GT_OQ>(a, b),
        // blendv(x, y, mask) takes `y` where the mask is set.
        |cond, no, yes| _mm256_blendv_ps(no, yes, cond)
    );
    let margin = _mm256_set1_ps(margin);
    let inside = _mm256_cmp_ps::<_CMP_LT_OQ>(d, sub(margin, band));
    let outside = _mm256_cmp_ps::<_CMP_GT_OQ>(d, add(margin, band));
    let sure = _mm256_movemask_ps(inside) as u32;
    let decided = sure | _mm256_movemask_ps(outside) as u32;
    (sure, !decided & 0xff)
}

/// The 8 x 8 transpose of eight registers: lane `l` of output `k` is lane `k` of input `l`.
#[target_feature(enable = "avx2")]
#[inline]
pub(super) fn transpose8(r: [std::arch::x86_64::__m256; 8]) -> [std::arch::x86_64::__m256; 8] {
    use std::arch::x86_64::{
        _mm256_permute2f128_ps, _mm256_shuffle_ps, _mm256_unpackhi_ps, _mm256_unpacklo_ps,
    };
    // Pairs of rows interleaved, then pairs of pairs, then the 128-bit halves exchanged.
    let t0 = _mm256_unpacklo_ps(r[0], r[1]);
    let t1 = _mm256_unpackhi_ps(r[0], r[1]);
    let t2 = _mm256_unpacklo_ps(r[2], r[3]);
    let t3 = _mm256_unpackhi_ps(r[2], r[3]);
    let t4 = _mm256_unpacklo_ps(r[4], r[5]);
    let t5 = _mm256_unpackhi_ps(r[4], r[5]);
    let t6 = _mm256_unpacklo_ps(r[6], r[7]);
    let t7 = _mm256_unpackhi_ps(r[6], r[7]);
    let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
    let s1 = _mm256_shuffle_ps::<0xee>(t0, t2);
    let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
    let s3 = _mm256_shuffle_ps::<0xee>(t1, t3);
    let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
    let s5 = _mm256_shuffle_ps::<0xee>(t4, t6);
    let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
    let s7 = _mm256_shuffle_ps::<0xee>(t5, t7);
    [
        _mm256_permute2f128_ps::<0x20>(s0, s4),
        _mm256_permute2f128_ps::<0x20>(s1, s5),
        _mm256_permute2f128_ps::<0x20>(s2, s6),
        _mm256_permute2f128_ps::<0x20>(s3, s7),
        _mm256_permute2f128_ps::<0x31>(s0, s4),
        _mm256_permute2f128_ps::<0x31>(s1, s5),
        _mm256_permute2f128_ps::<0x31>(s2, s6),
        _mm256_permute2f128_ps::<0x31>(s3, s7),
    ]
}

/// The sections `ents` of a cell (with their earlier-cell bit sets) into blocks of sixteen,
/// field by field; the lanes past the last section get NaN boxes, which fail every comparison.
/// Returns the union of the bit sets.
fn gather_blocks(boxes: &[PBox], ents: &[u32], earlier: &[u64], blocks: &mut [Block16]) -> u64 {
    let mut any = 0;
    for (blk, (ents, earlier)) in blocks
        .iter_mut()
        .zip(ents.chunks(16).zip(earlier.chunks(16)))
    {
        for (l, (&e, &bits)) in ents.iter().zip(earlier).enumerate() {
            let b = &boxes[e as usize];
            for k in 0..3 {
                blk.lo[k][l] = b.lo[k];
                blk.hi[k][l] = b.hi[k];
            }
            blk.skel[l] = b.skeleton;
            blk.seg[l] = b.segment;
            blk.ents[l] = e;
            blk.earlier[l] = bits;
            any |= bits;
        }
        for l in ents.len()..16 {
            for k in 0..3 {
                blk.lo[k][l] = f32::NAN;
                blk.hi[k][l] = f32::NAN;
            }
        }
    }
    any
}

/// A row of a cell with AVX2, on the cell in blocks of sixteen (the column kernel's row result): the
/// box tests eight lanes at a time, less the lanes whose pair an earlier cell surely reports
/// (in crowded cells of long sections most box hits are such repeats: eight are ruled out for
/// the cost of one in the hit loop), then the neighbour and owner tests hit by hit (lane-wise,
/// without a compress, they took more instructions than they saved). Every field of a block
/// sits at a fixed offset from one pointer, so the row keeps its registers (with a pointer per
/// column they were spilled and reloaded at every row). `unknown_cell` says that the cell holds
/// a bit set with [`UNKNOWN`](crate::pairs::UNKNOWN) (else that test is left out). A pair the bit sets cannot tell
/// gives `None`, for `Grid::row_blocks` to do again with the key lists.
#[target_feature(enable = "avx2")]
#[inline]
#[expect(
    unsafe_code,
    reason = "unaligned loads of block columns; sound: each reads eight floats or four `u64`s of a sixteen-lane column"
)]
fn row_avx2(
    blocks: &[Block16],
    m: usize,
    a: usize,
    skip: u32,
    unknown_cell: bool,
    row: &mut [[u32; 2]],
) -> Option<usize> {
    use std::arch::x86_64::{
        __m256, __m256i, _CMP_LE_OQ, _mm256_and_ps, _mm256_and_si256, _mm256_castsi256_pd,
        _mm256_cmp_ps, _mm256_cmpeq_epi64, _mm256_loadu_ps, _mm256_loadu_si256, _mm256_movemask_pd,
        _mm256_movemask_ps, _mm256_set1_epi64x, _mm256_set1_ps, _mm256_setzero_si256,
    };
    // `row` has room for one pair per section after `a`.
    assert!(a + 1 < m && blocks.len() >= m.div_ceil(16) && row.len() >= m - a - 1);
    let (ba, la) = (&blocks[a / 16], a % 16);
    let lo = [0, 1, 2].map(|k| _mm256_set1_ps(ba.lo[k][la]));
    let hi = [0, 1, 2].map(|k| _mm256_set1_ps(ba.hi[k][la]));
    let ea = ba.earlier[la];
    let (skel_a, seg_a, ent_a) = (ba.skel[la], ba.seg[la], ba.ents[la]);
    let shared_window = _mm256_set1_epi64x((ea & WINDOW) as i64);
    let unknown = _mm256_set1_epi64x(UNKNOWN as i64);
    let zero = _mm256_setzero_si256();
    let keep_all: u32 = if ea & UNKNOWN != 0 { 0xffff } else { 0 };
    let ps = |c: &[f32]| -> __m256 {
        // SAFETY: called on halves of sixteen floats: eight.
        unsafe { _mm256_loadu_ps(c.as_ptr()) }
    };
    let quad = |c: &[u64]| -> __m256i {
        // SAFETY: called on quarters of sixteen 64-bit integers: four.
        unsafe { _mm256_loadu_si256(c.as_ptr().cast()) }
    };
    let lanes4 = |v: __m256i| _mm256_movemask_pd(_mm256_castsi256_pd(v)) as u32;
    let le = |a: __m256, b: __m256| _mm256_cmp_ps::<_CMP_LE_OQ>(a, b);
    let mut k = 0usize;
    // The sections after `a`: the rest of its block, then the whole later blocks.
    let mut lanes = 0xffffu32 << (la + 1);
    for blk in &blocks[a / 16..m.div_ceil(16)] {
        let mut hit = 0u32;
        for h in 0..2 {
            let r = 8 * h..8 * h + 8;
            let x = _mm256_and_ps(
                le(ps(&blk.lo[0][r.clone()]), hi[0]),
                le(lo[0], ps(&blk.hi[0][r.clone()])),
            );
            let y = _mm256_and_ps(
                le(ps(&blk.lo[1][r.clone()]), hi[1]),
                le(lo[1], ps(&blk.hi[1][r.clone()])),
            );
            let z = _mm256_and_ps(
                le(ps(&blk.lo[2][r.clone()]), hi[2]),
                le(lo[2], ps(&blk.hi[2][r])),
            );
            let boxes = _mm256_movemask_ps(_mm256_and_ps(_mm256_and_ps(x, y), z)) as u32;
            // May this cell report it: the sets share no window bit, or either cover is too
            // long to be described.
            let mut may = 0u32;
            for q in 0..2 {
                let e = quad(&blk.earlier[8 * h + 4 * q..8 * h + 4 * q + 4]);
                let mut m4 = lanes4(_mm256_cmpeq_epi64(_mm256_and_si256(e, shared_window), zero));
                if unknown_cell {
                    let described = lanes4(_mm256_cmpeq_epi64(_mm256_and_si256(e, unknown), zero));
                    m4 |= !described & 0xf;
                }
                may |= m4 << (4 * q);
            }
            hit |= (boxes & (may | keep_all)) << (8 * h);
        }
        let mut bits = hit & lanes;
        lanes = 0xffff;
        while bits != 0 {
            let l = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let (here, unsure) = owner(ea, blk.earlier[l]);
            let apart = (skel_a != blk.skel[l]) | (seg_a.abs_diff(blk.seg[l]) > skip);
            if apart & unsure {
                return None;
            }
            // Written ahead, kept by advancing `k`: no branch on the outcome.
            row[k] = [ent_a, blk.ents[l]];
            k += usize::from(apart & here);
        }
    }
    Some(k)
}
/// [`small_covers_avx512`](super::avx512::small_covers_avx512) with AVX2: the same expressions (`small_cover_lanes!`) in four `f64`
/// lanes, run on each half of the eight sections, so the same ranges and masks. Without mask
/// registers the lane tests are compare results (all ones where true), blended and turned into
/// bits with `movemask`.
#[target_feature(enable = "avx2")]
#[inline]
#[expect(
    unsafe_code,
    reason = "SSE loads and AVX2 stores on local arrays; sound: each covers four floats or four `i64`s inside its array"
)]
fn small_covers_avx2(secs: &[Section], inv: f64, grow: f64, out: &mut Covers8) {
    use std::arch::x86_64::{
        __m256d, __m256i, _CMP_GE_OQ, _CMP_GT_OQ, _CMP_LE_OQ, _CMP_LT_OQ, _mm_loadu_ps,
        _mm256_add_epi64, _mm256_add_pd, _mm256_and_pd, _mm256_and_si256, _mm256_blendv_pd,
        _mm256_castpd_si256, _mm256_castsi256_pd, _mm256_cmp_pd, _mm256_cmpeq_epi64,
        _mm256_cmpgt_epi64, _mm256_cvtps_pd, _mm256_div_pd, _mm256_max_pd, _mm256_min_pd,
        _mm256_movemask_pd, _mm256_mul_pd, _mm256_or_si256, _mm256_set1_epi64x, _mm256_set1_pd,
        _mm256_setzero_si256, _mm256_storeu_si256, _mm256_sub_epi64, _mm256_sub_pd,
    };
    *out = [None; 8];
    let mut f = [[0.0f32; 8]; 7];
    let line = lines8(secs, &mut f);
    let bits = |m: __m256d| _mm256_movemask_pd(m) as u32;
    let lanes = |v: __m256i| -> [i64; 4] {
        let mut t = [0i64; 4];
        // SAFETY: four 64-bit integers.
        unsafe { _mm256_storeu_si256(t.as_mut_ptr().cast(), v) };
        t
    };
    let one = _mm256_set1_pd(1.0);
    let magic = _mm256_set1_pd(MAGIC);
    let magic_bits = _mm256_set1_epi64x(MAGIC.to_bits() as i64);
    let one_i = _mm256_set1_epi64x(1);
    // `floor_small`: the floor as an integer and as a float (exact: small integers).
    let floor = |v: __m256d| -> (__m256i, __m256d) {
        let sum = _mm256_add_pd(v, magic);
        let back = _mm256_sub_pd(sum, magic);
        let over = _mm256_cmp_pd::<_CMP_GT_OQ>(back, v);
        // `over` is all ones (-1) where set: adding it subtracts one.
        let k = _mm256_sub_epi64(_mm256_castpd_si256(sum), magic_bits);
        let k = _mm256_add_epi64(k, _mm256_castpd_si256(over));
        (k, _mm256_blendv_pd(back, _mm256_sub_pd(back, one), over))
    };
    let (two_i, sign_off) = (
        _mm256_set1_epi64x(2),
        _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX)),
    );
    for half in 0..2 {
        let wide = |c: &[f32; 8]| -> __m256d {
            // SAFETY: four floats of the eight, from `4 * half`.
            _mm256_cvtps_pd(unsafe { _mm_loadu_ps(c.as_ptr().add(4 * half)) })
        };
        let inv_v = _mm256_set1_pd(inv);
        let va: [__m256d; 3] = std::array::from_fn(|k| _mm256_mul_pd(wide(&f[k]), inv_v));
        let vb: [__m256d; 3] = std::array::from_fn(|k| _mm256_mul_pd(wide(&f[3 + k]), inv_v));
        let (ok, cl, ch, mask) = small_cover_lanes!(
            va, vb, wide(&f[6]), (line >> (4 * half)) & 0xf, inv, grow, __m256d,
            add: _mm256_add_pd,
            sub: _mm256_sub_pd,
            mul: _mm256_mul_pd,
            div: _mm256_div_pd,
            min: _mm256_min_pd,
            max: _mm256_max_pd,
            // |d| as d with the sign bit cleared.
            abs: |d| _mm256_and_pd(d, sign_off),
            splat: _mm256_set1_pd,
            cmp: _mm256_cmp_pd,
            and: _mm256_and_pd,
            bits: bits,
            blend: |m, no, yes| _mm256_blendv_pd(no, yes, m),
            floor: floor,
            int_sub: _mm256_sub_epi64,
            int_one: one_i,
            int_add: _mm256_add_epi64,
            narrow: |n| !bits(_mm256_castsi256_pd(_mm256_cmpgt_epi64(n, two_i))) & 0xf,
            single: |n| _mm256_castsi256_pd(_mm256_cmpeq_epi64(n, one_i)),
            int_zero: _mm256_setzero_si256(),
            set: |mask, keep, bit| _mm256_or_si256(
                mask,
                _mm256_and_si256(_mm256_castpd_si256(keep), _mm256_set1_epi64x(bit))
            )
        );
        let (cl, ch, mask) = (cl.map(lanes), ch.map(lanes), lanes(mask));
        covers_out(out, 4 * half, secs.len(), ok, (&cl, &ch, &mask));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::lcg;
    use crate::pairs::OUTSIDE;

    /// The AVX2 rows keep exactly the pairs of the row's rules, computed pair by pair: boxes
    /// overlapping (on a coarse lattice, so that they often touch exactly), sections not
    /// neighbours on one skeleton, and no earlier cell shared; a pair whose owner the bit sets
    /// cannot tell (cells outside the window, covers too long to be described) gives `None`.
    #[test]
    fn the_avx2_rows_keep_what_the_pair_rules_keep() {
        let Some(kernel) = Avx2::detect() else {
            eprintln!("no AVX2 on this processor: the AVX2 rows are not tested");
            return;
        };
        let mut z = 5u64;
        let set = |z: &mut u64, special: bool| -> u64 {
            match (lcg(z) * if special { 8.0 } else { 4.0 }) as u32 {
                0 => 0,
                4 => u64::MAX,
                5 => OUTSIDE,
                6 => OUTSIDE | 1 << (lcg(z) * 62.0) as u32,
                _ => (0..3).fold(0, |b, _| b | 1 << ((lcg(z) * 8.0) as u32 * 7)),
            }
        };
        let (mut decided, mut undecided) = (0, 0);
        for special in [false, true] {
            for m in [2usize, 9, 16, 17, 64, 130] {
                let mut blocks = vec![Block16::default(); m.div_ceil(16)];
                let (mut boxes, mut ents, mut earlier) = (Vec::new(), Vec::new(), Vec::new());
                for e in 0..m {
                    let lo = [0; 3].map(|_| (lcg(&mut z) * 4.0).floor() / 4.0);
                    let hi = lo.map(|v| v + (lcg(&mut z) * 3.0).floor() / 4.0);
                    let (skeleton, segment) =
                        ((lcg(&mut z) * 3.0) as u32, (lcg(&mut z) * 4.0) as u32);
                    boxes.push(PBox {
                        lo,
                        hi,
                        skeleton,
                        segment,
                    });
                    ents.push(e as u32);
                    earlier.push(set(&mut z, special));
                }
                let any = kernel.gather(&boxes, &ents, &earlier, &mut blocks);
                assert_eq!(any, earlier.iter().fold(0, |a, b| a | b));
                let mut row = vec![[0u32; 2]; m];
                for a in 0..m - 1 {
                    let mut expect = Vec::new();
                    let mut unsure_any = false;
                    for b in a + 1..m {
                        let (pa, pb) = (&boxes[a], &boxes[b]);
                        let overlap = (0..3).all(|k| pb.lo[k] <= pa.hi[k] && pa.lo[k] <= pb.hi[k]);
                        let apart =
                            pa.skeleton != pb.skeleton || pa.segment.abs_diff(pb.segment) > 1;
                        let (here, unsure) = owner(earlier[a], earlier[b]);
                        unsure_any |= overlap && apart && unsure;
                        if overlap && apart && here {
                            expect.push([a as u32, b as u32]);
                        }
                    }
                    let got = kernel.row(&blocks, m, a, 1, false, any & UNKNOWN != 0, &mut row);
                    if unsure_any {
                        assert_eq!(got, None, "m {m} a {a}");
                        undecided += 1;
                    } else {
                        let k = got.expect("decided by the bit sets");
                        assert_eq!(&row[..k], &expect[..], "m {m} a {a}");
                        decided += 1;
                    }
                }
            }
        }
        assert!(decided > 100 && undecided > 10, "{decided} {undecided}");
    }
}
