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
//! time. On a processor with AVX-512 the cell is laid out in blocks of sixteen instead, and a row
//! keeps its pairs with lane masks (box, neighbour and owner tests) and one compress per block,
//! with no loop over the hits. A crowded cell is searched as a sweep ([`Sweep`]): its entries
//! sorted along one axis, each row stopped where the boxes no longer reach. Every kernel gives
//! the same pairs in the same order.

use rayon::prelude::*;

use crate::grid::{Grid, unpack3};
use crate::{Real, Ssv};

/// Work of one parallel task, in pair tests: a cell of `m` sections counts `m * m` plus
/// [`CELL_WORK`]. The tasks cut the cells by this estimate alone, so that a few crowded cells
/// (long sections, dense hair) are spread over the threads as well as many sparse ones are, and
/// the output order does not depend on the number of threads.
const TASK_WORK: u64 = 1 << 16;

/// The fixed cost of visiting a cell, in pair tests.
const CELL_WORK: u64 = 16;

/// Lanes of the box test and of the exact test.
const LANES: usize = 8;

/// Multiplier that moves the low bit of each of the eight bytes of a word into its top byte.
#[cfg(any(test, not(target_arch = "x86_64")))]
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

/// A section's core for the exact test: `a`, `b`, radius, and the largest coordinate magnitude
/// (at least 1) that scales the rounding band. The radius is NaN for a shape that is not an
/// LSS (tested by the scalar kernel). The ends are kept as given (the kernels take `b - a`), so
/// that the LSS is rebuilt exactly from its line when the scalar test must decide.
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
    /// The sections of the current cell by column.
    cols: CellCols,
    /// Candidates (internal indices) waiting for the exact test: the first `n_cand`. The rest is
    /// room written ahead, so that appending needs no branch (half of the box hits are dropped,
    /// unpredictably).
    cand: Vec<[u32; 2]>,
    n_cand: usize,
    /// The sections of the current cell in blocks of sixteen (the AVX-512 and AVX2 kernels).
    blocks: Vec<Block16>,
    /// A crowded cell's entries in sweep order.
    sweep: Sweep,
}

/// Cells with at least this many sections are searched as a sweep ([`Sweep`]); smaller ones in
/// their stored order. Sorting costs more than it saves in small cells: sweeping every cell of
/// 32 or more made the `hair bench grid` scene's search (cells of 14.5 sections on average, few
/// over 64) 35% slower, and of 64 or more 8% slower.
const SWEEP_MIN: usize = 128;

/// A crowded cell's entries sorted by box minimum along one axis (the sweep axis), so that a
/// row stops at the first section whose minimum lies past the row's maximum: every later one
/// misses the row's box along that axis. In the dense parts of a head the hair is locally
/// parallel and a cell holds hundreds of sections that share few boxes; the sweep skips most of
/// the box tests of its rows. The sort key is the minimum, then the stored position, so that
/// the order (and the pairs' order) depends on the cell's contents alone.
#[derive(Debug, Default)]
struct Sweep {
    keys: Vec<u64>,
    /// The entries (internal indices) and their earlier-cell bit sets, in sweep order.
    ents: Vec<u32>,
    earlier: Vec<u64>,
    /// Box minimum and maximum along the sweep axis, in sweep order.
    lo: Vec<f32>,
    hi: Vec<f32>,
}

impl Sweep {
    /// Sorts the cell's entries `ents` (with their bit sets `earlier`) along the axis where
    /// their boxes are shortest against the spread of their minima: the axis where a row meets
    /// the fewest boxes.
    fn sort(&mut self, boxes: &[PBox], ents: &[u32], earlier: &[u64]) {
        let m = ents.len();
        let (mut extent, mut first, mut last) =
            ([0.0f32; 3], [f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for &i in ents {
            let b = &boxes[i as usize];
            for d in 0..3 {
                extent[d] += b.hi[d] - b.lo[d];
                first[d] = first[d].min(b.lo[d]);
                last[d] = last[d].max(b.lo[d]);
            }
        }
        // A row meets about m * (mean extent) / (spread of the minima + mean extent) boxes.
        let score = |d: usize| extent[d] / (last[d] - first[d] + extent[d] / m as f32);
        let axis = (1..3).fold(0, |best, d| if score(d) < score(best) { d } else { best });
        self.keys.clear();
        self.keys.extend(
            ents.iter().enumerate().map(|(e, &i)| {
                u64::from(ordered_bits(boxes[i as usize].lo[axis])) << 32 | e as u64
            }),
        );
        self.keys.sort_unstable();
        self.ents.clear();
        self.earlier.clear();
        self.lo.clear();
        self.hi.clear();
        for &key in &self.keys {
            let e = key as u32 as usize;
            let b = &boxes[ents[e] as usize];
            self.ents.push(ents[e]);
            self.earlier.push(earlier[e]);
            self.lo.push(b.lo[axis]);
            self.hi.push(b.hi[axis]);
        }
    }

    /// The end of row `a`: the first section after `a` whose minimum lies past `a`'s maximum
    /// along the sweep axis.
    fn row_end(&self, a: usize) -> usize {
        let hi = self.hi[a];
        a + 1 + self.lo[a + 1..].partition_point(|&lo| lo <= hi)
    }
}

/// The entries of the cell being searched, in the order its rows take them.
struct CellEntries<'a> {
    key: u64,
    /// Internal indices, and their earlier-cell bit sets.
    ents: &'a [u32],
    earlier: &'a [u64],
    /// The sweep order the entries are in, for a crowded cell.
    sweep: Option<&'a Sweep>,
}

impl CellEntries<'_> {
    /// The end of row `a`: past it, no box meets `a`'s (every entry without a sweep).
    #[inline(always)]
    fn row_end(&self, a: usize) -> usize {
        self.sweep.map_or(self.ents.len(), |s| s.row_end(a))
    }
}

/// The bits of a finite float as an unsigned integer in the same order.
fn ordered_bits(v: f32) -> u32 {
    let b = v.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// Sixteen sections of a cell, each field one AVX-512 register (two AVX2 ones): the layout of
/// the AVX-512 and AVX2 kernels. Every column of a block sits at a fixed offset from one
/// pointer, so that the row loop keeps its registers for the tests (with a pointer per column
/// they were spilled and reloaded in the loop). Lanes past the cell's last section have NaN
/// boxes, which fail every comparison.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Block16 {
    /// Box minimum and maximum, by axis.
    lo: [[f32; 16]; 3],
    hi: [[f32; 16]; 3],
    skel: [u32; 16],
    seg: [u32; 16],
    /// The entry's section (internal index).
    ents: [u32; 16],
    /// Earlier-cell bit sets ([`earlier_cells`]).
    earlier: [u64; 16],
}

/// What a pair search reports.
#[derive(Clone, Copy, Debug)]
struct Report {
    /// Only the pairs within the margin (else every candidate).
    exact: bool,
    /// Pairs by position in the pair search's order ([`Grid::search_order`]) instead of by
    /// section index.
    ranked: bool,
}

/// The sections of one cell by column, padded past the cell's `m` entries with [`PAD`] NaN boxes
/// (which fail every comparison) so that the row tests need no remainder.
#[derive(Debug, Default)]
struct CellCols {
    /// Bounding boxes: min x, y, z, max x, y, z.
    boxes: [Vec<f32>; 6],
    /// Earlier-cell bit sets ([`earlier_cells`]), padded with zeros.
    earlier: Vec<u64>,
    /// Skeleton and segment, padded with zeros.
    skel: Vec<u32>,
    seg: Vec<u32>,
}

/// The box columns of one cell, each `len` long (the entries and their padding), sliced once per
/// cell so that the rows need one bounds check instead of twelve.
#[derive(Clone, Copy, Debug)]
struct CellView<'a> {
    cols: [&'a [f32]; 6],
    earlier: &'a [u64],
}

impl<'a> CellView<'a> {
    fn new(cols: &'a CellCols, len: usize) -> Self {
        Self {
            cols: [0, 1, 2, 3, 4, 5].map(|k| &cols.boxes[k][..len]),
            earlier: &cols.earlier[..len],
        }
    }
}

/// Padding of the cell columns: a full group of eight lanes past the last entry.
const PAD: usize = 8;

/// The section `a` a row tests against the later ones.
#[derive(Clone, Copy, Debug)]
struct RowHead {
    lo: [f32; 3],
    hi: [f32; 3],
    /// The section's earlier-cell bit set in this cell.
    earlier: u64,
}

/// A reusable set of section pairs `[i, j]` with `i < j`, filled by [`Grid::candidate_pairs`] or
/// [`Grid::overlapping_pairs`]. It is stored in chunks (one per parallel task) so that filling it
/// copies nothing; the order (by first shared cell, then by position in the cell, or in the
/// cell's sweep order when it is crowded) is the same for any number of threads.
#[derive(Debug, Default)]
pub struct PairSet {
    chunks: Vec<PairChunk>,
    used: usize,
    /// First cell of each task, and the end.
    bounds: Vec<usize>,
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

    /// Number of chunks ([`PairSet::chunks`]).
    pub fn chunk_count(&self) -> usize {
        self.used
    }

    /// Chunk `i` of [`PairSet::chunks`] (empty past the last), for consumers that index them.
    pub fn chunk(&self, i: usize) -> &[[u32; 2]] {
        self.chunks[..self.used]
            .get(i)
            .map_or(&[], |c| c.pairs.as_slice())
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
            [l.a.x, l.a.y, l.a.z, l.b.x, l.b.y, l.b.z, l.radius, scale]
        }
        _ => [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, f32::NAN, 1.0],
    }
}

impl Grid {
    /// Every unique pair of sections that share a cell and whose bounding boxes (grown by the
    /// margin) overlap, skipping same-skeleton neighbours as configured. Contains every pair whose
    /// SSV distance is at most the margin. Each pair appears once, as `[i, j]` with `i < j`.
    pub fn candidate_pairs(&self, out: &mut PairSet) {
        self.enumerate_pairs(out, false, false);
    }

    /// The pairs whose SSV distance (hair-ssv's exact distance, signed) is at most the margin:
    /// [`Grid::candidate_pairs`] followed by the exact test, in one pass.
    pub fn overlapping_pairs(&self, out: &mut PairSet) {
        self.enumerate_pairs(out, true, false);
    }

    /// [`Grid::overlapping_pairs`], the same pairs in the same order, each given by the
    /// positions of its sections in [`Grid::search_order`] (the section with the lower index
    /// first). Data laid out in that order is read nearly in sequence while the pairs are
    /// processed: sections that share cells sit close together in it.
    pub fn overlapping_pairs_by_rank(&self, out: &mut PairSet) {
        self.enumerate_pairs(out, true, true);
    }

    /// The sections (indices into the slice given to [`Grid::rebuild`]) in the order the pair
    /// search visits them: by the first cell each covers, then by index.
    pub fn search_order(&self) -> &[u32] {
        &self.packed.order[..self.len()]
    }

    fn enumerate_pairs(&self, out: &mut PairSet, exact: bool, ranked: bool) {
        self.enumerate_pairs_with(out, Report { exact, ranked }, Kernel::best());
    }

    /// The pair search with the given kernels (a kernel this processor lacks falls back to the
    /// next narrower one). Every kernel gives the same pairs in the same order.
    fn enumerate_pairs_with(&self, out: &mut PairSet, report: Report, kernel: Kernel) {
        out.clear();
        let n_cells = self.cell_keys.len();
        let bounds = &mut out.bounds;
        bounds.clear();
        bounds.push(0);
        let mut work = 0u64;
        for (c, w) in self.cell_start.windows(2).enumerate() {
            let m = u64::from(w[1] - w[0]);
            work += m * m + CELL_WORK;
            if work >= TASK_WORK {
                bounds.push(c + 1);
                work = 0;
            }
        }
        if *bounds.last().unwrap_or(&0) < n_cells {
            bounds.push(n_cells);
        }
        let tasks = bounds.len() - 1;
        if out.chunks.len() < tasks {
            out.chunks.resize_with(tasks, PairChunk::default);
        }
        out.used = tasks;
        let kernel = kernel.min(Kernel::detected());
        let bounds = &out.bounds;
        out.chunks[..tasks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(t, chunk)| {
                let cells = bounds[t]..bounds[t + 1];
                match kernel {
                    Kernel::Avx512 => self.task_avx512(cells, chunk, report),
                    Kernel::Avx2 => self.task_avx2(cells, chunk, report),
                    Kernel::Base => self.task::<false, false>(cells, chunk, report),
                }
            });
    }

    /// One task of the pair search compiled for AVX-512: the rows test sixteen boxes per
    /// instruction and keep their pairs with lane masks and a compress (no loop over the hits);
    /// the exact test is the AVX2 one.
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    fn task_avx512(&self, cells: std::ops::Range<usize>, chunk: &mut PairChunk, report: Report) {
        #[target_feature(enable = "avx512f,avx2,popcnt,bmi1")]
        fn run(grid: &Grid, cells: std::ops::Range<usize>, chunk: &mut PairChunk, report: Report) {
            grid.task::<true, true>(cells, chunk, report);
        }
        // SAFETY: called only when `Kernel::best` found AVX-512F, AVX2, POPCNT and BMI1 on this
        // processor.
        unsafe { run(self, cells, chunk, report) }
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn task_avx512(&self, cells: std::ops::Range<usize>, chunk: &mut PairChunk, report: Report) {
        self.task::<false, false>(cells, chunk, report);
    }

    /// One task of the pair search compiled for AVX2: the row tests eight boxes per instruction
    /// and the exact test runs eight lanes per instruction. (The results are the same: Rust
    /// never fuses or reorders floating-point operations, whatever the instruction set.)
    #[cfg(target_arch = "x86_64")]
    #[allow(unsafe_code)]
    fn task_avx2(&self, cells: std::ops::Range<usize>, chunk: &mut PairChunk, report: Report) {
        #[target_feature(enable = "avx2")]
        fn run(grid: &Grid, cells: std::ops::Range<usize>, chunk: &mut PairChunk, report: Report) {
            grid.task::<true, false>(cells, chunk, report);
        }
        // SAFETY: called only when `has_avx2` found AVX2 on this processor.
        unsafe { run(self, cells, chunk, report) }
    }

    #[cfg(not(target_arch = "x86_64"))]
    fn task_avx2(&self, cells: std::ops::Range<usize>, chunk: &mut PairChunk, report: Report) {
        self.task::<false, false>(cells, chunk, report);
    }

    /// The pairs first reported by the cells of one task, into `chunk.pairs`.
    #[inline(always)]
    fn task<const AVX: bool, const WIDE: bool>(
        &self,
        cells: std::ops::Range<usize>,
        chunk: &mut PairChunk,
        report: Report,
    ) {
        chunk.pairs.clear();
        chunk.n_cand = 0;
        for c in cells {
            self.cell_pairs::<AVX, WIDE>(c, chunk, report);
        }
        self.finish::<AVX, WIDE>(&chunk.cand[..chunk.n_cand], &mut chunk.pairs, report);
        chunk.n_cand = 0;
    }

    /// The candidates first reported by cell `c`, into `chunk.cand` (flushed as it fills).
    #[inline(always)]
    fn cell_pairs<const AVX: bool, const WIDE: bool>(
        &self,
        c: usize,
        chunk: &mut PairChunk,
        report: Report,
    ) {
        let pk = &self.packed;
        let range = self.cell_start[c] as usize..self.cell_start[c + 1] as usize;
        let m = range.len();
        if m < 2 {
            return;
        }
        let PairChunk {
            pairs,
            cols,
            cand,
            n_cand,
            sweep,
            ..
        } = chunk;
        let (ents, earlier) = (&pk.items[range.clone()], &self.entry_earlier[range]);
        let sweep = (m >= SWEEP_MIN).then(|| {
            sweep.sort(&pk.boxes, ents, earlier);
            &*sweep
        });
        let cell = CellEntries {
            key: self.cell_keys[c],
            ents: sweep.map_or(ents, |s| &s.ents),
            earlier: sweep.map_or(earlier, |s| &s.earlier),
            sweep,
        };
        #[cfg(target_arch = "x86_64")]
        if AVX || WIDE {
            self.cell_pairs_blocks::<WIDE>(&cell, &mut chunk.blocks, pairs, cand, n_cand, report);
            return;
        }
        let (ents, earlier) = (cell.ents, cell.earlier);
        // Gather the cell's sections into columns.
        if cols.skel.len() < m + PAD {
            for col in cols.boxes.iter_mut() {
                col.resize(m + PAD, f32::NAN);
            }
            for col in [&mut cols.skel, &mut cols.seg] {
                col.resize(m + PAD, 0);
            }
            cols.earlier.resize(m + PAD, 0);
        }
        cols.earlier[..m].copy_from_slice(earlier);
        for col in cols.boxes.iter_mut() {
            col[m..m + PAD].fill(f32::NAN);
        }
        {
            // Slices, not vectors: their pointers stay in registers across the stores.
            let [lx, ly, lz, hx, hy, hz] = cols.boxes.each_mut().map(|c| &mut c[..m]);
            let (skel, seg) = (&mut cols.skel[..m], &mut cols.seg[..m]);
            for (e, &it) in ents.iter().enumerate() {
                let b = &pk.boxes[it as usize];
                lx[e] = b.lo[0];
                ly[e] = b.lo[1];
                lz[e] = b.lo[2];
                hx[e] = b.hi[0];
                hy[e] = b.hi[1];
                hz[e] = b.hi[2];
                skel[e] = b.skeleton;
                seg[e] = b.segment;
            }
        }
        let cols = &*cols;
        // The count of buffered candidates lives in a register for the whole cell (through the
        // `PairChunk` it would be stored and reloaded at every hit).
        let mut nc = *n_cand;
        let view = CellView::new(cols, m + PAD);
        for a in 0..m - 1 {
            // This row's candidates: at most one per box after `a`.
            if cand.len() < nc + m {
                cand.resize(nc + m, [0; 2]);
            }
            let row = &mut cand[nc..nc + m];
            let end = cell.row_end(a);
            let k = self.row(&cell, &view, cols, a, end, row);
            nc += k;
            if nc >= BATCH {
                self.finish::<AVX, false>(&cand[..nc], pairs, report);
                nc = 0;
            }
        }
        *n_cand = nc;
    }

    /// [`Grid::cell_pairs`] on the cell in blocks of sixteen: the AVX-512 rows ([`row_avx512`])
    /// when `WIDE`, else the AVX2 ones ([`row_avx2`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn cell_pairs_blocks<const WIDE: bool>(
        &self,
        cell: &CellEntries,
        blocks: &mut Vec<Block16>,
        pairs: &mut Vec<[u32; 2]>,
        cand: &mut Vec<[u32; 2]>,
        n_cand: &mut usize,
        report: Report,
    ) {
        let m = cell.ents.len();
        let n_blocks = m.div_ceil(16);
        if blocks.len() < n_blocks {
            blocks.resize(n_blocks, Block16::default());
        }
        let blocks = &mut blocks[..n_blocks];
        let (boxes, ents, earlier) = (&self.packed.boxes, cell.ents, cell.earlier);
        let any = if WIDE {
            // SAFETY: `WIDE` is true only in code reached from `Grid::task_avx512`, which runs
            // only when `Kernel::best` found AVX-512F on this processor.
            #[allow(unsafe_code)]
            unsafe {
                gather_avx512(boxes, ents, earlier, blocks)
            }
        } else {
            gather_blocks(boxes, ents, earlier, blocks)
        };
        let blocks = &*blocks;
        // Whether an owner test of this cell may be left undecided by the bit sets (both share
        // only `OUTSIDE`, or one is `UNKNOWN`): only with such bits in the cell.
        let special = any & (OUTSIDE | UNKNOWN) != 0;
        // Whether a cover of this cell is too long to be described (rare).
        let unknown = any & UNKNOWN != 0;
        let skip = self.config.skip_neighbours;
        let mut nc = *n_cand;
        for a in 0..m - 1 {
            let end = cell.row_end(a);
            if end <= a + 1 {
                continue;
            }
            // Room for this row's candidates (at most one per box after `a`) and for the
            // sixteen pairs the AVX-512 kernel writes past its last kept one.
            if cand.len() < nc + m + 16 {
                cand.resize(nc + m + 16, [0; 2]);
            }
            let row = &mut cand[nc..nc + m + 16];
            // SAFETY: reached only from `Grid::task_avx512` (`WIDE`), which runs only when
            // `Kernel::best` found AVX-512F, POPCNT and BMI1 on this processor, or from
            // `Grid::task_avx2`, which runs only when it found AVX2.
            #[allow(unsafe_code)]
            let k = if WIDE {
                unsafe { row_avx512(blocks, end, a, skip, special, row) }
            } else {
                unsafe { row_avx2(blocks, end, a, skip, unknown, row) }
            }
            .unwrap_or_else(|| self.row_blocks(cell.key, blocks, end, a, row));
            nc += k;
            if nc >= BATCH {
                self.finish::<true, WIDE>(&cand[..nc], pairs, report);
                nc = 0;
            }
        }
        *n_cand = nc;
    }

    /// Row `a` of a cell in blocks, one pair at a time with the key lists for an undecided
    /// owner: the wide kernel's fallback (written to the start of `row`; returns the count).
    #[cfg(target_arch = "x86_64")]
    fn row_blocks(
        &self,
        key: u64,
        blocks: &[Block16],
        m: usize,
        a: usize,
        row: &mut [[u32; 2]],
    ) -> usize {
        let at = |e: usize| (&blocks[e / 16], e % 16);
        let (ba, la) = at(a);
        let skip = self.config.skip_neighbours;
        let mut k = 0;
        for b in a + 1..m {
            let (bb, lb) = at(b);
            let overlap =
                (0..3).all(|x| bb.lo[x][lb] <= ba.hi[x][la] && ba.lo[x][la] <= bb.hi[x][lb]);
            let apart = ba.skel[la] != bb.skel[lb] || ba.seg[la].abs_diff(bb.seg[lb]) > skip;
            if !(overlap && apart) {
                continue;
            }
            let (here, unsure) = owner(ba.earlier[la], bb.earlier[lb]);
            let (ent_a, ent_b) = (ba.ents[la], bb.ents[lb]);
            if here || (unsure && self.first_shared(key, ent_a, ent_b)) {
                row[k] = [ent_a, ent_b];
                k += 1;
            }
        }
        k
    }

    /// The candidates of row `a` of a cell (its pairs with the sections after it, up to `end`,
    /// that this cell reports), written to the start of `row`; returns their count.
    #[inline(always)]
    fn row(
        &self,
        cell: &CellEntries,
        view: &CellView,
        cols: &CellCols,
        a: usize,
        end: usize,
        row: &mut [[u32; 2]],
    ) -> usize {
        let (key, ents) = (cell.key, cell.ents);
        let skip = self.config.skip_neighbours;
        let bx = &view.cols;
        let head = &RowHead {
            lo: [bx[0][a], bx[1][a], bx[2][a]],
            hi: [bx[3][a], bx[4][a], bx[5][a]],
            earlier: view.earlier[a],
        };
        let (skel_a, seg_a, ent_a) = (cols.skel[a], cols.seg[a], ents[a]);
        let mut k = 0;
        let b0 = a + 1;
        let n = end.saturating_sub(b0);
        for g in 0..n.div_ceil(64) {
            let start = b0 + 64 * g;
            let mut bits = row_hits_base(view, head, start, (n - 64 * g).min(64));
            // The neighbour and owner tests hit by hit, branch-free but for the rare undecided
            // owner.
            while bits != 0 {
                let b = start + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                let (skel_b, seg_b) = (cols.skel[b], cols.seg[b]);
                let (here, unsure) = owner(head.earlier, view.earlier[b]);
                let apart = (skel_a != skel_b) | (seg_a.abs_diff(seg_b) > skip);
                // Written ahead, kept by advancing `k`: no branch but for the rare `unsure`.
                row[k] = [ent_a, ents[b]];
                if apart & unsure {
                    k += usize::from(self.first_shared(key, ent_a, ents[b]));
                    continue;
                }
                k += usize::from(apart & here);
            }
        }
        k
    }

    /// Moves the buffered candidates to the output: as they are, or through the exact test.
    #[inline(always)]
    fn finish<const AVX: bool, const WIDE: bool>(
        &self,
        cand: &[[u32; 2]],
        pairs: &mut Vec<[u32; 2]>,
        report: Report,
    ) {
        let order = &self.packed.order;
        // The pair as reported: by section index, or by rank with the lower index first (the
        // same orientation).
        let orig = |[a, b]: [u32; 2]| {
            let (i, j) = (order[a as usize], order[b as usize]);
            match (report.ranked, i < j) {
                (false, _) => [i.min(j), i.max(j)],
                (true, true) => [a, b],
                (true, false) => [b, a],
            }
        };
        if !report.exact {
            pairs.extend(cand.iter().map(|&p| orig(p)));
            return;
        }
        let margin = self.config.margin;
        // Sixteen lanes with AVX-512, else eight.
        let width = if WIDE { 2 * LANES } else { LANES };
        // The lane tests of up to `BATCH` candidates first, then their kept pairs: with no
        // branch between them, one block's chain of divisions and square root overlaps the next
        // ones' instead of waiting behind a mispredicted push loop.
        for part in cand.chunks(BATCH) {
            let mut blocks = part.chunks_exact(width);
            let n_blocks = blocks.len();
            let mut keep = [0u16; BATCH / LANES];
            for (k, block) in keep.iter_mut().zip(&mut blocks) {
                *k = self.exact_lanes::<AVX, WIDE>(block, margin, (1 << width) - 1) as u16;
            }
            for (b, &k) in keep[..n_blocks].iter().enumerate() {
                let mut k = k;
                while k != 0 {
                    pairs.push(orig(part[width * b + k.trailing_zeros() as usize]));
                    k &= k - 1;
                }
            }
            // The last few candidates through the lanes too, padded with copies of the last one
            // and masked: the scalar test reads the shapes in section order, a cache miss each.
            let rest = blocks.remainder();
            if let Some(&last) = rest.last() {
                let mut block = [last; 2 * LANES];
                block[..rest.len()].copy_from_slice(rest);
                let block = &block[..width];
                let mut k = self.exact_lanes::<AVX, WIDE>(block, margin, (1 << rest.len()) - 1);
                while k != 0 {
                    pairs.push(orig(rest[k.trailing_zeros() as usize]));
                    k &= k - 1;
                }
            }
        }
    }

    /// The exact test on the candidates of `block` whose bits are set in `lanes` (bit `l` of the
    /// result set when candidate `l` is kept; the other lanes are computed and ignored): hair-ssv's
    /// segment-segment kernel run lane-wise on the packed lines. It agrees with the scalar kernel
    /// up to rounding, so a pair within a rounding band of the margin (and any pair that is not
    /// two LSS) is decided by [`Ssv::distance`] itself: the result is exactly
    /// `distance <= margin`.
    #[inline(always)]
    #[allow(unsafe_code)]
    fn exact_lanes<const AVX: bool, const WIDE: bool>(
        &self,
        block: &[[u32; 2]],
        margin: Real,
        lanes: u32,
    ) -> u32 {
        let lines = &self.packed.lines;
        #[cfg(target_arch = "x86_64")]
        let (mut sure, mut open) = if WIDE {
            // SAFETY: `WIDE` is true only in code reached from `Grid::task_avx512`, which runs
            // only when `Kernel::best` found AVX-512F on this processor.
            unsafe { lanes_decide_avx512(lines, block, margin) }
        } else if AVX {
            // SAFETY: `AVX` is true only in code reached from `Grid::task_avx2`, which runs only
            // when `has_avx2` found AVX2 on this processor.
            unsafe { lanes_decide_avx2(lines, block, margin) }
        } else {
            lanes_decide(lines, block, margin)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (mut sure, mut open) = lanes_decide(lines, block, margin);
        (sure, open) = (sure & lanes, open & lanes);
        while open != 0 {
            let l = open.trailing_zeros() as usize;
            open &= open - 1;
            if self.within_margin(block[l], margin) {
                sure |= 1 << l;
            }
        }
        sure
    }

    /// Whether the sections of the candidate `[a, b]` (internal indices) are within the margin
    /// by hair-ssv's exact distance, taken from the lower section index to the higher.
    fn within_margin(&self, [a, b]: [u32; 2], margin: Real) -> bool {
        let order = &self.packed.order;
        let (a, b) = if order[a as usize] < order[b as usize] {
            (a, b)
        } else {
            (b, a)
        };
        let (p, q) = (self.packed_shape(a as usize), self.packed_shape(b as usize));
        p.distance(&q) <= margin
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

/// The exact test on eight candidates (`block`, internal indices) in plain Rust: hair-ssv's
/// segment-segment kernel lane-wise on the packed lines ([`hair_ssv::lss_lss_lanes`]), then
/// `(sure, open)` lane masks: the distance is surely within `margin`, or within a rounding band
/// of it (or NaN: not two LSS) so that the scalar test must decide.
#[inline(always)]
fn lanes_decide(lines: &[Line], block: &[[u32; 2]], margin: Real) -> (u32, u32) {
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

/// The exact test's arithmetic on lanes of a vector type `$v`: from the transposed cores `$p`
/// and `$q` (eight registers each: `a`, `b`, radius, scale), the LSS-LSS distances and the
/// rounding bands, as `(d, band)`. Written once for the AVX2 and AVX-512 kernels, which then
/// run the same operations in the same order (hair-ssv's segment-segment kernel, lane-wise).
/// `$gt` compares into a lane mask, and `$select(mask, no, yes)` takes `yes` where it is set.
#[cfg(target_arch = "x86_64")]
macro_rules! lss_lanes {
    ($p:expr, $q:expr, $v:ty, $add:expr, $sub:expr, $mul:expr, $div:expr, $min:expr,
     $max:expr, $sqrt:expr, $splat:expr, $gt:expr, $select:expr) => {{
        let (p, q) = ($p, $q);
        let (add, sub, mul, div) = ($add, $sub, $mul, $div);
        let zero = $splat(0.0);
        let one = $splat(1.0);
        // `x.clamp(0.0, 1.0)` for any `x` but NaN's payload: `max(0, x)` keeps `x` when it is
        // NaN or -0.0 (the second operand wins ties and NaN), as `clamp` does.
        let clamp01 = |x: $v| $min(one, $max(zero, x));
        let dot =
            |a: [$v; 3], b: [$v; 3]| add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]));
        let cross = |a: [$v; 3], b: [$v; 3]| {
            [
                sub(mul(a[1], b[2]), mul(a[2], b[1])),
                sub(mul(a[2], b[0]), mul(a[0], b[2])),
                sub(mul(a[0], b[1]), mul(a[1], b[0])),
            ]
        };
        let u = [0, 1, 2].map(|k| sub(p[3 + k], p[k]));
        let v = [0, 1, 2].map(|k| sub(q[3 + k], q[k]));
        let r = [sub(p[0], q[0]), sub(p[1], q[1]), sub(p[2], q[2])];
        let a = dot(u, u);
        let e = dot(v, v);
        let b = dot(u, v);
        let c = dot(u, r);
        let f = dot(v, r);
        let denom = sub(mul(a, e), mul(b, b));
        let classic = div(sub(mul(b, f), mul(c, e)), denom);
        let n = cross(u, v);
        let m = cross(v, r);
        let nn = dot(n, n);
        let crossed = div(dot(n, m), nn);
        let s0 = $select($gt(nn, zero), zero, crossed);
        let s0 = $select($gt(denom, mul(mul($splat(0.0625), a), e)), s0, classic);
        let s0 = clamp01(s0);
        let inv_e = $select($gt(e, zero), zero, div(one, e));
        let inv_a = $select($gt(a, zero), zero, div(one, a));
        let t = clamp01(mul(add(mul(b, s0), f), inv_e));
        let s = clamp01(mul(sub(mul(b, t), c), inv_a));
        let w = [0, 1, 2].map(|k| sub(add(r[k], mul(u[k], s)), mul(v[k], t)));
        let d = sub($sqrt(dot(w, w)), add(p[6], q[6]));
        // `p.max(q)` for the scales, which are never NaN (at least 1).
        (d, mul($splat(1e-5), $max(p[7], q[7])))
    }};
}

/// [`lanes_decide`] with AVX2 intrinsics, the same operations in the same order (so the same
/// values): a core is eight floats, one register, so the eight first cores are loaded whole and
/// transposed in registers (the second ones the same way) instead of 128 single moves, and the
/// lane masks come from compares and `movemask` instead of a loop over the lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
#[allow(unsafe_code)]
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
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn transpose8(r: [std::arch::x86_64::__m256; 8]) -> [std::arch::x86_64::__m256; 8] {
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

/// Box tests of one row: bit `k` is set when the box at `start + k` (`k < len <= 64`) overlaps
/// the head's box.
///
/// On x86-64, four boxes per SSE2 compare and `movemask` (SSE2 is part of the base instruction
/// set): the portable form compiles to byte-wise compares whose conversion to bits took most of
/// the pair search's instructions.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
fn row_hits_base(view: &CellView, head: &RowHead, start: usize, len: usize) -> u64 {
    #[target_feature(enable = "sse2")]
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
fn row_hits_base(view: &CellView, head: &RowHead, start: usize, len: usize) -> u64 {
    row_hits_portable(view, head, start, len)
}

/// The box tests of one row in plain Rust (the kernel off x86-64; on x86-64, the tests' oracle).
#[cfg(any(test, not(target_arch = "x86_64")))]
#[inline(always)]
fn row_hits_portable(view: &CellView, head: &RowHead, start: usize, len: usize) -> u64 {
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

/// The kernels of the pair search, narrowest first. Each gives the same pairs in the same
/// order; the search runs the widest one the processor has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Kernel {
    /// SSE2 row tests on x86-64, plain Rust elsewhere.
    Base,
    /// AVX2 row tests and exact test.
    Avx2,
    /// AVX-512F rows ([`Grid::row_avx512`]) and the AVX2 exact test.
    Avx512,
}

/// The instruction set the pair search and the rebuild's covers use on this processor:
/// `"avx512"`, `"avx2"` or `"baseline"` (SSE2 on x86-64, plain Rust elsewhere): the widest it
/// has, or a narrower one asked for by `HAIR_GRID_KERNEL` ([`requested_kernel`]). Every kernel
/// gives the same cells and pairs in the same order; only the time differs, so benchmark
/// figures should name it.
pub fn kernel_name() -> &'static str {
    Kernel::best().name()
}

impl Kernel {
    /// The kernel the grid runs: the widest this processor has ([`Kernel::detected`]), no wider
    /// than `HAIR_GRID_KERNEL` asks ([`kernel_cap`]).
    pub(crate) fn best() -> Self {
        let detected = Self::detected();
        match kernel_cap() {
            Ok(Some(cap)) => detected.min(*cap),
            _ => detected,
        }
    }

    /// The widest kernel this processor runs (checked once by the standard library, then
    /// cached).
    pub(crate) fn detected() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("popcnt")
            && std::arch::is_x86_feature_detected!("bmi1")
            && has_avx2()
        {
            return Kernel::Avx512;
        }
        if has_avx2() {
            Kernel::Avx2
        } else {
            Kernel::Base
        }
    }

    fn name(self) -> &'static str {
        match self {
            Kernel::Avx512 => "avx512",
            Kernel::Avx2 => "avx2",
            Kernel::Base => "baseline",
        }
    }

    /// The kernel of a name as [`kernel_name`] gives it.
    fn from_name(name: &str) -> Option<Self> {
        match name {
            "avx512" => Some(Kernel::Avx512),
            "avx2" => Some(Kernel::Avx2),
            "baseline" => Some(Kernel::Base),
            _ => None,
        }
    }
}

/// The kernel the environment variable `HAIR_GRID_KERNEL` asks for (`avx512`, `avx2` or
/// `baseline`, as [`kernel_name`] names them), read once: `Ok(None)` when it is not set, and
/// `Err` with the value when it names no kernel (the grid then runs the widest kernel the
/// processor has, as when it is not set). It only narrows: a kernel the processor lacks is not
/// run, the widest it has is. For measuring the narrower kernels on a wide machine; every
/// kernel gives the same cells and pairs in the same order, so a simulation's states do not
/// change with it.
pub fn requested_kernel() -> Result<Option<&'static str>, String> {
    kernel_cap().clone().map(|k| k.map(Kernel::name))
}

/// [`requested_kernel`] as a kernel.
fn kernel_cap() -> &'static Result<Option<Kernel>, String> {
    static CAP: std::sync::OnceLock<Result<Option<Kernel>, String>> = std::sync::OnceLock::new();
    CAP.get_or_init(|| match std::env::var("HAIR_GRID_KERNEL") {
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(v)) => Err(v.to_string_lossy().into_owned()),
        Ok(v) => Kernel::from_name(v.trim()).map(Some).ok_or(v),
    })
}

/// The 16 x 8 transpose of sixteen rows of eight floats: lane `l` of output `k` is field `k` of
/// row `l`. Register `i` takes rows `i` and `i + 8`, one per 256-bit half, and each half is
/// transposed as eight by eight ([`transpose8`]'s steps, the last as a two-register pick).
#[cfg(target_arch = "x86_64")]
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

/// [`lanes_decide_avx2`] on sixteen candidates with AVX-512: the same operations in the same
/// order on every lane ([`lss_lanes`]), so the same values and decisions.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
#[allow(unsafe_code)]
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
/// columns, so each sixteen boxes are loaded whole and transposed in registers (about fifty
/// instructions) instead of written field by field (over two hundred).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
#[allow(unsafe_code)]
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

/// A row of a cell with AVX-512 ([`Grid::row`]'s result, on the cell in blocks of sixteen): the
/// pairs of section `a` with the later sections of the cell that this cell reports, written to
/// the start of `row`, and their count. Sixteen boxes per compare, and the neighbour and owner
/// tests lane-wise too, so that a block's kept pairs come out of one mask and a compress, with
/// no loop over the hits (with AVX2 that loop cost about as much as the box tests). `special`
/// says that the cell holds bit sets with [`OUTSIDE`] or [`UNKNOWN`]; then a row with a pair
/// the bit sets cannot tell ([`owner`]'s `unsure`, rare) gives `None`, for
/// [`Grid::row_blocks`] to do again with the key lists. (No call inside: around one, every
/// vector register would be spilled.)
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,popcnt,bmi1")]
#[inline]
#[allow(unsafe_code)]
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

/// The sections `ents` of a cell (with their earlier-cell bit sets) into blocks of sixteen,
/// field by field; the lanes past the last section get NaN boxes, which fail every comparison.
/// Returns the union of the bit sets.
#[cfg(target_arch = "x86_64")]
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

/// A row of a cell with AVX2, on the cell in blocks of sixteen ([`Grid::row`]'s result): the
/// box tests eight lanes at a time, less the lanes whose pair an earlier cell surely reports
/// (in crowded cells of long sections most box hits are such repeats: eight are ruled out for
/// the cost of one in the hit loop), then the neighbour and owner tests hit by hit (lane-wise,
/// without a compress, they took more instructions than they saved). Every field of a block
/// sits at a fixed offset from one pointer, so the row keeps its registers (with a pointer per
/// column they were spilled and reloaded at every row). `unknown_cell` says that the cell holds
/// a bit set with [`UNKNOWN`] (else that test is left out). A pair the bit sets cannot tell
/// gives `None`, for [`Grid::row_blocks`] to do again with the key lists.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
#[allow(unsafe_code)]
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

/// Whether the processor supports AVX2 (checked once by the standard library, then cached).
#[cfg(target_arch = "x86_64")]
fn has_avx2() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

#[cfg(not(target_arch = "x86_64"))]
fn has_avx2() -> bool {
    false
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

/// What the bit sets of two sections in a cell say about reporting their pair there:
/// `(here, unsure)`. `here`: no earlier cell is shared, so this cell reports the pair. `unsure`:
/// the bit sets cannot tell (a shared cell may lie outside the window), so the key lists decide.
/// Neither: an earlier shared cell reports it. Plain bit arithmetic, no branch: the outcome is
/// unpredictable, and a branch on it is mispredicted about every other box hit.
#[inline(always)]
fn owner(a: u64, b: u64) -> (bool, bool) {
    let both = a & b;
    let unsure = (both != 0) & (((a | b) & UNKNOWN != 0) | (both & WINDOW == 0));
    (both == 0, unsure)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{CellKey, GridConfig, Section};
    use hair_ssv::{Lss, Point};

    /// A seeded generator for the kernel tests.
    fn lcg(z: &mut u64) -> f32 {
        *z = z
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (*z >> 40) as f32 / (1u64 << 24) as f32
    }

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
                    assert_eq!(row_hits_base(&view, &head, start, len), expect);
                }
            }
        }
    }

    /// The AVX2 rows keep exactly the pairs of the row's rules, computed pair by pair: boxes
    /// overlapping (on a coarse lattice, so that they often touch exactly), sections not
    /// neighbours on one skeleton, and no earlier cell shared; a pair whose owner the bit sets
    /// cannot tell (cells outside the window, covers too long to be described) gives `None`.
    #[test]
    fn the_avx2_rows_keep_what_the_pair_rules_keep() {
        #[cfg(target_arch = "x86_64")]
        if has_avx2() {
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
                    let any = gather_blocks(&boxes, &ents, &earlier, &mut blocks);
                    assert_eq!(any, earlier.iter().fold(0, |a, b| a | b));
                    let mut row = vec![[0u32; 2]; m];
                    for a in 0..m - 1 {
                        let mut expect = Vec::new();
                        let mut unsure_any = false;
                        for b in a + 1..m {
                            let (pa, pb) = (&boxes[a], &boxes[b]);
                            let overlap =
                                (0..3).all(|k| pb.lo[k] <= pa.hi[k] && pa.lo[k] <= pb.hi[k]);
                            let apart =
                                pa.skeleton != pb.skeleton || pa.segment.abs_diff(pb.segment) > 1;
                            let (here, unsure) = owner(earlier[a], earlier[b]);
                            unsure_any |= overlap && apart && unsure;
                            if overlap && apart && here {
                                expect.push([a as u32, b as u32]);
                            }
                        }
                        #[allow(unsafe_code)]
                        // SAFETY: AVX2 was found on this processor.
                        let got =
                            unsafe { row_avx2(&blocks, m, a, 1, any & UNKNOWN != 0, &mut row) };
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

    #[test]
    fn the_lane_kernels_decide_as_the_scalar_distance() {
        let mut z = 9u64;
        // Segments on a coarse lattice (parallel, touching, crossing and zero-length ones come
        // up often), some with a NaN radius (not an LSS: always undecided).
        let line = |z: &mut u64| -> Line {
            let at = |z: &mut u64| (lcg(z) * 8.0).floor() * 0.25;
            let a = [at(z), at(z), at(z)];
            let u = if lcg(z) < 0.1 {
                [0.0; 3]
            } else {
                [at(z) - 1.0, at(z) - 1.0, at(z) - 1.0]
            };
            let radius = if lcg(z) < 0.05 {
                f32::NAN
            } else {
                lcg(z) * 0.5
            };
            let b = [0, 1, 2].map(|k| a[k] + u[k]);
            let scale = a.iter().chain(&b).map(|c| c.abs()).fold(1.0f32, f32::max);
            [a[0], a[1], a[2], b[0], b[1], b[2], radius, scale]
        };
        let lines: Vec<Line> = (0..64).map(|_| line(&mut z)).collect();
        let scalar = |l: &Line, m: &Line| {
            let shape = |l: &Line| {
                Ssv::Line(Lss::new(
                    Point::new(l[0], l[1], l[2]),
                    Point::new(l[3], l[4], l[5]),
                    l[6],
                ))
            };
            shape(l).distance(&shape(m))
        };
        let mut decided = 0;
        let mut previous = vec![[0u32, 1u32]; LANES];
        let mut wide16 = 0;
        for _ in 0..500 {
            let block: Vec<[u32; 2]> = (0..LANES)
                .map(|_| [(lcg(&mut z) * 64.0) as u32, (lcg(&mut z) * 64.0) as u32])
                .collect();
            let margin = if lcg(&mut z) < 0.5 { 0.0 } else { 0.1 };
            let (sure, open) = lanes_decide(&lines, &block, margin);
            for (l, &[a, b]) in block.iter().enumerate() {
                let (la, lb) = (&lines[a as usize], &lines[b as usize]);
                if open >> l & 1 == 0 {
                    decided += 1;
                    let within = scalar(la, lb) <= margin;
                    assert_eq!(sure >> l & 1 != 0, within, "{la:?} {lb:?}");
                } else {
                    assert_eq!(sure >> l & 1, 0);
                }
            }
            #[cfg(target_arch = "x86_64")]
            if has_avx2() {
                #[allow(unsafe_code)]
                // SAFETY: AVX2 was found on this processor.
                let wide = unsafe { lanes_decide_avx2(&lines, &block, margin) };
                assert_eq!(wide, (sure, open));
            }
            // Sixteen lanes: this block, then the previous one.
            #[cfg(target_arch = "x86_64")]
            if Kernel::detected() == Kernel::Avx512 {
                let pair: Vec<[u32; 2]> = block.iter().chain(&previous).copied().collect();
                #[allow(unsafe_code)]
                // SAFETY: AVX-512F was found on this processor.
                let wide = unsafe { lanes_decide_avx512(&lines, &pair, margin) };
                let (sure_p, open_p) = lanes_decide(&lines, &previous, margin);
                assert_eq!(wide, (sure | sure_p << 8, open | open_p << 8));
                wide16 += 1;
            }
            previous = block;
        }
        #[cfg(target_arch = "x86_64")]
        if Kernel::detected() == Kernel::Avx512 {
            assert_eq!(wide16, 500);
        }
        assert!(decided > 3000, "{decided}");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        /// Seeded random strands (some long and thick, some of zero length), any margin and
        /// neighbour skipping: every kernel gives the same candidates and pairs in the same
        /// order.
        #[test]
        fn every_kernel_gives_the_same_pairs_on_random_strands(
            seed in 0u64..u64::MAX,
            strands in 1u32..60,
            margin in proptest::prop_oneof![proptest::strategy::Just(0.0f32), 0.0f32..0.01],
            skip in 0u32..3,
        ) {
            let mut z = seed;
            let mut sections = Vec::new();
            for s in 0..strands {
                let mut p = Point::new(lcg(&mut z), lcg(&mut z), lcg(&mut z)) * 0.03;
                let (n, step, radius) = match s % 7 {
                    0 => (2, 0.03, 0.003),
                    1 => (3, 0.0, 0.0005),
                    _ => (8, 0.012, 0.0005 + 0.001 * lcg(&mut z)),
                };
                for k in 0..n {
                    let d = Point::new(lcg(&mut z), lcg(&mut z), lcg(&mut z))
                        - Point::new(0.5, 0.5, 0.5);
                    let q = p + d * step;
                    sections.push(Section {
                        skeleton: s,
                        segment: k,
                        shape: Ssv::Line(Lss::new(p, q, radius)),
                    });
                    p = q;
                }
            }
            let mut grid = crate::Grid::new(GridConfig {
                margin,
                skip_neighbours: skip,
                ..GridConfig::default()
            });
            proptest::prop_assume!(grid.rebuild(&sections).is_ok());
            for (exact, ranked) in [(false, false), (true, false), (true, true)] {
                let report = Report { exact, ranked };
                let mut base = PairSet::new();
                grid.enumerate_pairs_with(&mut base, report, Kernel::Base);
                for kernel in [Kernel::Avx2, Kernel::Avx512] {
                    let mut other = PairSet::new();
                    grid.enumerate_pairs_with(&mut other, report, kernel);
                    proptest::prop_assert_eq!(base.to_vec(), other.to_vec(), "{:?}", kernel);
                }
            }
        }
    }

    #[test]
    fn the_pair_search_is_the_same_with_every_kernel() {
        // Strands in a 4 cm box, dense enough for cells of tens of sections.
        let mut z = 11u64;
        let mut sections = Vec::new();
        for s in 0..400u32 {
            let mut p = Point::new(lcg(&mut z), lcg(&mut z), lcg(&mut z)) * 0.04;
            for k in 0..8 {
                let d =
                    Point::new(lcg(&mut z), lcg(&mut z), lcg(&mut z)) - Point::new(0.5, 0.5, 0.5);
                let q = p + d * 0.012;
                let shape = Ssv::Line(Lss::new(p, q, 0.0005));
                sections.push(Section {
                    skeleton: s,
                    segment: k,
                    shape,
                });
                p = q;
            }
        }
        // And a few long, thick sections across the box: covers with earlier cells outside the
        // window and covers too long to be described, whose owners the key lists decide.
        for s in 0..24u32 {
            let p = Point::new(lcg(&mut z), lcg(&mut z), lcg(&mut z)) * 0.04;
            let q = Point::new(lcg(&mut z), lcg(&mut z), lcg(&mut z)) * 0.04;
            let radius = if s % 3 == 0 { 0.004 } else { 0.001 };
            sections.push(Section {
                skeleton: 400 + s,
                segment: 0,
                shape: Ssv::Line(Lss::new(p, q, radius)),
            });
        }
        let mut grid = crate::Grid::new(GridConfig::default());
        grid.rebuild(&sections).unwrap();
        let bits = &grid.entry_earlier[..grid.entry_count()];
        assert!(bits.iter().any(|b| b & UNKNOWN != 0));
        assert!(bits.iter().any(|b| b & (OUTSIDE | UNKNOWN) == OUTSIDE));
        let kernels = [Kernel::Base, Kernel::Avx2, Kernel::Avx512];
        for exact in [false, true] {
            let report = Report {
                exact,
                ranked: false,
            };
            let mut base = PairSet::new();
            grid.enumerate_pairs_with(&mut base, report, Kernel::Base);
            assert!(base.len() > 1000, "{}", base.len());
            for kernel in kernels {
                let mut other = PairSet::new();
                grid.enumerate_pairs_with(&mut other, report, kernel);
                assert_eq!(base.to_vec(), other.to_vec(), "{kernel:?}");
            }
        }
        // By rank: the same pairs in the same order, with every kernel.
        let order = grid.search_order();
        let mut sorted = order.to_vec();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(k, &i)| k == i as usize));
        let mut plain = PairSet::new();
        grid.overlapping_pairs(&mut plain);
        for kernel in kernels {
            let mut ranked = PairSet::new();
            grid.enumerate_pairs_with(
                &mut ranked,
                Report {
                    exact: true,
                    ranked: true,
                },
                kernel,
            );
            let back: Vec<[u32; 2]> = ranked
                .iter()
                .map(|[a, b]| [order[a as usize], order[b as usize]])
                .collect();
            assert_eq!(back, plain.to_vec());
        }
    }

    #[test]
    fn crowded_cells_are_swept_keeping_every_pair_in_one_order_for_every_kernel() {
        let sections = crate::test_scenes::wisp(300, 5);
        let config = GridConfig {
            margin: 0.001,
            ..GridConfig::default()
        };
        let mut grid = crate::Grid::new(config.clone());
        grid.rebuild(&sections).unwrap();
        // The cells are crowded enough to be swept, and the sweep ends rows early.
        let (mut swept, mut rows, mut cut) = (0, 0, 0);
        let mut sweep = Sweep::default();
        for c in 0..grid.cell_count() {
            let r = grid.cell_start[c] as usize..grid.cell_start[c + 1] as usize;
            if r.len() < SWEEP_MIN {
                continue;
            }
            swept += 1;
            let (ents, earlier) = (
                &grid.packed.items[r.clone()],
                &grid.entry_earlier[r.clone()],
            );
            sweep.sort(&grid.packed.boxes, ents, earlier);
            // A permutation of the cell's entries, by box minimum.
            let mut a = sweep.ents.clone();
            let mut b = ents.to_vec();
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b);
            assert!(sweep.lo.windows(2).all(|w| w[0] <= w[1]));
            rows += r.len() - 1;
            cut += (0..r.len() - 1)
                .filter(|&a| sweep.row_end(a) < r.len())
                .count();
        }
        assert!(swept >= 4, "{swept} swept cells");
        assert!(cut > rows / 2, "{cut} of {rows} rows ended early");
        // Every kernel: the same pairs in the same order, and exactly the pairs within the
        // margin by brute force.
        let report = Report {
            exact: true,
            ranked: false,
        };
        let mut base = PairSet::new();
        grid.enumerate_pairs_with(&mut base, report, Kernel::Base);
        for kernel in [Kernel::Avx2, Kernel::Avx512] {
            let mut other = PairSet::new();
            grid.enumerate_pairs_with(&mut other, report, kernel);
            assert_eq!(base.to_vec(), other.to_vec(), "{kernel:?}");
        }
        let mut got = base.to_vec();
        got.sort_unstable();
        let mut brute = Vec::new();
        for i in 0..sections.len() {
            for j in i + 1..sections.len() {
                let (a, b) = (&sections[i], &sections[j]);
                let neighbours = a.skeleton == b.skeleton
                    && a.segment.abs_diff(b.segment) <= config.skip_neighbours;
                if !neighbours && a.shape.distance(&b.shape) <= config.margin {
                    brute.push([i as u32, j as u32]);
                }
            }
        }
        assert!(brute.len() > 10_000, "{}", brute.len());
        assert_eq!(got, brute);
    }

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
        let (yes, no, unsure) = ((true, false), (false, false), (false, true));
        assert_eq!(owner(0, bit([-1, 0, 0])), yes);
        assert_eq!(owner(bit([-1, 0, 0]), bit([0, -1, 0])), yes);
        assert_eq!(owner(bit([-1, 0, 0]), bit([-1, 0, 0])), no);
        assert_eq!(owner(OUTSIDE, OUTSIDE | bit([0, 0, -1])), unsure);
        assert_eq!(owner(u64::MAX, bit([0, 0, -1])), unsure);
        assert_eq!(owner(u64::MAX, 0), yes);
    }
}
