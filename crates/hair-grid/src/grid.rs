//! The sparse uniform grid of hair sections (Ward & Lin 2003 §5.3; salon paper §4.3.1), rebuilt
//! every step by a parallel counting sort of (cell, section) entries.

use std::sync::atomic::AtomicU64;
use std::sync::atomic::Ordering::Relaxed;

use rayon::prelude::*;

use crate::cell_key::{CellKey, LATTICE_HALF};
use crate::cover::{self, CellBox};
use crate::kernel::{Kernel, Selected};
use crate::pairs::{Line, PBox, Packed, line_of};
use crate::{GridError, Point, Real, Ssv};

/// Sections per cover chunk: the unit of parallel work when inserting, fixed so that the output
/// does not depend on the number of threads.
pub(crate) const CHUNK: usize = 1024;

/// Slack added to every cover and bounding box, in cells, against rounding.
pub(crate) const EPS_CELLS: f64 = 1e-3;

/// One hair section to insert: which skeleton and segment it belongs to, and its swept sphere
/// volume (an LSS for strand groups and clusters, an RSS for strips).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Section {
    /// Skeleton (strand) the section belongs to.
    pub skeleton: u32,
    /// Index of the segment along its skeleton, from the root.
    pub segment: u32,
    /// The section's volume.
    pub shape: Ssv,
}

/// How the grid is built and which pairs it reports.
#[derive(Clone, Debug, PartialEq)]
pub struct GridConfig {
    /// Cell edge length in metres; `None` uses the mean core length of the inserted sections
    /// (Ward & Lin §5.3; the longer extent for an RSS, 0 for a PSS), or their mean diameter
    /// where that is larger (sections fatter than long), recomputed at each rebuild.
    pub cell_size: Option<Real>,
    /// Two sections closer than this (metres, signed SSV distance) count as a pair. Sections are
    /// inserted grown by half of it. Default 0: only overlapping sections.
    pub margin: Real,
    /// Pairs of sections on the same skeleton whose segment indices differ by at most this are not
    /// reported (they touch at their shared node). 0 reports them all. Default 1.
    pub skip_neighbours: u32,
    /// Largest number of cells one section may cover; more gives [`GridError::TooManyCells`]
    /// (a guard against a huge radius or a tiny cell size). Default 2^16.
    pub max_cells_per_item: u32,
    /// Largest number of cells an influence volume or a body triangle may cover; more gives
    /// [`GridError::TooManyCells`]. Influence volumes are clipped to the cells around the hair
    /// first. Default 2^24.
    pub max_cells_per_volume: u64,
    /// The instruction set of the pair search and of the rebuild's covers. Every kernel gives
    /// the same cells and pairs in the same order; only the time differs. Default
    /// [`Kernel::Auto`]: the widest this processor has. [`Grid::try_new`] refuses a kernel the
    /// processor lacks; [`Grid::new`] and [`Grid::set_config`] run the widest narrower one
    /// instead ([`Grid::kernel`] tells which runs).
    pub kernel: Kernel,
}

impl Default for GridConfig {
    fn default() -> Self {
        Self {
            cell_size: None,
            margin: 0.0,
            skip_neighbours: 1,
            max_cells_per_item: 1 << 16,
            max_cells_per_volume: 1 << 24,
            kernel: Kernel::Auto,
        }
    }
}

/// The pair search's box and line of a section, its box grown by `slack`.
#[inline(always)]
fn placed(s: &Section, slack: Real) -> (PBox, Line) {
    let (a, b) = s.shape.aabb();
    let pbox = PBox {
        lo: [a.x - slack, a.y - slack, a.z - slack],
        hi: [b.x + slack, b.y + slack, b.z + slack],
        skeleton: s.skeleton,
        segment: s.segment,
    };
    (pbox, line_of(&s.shape))
}

/// One entry in the scatter's output: its section (low half) and the section's rank in the pair
/// search's order (high half), then its earlier cells, side by side so that a write touches one
/// cache line (relaxed atomic stores: plain moves on common targets). The rank is looked up once
/// per section here rather than once per entry in the copy.
#[derive(Debug, Default)]
#[repr(C, align(16))]
struct Slot {
    item: AtomicU64,
    earlier: AtomicU64,
}

/// One chunk of sections: their covers, item-major (the packed cell keys of each section,
/// ascending), and for each (section, cell) entry the section's earlier cells as a bit set
/// ([`crate::pairs::earlier_cells`]).
#[derive(Debug, Default)]
pub(crate) struct CoverChunk {
    pub keys: Vec<u64>,
    /// Dense path: each entry's index in the box of the covers (set by the count pass).
    pub dense: Vec<u32>,
    pub earlier: Vec<u64>,
    pub start: Vec<u32>,
    scratch: Vec<[i64; 3]>,
    error: Option<GridError>,
    lo: [i64; 3],
    hi: [i64; 3],
}

/// The localization grid: a caller-owned, reusable structure that is cleared and refilled by
/// [`Grid::rebuild`] each step (no allocation once its buffers have grown to the scene).
///
/// Sections are numbered by their position in the slice given to `rebuild`. Cells are listed in
/// increasing [`CellKey`] order, and the sections of a cell in increasing index order, for any
/// number of threads.
#[derive(Debug)]
pub struct Grid {
    pub(crate) config: GridConfig,
    /// The kernel of `config.kernel` on this processor.
    pub(crate) kernel: Selected,
    pub(crate) cell_size: Real,
    pub(crate) inv: f64,
    len: usize,
    /// Lowest cell of the box of all covers.
    pub(crate) origin: [i64; 3],
    /// Cells of that box along each axis (0 when empty).
    pub(crate) dims: [u64; 3],
    pub(crate) chunks: Vec<CoverChunk>,
    pub(crate) n_chunks: usize,
    /// The shapes of the sections that are not an LSS, by section index (the other slots are
    /// stale: an LSS is rebuilt from its line in `packed`, so that the rebuild does not copy
    /// every shape).
    shapes: Vec<Ssv>,
    entries: usize,
    /// Dense path: after the scatter, `prefix[k]` is the end of box cell `k` in `sorted_items`.
    dense: bool,
    prefix: Vec<u32>,
    /// Dense path: per block of chunks, its entry count per box cell, then its cursor.
    block_counts: Vec<Vec<u32>>,
    /// Dense path: the scatter's output before it is copied to `sorted_items` and
    /// `entry_earlier`: per entry, its section then its earlier cells, side by side so that a
    /// write touches one cache line.
    scatter: Vec<Slot>,
    /// Dense path: index among the non-empty cells of each box cell.
    dense_cell: Vec<u32>,
    /// Section data in the pair search's order.
    pub(crate) packed: Packed,
    /// Per entry, in cell order: the section's cells before this one, as a bit set.
    pub(crate) entry_earlier: Vec<u64>,
    pub(crate) sorted_items: Vec<u32>,
    /// Packed keys of the non-empty cells, ascending.
    pub(crate) cell_keys: Vec<u64>,
    pub(crate) cell_start: Vec<u32>,
    tmp: Vec<(u64, u32, u64)>,
}

impl Default for Grid {
    fn default() -> Self {
        Self::new(GridConfig::default())
    }
}

/// The first bad field of a shape, if any.
fn invalid_field(shape: &Ssv) -> Option<&'static str> {
    let fp = |p: &Point| p.x.is_finite() && p.y.is_finite() && p.z.is_finite();
    let r = shape.radius();
    if !(r.is_finite() && r >= 0.0) {
        return Some("radius");
    }
    match shape {
        Ssv::Point(p) => (!fp(&p.center)).then_some("center"),
        Ssv::Line(l) => {
            if !fp(&l.a) {
                Some("a")
            } else if !fp(&l.b) {
                Some("b")
            } else {
                None
            }
        }
        Ssv::Rect(q) => {
            if !fp(&q.origin) {
                Some("origin")
            } else if !q.axes.iter().all(|a| a.iter().all(|v| v.is_finite())) {
                Some("axes")
            } else if !q.extents.iter().all(|e| e.is_finite() && *e >= 0.0) {
                Some("extents")
            } else if !q.corners().iter().all(fp) {
                Some("origin")
            } else {
                None
            }
        }
    }
}

/// A length in integer nanometres, `(l.min(9e9) * 1e9).round() as u64` (0 when not finite or
/// negative): a chunk's sum of lengths, each clamped at 1e9 m, so at most 1024e9 m; the clamp
/// keeps the value within `i64`. `round` is a libm call on the baseline target, and float to
/// `u64` conversions take several instructions: for `0 <= x <= 9e18` the value is `trunc(x)`
/// (an `i64` conversion), plus one when the fraction `x - trunc(x)` (exact) is at least 1/2.
#[inline]
fn nanometres(l: f64) -> u64 {
    if !(l > 0.0 && l < f64::INFINITY) {
        return 0;
    }
    let x = if l < 9e9 { l } else { 9e9 } * 1e9;
    let t = x as i64;
    (t + i64::from(x - t as f64 >= 0.5)) as u64
}

/// Core length used for the default cell size.
#[inline]
fn core_length(shape: &Ssv) -> f64 {
    match shape {
        Ssv::Point(_) => 0.0,
        Ssv::Line(l) => f64::from((l.b - l.a).norm()),
        Ssv::Rect(q) => f64::from(q.extents[0].max(q.extents[1])),
    }
}

#[inline]
pub(crate) fn cells_of(p: &Point, inv: f64) -> [f64; 3] {
    [
        f64::from(p.x) * inv,
        f64::from(p.y) * inv,
        f64::from(p.z) * inv,
    ]
}

/// The core of a shape in cell units (1, 2 or 4 vertices) and the cover half-side in cells.
#[inline]
pub(crate) fn core_in_cells(shape: &Ssv, inv: f64, grow: f64) -> ([[f64; 3]; 4], usize, f64) {
    let r = (f64::from(shape.radius()) + grow) * inv + EPS_CELLS;
    let mut v = [[0.0; 3]; 4];
    match shape {
        Ssv::Point(p) => {
            v[0] = cells_of(&p.center, inv);
            (v, 1, r)
        }
        Ssv::Line(l) => {
            v[0] = cells_of(&l.a, inv);
            v[1] = cells_of(&l.b, inv);
            (v, 2, r)
        }
        Ssv::Rect(q) => {
            for (k, c) in q.corners().iter().enumerate() {
                v[k] = cells_of(c, inv);
            }
            (v, 4, r)
        }
    }
}

/// Inclusive cell range of a core grown by `r` cells (the same expression the walks use).
#[inline]
pub(crate) fn cell_range(v: &[[f64; 3]], r: f64) -> ([i64; 3], [i64; 3]) {
    let mut lo = [i64::MAX; 3];
    let mut hi = [i64::MIN; 3];
    for k in 0..3 {
        let mn = v.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min);
        let mx = v.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max);
        lo[k] = cover::floor_i(mn - r);
        hi[k] = cover::floor_i(mx + r);
    }
    (lo, hi)
}

/// Emits the cover of a core (1, 2 or 4 vertices) in increasing cell order.
pub(crate) fn walk_core(
    v: &[[f64; 3]],
    r: f64,
    clip: &CellBox,
    limit: u64,
    scratch: &mut Vec<[i64; 3]>,
    emit: &mut impl FnMut([i64; 3]),
) -> Result<u64, cover::OverLimit> {
    match v.len() {
        1 => cover::segment(v[0], v[0], r, clip, limit, emit),
        2 => cover::segment(v[0], v[1], r, clip, limit, emit),
        _ => cover::polygon(v, r, clip, limit, scratch, emit),
    }
}

/// Points and segments whose cell range holds at most this many cells (and at most 4 along each
/// axis) are covered by testing each cell of the range ([`cover::short_segment`]), into a local
/// array; the others by the slab walk.
const SHORT: usize = 32;

/// The cell range and cover mask ([`cover::short_mask`]) of a valid LSS whose cell range is
/// short (as in the general path), or `None` for any other LSS (not finite, negative radius,
/// outside the lattice, a longer range): the general path then covers it or reports the error.
/// Every value is computed by the same expressions as [`core_in_cells`] and [`cell_range`].
#[inline]
pub(crate) fn short_line(
    l: &hair_ssv::Lss,
    inv: f64,
    grow: f64,
) -> Option<([i64; 3], [i64; 3], u64)> {
    // The shape is valid and inside the lattice when the radius is not negative and the ends,
    // in cells and grown by `r`, lie in `[-2^20, 2^20)`: `floor(v) >= -2^20` is `v >= -2^20`,
    // `floor(v) < 2^20` is `v < 2^20`, and any NaN or infinite coordinate or radius fails one
    // of these comparisons (a NaN radius too). One test of six values instead of one per
    // coordinate, then one per cell bound.
    if l.radius < 0.0 {
        return None;
    }
    let (va, vb) = (cells_of(&l.a, inv), cells_of(&l.b, inv));
    let r = (f64::from(l.radius) + grow) * inv + EPS_CELLS;
    let half = LATTICE_HALF as f64;
    let mut lo = [0.0f64; 3];
    let mut hi = [0.0f64; 3];
    let mut inside = true;
    for k in 0..3 {
        let (mn, mx) = if va[k] < vb[k] {
            (va[k], vb[k])
        } else {
            (vb[k], va[k])
        };
        (lo[k], hi[k]) = (mn - r, mx + r);
        inside &= (lo[k] >= -half) & (hi[k] < half);
    }
    if !inside {
        return None;
    }
    let mut cl = [0i64; 3];
    let mut ch = [0i64; 3];
    let mut n = [0usize; 3];
    for k in 0..3 {
        cl[k] = cover::floor_small(lo[k]);
        ch[k] = cover::floor_small(hi[k]);
        n[k] = (ch[k] - cl[k] + 1) as usize;
    }
    let short = (n[0] <= 4) & (n[1] <= 4) & (n[2] <= 4) && n[0] * n[1] * n[2] <= SHORT;
    short.then(|| {
        let mask = if n[0] <= 2 && n[1] <= 2 && n[2] <= 2 {
            SMALL | cover::small_mask(va, vb, r, cl, n)
        } else {
            cover::short_mask(va, vb, r, cl, n)
        };
        (cl, ch, mask)
    })
}

/// A short cover ([`short_line`]'s result) for up to eight sections.
pub(crate) type Covers8 = [Option<([i64; 3], [i64; 3], u64)>; 8];

/// Bit of a cell `d = (dx, dy, dz)` away, each in `-3..=3`, in an earlier-cell bit set
/// ([`crate::pairs::earlier_bits`]): `25 (dx + 2) + 5 (dy + 2) + (dz + 2)` inside the 5 x 5 x 5
/// window (`dx >= -2`, `|dy|, |dz| <= 2`), else `OUTSIDE`. Indexed by `49 dx + 7 dy + dz + 171`
/// (unique for such offsets), so that an offset is one subtraction of two cell codes
/// ([`SHORT_CODE`]) and one load.
const OFFSET_BIT: [u64; 343] = {
    let mut t = [0u64; 343];
    let mut i = 0;
    while i < 343 {
        let (dx, dy, dz) = (i as i64 / 49 - 3, (i as i64 / 7) % 7 - 3, i as i64 % 7 - 3);
        // Offsets not before the cell in key order are unused.
        let before = dx < 0 || (dx == 0 && (dy < 0 || (dy == 0 && dz < 0)));
        t[i] = if !before {
            0
        } else if dx < -2 || dy < -2 || dy > 2 || dz < -2 || dz > 2 {
            crate::pairs::OUTSIDE
        } else {
            1 << ((dx + 2) * 25 + (dy + 2) * 5 + (dz + 2))
        };
        i += 1;
    }
    t
};

/// Code `49 i + 7 j + k` of the cell `(i, j, k)` of a short range, by its mask bit
/// `16 i + 4 j + k`.
const SHORT_CODE: [u16; 64] = {
    let mut t = [0u16; 64];
    let mut b = 0;
    while b < 64 {
        t[b] = (49 * (b >> 4) + 7 * ((b >> 2) & 3) + (b & 3)) as u16;
        b += 1;
    }
    t
};

/// Packed-key offsets from the first cell of a range `side` cells wide along each axis, by the
/// bit `side² i + side j + k` of the cell `(i, j, k)`.
const fn key_offsets<const N: usize>(side: usize) -> [u64; N] {
    let mut t = [0u64; N];
    let mut b = 0;
    while b < N {
        let (i, j, k) = (b / (side * side), (b / side) % side, b % side);
        t[b] = ((i as u64) << 42) | ((j as u64) << 21) | k as u64;
        b += 1;
    }
    t
}

/// Packed-key offset of the cell `(i, j, k)` of a short range from its first cell, by mask bit.
const SHORT_KEY: [u64; 64] = key_offsets(4);

/// Covers within the 2 x 2 x 2 cells from the first cell of their range (most short covers):
/// cell `(i, j, k)` is bit `4 i + 2 j + k` of a byte, and `EARLIER8[byte][bit]` is that cell's
/// earlier-cell bit set (all such offsets lie inside the window).
const EARLIER8: [[u64; 8]; 256] = {
    let mut t = [[0u64; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let mut c = 0;
        while c < 8 {
            let mut bits = 0u64;
            let mut p = 0;
            while p < c {
                if m & (1 << p) != 0 {
                    let dx = (p >> 2) as i64 - (c >> 2) as i64;
                    let dy = ((p >> 1) & 1) as i64 - ((c >> 1) & 1) as i64;
                    let dz = (p & 1) as i64 - (c & 1) as i64;
                    bits |= 1 << ((dx + 2) * 25 + (dy + 2) * 5 + (dz + 2));
                }
                p += 1;
            }
            t[m][c] = bits;
            c += 1;
        }
        m += 1;
    }
    t
};

/// Packed-key offset of the cell `(i, j, k)` of a 2 x 2 x 2 cover, by its bit `4 i + 2 j + k`.
const KEY8: [u64; 8] = key_offsets(2);

/// Marks a cover mask given by [`cover::small_mask`] (a byte). Never a cell of a
/// [`cover::short_mask`]: bit 63 is the cell `(3, 3, 3)` of a range of 64 cells, more than
/// [`SHORT`].
pub(crate) const SMALL: u64 = 1 << 63;

/// Appends the keys of a cover given as a mask over the cells from `cl` (bit `16 i + 4 j + k`
/// for cell `cl + (i, j, k)`, so that bit order is key order; or [`SMALL`] and the byte of a
/// [`cover::small_mask`]) and their earlier-cell bit sets,
/// the same sets as [`crate::pairs::earlier_bits`] gives (an earlier cell `dx < -2` away along
/// x is `OUTSIDE` there too, only found without looking further back).
#[inline]
fn push_mask(cl: [i64; 3], mut mask: u64, keys: &mut Vec<u64>, earlier: &mut Vec<u64>) {
    let base = pack_i64(cl);
    if mask & SMALL != 0 {
        let m8 = mask & 0xff;
        let row = &EARLIER8[m8 as usize];
        let mut rest = m8;
        while rest != 0 {
            let b = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            keys.push(base + KEY8[b & 7]);
            earlier.push(row[b & 7]);
        }
        return;
    }
    let mut prev = [0u16; SHORT];
    let mut m = 0;
    while mask != 0 {
        let t = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        keys.push(base + SHORT_KEY[t]);
        // 171 + code(p) - code(t) >= 0: the offset index of p from t.
        let c = 171 - SHORT_CODE[t] as usize;
        let mut bits = 0u64;
        for &p in &prev[..m] {
            bits |= OFFSET_BIT[c + p as usize];
        }
        earlier.push(bits);
        prev[m & (SHORT - 1)] = SHORT_CODE[t];
        m += 1;
    }
}

const AXES: [char; 3] = ['x', 'y', 'z'];

/// How far ahead the build's scattered reads and writes fetch their cache lines (in items).
const PREFETCH: usize = 16;

/// Asks the processor to fetch the cache line at `p` (nothing off x86-64). A hint only: it
/// reads nothing the program sees and never faults, whatever the address.
#[inline(always)]
fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    #[expect(
        unsafe_code,
        reason = "the prefetch intrinsic takes a raw pointer; sound: it is a hint that reads nothing and never faults"
    )]
    // SAFETY: a prefetch neither reads memory the program sees nor faults on any address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
const MASK21: u64 = (1 << 21) - 1;

/// Dense index in the box `(biased origin, dims)` of a packed key inside it (wrapping: the
/// count pass takes the negated index of key 0 as its offset).
#[inline]
fn dense_of(k: u64, bo: [u64; 3], dims: [u64; 3]) -> u64 {
    (((k >> 42).wrapping_sub(bo[0]))
        .wrapping_mul(dims[1])
        .wrapping_add(((k >> 21) & MASK21).wrapping_sub(bo[1])))
    .wrapping_mul(dims[2])
    .wrapping_add((k & MASK21).wrapping_sub(bo[2]))
}

/// Lattice coordinates of a packed key.
#[inline]
pub(crate) fn unpack3(k: u64) -> [i32; 3] {
    let c = |v: u64| (v & MASK21) as i64 - LATTICE_HALF;
    [c(k >> 42) as i32, c(k >> 21) as i32, c(k) as i32]
}

#[inline]
fn pack_i64(c: [i64; 3]) -> u64 {
    let b = |v: i64| (v + LATTICE_HALF) as u64;
    (b(c[0]) << 42) | (b(c[1]) << 21) | b(c[2])
}

impl Grid {
    /// An empty grid with the given configuration. A [`GridConfig::kernel`] this processor
    /// lacks is replaced by the widest narrower one it has ([`Grid::try_new`] refuses it).
    pub fn new(config: GridConfig) -> Self {
        Self::with_kernel(Selected::at_most(config.kernel), config)
    }

    /// An empty grid with the given configuration, whose kernel this processor runs.
    ///
    /// # Errors
    /// [`GridError::KernelUnavailable`] when [`GridConfig::kernel`] names a kernel this
    /// processor lacks.
    pub fn try_new(config: GridConfig) -> Result<Self, GridError> {
        Ok(Self::with_kernel(Selected::try_new(config.kernel)?, config))
    }

    fn with_kernel(kernel: Selected, config: GridConfig) -> Self {
        Self {
            config,
            kernel,
            cell_size: 0.0,
            inv: 0.0,
            len: 0,
            origin: [0; 3],
            dims: [0; 3],
            chunks: Vec::new(),
            n_chunks: 0,
            shapes: Vec::new(),
            entries: 0,
            dense: false,
            prefix: Vec::new(),
            block_counts: Vec::new(),
            scatter: Vec::new(),
            dense_cell: Vec::new(),
            packed: Packed::default(),
            entry_earlier: Vec::new(),
            sorted_items: Vec::new(),
            cell_keys: Vec::new(),
            cell_start: vec![0],
            tmp: Vec::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &GridConfig {
        &self.config
    }

    /// Replaces the configuration; takes effect at the next [`Grid::rebuild`]. A kernel this
    /// processor lacks is replaced as in [`Grid::new`].
    pub fn set_config(&mut self, config: GridConfig) {
        self.kernel = Selected::at_most(config.kernel);
        self.config = config;
    }

    /// The kernel this grid runs (never [`Kernel::Auto`]): [`GridConfig::kernel`] resolved on
    /// this processor.
    pub fn kernel(&self) -> Kernel {
        self.kernel.kernel()
    }

    /// Cell edge length of the last rebuild, in metres (0 before the first).
    pub fn cell_size(&self) -> Real {
        self.cell_size
    }

    /// Number of sections inserted by the last rebuild.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the grid holds no section.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Number of non-empty cells.
    pub fn cell_count(&self) -> usize {
        self.cell_keys.len()
    }

    /// Number of (cell, section) entries: the sum over sections of the cells each covers.
    pub fn entry_count(&self) -> usize {
        self.entries
    }

    /// The box and ids of section `i`, in the pair search's data.
    #[inline]
    pub(crate) fn pbox(&self, i: usize) -> &PBox {
        &self.packed.boxes[self.packed.rank[i] as usize]
    }

    /// The volume of section `i` (`i < len`).
    #[inline]
    pub(crate) fn shape_at(&self, i: usize) -> Ssv {
        self.packed_shape(self.packed.rank[i] as usize)
    }

    /// The volume of the section at internal index `a` (its place in the pair search's order):
    /// an LSS is rebuilt, bit for bit, from its line, which lies near the other lines the search
    /// reads (the caller's shapes are not kept).
    #[inline]
    pub(crate) fn packed_shape(&self, a: usize) -> Ssv {
        let l = &self.packed.lines[a];
        if l[6].is_nan() {
            self.shapes[self.packed.order[a] as usize]
        } else {
            Ssv::Line(hair_ssv::Lss::new(
                Point::new(l[0], l[1], l[2]),
                Point::new(l[3], l[4], l[5]),
                l[6],
            ))
        }
    }

    /// The volume of section `i`.
    pub fn shape(&self, i: usize) -> Option<Ssv> {
        (i < self.len).then(|| self.shape_at(i))
    }

    /// Skeleton id of section `i`.
    pub fn skeleton(&self, i: usize) -> Option<u32> {
        (i < self.len).then(|| self.pbox(i).skeleton)
    }

    /// Segment id of section `i`.
    pub fn segment(&self, i: usize) -> Option<u32> {
        (i < self.len).then(|| self.pbox(i).segment)
    }

    /// Bounding box `(min, max)` of section `i` as the grid uses it: grown by half the margin and
    /// a rounding slack of 0.001 cell.
    pub fn aabb(&self, i: usize) -> Option<(Point, Point)> {
        (i < self.len).then(|| {
            let b = self.pbox(i);
            (Point::from(b.lo), Point::from(b.hi))
        })
    }

    /// The box of cells holding sections.
    pub(crate) fn cell_box(&self) -> CellBox {
        let mut hi = [0i64; 3];
        for (k, h) in hi.iter_mut().enumerate() {
            *h = self.origin[k] + self.dims[k] as i64 - 1;
        }
        CellBox {
            lo: self.origin,
            hi,
        }
    }

    /// Key of the `c`-th non-empty cell.
    pub fn cell_key(&self, c: usize) -> Option<CellKey> {
        self.cell_keys.get(c).map(|&k| CellKey::unpack(k))
    }

    /// Sections in the `c`-th non-empty cell, ascending.
    pub fn cell_sections_at(&self, c: usize) -> &[u32] {
        if c + 1 >= self.cell_start.len() {
            return &[];
        }
        &self.sorted_items[self.cell_start[c] as usize..self.cell_start[c + 1] as usize]
    }

    /// The non-empty cells with their sections, in increasing key order.
    pub fn cells(&self) -> impl ExactSizeIterator<Item = (CellKey, &[u32])> + '_ {
        (0..self.cell_keys.len())
            .map(|c| (CellKey::unpack(self.cell_keys[c]), self.cell_sections_at(c)))
    }

    /// Range in `sorted_items` of the cell `c` (lattice coordinates).
    #[inline]
    pub(crate) fn range_of(&self, c: [i64; 3]) -> std::ops::Range<usize> {
        let mut d = 0u64;
        for k in 0..3 {
            let o = c[k] - self.origin[k];
            if o < 0 || o as u64 >= self.dims[k] {
                return 0..0;
            }
            d = d * self.dims[k] + o as u64;
        }
        if self.dense {
            let d = d as usize;
            let s = if d == 0 {
                0
            } else {
                self.prefix[d - 1] as usize
            };
            s..self.prefix[d] as usize
        } else {
            match self.cell_keys.binary_search(&pack_i64(c)) {
                Ok(i) => self.cell_start[i] as usize..self.cell_start[i + 1] as usize,
                Err(_) => 0..0,
            }
        }
    }

    /// Index among the non-empty cells of cell `c` (lattice coordinates).
    pub(crate) fn cell_index(&self, c: [i64; 3]) -> Option<usize> {
        let inside =
            (0..3).all(|k| c[k] >= self.origin[k] && c[k] - self.origin[k] < self.dims[k] as i64);
        if !inside {
            return None;
        }
        self.cell_keys.binary_search(&pack_i64(c)).ok()
    }

    /// Sections in cell `key`, ascending (empty when the cell holds none).
    pub fn cell_sections(&self, key: CellKey) -> &[u32] {
        let c = [i64::from(key.x), i64::from(key.y), i64::from(key.z)];
        &self.sorted_items[self.range_of(c)]
    }

    /// Packed keys of the cells section `i` covers, ascending.
    #[inline]
    pub(crate) fn item_keys(&self, i: usize) -> &[u64] {
        let ch = &self.chunks[i / CHUNK];
        let l = i % CHUNK;
        &ch.keys[ch.start[l] as usize..ch.start[l + 1] as usize]
    }

    /// The cells section `i` covers, in increasing key order (empty for an unknown index).
    pub fn section_cells(&self, i: usize) -> impl Iterator<Item = CellKey> + '_ {
        let keys = if i < self.len { self.item_keys(i) } else { &[] };
        keys.iter().map(|&k| CellKey::unpack(k))
    }

    /// Clears the grid and inserts `sections`: validates them, picks the cell size, covers each
    /// section's core grown by its radius (and half the margin), and sorts the entries by cell.
    /// O(n) and parallel; the result is the same for any number of threads.
    ///
    /// # Errors
    /// [`GridError::InvalidShape`] for a non-finite coordinate or a bad radius,
    /// [`GridError::NonPositiveCellSize`], [`GridError::InvalidMargin`],
    /// [`GridError::TooManyCells`] when one section covers more than
    /// `max_cells_per_item` cells, and [`GridError::OutsideLattice`]. The first bad section (by
    /// index) is reported. On error the grid is left empty.
    pub fn rebuild(&mut self, sections: &[Section]) -> Result<(), GridError> {
        let result = self.rebuild_inner(sections);
        if result.is_err() {
            self.clear();
        }
        result
    }

    /// Empties the grid, keeping its buffers.
    pub fn clear(&mut self) {
        self.len = 0;
        self.origin = [0; 3];
        self.dims = [0; 3];
        self.n_chunks = 0;
        self.entries = 0;
        self.dense = false;
        self.prefix.clear();
        self.cell_keys.clear();
        self.cell_start.clear();
        self.cell_start.push(0);
    }

    fn rebuild_inner(&mut self, sections: &[Section]) -> Result<(), GridError> {
        self.clear();
        let margin = self.config.margin;
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(GridError::InvalidMargin { margin });
        }
        // Cell size. The mean is summed in integer nanometres across chunks so that it does not
        // depend on how rayon splits the work.
        let h = match self.config.cell_size {
            Some(h) => {
                if !(h.is_finite() && h > 0.0) {
                    return Err(GridError::NonPositiveCellSize {
                        cell_size: h,
                        source_of: "GridConfig::cell_size",
                    });
                }
                h
            }
            None => {
                if sections.is_empty() {
                    1.0
                } else {
                    // Per chunk, a plain loop (no per-section closure calls from rayon), in
                    // floats: the chunks do not depend on the thread count. Then the chunks'
                    // sums in nanometres, saturating: a sum of terms that are never negative
                    // saturates to the same value in any order. Each length counts at most
                    // 1e9 m, and a non-finite one as 0.
                    let (total, radii) = sections
                        .par_chunks(CHUNK)
                        .map(|c| {
                            let (l, r) = c.iter().fold((0f64, 0f64), |(l, r), s| {
                                let length = core_length(&s.shape);
                                let length = if length > 0.0 && length < f64::INFINITY {
                                    length.min(1e9)
                                } else {
                                    0.0
                                };
                                (l + length, r + f64::from(s.shape.radius()))
                            });
                            (nanometres(l), nanometres(r))
                        })
                        .reduce(
                            || (0, 0),
                            |a, b| (a.0.saturating_add(b.0), a.1.saturating_add(b.1)),
                        );
                    let mean = (total as f64 * 1e-9 / sections.len() as f64) as Real;
                    // Sections fatter than they are long would each cover hundreds or
                    // thousands of cells of their length (a 0.5 m radius on 4 cm segments
                    // made a search of billions of box tests): then the mean diameter.
                    let diameter = (2.0 * radii as f64 * 1e-9 / sections.len() as f64) as Real;
                    let mean = if mean > 0.0 { mean.max(diameter) } else { mean };
                    if !(mean.is_finite() && mean > 0.0) {
                        // A bad shape explains it better than the mean does.
                        if let Some(index) = sections
                            .par_iter()
                            .position_first(|s| invalid_field(&s.shape).is_some())
                        {
                            let field = invalid_field(&sections[index].shape).unwrap_or("shape");
                            return Err(GridError::InvalidShape {
                                what: "section",
                                index,
                                field,
                            });
                        }
                        return Err(GridError::NonPositiveCellSize {
                            cell_size: mean,
                            source_of: "mean segment length",
                        });
                    }
                    mean
                }
            }
        };
        self.cell_size = h;
        self.inv = 1.0 / f64::from(h);
        let inv = self.inv;
        let grow = f64::from(margin) * 0.5;
        let slack = (grow + EPS_CELLS * f64::from(h)) as Real;
        self.len = sections.len();
        if sections.is_empty() {
            return Ok(());
        }

        // One pass per chunk: validate, copy, box, cover (packed global keys).
        let n_chunks = sections.len().div_ceil(CHUNK);
        if self.chunks.len() < n_chunks {
            self.chunks.resize_with(n_chunks, CoverChunk::default);
        }
        self.n_chunks = n_chunks;
        let limit = u64::from(self.config.max_cells_per_item);
        let clip = CellBox::ALL;
        // Eight short covers at a time where the kernel has lanes for them.
        let kernel = self.kernel;
        if self.shapes.len() < sections.len() {
            self.shapes.resize(sections.len(), sections[0].shape);
        }
        self.chunks[..n_chunks]
            .par_iter_mut()
            .zip(sections.par_chunks(CHUNK))
            .zip(self.shapes.par_chunks_mut(CHUNK))
            .enumerate()
            .for_each(|(ci, ((chunk, secs), shapes))| {
                let CoverChunk {
                    keys,
                    dense: _,
                    earlier,
                    start,
                    scratch,
                    error,
                    lo,
                    hi,
                } = chunk;
                keys.clear();
                earlier.clear();
                start.clear();
                start.push(0);
                *error = None;
                *lo = [i64::MAX; 3];
                *hi = [i64::MIN; 3];
                let mut buf = [[0i64; 3]; SHORT];
                let mut group: Covers8 = [None; 8];
                for (l, s) in secs.iter().enumerate() {
                    let index = ci * CHUNK + l;
                    if error.is_some() {
                        break;
                    }
                    if l % 8 == 0 {
                        kernel.small_covers(&secs[l..], inv, grow, &mut group);
                    }
                    // Nearly every hair section is a valid LSS with a small cell range: its cover
                    // comes as a mask, from which the keys and earlier-cell bit sets follow
                    // without a list of cells. Anything else, including every error, takes the
                    // general path below.
                    // (No popcount on the baseline target: the cells are counted only when the
                    // limit is below the largest short cover.)
                    if let Ssv::Line(ln) = &s.shape
                        && let Some((cl, ch, mask)) =
                            group[l % 8].or_else(|| short_line(ln, inv, grow))
                        && (limit >= SHORT as u64
                            || u64::from((mask & !SMALL).count_ones()) <= limit)
                    {
                        for k in 0..3 {
                            lo[k] = lo[k].min(cl[k]);
                            hi[k] = hi[k].max(ch[k]);
                        }
                        push_mask(cl, mask, keys, earlier);
                        start.push(keys.len() as u32);
                        continue;
                    }
                    if let Some(field) = invalid_field(&s.shape) {
                        *error = Some(GridError::InvalidShape {
                            what: "section",
                            index,
                            field,
                        });
                        break;
                    }
                    if !matches!(s.shape, Ssv::Line(_)) {
                        shapes[l] = s.shape;
                    }
                    let (v, n, r) = core_in_cells(&s.shape, inv, grow);
                    let (cl, ch) = cell_range(&v[..n], r);
                    for k in 0..3 {
                        for cell in [cl[k], ch[k]] {
                            if !(-LATTICE_HALF..LATTICE_HALF).contains(&cell) && error.is_none() {
                                *error = Some(GridError::OutsideLattice {
                                    what: "section",
                                    index,
                                    axis: AXES[k],
                                    cell,
                                    limit: LATTICE_HALF,
                                });
                            }
                        }
                        lo[k] = lo[k].min(cl[k]);
                        hi[k] = hi[k].max(ch[k]);
                    }
                    if error.is_some() {
                        break;
                    }
                    let first = keys.len();
                    // Fast path for a short segment or a point: each cell of its small cell
                    // range is tested, into a local array whose coordinates then give the
                    // earlier-cell bit sets directly.
                    let mut res = Ok(0);
                    let mut fast = false;
                    let extent = [0, 1, 2].map(|k| ch[k] - cl[k] + 1);
                    let short = extent.iter().all(|&e| e <= 4)
                        && extent[0] * extent[1] * extent[2] <= SHORT as i64;
                    if n <= 2 && short {
                        let m = cover::short_segment(v[0], v[n - 1], r, cl, ch, &mut buf);
                        if m as u64 > limit {
                            res = Err(cover::OverLimit);
                        } else {
                            keys.extend(buf[..m].iter().map(|&c| pack_i64(c)));
                            crate::pairs::earlier_bits(&buf[..m], earlier);
                            fast = true;
                        }
                    }
                    if !fast && res.is_ok() {
                        res = walk_core(&v[..n], r, &clip, limit, scratch, &mut |c| {
                            keys.push(pack_i64(c));
                        });
                        if res.is_ok() {
                            crate::pairs::earlier_cells(&keys[first..], earlier);
                        }
                    }
                    if res.is_err() {
                        *error = Some(GridError::TooManyCells {
                            what: "section",
                            index,
                            limit,
                            cell_size: h,
                        });
                        break;
                    }
                    start.push(keys.len() as u32);
                }
            });
        if let Some(e) = self.chunks[..n_chunks].iter().find_map(|c| c.error.clone()) {
            return Err(e);
        }
        let mut lo = [i64::MAX; 3];
        let mut hi = [i64::MIN; 3];
        for c in &self.chunks[..n_chunks] {
            for k in 0..3 {
                lo[k] = lo[k].min(c.lo[k]);
                hi[k] = hi[k].max(c.hi[k]);
            }
        }
        self.origin = lo;
        for k in 0..3 {
            self.dims[k] = (hi[k] - lo[k] + 1) as u64;
        }
        self.entries = self.chunks[..n_chunks].iter().map(|c| c.keys.len()).sum();
        self.sort_entries();
        self.pack(sections, slack);
        Ok(())
    }

    /// Copies the section data into the pair search's order (by first cell, then by index; a
    /// counting sort over the cells), each box grown by `slack`, and renumbers the entries. On
    /// the dense path the sort and the renumbering were done with the entries
    /// ([`Grid::sort_entries`]).
    fn pack(&mut self, sections: &[Section], slack: Real) {
        let n = self.len;
        if !self.dense {
            let n_cells = self.cell_keys.len();
            let chunks = &self.chunks[..self.n_chunks];
            let pk = &mut self.packed;
            // Cell index of each section's first cell (`n_cells` for an empty cover).
            pk.first.resize(n.max(pk.first.len()), 0);
            let cell_keys = &self.cell_keys;
            pk.first[..n]
                .par_chunks_mut(CHUNK)
                .zip(chunks.par_iter())
                .for_each(|(first, ch)| {
                    for (l, f) in first.iter_mut().enumerate() {
                        let (s, e) = (ch.start[l] as usize, ch.start[l + 1] as usize);
                        *f = if s == e {
                            n_cells as u32
                        } else {
                            cell_keys
                                .binary_search(&ch.keys[s])
                                .map_or(n_cells as u32, |c| c as u32)
                        };
                    }
                });
            Self::rank_sections(&mut self.packed, n, n_cells, None);
            let pk = &mut self.packed;
            let rank = &pk.rank;
            let entries = self.entries;
            if pk.items.len() < entries {
                pk.items.resize(entries, 0);
            }
            pk.items[..entries]
                .par_chunks_mut(1 << 14)
                .zip(self.sorted_items[..entries].par_chunks(1 << 14))
                .for_each(|(out, inp)| {
                    for (o, &i) in out.iter_mut().zip(inp) {
                        *o = rank[i as usize];
                    }
                });
        }
        // Gather the data in the new order.
        let pk = &mut self.packed;
        pk.boxes.resize(n, PBox::default());
        pk.lines.resize(n, [0.0; 8]);
        let order = &pk.order;
        pk.boxes
            .par_chunks_mut(CHUNK)
            .zip(pk.lines.par_chunks_mut(CHUNK))
            .zip(order.par_chunks(CHUNK))
            .for_each(|((boxes, lines), order)| {
                for (k, &i) in order.iter().enumerate() {
                    // The sections are read in the search's order, scattered over the scene's:
                    // fetch ahead (both lines a section may straddle), or each one waits for
                    // memory.
                    if let Some(&f) = order.get(k + PREFETCH) {
                        let p = sections.as_ptr().wrapping_add(f as usize);
                        prefetch(p);
                        prefetch(p.cast::<u8>().wrapping_add(size_of::<Section>() - 1));
                    }
                    (boxes[k], lines[k]) = placed(&sections[i as usize], slack);
                }
            });
    }

    /// The pair search's order of the sections: by first cell (`packed.first`: a cell index,
    /// `n_cells` for an empty cover; or, given `dense_cell`, a box index mapped through it,
    /// `u32::MAX` for an empty cover), then by index. A stable counting sort, counted and ranked
    /// in parallel over blocks of consecutive sections (any blocking gives the same ranks: within
    /// a cell, block 0's sections come first, then block 1's), then the inverse permutation in
    /// one sequential pass.
    fn rank_sections(pk: &mut Packed, n: usize, n_cells: usize, dense_cell: Option<&[u32]>) {
        let blocks = rayon::current_num_threads().min(n >> 14).clamp(1, 8);
        let per = n.div_ceil(blocks).max(1);
        let blocks = n.div_ceil(per).max(1);
        let width = n_cells + 1;
        pk.counts.clear();
        pk.counts.resize(blocks * width, 0);
        pk.first[..n]
            .par_chunks_mut(per)
            .zip(pk.counts.par_chunks_mut(width))
            .for_each(|(first, count)| {
                if let Some(map) = dense_cell {
                    for f in first.iter_mut() {
                        *f = if *f == u32::MAX {
                            n_cells as u32
                        } else {
                            map[*f as usize]
                        };
                    }
                }
                for &f in first.iter() {
                    count[f as usize] += 1;
                }
            });
        // Exclusive prefix, cell-major then block-minor: each block's count becomes its cursor.
        let mut run = 0u32;
        for c in 0..width {
            for b in 0..blocks {
                let x = pk.counts[b * width + c];
                pk.counts[b * width + c] = run;
                run += x;
            }
        }
        pk.rank.resize(n, 0);
        pk.rank[..n]
            .par_chunks_mut(per)
            .zip(pk.first[..n].par_chunks(per))
            .zip(pk.counts.par_chunks_mut(width))
            .for_each(|((rank, first), cursor)| {
                for (r, &f) in rank.iter_mut().zip(first) {
                    let c = &mut cursor[f as usize];
                    *r = *c;
                    *c += 1;
                }
            });
        pk.order.resize(n, 0);
        for (i, &r) in pk.rank[..n].iter().enumerate() {
            pk.order[r as usize] = i as u32;
        }
    }

    /// Sorts the entries by cell: a parallel counting sort over the dense box of the covers when
    /// it is not much larger than the number of entries, else a parallel comparison sort of
    /// (cell, section).
    fn sort_entries(&mut self) {
        let entries = self.entries;
        let box_cells = self.dims[0]
            .checked_mul(self.dims[1])
            .and_then(|v| v.checked_mul(self.dims[2]))
            .unwrap_or(u64::MAX);
        self.dense = box_cells <= (4 * entries as u64).max(1 << 16)
            && box_cells < u64::from(u32::MAX)
            && entries < u32::MAX as usize;
        // Only grown: every entry below `entries` is written below.
        if self.sorted_items.len() < entries {
            self.sorted_items.resize(entries, 0);
            self.entry_earlier.resize(entries, 0);
        }
        self.cell_keys.clear();
        self.cell_start.clear();
        self.cell_start.push(0);
        let bo = [0, 1, 2].map(|k| (self.origin[k] + LATTICE_HALF) as u64);
        let dims = self.dims;
        if self.dense {
            let n = self.len;
            let chunks = &mut self.chunks[..self.n_chunks];
            let nb = box_cells as usize;
            // Blocks of chunks, one per thread: each counts and places only its own entries.
            // Within a cell the entries of block 0 come first, then block 1's, and so on, so
            // the order (by section index) does not depend on the number of blocks. Each block
            // holds a count per box cell, so beyond two blocks there are no more blocks than
            // entries per box cell (the counts then take no more room than the entries).
            let n_chunks = chunks.len();
            let blocks = rayon::current_num_threads()
                .min((entries / nb.max(1)).max(2))
                .clamp(1, 64)
                .min(n_chunks.max(1));
            let per_block = n_chunks.div_ceil(blocks).max(1);
            let blocks = n_chunks.div_ceil(per_block).max(1);
            if self.block_counts.len() < blocks {
                self.block_counts.resize_with(blocks, Vec::new);
            }
            let counts = &mut self.block_counts[..blocks];
            // Each section's first cell, as a box index (`u32::MAX` for an empty cover), for
            // the pair search's order below.
            let pk = &mut self.packed;
            pk.first.resize(n.max(pk.first.len()), 0);
            let dyz = dims[1] * dims[2];
            let d0 = dense_of(0, bo, dims).wrapping_neg();
            counts
                .par_iter_mut()
                .zip(chunks.par_chunks_mut(per_block))
                .zip(pk.first[..n].par_chunks_mut(per_block * CHUNK))
                .for_each(|((count, chs), first)| {
                    count.clear();
                    count.resize(nb, 0);
                    let count = &mut count[..];
                    for (ch, first) in chs.iter_mut().zip(first.chunks_mut(CHUNK)) {
                        // The box index is linear in the key's three fields: no per-field
                        // subtraction of the origin.
                        ch.dense.clear();
                        ch.dense.extend(ch.keys.iter().map(|&k| {
                            let d = ((k >> 42) * dyz)
                                .wrapping_add(((k >> 21) & MASK21) * dims[2])
                                .wrapping_add(k & MASK21)
                                .wrapping_sub(d0) as u32;
                            count[d as usize] += 1;
                            d
                        }));
                        for (f, w) in first.iter_mut().zip(ch.start.windows(2)) {
                            *f = if w[0] == w[1] {
                                u32::MAX
                            } else {
                                ch.dense[w[0] as usize]
                            };
                        }
                    }
                });
            // Cell-major, block-minor exclusive prefix: each block's count becomes its cursor,
            // and `prefix[k]` the end of cell k. The non-empty cells are listed in the same
            // pass, walking the box row by row.
            self.prefix.clear();
            self.prefix.resize(nb, 0);
            self.dense_cell.resize(nb, 0);
            let mut run = 0u32;
            let (prefix, dense_cell) = (&mut self.prefix[..nb], &mut self.dense_cell[..nb]);
            let (cell_keys, cell_start) = (&mut self.cell_keys, &mut self.cell_start);
            let mut d = 0;
            for x in 0..dims[0] {
                for y in 0..dims[1] {
                    let row = ((x + bo[0]) << 42) | ((y + bo[1]) << 21) | bo[2];
                    for z in 0..dims[2] {
                        let prev = run;
                        if let [count] = counts {
                            // One block (one thread): no inner loop.
                            let c = count[d];
                            count[d] = run;
                            run += c;
                        } else {
                            for count in counts.iter_mut() {
                                let c = count[d];
                                count[d] = run;
                                run += c;
                            }
                        }
                        prefix[d] = run;
                        dense_cell[d] = cell_keys.len() as u32;
                        if run > prev {
                            cell_keys.push(row + z);
                            cell_start.push(run);
                        }
                        d += 1;
                    }
                }
            }
            // The pair search's order, so that the copy below renumbers the entries.
            let n_cells = self.cell_keys.len();
            Self::rank_sections(&mut self.packed, n, n_cells, Some(&self.dense_cell));
            // Scatter: the blocks write disjoint positions of shared buffers (relaxed atomic
            // stores, plain moves on common targets), then one copy.
            if self.scatter.len() < entries {
                self.scatter.resize_with(entries, Slot::default);
            }
            let out = &self.scatter[..entries];
            let chunks = &self.chunks[..self.n_chunks];
            let counts = &mut self.block_counts[..blocks];
            let rank = &self.packed.rank;
            counts
                .par_iter_mut()
                .zip(chunks.par_chunks(per_block))
                .enumerate()
                .for_each(|(b, (cursor, chs))| {
                    // A plain slice, so that its address stays in a register across the
                    // stores.
                    let cursor = &mut cursor[..];
                    for (j, ch) in chs.iter().enumerate() {
                        let first = (b * per_block + j) * CHUNK;
                        for (l, w) in ch.start.windows(2).enumerate() {
                            let item = (first + l) as u64 | u64::from(rank[first + l]) << 32;
                            let range = w[0] as usize..w[1] as usize;
                            for (p, (&d, &earlier)) in ch.dense[range.clone()]
                                .iter()
                                .zip(&ch.earlier[range.clone()])
                                .enumerate()
                            {
                                // The slots are written all over the buffer: fetch the line
                                // of an entry a few ahead (its cursor may still move by a slot
                                // or two before it is written; the line is the same or next).
                                if let Some(&ahead) = ch.dense.get(range.start + p + PREFETCH) {
                                    prefetch(out.as_ptr().wrapping_add(
                                        cursor.get(ahead as usize).map_or(0, |&c| c as usize),
                                    ));
                                }
                                let c = &mut cursor[d as usize];
                                let slot = &out[*c as usize];
                                slot.item.store(item, Relaxed);
                                slot.earlier.store(earlier, Relaxed);
                                *c += 1;
                            }
                        }
                    }
                });
            let pk = &mut self.packed;
            if pk.items.len() < entries {
                pk.items.resize(entries, 0);
            }
            self.sorted_items[..entries]
                .par_chunks_mut(1 << 14)
                .zip(self.entry_earlier[..entries].par_chunks_mut(1 << 14))
                .zip(pk.items[..entries].par_chunks_mut(1 << 14))
                .zip(out.par_chunks(1 << 14))
                .for_each(|(((items, earlier), packed), from)| {
                    for (((item, earlier), packed), f) in items
                        .iter_mut()
                        .zip(earlier.iter_mut())
                        .zip(packed.iter_mut())
                        .zip(from)
                    {
                        let i = f.item.load(Relaxed);
                        *item = i as u32;
                        *packed = (i >> 32) as u32;
                        *earlier = f.earlier.load(Relaxed);
                    }
                });
        } else {
            let chunks = &self.chunks[..self.n_chunks];
            self.prefix.clear();
            self.tmp.clear();
            for (ci, ch) in chunks.iter().enumerate() {
                for l in 0..ch.start.len() - 1 {
                    let item = (ci * CHUNK + l) as u32;
                    let range = ch.start[l] as usize..ch.start[l + 1] as usize;
                    for (&k, &earlier) in ch.keys[range.clone()].iter().zip(&ch.earlier[range]) {
                        self.tmp.push((k, item, earlier));
                    }
                }
            }
            self.tmp.par_sort_unstable();
            for (e, &(k, item, earlier)) in self.tmp.iter().enumerate() {
                self.sorted_items[e] = item;
                self.entry_earlier[e] = earlier;
                if e > 0 && self.tmp[e - 1].0 != k {
                    self.cell_keys.push(self.tmp[e - 1].0);
                    self.cell_start.push(e as u32);
                }
            }
            if let Some(&(k, _, _)) = self.tmp.last() {
                self.cell_keys.push(k);
                self.cell_start.push(entries as u32);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hair_ssv::Lss;

    #[test]
    fn short_lines_leave_bad_or_far_shapes_to_the_general_path() {
        let p = |x: f32| Point::new(x, 0.5, 0.5);
        let ok = Lss::new(p(0.2), p(0.7), 0.01);
        assert!(short_line(&ok, 1.0, 0.0).is_some());
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 2e6, -2e6] {
            assert!(short_line(&Lss::new(p(bad), p(0.7), 0.01), 1.0, 0.0).is_none());
            assert!(short_line(&Lss::new(p(0.2), p(bad), 0.01), 1.0, 0.0).is_none());
        }
        for r in [f32::NAN, f32::INFINITY, -0.01] {
            assert!(short_line(&Lss::new(p(0.2), p(0.7), r), 1.0, 0.0).is_none());
        }
        // The last cells inside the lattice, and one beyond.
        let edge = LATTICE_HALF as f32 - 0.6;
        assert!(short_line(&Lss::new(p(edge), p(edge + 0.2), 0.01), 1.0, 0.0).is_some());
        assert!(short_line(&Lss::new(p(edge), p(edge + 0.7), 0.01), 1.0, 0.0).is_none());
    }

    #[test]
    fn short_lines_give_the_keys_and_bit_sets_of_the_walk() {
        // Seeded segments of about one cell, some along a lattice axis, at several radii.
        let mut z = 11u64;
        let mut unit = || {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (z >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut tested = 0;
        for n in 0..20_000 {
            let a = Point::new(unit() * 8.0 - 4.0, unit() * 8.0 - 4.0, unit() * 8.0 - 4.0);
            let mut b = Point::new(a.x + unit() * 2.0 - 1.0, a.y + unit() - 0.5, a.z + unit());
            if n % 5 == 0 {
                b[n % 3] = a[n % 3];
            }
            let l = Lss::new(a, b, unit() * 0.3);
            let (inv, grow) = (1.0 + f64::from(unit()), f64::from(unit()) * 0.01);
            let Some((cl, _, mask)) = short_line(&l, inv, grow) else {
                continue;
            };
            let (mut keys, mut bits) = (Vec::new(), Vec::new());
            push_mask(cl, mask, &mut keys, &mut bits);
            let (v, m, r) = core_in_cells(&Ssv::Line(l), inv, grow);
            let mut walk = Vec::new();
            walk_core(
                &v[..m],
                r,
                &CellBox::ALL,
                u64::MAX,
                &mut Vec::new(),
                &mut |c| walk.push(pack_i64(c)),
            )
            .unwrap();
            let mut walk_bits = Vec::new();
            crate::pairs::earlier_cells(&walk, &mut walk_bits);
            assert_eq!(keys, walk, "{l:?}");
            assert_eq!(bits, walk_bits, "{l:?}");
            tested += 1;
        }
        assert!(tested > 10_000, "{tested}");
    }
}
