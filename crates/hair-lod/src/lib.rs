//! hair-lod (being written).
