//! The crate's error type.

use hair_dynamics::DynamicsError;
use hair_grid::GridError;

/// What a collision stage can fail on: the strand state refusing a correction (a non-finite
/// target), the grid refusing its input, or a node the volume model cannot place.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CollideError {
    /// The strand state refused a correction or a constraint.
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    /// The grid refused its input.
    #[error(transparent)]
    Grid(#[from] GridError),
    /// A node's position or velocity is not finite (the volume model cannot place it).
    #[error("hair-hair volume: node {node} has a non-finite position or velocity")]
    NonFiniteNode {
        /// The node's index in the state.
        node: usize,
    },
}
