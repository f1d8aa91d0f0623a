//! `hair`: interactive, physically based hair.
//!
//! The facade re-exports the layers as modules.

pub use hair_dynamics as dynamics;
pub use hair_grid as grid;
pub use hair_lod as lod;
pub use hair_ssv as ssv;
