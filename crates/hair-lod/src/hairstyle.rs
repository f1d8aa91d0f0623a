//! The input of a hierarchy: strands with their roots, root frames and points.

use crate::{LodError, Point, Real};
use nalgebra::Rotation3;

/// One strand of a hairstyle, as rendered: its root on the scalp and its points, root first.
#[derive(Clone, Debug, PartialEq)]
pub struct Strand {
    /// Root position on the scalp (m, head frame).
    pub root: Point,
    /// Root frame: its z axis is the direction the hair leaves the scalp.
    pub frame: Rotation3<Real>,
    /// The strand's points at rest (m, head frame), root first; at least two.
    pub points: Vec<Point>,
}

/// A hairstyle: every strand on the head.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hairstyle {
    /// The strands, in any order; a strand's index here is its id in the hierarchy.
    pub strands: Vec<Strand>,
}

impl Hairstyle {
    /// Checks that there is at least one strand, that every strand has two points or more, and
    /// that roots, frames and points are finite. The error names the first bad strand.
    pub fn validate(&self) -> Result<(), LodError> {
        if self.strands.is_empty() {
            return Err(LodError::EmptyHairstyle);
        }
        for (s, strand) in self.strands.iter().enumerate() {
            if !strand.root.coords.iter().all(|c| c.is_finite()) {
                return Err(LodError::NonFiniteRoot {
                    strand: s,
                    field: "position",
                });
            }
            if !strand.frame.matrix().iter().all(|c| c.is_finite()) {
                return Err(LodError::NonFiniteRoot {
                    strand: s,
                    field: "frame",
                });
            }
            if strand.points.len() < 2 {
                return Err(LodError::TooFewPoints {
                    strand: s,
                    count: strand.points.len(),
                });
            }
            if let Some(point) = strand
                .points
                .iter()
                .position(|p| !p.coords.iter().all(|c| c.is_finite()))
            {
                return Err(LodError::NonFinitePoint { strand: s, point });
            }
        }
        Ok(())
    }
}
