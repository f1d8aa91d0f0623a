//! Integer cell coordinates on the global lattice and their packing into sortable 64-bit keys.

use crate::{Point, Real};

/// Largest cell coordinate magnitude the lattice addresses: coordinates lie in
/// `[-LATTICE_HALF, LATTICE_HALF)`, so that a [`CellKey`] packs into 63 bits.
pub const LATTICE_HALF: i64 = 1 << 20;

/// Integer coordinates of one cell of the global lattice: cell `(x, y, z)` is the half-open box
/// `[x h, (x + 1) h) x [y h, (y + 1) h) x [z h, (z + 1) h)` for cell size `h`, so grids of the same
/// cell size agree on their cells wherever their items lie.
///
/// The derived order (lexicographic in `x`, `y`, `z`) is the order of [`CellKey::pack`] and the
/// order in which the grid lists its cells.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct CellKey {
    /// Cell index along x.
    pub x: i32,
    /// Cell index along y.
    pub y: i32,
    /// Cell index along z.
    pub z: i32,
}

impl CellKey {
    /// A key from its three coordinates.
    #[inline]
    pub const fn new(x: i32, y: i32, z: i32) -> Self {
        Self { x, y, z }
    }

    /// The cell holding `p` for cell size `cell_size`, or `None` when `p` is not finite, the cell
    /// size is not positive, or the cell lies outside the lattice (`|coordinate| >= 2^20`).
    pub fn containing(p: &Point, cell_size: Real) -> Option<Self> {
        if !(cell_size.is_finite() && cell_size > 0.0) {
            return None;
        }
        let inv = 1.0 / f64::from(cell_size);
        let c = |v: Real| -> Option<i32> {
            if !v.is_finite() {
                return None;
            }
            let f = (f64::from(v) * inv).floor();
            if f < -(LATTICE_HALF as f64) || f >= LATTICE_HALF as f64 {
                return None;
            }
            Some(f as i32)
        };
        Some(Self::new(c(p.x)?, c(p.y)?, c(p.z)?))
    }

    /// Packs the key into a `u64` whose integer order is the key order (each coordinate biased by
    /// 2^20 into 21 bits), or `None` outside the lattice. Packed keys are a deterministic,
    /// collision-free hash of the cell.
    #[inline]
    pub fn pack(self) -> Option<u64> {
        let b = |v: i32| -> Option<u64> {
            let s = i64::from(v) + LATTICE_HALF;
            if (0..2 * LATTICE_HALF).contains(&s) {
                Some(s as u64)
            } else {
                None
            }
        };
        Some((b(self.x)? << 42) | (b(self.y)? << 21) | b(self.z)?)
    }

    /// Inverse of [`CellKey::pack`].
    #[inline]
    pub fn unpack(key: u64) -> Self {
        let m = (1u64 << 21) - 1;
        let u = |s: u64| ((s & m) as i64 - LATTICE_HALF) as i32;
        Self::new(u(key >> 42), u(key >> 21), u(key))
    }

    /// The cell's box `(min, max)` in metres for cell size `cell_size`.
    pub fn bounds(self, cell_size: Real) -> (Point, Point) {
        let h = cell_size;
        let lo = Point::new(self.x as Real * h, self.y as Real * h, self.z as Real * h);
        (lo, Point::new(lo.x + h, lo.y + h, lo.z + h))
    }
}
