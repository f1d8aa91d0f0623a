//! The error type of the crate.

use thiserror::Error;

/// Everything that can go wrong when building or stepping strands.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum DynamicsError {
    /// A parameter is NaN or infinite.
    #[error("parameter `{name}` is not finite ({value})")]
    NonFiniteParameter {
        /// Which parameter.
        name: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A parameter is outside its documented range.
    #[error("parameter `{name}` = {value} is out of range: {expected}")]
    OutOfRange {
        /// Which parameter.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What the range is.
        expected: &'static str,
    },
    /// The time step is not a positive finite number.
    #[error("time step {dt} s is not a positive finite number")]
    InvalidTimeStep {
        /// The offending time step.
        dt: f64,
    },
    /// A skeleton was given fewer than two control points.
    #[error("skeleton {skeleton}: {count} control points, at least 2 are needed")]
    TooFewPoints {
        /// Index of the skeleton (in the order given).
        skeleton: usize,
        /// How many points it had.
        count: usize,
    },
    /// A segment of a skeleton has zero (or non-finite) length.
    #[error("skeleton {skeleton}, segment {segment}: length {length} m is not positive and finite")]
    DegenerateSegment {
        /// Index of the skeleton.
        skeleton: usize,
        /// Index of the segment's end node.
        segment: usize,
        /// The offending length.
        length: f64,
    },
    /// A per-node value of a skeleton is invalid.
    #[error("skeleton {skeleton}, node {node}: `{field}` = {value} is invalid ({expected})")]
    InvalidNode {
        /// Index of the skeleton.
        skeleton: usize,
        /// Index of the node within the skeleton.
        node: usize,
        /// Which field.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What is expected.
        expected: &'static str,
    },
    /// A skeleton handle does not name a live skeleton.
    #[error("skeleton {skeleton} does not exist")]
    UnknownSkeleton {
        /// The handle given.
        skeleton: usize,
    },
    /// A node index is outside its skeleton or outside the state.
    #[error("node {node} is out of range (the state has {count} nodes)")]
    UnknownNode {
        /// The index given.
        node: usize,
        /// How many there are.
        count: usize,
    },
    /// The state went non-finite during a step; the skeleton was restored to its previous state.
    #[error(
        "step {step}: skeleton {skeleton} went non-finite at node {node}; it was restored to its state before the step"
    )]
    NonFiniteState {
        /// The step counter at which it happened.
        step: u64,
        /// The skeleton.
        skeleton: usize,
        /// The first non-finite node within the skeleton.
        node: usize,
    },
}

/// Checks that a scalar parameter is finite.
pub(crate) fn finite(name: &'static str, value: f32) -> Result<(), DynamicsError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(DynamicsError::NonFiniteParameter {
            name,
            value: f64::from(value),
        })
    }
}

/// Checks that a scalar parameter is finite and not negative.
pub(crate) fn non_negative(name: &'static str, value: f32) -> Result<(), DynamicsError> {
    finite(name, value)?;
    if value < 0.0 {
        return Err(DynamicsError::OutOfRange {
            name,
            value: f64::from(value),
            expected: ">= 0",
        });
    }
    Ok(())
}

/// Checks that a vector parameter is finite.
pub(crate) fn finite_vec(name: &'static str, v: &crate::Vector) -> Result<(), DynamicsError> {
    for c in v.iter() {
        finite(name, *c)?;
    }
    Ok(())
}
