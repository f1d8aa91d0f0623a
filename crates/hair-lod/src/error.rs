//! The error type of the crate.

use thiserror::Error;

/// Everything that can go wrong when building a hierarchy, selecting levels or changing them.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum LodError {
    /// The hairstyle has no strands.
    #[error("the hairstyle has no strands")]
    EmptyHairstyle,
    /// A strand has fewer than two points.
    #[error("strand {strand}: {count} points, at least 2 are needed")]
    TooFewPoints {
        /// Index of the strand in the hairstyle.
        strand: usize,
        /// How many points it has.
        count: usize,
    },
    /// A strand's root position or root frame is NaN or infinite.
    #[error("strand {strand}: root {field} is not finite")]
    NonFiniteRoot {
        /// Index of the strand in the hairstyle.
        strand: usize,
        /// `"position"` or `"frame"`.
        field: &'static str,
    },
    /// A strand's point is NaN or infinite.
    #[error("strand {strand}, point {point}: not finite")]
    NonFinitePoint {
        /// Index of the strand in the hairstyle.
        strand: usize,
        /// Index of the point in the strand.
        point: usize,
    },
    /// A parameter is NaN, infinite or outside its range.
    #[error("parameter `{name}` = {value} is out of range: {expected}")]
    InvalidParameter {
        /// Which parameter.
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What the range is.
        expected: &'static str,
    },
    /// Two thresholds that must be ordered are not.
    #[error(
        "thresholds out of order: `{lower}` = {lower_value} must be below `{upper}` = {upper_value}"
    )]
    ThresholdOrder {
        /// The parameter that must be the smaller.
        lower: &'static str,
        /// Its value.
        lower_value: f64,
        /// The parameter that must be the larger.
        upper: &'static str,
        /// Its value.
        upper_value: f64,
    },
    /// A per-node input slice has the wrong length.
    #[error("input `{name}` has {got} entries, the hierarchy has {expected} nodes")]
    InputLength {
        /// Which input.
        name: &'static str,
        /// How many entries were given.
        got: usize,
        /// How many nodes there are.
        expected: usize,
    },
    /// A node index is not in the hierarchy.
    #[error("node {node} does not exist (the hierarchy has {count} nodes)")]
    UnknownNode {
        /// The index given.
        node: u32,
        /// How many nodes there are.
        count: usize,
    },
    /// An operation needs an active node (or active children) and did not get one.
    #[error("node {node} is not in the state the operation needs: {reason}")]
    NotAllowed {
        /// The node concerned.
        node: u32,
        /// Why the operation cannot be done.
        reason: &'static str,
    },
    /// A node's control points, as a caller's layout places them, are not within its fields.
    #[error("node {node}: control points {start}..{end} are not within fields of {len} values")]
    PointsOutOfRange {
        /// The node.
        node: u32,
        /// Where the layout starts its points.
        start: usize,
        /// Where the layout ends them.
        end: usize,
        /// Length of the shortest field.
        len: usize,
    },
    /// The front, state and hierarchy do not belong together.
    #[error("front or state was made for another hierarchy ({what})")]
    Mismatch {
        /// What differs.
        what: &'static str,
    },
}

pub(crate) fn finite_positive(name: &'static str, value: f32) -> Result<(), LodError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(LodError::InvalidParameter {
            name,
            value: f64::from(value),
            expected: "finite and > 0",
        })
    }
}

pub(crate) fn finite_non_negative(name: &'static str, value: f32) -> Result<(), LodError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(LodError::InvalidParameter {
            name,
            value: f64::from(value),
            expected: "finite and >= 0",
        })
    }
}

pub(crate) fn ordered(
    lower: &'static str,
    lo: f32,
    upper: &'static str,
    hi: f32,
) -> Result<(), LodError> {
    if lo < hi {
        Ok(())
    } else {
        Err(LodError::ThresholdOrder {
            lower,
            lower_value: f64::from(lo),
            upper,
            upper_value: f64::from(hi),
        })
    }
}
