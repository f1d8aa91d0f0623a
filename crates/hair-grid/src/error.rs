//! The crate's one error type.

use crate::Real;

/// Everything that can go wrong when building or querying the grid from untrusted input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GridError {
    /// A coordinate, radius or extent of an item is NaN or infinite, or a radius is negative.
    #[error("{what} {index}: field `{field}` is not finite (or is a negative radius)")]
    InvalidShape {
        /// Which kind of item (`"section"`, `"body triangle"`, `"influence volume"`).
        what: &'static str,
        /// Index of the item in the caller's slice.
        index: usize,
        /// Which field is bad.
        field: &'static str,
    },
    /// The cell size (given, or derived from the mean segment length) is not a positive finite
    /// number.
    #[error("cell size is {cell_size} ({source_of}), must be finite and > 0")]
    NonPositiveCellSize {
        /// The offending value, in metres.
        cell_size: Real,
        /// Where it came from (`"GridConfig::cell_size"` or `"mean segment length"`).
        source_of: &'static str,
    },
    /// The pair margin is negative or not finite.
    #[error("GridConfig::margin is {margin}, must be finite and >= 0")]
    InvalidMargin {
        /// The offending margin, in metres.
        margin: Real,
    },
    /// One item would cover more cells than `GridConfig::max_cells_per_item`.
    #[error("{what} {index} covers more than {limit} cells (cell size {cell_size} m)")]
    TooManyCells {
        /// Which kind of item.
        what: &'static str,
        /// Index of the item in the caller's slice.
        index: usize,
        /// The limit that was exceeded.
        limit: u64,
        /// Cell size in use, in metres.
        cell_size: Real,
    },
    /// An item reaches a cell outside the lattice (cell coordinates must lie in
    /// `[-2^20, 2^20)`: 10 km either side of the origin for 1 cm cells).
    #[error(
        "{what} {index} reaches cell coordinate {cell} along {axis}, outside the lattice (+-{limit})"
    )]
    OutsideLattice {
        /// Which kind of item.
        what: &'static str,
        /// Index of the item in the caller's slice.
        index: usize,
        /// `'x'`, `'y'` or `'z'`.
        axis: char,
        /// The cell coordinate reached.
        cell: i64,
        /// The lattice half-width in cells.
        limit: i64,
    },
    /// A per-section input slice does not match the number of sections in the grid.
    #[error("{what}: {found} values given, the grid holds {expected} sections")]
    LengthMismatch {
        /// Which input (`"ActivityInput::speeds"`, ...).
        what: &'static str,
        /// Number of sections in the grid.
        expected: usize,
        /// Number of values given.
        found: usize,
    },
    /// A section index given as input is not a section of the grid.
    #[error("{what}: section {index} given, the grid holds {sections} sections")]
    UnknownSection {
        /// Which input (`"ActivityInput::touched_sections"`, ...).
        what: &'static str,
        /// The offending index.
        index: u32,
        /// Number of sections in the grid.
        sections: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("body triangle {index}: vertex index {vertex} out of range ({vertices} vertices)")]
    BadTriangleIndex {
        /// Triangle index.
        index: usize,
        /// The offending vertex index.
        vertex: u32,
        /// Number of vertices given.
        vertices: usize,
    },
    /// A configuration value is out of range.
    #[error("{field} is {value}, {requirement}")]
    InvalidConfig {
        /// The field (`"ActivityConfig::dormant_after"`, ...).
        field: &'static str,
        /// The offending value.
        value: Real,
        /// What is required.
        requirement: &'static str,
    },
    /// A kernel name that names no kernel ([`Kernel::from_name`](crate::Kernel::from_name)).
    #[error("`{name}` names no grid kernel (auto, avx512, avx2 or baseline)")]
    UnknownKernel {
        /// The name given.
        name: String,
    },
    /// `GridConfig::kernel` names a kernel whose instructions this processor lacks
    /// ([`Grid::try_new`](crate::Grid::try_new)).
    #[error(
        "GridConfig::kernel is {kernel}, which this processor cannot run (the widest it runs is {widest})"
    )]
    KernelUnavailable {
        /// The kernel asked for.
        kernel: &'static str,
        /// The widest kernel this processor runs.
        widest: &'static str,
    },
}
