//! hair-grid (being written).
