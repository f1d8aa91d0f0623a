//! hair-dynamics (being written).
