//! Hair-hair pairs from the grid (Ward & Lin 2003 §5.3): sections sharing a cell are candidates;
//! each pair is reported once, in the first cell both cover.
//!
//! The search runs on a copy of the section data made at each rebuild (`Packed`): sections are
//! renumbered by their first cell, so that walking the cells in key order touches a sliding window
//! of nearby memory instead of the whole scene (with the caller's order, a strand order, every
//! section of a cell is a cache miss). Per cell, a row tests one section's box against the later
//! ones with packed compares; a box hit is kept when the cell is the first one both cover, read
//! from the earlier-cell bit sets stored with the entries (`earlier_cells`, `owner`;
//! `Grid::first_shared` when they cannot tell); the survivors get the exact SSV test, a lane of
//! candidates at a time. How a row and the exact test run is the kernel's ([`crate::kernel`]):
//! the cell by columns (baseline) or in blocks of sixteen (AVX2, AVX-512). A crowded cell is
//! searched as a sweep ([`Sweep`]): its entries sorted along one axis, each row stopped where the
//! boxes no longer reach. Every kernel gives the same pairs in the same order.

use rayon::prelude::*;

use crate::grid::{Grid, unpack3};
#[cfg(target_arch = "x86_64")]
use crate::kernel::BlockRows;
use crate::kernel::{Isa, Selected, baseline};
use crate::{Real, Ssv};

/// Work of one parallel task, in pair tests: a cell of `m` sections counts `m * m` plus
/// [`CELL_WORK`]. The tasks cut the cells by this estimate alone, so that a few crowded cells
/// (long sections, dense hair) are spread over the threads as well as many sparse ones are, and
/// the output order does not depend on the number of threads.
const TASK_WORK: u64 = 1 << 16;

/// The fixed cost of visiting a cell, in pair tests.
const CELL_WORK: u64 = 16;

/// Lanes of the box test and of the exact test (sixteen with AVX-512).
pub(crate) const LANES: usize = 8;

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

/// One parallel task's output and scratch.
#[derive(Debug, Default)]
pub(crate) struct PairChunk {
    work: CellWork,
    /// A crowded cell's entries in sweep order.
    sweep: Sweep,
}

/// What a kernel's cell search writes: the task's pairs, its candidates and the cell's layout.
#[derive(Debug, Default)]
pub(crate) struct CellWork {
    pairs: Vec<[u32; 2]>,
    /// The sections of the current cell by column (the baseline kernel).
    cols: CellCols,
    /// Candidates (internal indices) waiting for the exact test: the first `n_cand`. The rest is
    /// room written ahead, so that appending needs no branch (half of the box hits are dropped,
    /// unpredictably).
    cand: Vec<[u32; 2]>,
    n_cand: usize,
    /// The sections of the current cell in blocks of sixteen (the AVX-512 and AVX2 kernels).
    blocks: Vec<Block16>,
}

/// Cells with at least this many sections are searched as a sweep ([`Sweep`]); smaller ones in
/// their stored order, since in small cells sorting costs more than it saves
/// (`docs/perf/grid.md`, "Sweeps in crowded cells").
const SWEEP_MIN: usize = 128;

/// A crowded cell's entries sorted by box minimum along one axis (the sweep axis), so that a
/// row stops at the first section whose minimum lies past the row's maximum: every later one
/// misses the row's box along that axis. In the dense parts of a head the hair is locally
/// parallel and a cell holds hundreds of sections that share few boxes; the sweep skips most of
/// the box tests of its rows. The sort key is the minimum, then the stored position, so that
/// the order (and the pairs' order) depends on the cell's contents alone.
#[derive(Debug, Default)]
pub(crate) struct Sweep {
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
pub(crate) struct CellEntries<'a> {
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
pub(crate) struct Block16 {
    /// Box minimum and maximum, by axis.
    pub lo: [[f32; 16]; 3],
    pub hi: [[f32; 16]; 3],
    pub skel: [u32; 16],
    pub seg: [u32; 16],
    /// The entry's section (internal index).
    pub ents: [u32; 16],
    /// Earlier-cell bit sets ([`earlier_cells`]).
    pub earlier: [u64; 16],
}

/// What a pair search reports.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Report {
    /// Only the pairs within the margin (else every candidate).
    pub exact: bool,
    /// Pairs by position in the pair search's order ([`Grid::search_order`]) instead of by
    /// section index.
    pub ranked: bool,
}

/// The sections of one cell by column, padded past the cell's `m` entries with [`PAD`] NaN boxes
/// (which fail every comparison) so that the row tests need no remainder.
#[derive(Debug, Default)]
pub(crate) struct CellCols {
    /// Bounding boxes: min x, y, z, max x, y, z.
    pub boxes: [Vec<f32>; 6],
    /// Earlier-cell bit sets ([`earlier_cells`]), padded with zeros.
    pub earlier: Vec<u64>,
    /// Skeleton and segment, padded with zeros.
    pub skel: Vec<u32>,
    pub seg: Vec<u32>,
}

/// The box columns of one cell, each `len` long (the entries and their padding), sliced once per
/// cell so that the rows need one bounds check instead of twelve.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CellView<'a> {
    pub cols: [&'a [f32]; 6],
    pub earlier: &'a [u64],
}

impl<'a> CellView<'a> {
    pub(crate) fn new(cols: &'a CellCols, len: usize) -> Self {
        Self {
            cols: [0, 1, 2, 3, 4, 5].map(|k| &cols.boxes[k][..len]),
            earlier: &cols.earlier[..len],
        }
    }
}

/// Padding of the cell columns: a full group of eight lanes past the last entry.
pub(crate) const PAD: usize = 8;

/// The section `a` a row tests against the later ones.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RowHead {
    pub lo: [f32; 3],
    pub hi: [f32; 3],
    /// The section's earlier-cell bit set in this cell.
    pub earlier: u64,
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
        self.chunks[..self.used]
            .iter()
            .map(|c| c.work.pairs.len())
            .sum()
    }

    /// Whether there is no pair.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The pairs, chunk by chunk (for parallel consumers: `par_bridge` or index the chunks).
    pub fn chunks(&self) -> impl Iterator<Item = &[[u32; 2]]> + '_ {
        self.chunks[..self.used]
            .iter()
            .map(|c| c.work.pairs.as_slice())
    }

    /// Number of chunks ([`PairSet::chunks`]).
    pub fn chunk_count(&self) -> usize {
        self.used
    }

    /// Chunk `i` of [`PairSet::chunks`] (empty past the last), for consumers that index them.
    pub fn chunk(&self, i: usize) -> &[[u32; 2]] {
        self.chunks[..self.used]
            .get(i)
            .map_or(&[], |c| c.work.pairs.as_slice())
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
            c.work.pairs.clear();
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
        self.enumerate_pairs_with(out, Report { exact, ranked }, self.kernel);
    }

    /// The pair search with the given kernel. Every kernel gives the same pairs in the same
    /// order.
    pub(crate) fn enumerate_pairs_with(&self, out: &mut PairSet, report: Report, kernel: Selected) {
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
        let bounds = &out.bounds;
        out.chunks[..tasks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(t, chunk)| kernel.task(self, bounds[t]..bounds[t + 1], chunk, report));
    }

    /// The pairs first reported by the cells of one task, into `chunk`'s pairs. Inlined into
    /// each kernel's [`Isa::task`], which compiles it for its instruction set.
    #[inline(always)]
    pub(crate) fn task<K: Isa>(
        &self,
        isa: K,
        cells: std::ops::Range<usize>,
        chunk: &mut PairChunk,
        report: Report,
    ) {
        let PairChunk { work, sweep } = chunk;
        work.pairs.clear();
        work.n_cand = 0;
        for c in cells {
            self.cell_pairs(isa, c, work, sweep, report);
        }
        self.finish(isa, &work.cand[..work.n_cand], &mut work.pairs, report);
        work.n_cand = 0;
    }

    /// The candidates first reported by cell `c`, into `work.cand` (flushed as it fills): the
    /// cell's entries, in sweep order when it is crowded, searched by the kernel.
    #[inline(always)]
    fn cell_pairs<K: Isa>(
        &self,
        isa: K,
        c: usize,
        work: &mut CellWork,
        sweep: &mut Sweep,
        report: Report,
    ) {
        let pk = &self.packed;
        let range = self.cell_start[c] as usize..self.cell_start[c + 1] as usize;
        let m = range.len();
        if m < 2 {
            return;
        }
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
        isa.cell(self, &cell, work, report);
    }

    /// A cell's rows by column ([`Grid::row`]): the baseline kernel's cell search.
    #[inline(always)]
    pub(crate) fn cell_pairs_columns<K: Isa>(
        &self,
        isa: K,
        cell: &CellEntries,
        work: &mut CellWork,
        report: Report,
    ) {
        let pk = &self.packed;
        let m = cell.ents.len();
        let CellWork {
            pairs,
            cols,
            cand,
            n_cand,
            ..
        } = work;
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
            let k = self.row(cell, &view, cols, a, end, row);
            nc += k;
            if nc >= BATCH {
                self.finish(isa, &cand[..nc], pairs, report);
                nc = 0;
            }
        }
        *n_cand = nc;
    }

    /// A cell's rows in blocks of sixteen ([`BlockRows`]): the AVX2 and AVX-512 kernels' cell
    /// search.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn cell_pairs_blocks<K: BlockRows>(
        &self,
        isa: K,
        cell: &CellEntries,
        work: &mut CellWork,
        report: Report,
    ) {
        let CellWork {
            pairs,
            cand,
            n_cand,
            blocks,
            ..
        } = work;
        let m = cell.ents.len();
        let n_blocks = m.div_ceil(16);
        if blocks.len() < n_blocks {
            blocks.resize(n_blocks, Block16::default());
        }
        let blocks = &mut blocks[..n_blocks];
        let any = isa.gather(&self.packed.boxes, cell.ents, cell.earlier, blocks);
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
            let k = isa
                .row(blocks, end, a, skip, special, unknown, row)
                .unwrap_or_else(|| self.row_blocks(cell.key, blocks, end, a, row));
            nc += k;
            if nc >= BATCH {
                self.finish(isa, &cand[..nc], pairs, report);
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
            let mut bits = baseline::row_hits(view, head, start, (n - 64 * g).min(64));
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
    fn finish<K: Isa>(&self, isa: K, cand: &[[u32; 2]], pairs: &mut Vec<[u32; 2]>, report: Report) {
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
        let width = K::EXACT_LANES;
        // The lane tests of up to `BATCH` candidates first, then their kept pairs: with no
        // branch between them, one block's chain of divisions and square root overlaps the next
        // ones' instead of waiting behind a mispredicted push loop.
        for part in cand.chunks(BATCH) {
            let mut blocks = part.chunks_exact(width);
            let n_blocks = blocks.len();
            let mut keep = [0u16; BATCH / LANES];
            for (k, block) in keep.iter_mut().zip(&mut blocks) {
                *k = self.exact_lanes(isa, block, margin, (1 << width) - 1) as u16;
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
                let mut k = self.exact_lanes(isa, block, margin, (1 << rest.len()) - 1);
                while k != 0 {
                    pairs.push(orig(rest[k.trailing_zeros() as usize]));
                    k &= k - 1;
                }
            }
        }
    }

    /// The exact test on the candidates of `block` whose bits are set in `lanes` (bit `l` of the
    /// result set when candidate `l` is kept; the other lanes are computed and ignored): hair-ssv's
    /// segment-segment kernel run lane-wise on the packed lines ([`Isa::exact`]). It agrees with
    /// the scalar kernel up to rounding, so a pair within a rounding band of the margin (and any
    /// pair that is not two LSS) is decided by [`Ssv::distance`] itself: the result is exactly
    /// `distance <= margin`.
    #[inline(always)]
    fn exact_lanes<K: Isa>(&self, isa: K, block: &[[u32; 2]], margin: Real, lanes: u32) -> u32 {
        let (mut sure, mut open) = isa.exact(&self.packed.lines, block, margin);
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

/// Bit sets of the earlier cells ([`earlier_cells`]): a cell `d` away from the entry's cell
/// (`d` in `-2..=2` on each axis, before it in key order) is bit `25 (dx + 2) + 5 (dy + 2) +
/// (dz + 2)`, one of bits 0 to 61 since key order is lexicographic.
pub(crate) const WINDOW: u64 = (1 << 62) - 1;
/// Set when some earlier cell lies outside that window.
pub(crate) const OUTSIDE: u64 = 1 << 63;
/// Set (with every other bit) when the cover is too long to be described.
pub(crate) const UNKNOWN: u64 = 1 << 62;

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
pub(crate) fn owner(a: u64, b: u64) -> (bool, bool) {
    let both = a & b;
    let unsure = (both != 0) & (((a | b) & UNKNOWN != 0) | (both & WINDOW == 0));
    (both == 0, unsure)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernel::{Kernel, lcg};
    use crate::{CellKey, GridConfig, Section};
    use hair_ssv::{Lss, Point};

    /// The kernel, or the widest narrower one this processor runs.
    fn kernel(k: Kernel) -> Selected {
        Selected::at_most(k)
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
                grid.enumerate_pairs_with(&mut base, report, kernel(Kernel::Baseline));
                for k in [Kernel::Avx2, Kernel::Avx512] {
                    let mut other = PairSet::new();
                    grid.enumerate_pairs_with(&mut other, report, kernel(k));
                    proptest::prop_assert_eq!(base.to_vec(), other.to_vec(), "{:?}", k);
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
        let kernels = [Kernel::Baseline, Kernel::Avx2, Kernel::Avx512];
        for exact in [false, true] {
            let report = Report {
                exact,
                ranked: false,
            };
            let mut base = PairSet::new();
            grid.enumerate_pairs_with(&mut base, report, kernel(Kernel::Baseline));
            assert!(base.len() > 1000, "{}", base.len());
            for k in kernels {
                let mut other = PairSet::new();
                grid.enumerate_pairs_with(&mut other, report, kernel(k));
                assert_eq!(base.to_vec(), other.to_vec(), "{k:?}");
            }
        }
        // By rank: the same pairs in the same order, with every kernel.
        let order = grid.search_order();
        let mut sorted = order.to_vec();
        sorted.sort_unstable();
        assert!(sorted.iter().enumerate().all(|(k, &i)| k == i as usize));
        let mut plain = PairSet::new();
        grid.overlapping_pairs(&mut plain);
        for k in kernels {
            let mut ranked = PairSet::new();
            grid.enumerate_pairs_with(
                &mut ranked,
                Report {
                    exact: true,
                    ranked: true,
                },
                kernel(k),
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
        grid.enumerate_pairs_with(&mut base, report, kernel(Kernel::Baseline));
        for k in [Kernel::Avx2, Kernel::Avx512] {
            let mut other = PairSet::new();
            grid.enumerate_pairs_with(&mut other, report, kernel(k));
            assert_eq!(base.to_vec(), other.to_vec(), "{k:?}");
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
