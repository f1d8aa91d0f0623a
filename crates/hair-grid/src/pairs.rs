//! Hair-hair pairs from the grid (Ward & Lin 2003 §5.3): sections sharing a cell are candidates;
//! each pair is reported once, in the first cell both cover.
//!
//! The search runs on a copy of the section data made at each rebuild (`Packed`): sections are
//! renumbered by their first cell, so that walking the cells in key order touches a sliding window
//! of nearby memory instead of the whole scene (with the caller's order, a strand order, every
//! section of a cell is a cache miss). Per cell, the boxes are gathered into columns and tested
//! a row at a time with packed compares; a box hit is kept when the cell is the first one both
//! cover, read from the earlier-cell bit sets stored with the entries (`earlier_cells`, `owner`;
//! `Grid::first_shared` when they cannot tell); the survivors get the exact SSV test, eight at a
//! time.

use rayon::prelude::*;

use crate::grid::{Grid, unpack3};
use crate::{Real, Ssv};

/// Cells handled by one parallel task: fixed, so that the output order does not depend on the
/// number of threads.
const CELLS_PER_TASK: usize = 256;

/// Lanes of the box test and of the exact test.
const LANES: usize = 8;

/// Multiplier that moves the low bit of each of the eight bytes of a word into its top byte.
const GATHER_BYTES: u64 = 0x0102_0408_1020_4080;

/// Candidate pairs buffered before the exact test.
const BATCH: usize = 512;

/// A section's bounding box (grown by half the margin and the rounding slack) and its ids, in the
/// pair search's order.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(32))]
pub(crate) struct PBox {
    pub lo: [f32; 3],
    pub hi: [f32; 3],
    pub skeleton: u32,
    pub segment: u32,
}

/// A section's core for the exact test: `a`, `b - a`, radius, and the largest coordinate
/// magnitude (at least 1) that scales the rounding band. The radius is NaN for a shape that is
/// not an LSS (tested by the scalar kernel).
pub(crate) type Line = [f32; 8];

/// Section data in the pair search's order (by first cell, then by index).
#[derive(Debug, Default)]
pub(crate) struct Packed {
    /// Internal index to section index.
    pub order: Vec<u32>,
    /// Section index to internal index.
    pub rank: Vec<u32>,
    /// Per entry, in cell order, the internal index of its section.
    pub items: Vec<u32>,
    pub boxes: Vec<PBox>,
    pub lines: Vec<Line>,
    /// Scratch: index of each section's first cell, and counts per cell.
    pub first: Vec<u32>,
    pub counts: Vec<u32>,
}

#[derive(Debug, Default)]
struct PairChunk {
    pairs: Vec<[u32; 2]>,
    /// The boxes of the current cell by column: min x, y, z, max x, y, z.
    cols: [Vec<f32>; 6],
    /// Skeleton and segment of each section of the current cell.
    ids: Vec<[u32; 2]>,
    /// One row of box-test results, a byte per box.
    hits: Vec<u8>,
    /// Candidates (internal indices) waiting for the exact test: the first `n_cand`. The rest is
    /// room written ahead, so that appending needs no branch (half of the box hits are dropped,
    /// unpredictably).
    cand: Vec<[u32; 2]>,
    n_cand: usize,
}

/// A reusable set of section pairs `[i, j]` with `i < j`, filled by [`Grid::candidate_pairs`] or
/// [`Grid::overlapping_pairs`]. It is stored in chunks (one per parallel task) so that filling it
/// copies nothing; the order (by first shared cell, then by position in the cell) is the same for
/// any number of threads.
#[derive(Debug, Default)]
pub struct PairSet {
    chunks: Vec<PairChunk>,
    used: usize,
}

impl PairSet {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.chunks[..self.used].iter().map(|c| c.pairs.len()).sum()
    }

    /// Whether there is no pair.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The pairs, chunk by chunk (for parallel consumers: `par_bridge` or index the chunks).
    pub fn chunks(&self) -> impl Iterator<Item = &[[u32; 2]]> + '_ {
        self.chunks[..self.used].iter().map(|c| c.pairs.as_slice())
    }

    /// All pairs in order.
    pub fn iter(&self) -> impl Iterator<Item = [u32; 2]> + '_ {
        self.chunks().flat_map(|c| c.iter().copied())
    }

    /// All pairs in order, copied into a new vector.
    pub fn to_vec(&self) -> Vec<[u32; 2]> {
        self.iter().collect()
    }

    /// Empties the set, keeping its buffers.
    pub fn clear(&mut self) {
        for c in &mut self.chunks[..self.used] {
            c.pairs.clear();
        }
        self.used = 0;
    }
}

/// Whether two ascending key lists share a key.
#[inline]
fn share_any(a: &[u64], b: &[u64]) -> bool {
    let (mut p, mut q) = (0, 0);
    while p < a.len() && q < b.len() {
        let (x, y) = (a[p], b[q]);
        if x == y {
            return true;
        }
        if x < y {
            p += 1;
        } else {
            q += 1;
        }
    }
    false
}

/// The `Line` of a shape.
pub(crate) fn line_of(shape: &Ssv) -> Line {
    match shape {
        Ssv::Line(l) => {
            let scale = [l.a, l.b]
                .iter()
                .flat_map(|p| p.iter())
                .fold(1.0f32, |m, c| m.max(c.abs()));
            [
                l.a.x,
                l.a.y,
                l.a.z,
                l.b.x - l.a.x,
                l.b.y - l.a.y,
                l.b.z - l.a.z,
                l.radius,
                scale,
            ]
        }
        _ => [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f32::NAN, 1.0],
    }
}

impl Grid {
    /// Every unique pair of sections that share a cell and whose bounding boxes (grown by the
    /// margin) overlap, skipping same-skeleton neighbours as configured. Contains every pair whose
    /// SSV distance is at most the margin. Each pair appears once, as `[i, j]` with `i < j`.
    pub fn candidate_pairs(&self, out: &mut PairSet) {
        self.enumerate_pairs(out, false);
    }

    /// The pairs whose SSV distance (hair-ssv's exact distance, signed) is at most the margin:
    /// [`Grid::candidate_pairs`] followed by the exact test, in one pass.
    pub fn overlapping_pairs(&self, out: &mut PairSet) {
        self.enumerate_pairs(out, true);
    }

    fn enumerate_pairs(&self, out: &mut PairSet, exact: bool) {
        out.clear();
        let n_cells = self.cell_keys.len();
        let tasks = n_cells.div_ceil(CELLS_PER_TASK);
        if out.chunks.len() < tasks {
            out.chunks.resize_with(tasks, PairChunk::default);
        }
        out.used = tasks;
        out.chunks[..tasks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(t, chunk)| {
                chunk.pairs.clear();
                chunk.n_cand = 0;
                let c0 = t * CELLS_PER_TASK;
                let c1 = (c0 + CELLS_PER_TASK).min(n_cells);
                for c in c0..c1 {
                    self.cell_pairs(c, chunk, exact);
                }
                self.finish(&chunk.cand[..chunk.n_cand], &mut chunk.pairs, exact);
                chunk.n_cand = 0;
            });
    }

    /// The candidates first reported by cell `c`, into `chunk.cand` (flushed as it fills).
    #[inline]
    fn cell_pairs(&self, c: usize, chunk: &mut PairChunk, exact: bool) {
        let pk = &self.packed;
        let range = self.cell_start[c] as usize..self.cell_start[c + 1] as usize;
        let ents = &pk.items[range.clone()];
        let earlier = &self.entry_earlier[range];
        let m = ents.len();
        if m < 2 {
            return;
        }
        let skip = self.config.skip_neighbours;
        let PairChunk {
            pairs,
            cols,
            ids,
            hits,
            cand,
            n_cand,
        } = chunk;
        // Gather the boxes into columns, padded with NaN (which fails every comparison) so that
        // the row test needs no remainder.
        if hits.len() < m + 8 {
            hits.resize(m + 8, 0);
            for col in cols.iter_mut() {
                col.resize(m + 8, f32::NAN);
            }
            ids.resize(m + 8, [0; 2]);
        }
        for col in cols.iter_mut() {
            col[m..m + 8].fill(f32::NAN);
        }
        {
            let [lx, ly, lz, hx, hy, hz] = &mut *cols;
            for (e, &it) in ents.iter().enumerate() {
                let b = &pk.boxes[it as usize];
                lx[e] = b.lo[0];
                ly[e] = b.lo[1];
                lz[e] = b.lo[2];
                hx[e] = b.hi[0];
                hy[e] = b.hi[1];
                hz[e] = b.hi[2];
                ids[e] = [b.skeleton, b.segment];
            }
        }
        let [lx, ly, lz, hx, hy, hz] = &*cols;
        for a in 0..m - 1 {
            let lo = [lx[a], ly[a], lz[a]];
            let hi = [hx[a], hy[a], hz[a]];
            let [skel_a, seg_a] = ids[a];
            let earlier_a = earlier[a];
            if cand.len() < *n_cand + m {
                cand.resize(*n_cand + m, [0; 2]);
            }
            // One row of box tests, padded to a multiple of eight lanes with the NaN boxes so
            // that it compiles to packed compares with no remainder: a byte per box. (Moving the
            // neighbour and owner tests into this loop removes branch misses but costs more
            // instructions than it saves.)
            let b0 = a + 1;
            let n = (m - b0 + 7) & !7;
            let (x0, y0, z0) = (&lx[b0..b0 + n], &ly[b0..b0 + n], &lz[b0..b0 + n]);
            let (x1, y1, z1) = (&hx[b0..b0 + n], &hy[b0..b0 + n], &hz[b0..b0 + n]);
            let row = &mut hits[..n];
            for k in 0..n {
                row[k] = u8::from(
                    (x0[k] <= hi[0])
                        & (x1[k] >= lo[0])
                        & (y0[k] <= hi[1])
                        & (y1[k] >= lo[1])
                        & (z0[k] <= hi[2])
                        & (z1[k] >= lo[2]),
                );
            }
            // The bytes to bits, 64 boxes at a time, branch-free (a branch per group of boxes
            // would be mispredicted about as often as there are hits).
            for (g, group) in row.chunks(64).enumerate() {
                let mut bits = 0u64;
                for (w, word) in group.chunks_exact(8).enumerate() {
                    let word = u64::from_le_bytes([
                        word[0], word[1], word[2], word[3], word[4], word[5], word[6], word[7],
                    ]);
                    // Each byte is 0 or 1: the product gathers the eight low bits into the top
                    // byte.
                    bits |= (word.wrapping_mul(GATHER_BYTES) >> 56) << (8 * w);
                }
                while bits != 0 {
                    let b = b0 + 64 * g + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let [skel_b, seg_b] = ids[b];
                    let neighbours = (skel_a == skel_b) & (seg_a.abs_diff(seg_b) <= skip);
                    let verdict = owner(earlier_a, earlier[b]);
                    let pair = [ents[a], ents[b]];
                    if !neighbours & (verdict == Owner::Unsure) {
                        if self.first_shared(self.cell_keys[c], pair[0], pair[1]) {
                            cand[*n_cand] = pair;
                            *n_cand += 1;
                        }
                        continue;
                    }
                    cand[*n_cand] = pair;
                    *n_cand += usize::from(!neighbours & (verdict == Owner::Yes));
                }
            }
            if *n_cand >= BATCH {
                self.finish(&cand[..*n_cand], pairs, exact);
                *n_cand = 0;
            }
        }
    }

    /// Moves the buffered candidates to the output: as they are, or through the exact test.
    fn finish(&self, cand: &[[u32; 2]], pairs: &mut Vec<[u32; 2]>, exact: bool) {
        let pk = &self.packed;
        let order = &pk.order;
        let orig = |[a, b]: [u32; 2]| {
            let (i, j) = (order[a as usize], order[b as usize]);
            [i.min(j), i.max(j)]
        };
        if !exact {
            pairs.extend(cand.iter().map(|&p| orig(p)));
            return;
        }
        let margin = self.config.margin;
        let mut blocks = cand.chunks_exact(LANES);
        for block in &mut blocks {
            let mut keep = self.exact_lanes(block, margin);
            while keep != 0 {
                pairs.push(orig(block[keep.trailing_zeros() as usize]));
                keep &= keep - 1;
            }
        }
        for &p in blocks.remainder() {
            let [i, j] = orig(p);
            if self
                .shape_at(i as usize)
                .distance(self.shape_at(j as usize))
                <= margin
            {
                pairs.push([i, j]);
            }
        }
    }

    /// The exact test on eight candidates (bit `l` set when candidate `l` is kept): hair-ssv's segment-segment kernel run lane-wise on the
    /// packed lines. It agrees with the scalar kernel up to rounding, so a pair within a rounding
    /// band of the margin (and any pair that is not two LSS) is decided by [`Ssv::distance`]
    /// itself: the result is exactly `distance <= margin`.
    #[inline]
    fn exact_lanes(&self, block: &[[u32; 2]], margin: Real) -> u32 {
        let lines = &self.packed.lines;
        let mut p = [[0.0f32; LANES]; 8];
        let mut q = [[0.0f32; LANES]; 8];
        for (l, &[a, b]) in block.iter().enumerate().take(LANES) {
            let (la, lb) = (&lines[a as usize], &lines[b as usize]);
            for k in 0..8 {
                p[k][l] = la[k];
                q[k][l] = lb[k];
            }
        }
        let mut d = [0.0f32; LANES];
        let mut band = [0.0f32; LANES];
        for l in 0..LANES {
            let (ux, uy, uz) = (p[3][l], p[4][l], p[5][l]);
            let (vx, vy, vz) = (q[3][l], q[4][l], q[5][l]);
            let (rx, ry, rz) = (p[0][l] - q[0][l], p[1][l] - q[1][l], p[2][l] - q[2][l]);
            let a = ux * ux + uy * uy + uz * uz;
            let e = vx * vx + vy * vy + vz * vz;
            let b = ux * vx + uy * vy + uz * vz;
            let c = ux * rx + uy * ry + uz * rz;
            let f = vx * rx + vy * ry + vz * rz;
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
            let s0 = s0.clamp(0.0, 1.0);
            let inv_e = if e > 0.0 { 1.0 / e } else { 0.0 };
            let inv_a = if a > 0.0 { 1.0 / a } else { 0.0 };
            let t = ((b * s0 + f) * inv_e).clamp(0.0, 1.0);
            let s = ((b * t - c) * inv_a).clamp(0.0, 1.0);
            let (wx, wy, wz) = (
                rx + ux * s - vx * t,
                ry + uy * s - vy * t,
                rz + uz * s - vz * t,
            );
            d[l] = (wx * wx + wy * wy + wz * wz).sqrt() - (p[6][l] + q[6][l]);
            band[l] = 1e-5 * p[7][l].max(q[7][l]);
        }
        // Bit masks: surely in, and undecided (within the band, or NaN: not two LSS).
        let (mut sure, mut open) = (0u32, 0u32);
        for l in 0..LANES {
            let inside = d[l] < margin - band[l];
            let outside = d[l] > margin + band[l];
            sure |= u32::from(inside) << l;
            open |= u32::from(!(inside | outside)) << l;
        }
        while open != 0 {
            let l = open.trailing_zeros() as usize;
            open &= open - 1;
            let [a, b] = block[l];
            let (i, j) = (self.packed.order[a as usize], self.packed.order[b as usize]);
            let (i, j) = (i.min(j) as usize, i.max(j) as usize);
            if self.shape_at(i).distance(self.shape_at(j)) <= margin {
                sure |= 1 << l;
            }
        }
        sure
    }

    /// Whether the cell `key`, covered by the sections of internal indices `a` and `b`, is the
    /// first cell (in key order) that both cover, from their key lists: the fallback when their
    /// earlier-cell bit sets cannot tell (a shared cell may lie outside the window).
    fn first_shared(&self, key: u64, a: u32, b: u32) -> bool {
        let before = |it: u32| {
            let k = self.item_keys(self.packed.order[it as usize] as usize);
            &k[..k.partition_point(|&x| x < key)]
        };
        !share_any(before(a), before(b))
    }
}

/// Bit sets of the earlier cells ([`earlier_cells`]): a cell `d` away from the entry's cell
/// (`d` in `-2..=2` on each axis, before it in key order) is bit `25 (dx + 2) + 5 (dy + 2) +
/// (dz + 2)`, one of bits 0 to 61 since key order is lexicographic.
const WINDOW: u64 = (1 << 62) - 1;
/// Set when some earlier cell lies outside that window.
pub(crate) const OUTSIDE: u64 = 1 << 63;
/// Set (with every other bit) when the cover is too long to be described.
const UNKNOWN: u64 = 1 << 62;

/// Covers longer than this get [`UNKNOWN`] bit sets (the computation is quadratic in the
/// cover's length).
const MAX_DESCRIBED: usize = 64;

/// For each cell of a cover (ascending packed keys), the cover's cells before it in key order,
/// as a bit set in a 5 x 5 x 5 window around it (see [`WINDOW`]). Two sections sharing a cell
/// report their pair there only when their bit sets for that cell have no bit in common: then
/// they share no earlier cell, so each pair is reported once, without a hash set. (When the sets
/// share only [`OUTSIDE`], or one is [`UNKNOWN`], the key lists decide.) If they have nothing in
/// common, at most one cover has earlier cells outside the window, and the other's all lie
/// inside it, where the bits show that none is shared.
pub(crate) fn earlier_cells(keys: &[u64], out: &mut Vec<u64>) {
    if keys.len() > MAX_DESCRIBED {
        out.push(0);
        out.extend(std::iter::repeat_n(u64::MAX, keys.len() - 1));
        return;
    }
    for (k, &key) in keys.iter().enumerate() {
        let c = unpack3(key);
        let mut bits = 0u64;
        for &prev in keys[..k].iter().rev() {
            let p = unpack3(prev);
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            if d[0] < -2 {
                // Every cell before this one is further away along x.
                bits |= OUTSIDE;
                break;
            }
            if d[1].abs() > 2 || d[2].abs() > 2 {
                bits |= OUTSIDE;
                continue;
            }
            bits |= 1 << ((d[0] + 2) * 25 + (d[1] + 2) * 5 + (d[2] + 2));
        }
        out.push(bits);
    }
}

/// [`earlier_cells`] of a cover given by its cell coordinates (ascending), for covers of at
/// most [`MAX_DESCRIBED`] cells.
pub(crate) fn earlier_bits(cells: &[[i64; 3]], out: &mut Vec<u64>) {
    let cells = &cells[..cells.len().min(MAX_DESCRIBED)];
    out.extend(cells.iter().enumerate().map(|(k, c)| {
        let mut b = 0u64;
        for p in cells[..k].iter().rev() {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            if d[0] < -2 {
                b |= OUTSIDE;
                break;
            }
            let far = (d[1] + 2) as u64 > 4 || (d[2] + 2) as u64 > 4;
            let bit = 1u64 << (((d[0] + 2) * 25 + (d[1] + 2) * 5 + (d[2] + 2)) & 63);
            b |= if far { OUTSIDE } else { bit };
        }
        b
    }));
}

/// What the bit sets of two sections in a cell say about reporting their pair there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Owner {
    /// No earlier cell is shared: report here.
    Yes,
    /// An earlier cell is shared: it reports the pair.
    No,
    /// The bit sets cannot tell (a shared cell may lie outside the window): read the key lists.
    Unsure,
}

#[inline]
fn owner(a: u64, b: u64) -> Owner {
    let both = a & b;
    let unsure = ((a | b) & UNKNOWN != 0) | (both & WINDOW == 0);
    // Selects rather than branches: the outcome is unpredictable.
    match (both == 0, unsure) {
        (true, _) => Owner::Yes,
        (false, true) => Owner::Unsure,
        (false, false) => Owner::No,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::CellKey;

    fn keys(cells: &[[i32; 3]]) -> Vec<u64> {
        cells
            .iter()
            .map(|c| CellKey::new(c[0], c[1], c[2]).pack().unwrap())
            .collect()
    }

    fn bit(d: [i32; 3]) -> u64 {
        1 << ((d[0] + 2) * 25 + (d[1] + 2) * 5 + (d[2] + 2))
    }

    #[test]
    fn earlier_cells_lists_the_cells_before_each_one() {
        let mut out = Vec::new();
        earlier_cells(&keys(&[[0, 0, 0], [0, 0, 1], [1, 0, 0]]), &mut out);
        assert_eq!(
            out,
            vec![0, bit([0, 0, -1]), bit([-1, 0, 0]) | bit([-1, 0, 1])]
        );
        // A cell three steps back along x is outside the window.
        out.clear();
        earlier_cells(&keys(&[[0, 0, 0], [3, 0, 0]]), &mut out);
        assert_eq!(out, vec![0, OUTSIDE]);
    }

    #[test]
    fn earlier_bits_match_earlier_cells() {
        let cells: Vec<[i64; 3]> = vec![
            [-3, 0, 0],
            [-1, 0, 0],
            [0, -3, 1],
            [0, 0, 0],
            [0, 0, 1],
            [0, 2, -2],
            [1, 0, 0],
            [1, 3, 0],
            [2, 0, 2],
        ];
        let k: Vec<[i32; 3]> = cells.iter().map(|c| c.map(|v| v as i32)).collect();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        earlier_cells(&keys(&k), &mut a);
        earlier_bits(&cells, &mut b);
        assert_eq!(a, b);
    }

    #[test]
    fn owner_reads_the_bit_sets() {
        assert_eq!(owner(0, bit([-1, 0, 0])), Owner::Yes);
        assert_eq!(owner(bit([-1, 0, 0]), bit([0, -1, 0])), Owner::Yes);
        assert_eq!(owner(bit([-1, 0, 0]), bit([-1, 0, 0])), Owner::No);
        assert_eq!(owner(OUTSIDE, OUTSIDE | bit([0, 0, -1])), Owner::Unsure);
        assert_eq!(owner(u64::MAX, bit([0, 0, -1])), Owner::Unsure);
        assert_eq!(owner(u64::MAX, 0), Owner::Yes);
    }
}
