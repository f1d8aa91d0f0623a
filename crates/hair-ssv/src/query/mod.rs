//! Exact closest-point kernels between the cores of swept sphere volumes and triangles.
//!
//! Every kernel returns a [`Closest`]: the closest point on the first argument, the closest point
//! on the second, and the squared distance between them. Degenerate inputs (zero-length segments,
//! zero-area rectangles, parallel or coincident features) give the exact answer, never NaN.

mod point_rectangle;
mod point_segment;
mod point_triangle;
pub(crate) mod rectangle_rectangle;
mod rectangle_triangle;
pub(crate) mod segment_rectangle;
mod segment_segment;
mod segment_triangle;
pub(crate) mod separation;

pub use point_rectangle::point_rectangle;
pub use point_segment::point_segment;
pub use point_triangle::point_triangle;
pub(crate) use point_triangle::{TriLanes, point_triangle_lanes_in};
pub use rectangle_rectangle::rectangle_rectangle;
pub use rectangle_triangle::rectangle_triangle;
pub use segment_rectangle::segment_rectangle;
pub use segment_segment::{segment_segment, segment_segment_dist_sq};
pub use segment_triangle::segment_triangle;

use crate::{Point, Real};

/// Closest points between two features and their squared distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Closest {
    /// Closest point on the first feature.
    pub on_a: Point,
    /// Closest point on the second feature.
    pub on_b: Point,
    /// Squared distance between `on_a` and `on_b`.
    pub dist_sq: Real,
}

impl Closest {
    /// Distance between the closest points.
    #[inline]
    pub fn distance(&self) -> Real {
        self.dist_sq.sqrt()
    }

    /// The same result with the two features swapped.
    #[inline]
    pub fn swapped(self) -> Self {
        Self {
            on_a: self.on_b,
            on_b: self.on_a,
            dist_sq: self.dist_sq,
        }
    }

    #[inline]
    pub(crate) fn from_points(on_a: Point, on_b: Point) -> Self {
        Self {
            on_a,
            on_b,
            dist_sq: (on_b - on_a).norm_squared(),
        }
    }

    /// Keeps whichever of `self` and `other` is closer (`self` on ties).
    #[inline]
    pub(crate) fn min(self, other: Self) -> Self {
        if other.dist_sq < self.dist_sq {
            other
        } else {
            self
        }
    }
}

/// `x` clamped to `[0, hi]` without panicking (NaN-free for finite `x`).
#[inline(always)]
pub(crate) fn clamp_to(x: Real, hi: Real) -> Real {
    x.max(0.0).min(hi)
}
