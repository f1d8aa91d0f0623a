//! The crate's error type.

use hair_dynamics::DynamicsError;
use hair_grid::GridError;

/// What a collision stage can fail on: the strand state refusing a correction (a non-finite
/// target), or the grid refusing its input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CollideError {
    /// The strand state refused a correction or a constraint.
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// The grid refused its input.
    #[error(transparent)]
    Grid(#[from] GridError),
}
