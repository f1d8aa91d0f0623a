//! Hair-hair pairs from the grid (Ward & Lin 2003 §5.3): sections sharing a cell are candidates;
//! each pair is reported once, in the first cell both cover.

use rayon::prelude::*;

use hair_ssv::{Lss, distance_lss_lss_batch};

use crate::grid::Grid;
use crate::{Real, Ssv};

/// Cells handled by one parallel task: fixed, so that the output order does not depend on the
/// number of threads.
const CELLS_PER_TASK: usize = 256;

#[derive(Debug, Default)]
struct PairChunk {
    pairs: Vec<[u32; 2]>,
    boxes: Vec<[Real; 6]>,
    ids: Vec<(u32, u32)>,
    keys: Vec<u64>,
    key_start: Vec<u32>,
    order: Vec<u32>,
    batch: Vec<(Lss, Lss)>,
    batch_ids: Vec<[u32; 2]>,
    dist: Vec<Real>,
}

/// LSS pairs tested at once by hair-ssv's batched kernel.
const BATCH: usize = 256;

/// Runs the exact test on the buffered LSS pairs. The batched kernel agrees with the scalar one
/// up to rounding, so pairs within a rounding band of the margin are decided by the scalar
/// kernel: the result is exactly [`Ssv::distance`]`<= margin`.
fn flush(
    grid: &Grid,
    batch: &mut Vec<(Lss, Lss)>,
    ids: &mut Vec<[u32; 2]>,
    dist: &mut Vec<Real>,
    pairs: &mut Vec<[u32; 2]>,
    margin: Real,
) {
    dist.clear();
    dist.resize(batch.len(), 0.0);
    distance_lss_lss_batch(batch, dist);
    for ((&d, &[i, j]), (p, q)) in dist.iter().zip(ids.iter()).zip(batch.iter()) {
        let scale = [p.a, p.b, q.a, q.b]
            .iter()
            .flat_map(|v| v.iter())
            .fold(1.0f32, |m, c| m.max(c.abs()));
        let band = 1e-5 * scale;
        let keep = if d > margin + band {
            false
        } else if d < margin - band {
            true
        } else {
            grid.shape_at(i as usize)
                .distance(grid.shape_at(j as usize))
                <= margin
        };
        if keep {
            pairs.push([i, j]);
        }
    }
    batch.clear();
    ids.clear();
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
        let skip = self.config.skip_neighbours;
        let margin = self.config.margin;
        out.chunks[..tasks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(t, chunk)| {
                let PairChunk {
                    pairs,
                    boxes,
                    ids,
                    keys,
                    key_start,
                    order,
                    batch,
                    batch_ids,
                    dist,
                } = chunk;
                batch.clear();
                batch_ids.clear();
                pairs.clear();
                let c0 = t * CELLS_PER_TASK;
                let c1 = (c0 + CELLS_PER_TASK).min(n_cells);
                for c in c0..c1 {
                    let items = self.cell_sections_at(c);
                    let m = items.len();
                    if m < 2 {
                        continue;
                    }
                    let key = self.cell_keys[c];
                    // Gather the cell's sections into local arrays: boxes, ids, and the cells
                    // each covers up to this one (enough to find the first shared cell).
                    boxes.clear();
                    ids.clear();
                    keys.clear();
                    key_start.clear();
                    key_start.push(0);
                    for &it in items {
                        let it = it as usize;
                        let r = self.rec(it);
                        boxes.push(r.aabb);
                        ids.push((r.skeleton, r.segment));
                        for &k in self.item_keys(it) {
                            if k >= key {
                                break;
                            }
                            keys.push(k);
                        }
                        key_start.push(keys.len() as u32);
                    }
                    // Sweep along the axis where the boxes are thinnest relative to their
                    // spread: sort by the box minimum on it, then pair only boxes that overlap
                    // on it.
                    let mut ext = [0.0f32; 3];
                    let mut lo = [f32::INFINITY; 3];
                    let mut hi = [f32::NEG_INFINITY; 3];
                    for bx in boxes.iter() {
                        for k in 0..3 {
                            ext[k] += bx[k + 3] - bx[k];
                            lo[k] = lo[k].min(bx[k]);
                            hi[k] = hi[k].max(bx[k + 3]);
                        }
                    }
                    let score = |k: usize| ext[k] / (hi[k] - lo[k]).max(f32::MIN_POSITIVE);
                    let axis = (0..3)
                        .min_by(|&x, &y| score(x).total_cmp(&score(y)))
                        .unwrap_or(0);
                    order.clear();
                    order.extend(0..m as u32);
                    order.sort_unstable_by(|&x, &y| {
                        boxes[x as usize][axis]
                            .total_cmp(&boxes[y as usize][axis])
                            .then(x.cmp(&y))
                    });
                    for (p, &a) in order.iter().enumerate() {
                        let a = a as usize;
                        let ba = boxes[a];
                        let (ska, sga) = ids[a];
                        let ka = &keys[key_start[a] as usize..key_start[a + 1] as usize];
                        let amax = ba[axis + 3];
                        for &b in &order[p + 1..] {
                            let b = b as usize;
                            let bb = &boxes[b];
                            if bb[axis] > amax {
                                break;
                            }
                            let apart = (ba[0] > bb[3])
                                | (bb[0] > ba[3])
                                | (ba[1] > bb[4])
                                | (bb[1] > ba[4])
                                | (ba[2] > bb[5])
                                | (bb[2] > ba[5]);
                            if apart {
                                continue;
                            }
                            let (skb, sgb) = ids[b];
                            if ska == skb && sga.abs_diff(sgb) <= skip {
                                continue;
                            }
                            // Reported here only if no earlier cell is shared.
                            let kb = &keys[key_start[b] as usize..key_start[b + 1] as usize];
                            if share_any(ka, kb) {
                                continue;
                            }
                            let (i, j) = (items[a].min(items[b]), items[a].max(items[b]));
                            if exact {
                                match (self.shape_at(i as usize), self.shape_at(j as usize)) {
                                    (Ssv::Line(p), Ssv::Line(q)) => {
                                        batch.push((*p, *q));
                                        batch_ids.push([i, j]);
                                        if batch.len() == BATCH {
                                            flush(self, batch, batch_ids, dist, pairs, margin);
                                        }
                                    }
                                    (p, q) => {
                                        if p.distance(q) <= margin {
                                            pairs.push([i, j]);
                                        }
                                    }
                                }
                                continue;
                            }
                            pairs.push([i, j]);
                        }
                    }
                }
                if !batch.is_empty() {
                    flush(self, batch, batch_ids, dist, pairs, margin);
                }
            });
    }
}
