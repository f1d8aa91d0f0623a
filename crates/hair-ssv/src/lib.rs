//! hair-ssv (being written).
