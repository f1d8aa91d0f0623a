//! Body triangles in the grid (salon paper §4.3.1-4.3.2): inserted once while the body is static
//! in its frame; cells holding both hair and body are the ones to check for hair-object
//! collision.

use rayon::prelude::*;

use crate::cell_key::{CellKey, LATTICE_HALF};
use crate::cover::{self, CellBox};
use crate::grid::{EPS_CELLS, Grid, cells_of};
use crate::{GridError, Point, Real};

/// Body triangles sorted into cells of the global lattice. Built once (the body is static in
/// its own frame: give the hair in that frame); any cell size works with any hair grid.
#[derive(Clone, Debug, Default)]
pub struct BodyGrid {
    cell_size: Real,
    /// Packed [`CellKey`]s of the non-empty cells, ascending.
    keys: Vec<u64>,
    start: Vec<u32>,
    triangles: Vec<u32>,
}

impl BodyGrid {
    /// Sorts the triangles `indices` of the mesh `vertices` into cells of size `cell_size`, each
    /// triangle grown by `margin` metres (the hair-object proximity threshold).
    ///
    /// # Errors
    /// [`GridError::NonPositiveCellSize`], [`GridError::InvalidMargin`],
    /// [`GridError::BadTriangleIndex`], [`GridError::InvalidShape`] for a non-finite vertex,
    /// [`GridError::OutsideLattice`], [`GridError::TooManyCells`] (limit `max_cells` per
    /// triangle).
    pub fn new(
        vertices: &[Point],
        indices: &[[u32; 3]],
        cell_size: Real,
        margin: Real,
        max_cells: u64,
    ) -> Result<Self, GridError> {
        if !(cell_size.is_finite() && cell_size > 0.0) {
            return Err(GridError::NonPositiveCellSize {
                cell_size,
                source_of: "BodyGrid::new cell_size",
            });
        }
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(GridError::InvalidMargin { margin });
        }
        for (index, tri) in indices.iter().enumerate() {
            for &v in tri {
                if v as usize >= vertices.len() {
                    return Err(GridError::BadTriangleIndex {
                        index,
                        vertex: v,
                        vertices: vertices.len(),
                    });
                }
            }
            if !tri
                .iter()
                .all(|&v| vertices[v as usize].iter().all(|c| c.is_finite()))
            {
                return Err(GridError::InvalidShape {
                    what: "body triangle",
                    index,
                    field: "vertices",
                });
            }
        }
        let inv = 1.0 / f64::from(cell_size);
        let r = f64::from(margin) * inv + EPS_CELLS;
        let per_tri: Vec<Result<Vec<u64>, GridError>> = indices
            .par_iter()
            .enumerate()
            .map(|(index, tri)| {
                let v = tri.map(|i| cells_of(&vertices[i as usize], inv));
                let (lo, hi) = crate::grid::cell_range(&v, r);
                for k in 0..3 {
                    for cell in [lo[k], hi[k]] {
                        if !(-LATTICE_HALF..LATTICE_HALF).contains(&cell) {
                            return Err(GridError::OutsideLattice {
                                what: "body triangle",
                                index,
                                axis: ['x', 'y', 'z'][k],
                                cell,
                                limit: LATTICE_HALF,
                            });
                        }
                    }
                }
                let mut out = Vec::new();
                let mut scratch = Vec::new();
                cover::polygon(&v, r, &CellBox::ALL, max_cells, &mut scratch, &mut |c| {
                    if let Some(k) = CellKey::new(c[0] as i32, c[1] as i32, c[2] as i32).pack() {
                        out.push(k);
                    }
                })
                .map_err(|_| GridError::TooManyCells {
                    what: "body triangle",
                    index,
                    limit: max_cells,
                    cell_size,
                })?;
                Ok(out)
            })
            .collect();
        let mut entries: Vec<(u64, u32)> = Vec::new();
        for (t, cells) in per_tri.into_iter().enumerate() {
            for k in cells? {
                entries.push((k, t as u32));
            }
        }
        entries.par_sort_unstable();
        let mut grid = BodyGrid {
            cell_size,
            keys: Vec::new(),
            start: vec![0],
            triangles: Vec::with_capacity(entries.len()),
        };
        for (e, &(k, t)) in entries.iter().enumerate() {
            if e > 0 && entries[e - 1].0 != k {
                grid.keys.push(entries[e - 1].0);
                grid.start.push(e as u32);
            }
            grid.triangles.push(t);
        }
        if let Some(&(k, _)) = entries.last() {
            grid.keys.push(k);
            grid.start.push(entries.len() as u32);
        }
        Ok(grid)
    }

    /// Cell size, metres.
    pub fn cell_size(&self) -> Real {
        self.cell_size
    }

    /// Number of non-empty cells.
    pub fn cell_count(&self) -> usize {
        self.keys.len()
    }

    /// The non-empty cells with their triangles, in increasing key order.
    pub fn cells(&self) -> impl Iterator<Item = (CellKey, &[u32])> + '_ {
        self.keys.iter().enumerate().map(|(c, &k)| {
            (
                CellKey::unpack(k),
                &self.triangles[self.start[c] as usize..self.start[c + 1] as usize],
            )
        })
    }

    /// Triangles in cell `key`.
    pub fn cell_triangles(&self, key: CellKey) -> &[u32] {
        match key.pack().map(|k| self.keys.binary_search(&k)) {
            Some(Ok(c)) => &self.triangles[self.start[c] as usize..self.start[c + 1] as usize],
            _ => &[],
        }
    }
}

/// The hair cells that overlap body cells, with the sections and the triangles to check there:
/// filled by [`Grid::body_cells`], reusable.
#[derive(Clone, Debug, Default)]
pub struct BodyCells {
    cells: Vec<u32>,
    tri_start: Vec<u32>,
    triangles: Vec<u32>,
    scratch: Vec<(u32, u32)>,
}

impl BodyCells {
    /// An empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of hair cells that hold body triangles.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether no hair cell holds a body triangle.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// For each such cell, in increasing key order: its index among the grid's non-empty cells
    /// (see [`Grid::cell_key`] and [`Grid::cell_sections_at`]) and the body triangles (ascending,
    /// unique) whose cells overlap it.
    pub fn iter(&self) -> impl Iterator<Item = (usize, &[u32])> + '_ {
        self.cells.iter().enumerate().map(|(c, &cell)| {
            (
                cell as usize,
                &self.triangles[self.tri_start[c] as usize..self.tri_start[c + 1] as usize],
            )
        })
    }
}

impl Grid {
    /// Cells holding both hair and body (salon paper §4.3.2), with their triangles, into `out`.
    /// The body may use another cell size: a hair cell collects the triangles of every body cell
    /// its box overlaps.
    pub fn body_cells(&self, body: &BodyGrid, out: &mut BodyCells) {
        out.cells.clear();
        out.tri_start.clear();
        out.triangles.clear();
        out.scratch.clear();
        out.tri_start.push(0);
        if self.is_empty() || body.keys.is_empty() {
            return;
        }
        let hb = f64::from(body.cell_size);
        let hg = f64::from(self.cell_size);
        // For each body cell, the hair cells its box overlaps (closed boxes, so shared faces
        // count, conservatively).
        for (c, &k) in body.keys.iter().enumerate() {
            let key = CellKey::unpack(k);
            let b = [key.x, key.y, key.z].map(i64::from);
            let mut lo = [0i64; 3];
            let mut hi = [0i64; 3];
            for a in 0..3 {
                lo[a] = ((b[a] as f64 * hb) / hg).floor() as i64 - 1;
                hi[a] = (((b[a] + 1) as f64 * hb) / hg).floor() as i64;
            }
            let bx = self.cell_box();
            for a in 0..3 {
                lo[a] = lo[a].max(bx.lo[a]);
                hi[a] = hi[a].min(bx.hi[a]);
            }
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        // Exact overlap of closed boxes in metres.
                        let overlaps = [x, y, z].iter().zip(b.iter()).all(|(&g, &bb)| {
                            (g as f64) * hg <= (bb + 1) as f64 * hb
                                && (bb as f64) * hb <= (g + 1) as f64 * hg
                        });
                        if !overlaps {
                            continue;
                        }
                        if let Some(ci) = self.cell_index([x, y, z]) {
                            for &t in
                                &body.triangles[body.start[c] as usize..body.start[c + 1] as usize]
                            {
                                out.scratch.push((ci as u32, t));
                            }
                        }
                    }
                }
            }
        }
        out.scratch.par_sort_unstable();
        out.scratch.dedup();
        for (e, &(ci, t)) in out.scratch.iter().enumerate() {
            if e == 0 || out.scratch[e - 1].0 != ci {
                if e > 0 {
                    out.tri_start.push(out.triangles.len() as u32);
                }
                out.cells.push(ci);
            }
            out.triangles.push(t);
        }
        if !out.cells.is_empty() {
            out.tri_start.push(out.triangles.len() as u32);
        }
    }
}
