//! The cylindrical collision table of Kurihara, Anjyo & Thalmann 1993, §3.1: the radius and
//! normal of a body part sampled on an azimuth x height grid, looked up by bilinear
//! interpolation (eq. 8-10), with the nearest surface point of eq. 11.

use crate::surface_map::{Grid, sample};
use crate::{Bvh, MapFrame, MapSample, Point, Real, SsvError, SurfaceMap};

/// Sampling of a [`CylinderMap`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CylinderMapConfig {
    /// Samples around the axis (Kurihara used 40).
    pub azimuth_samples: usize,
    /// Samples along the axis (Kurihara used 40).
    pub height_samples: usize,
    /// Heights along the axis, relative to the frame's origin, metres: `(low, high)`.
    pub heights: (Real, Real),
    /// Rays start this far from the axis and travel inwards, so the table records the outermost
    /// surface within this radius, metres.
    pub max_radius: Real,
}

impl Default for CylinderMapConfig {
    fn default() -> Self {
        Self {
            azimuth_samples: 64,
            height_samples: 64,
            heights: (-0.1, 0.1),
            max_radius: 0.3,
        }
    }
}

/// A cylindrical collision table for one body part.
#[derive(Clone, Debug, PartialEq)]
pub struct CylinderMap {
    frame: MapFrame,
    heights: (Real, Real),
    grid: Grid,
}

impl CylinderMap {
    /// Samples the mesh in `bvh` by casting a ray towards the axis at every grid node.
    /// Where a ray misses, the radius is zero (nothing there).
    pub fn build(bvh: &Bvh, frame: MapFrame, config: &CylinderMapConfig) -> Result<Self, SsvError> {
        let bad = |reason: String| SsvError::InvalidMap {
            map: "CylinderMap",
            reason,
        };
        let (m, n) = (config.azimuth_samples, config.height_samples);
        if m < 3 || n < 2 {
            return Err(bad(format!("needs at least 3 x 2 samples, got {m} x {n}")));
        }
        let (h0, h1) = config.heights;
        if !(h0.is_finite() && h1.is_finite() && h1 > h0) {
            return Err(bad(format!(
                "field `heights` ({h0}, {h1}) must be finite and increasing"
            )));
        }
        if !(config.max_radius.is_finite() && config.max_radius > 0.0) {
            return Err(bad(format!(
                "field `max_radius` ({}) must be positive",
                config.max_radius
            )));
        }
        let dv = (h1 - h0) / (n - 1) as Real;
        let grid = Grid::cast(bvh, (m, n), (h0, dv), config.max_radius, |i, j| {
            let centre = frame.origin + frame.axis * (h0 + dv * j as Real);
            (
                centre,
                frame.radial(std::f32::consts::TAU * i as Real / m as Real),
            )
        });
        Ok(Self {
            frame,
            heights: (h0, h1),
            grid,
        })
    }

    /// The map's frame.
    pub fn frame(&self) -> &MapFrame {
        &self.frame
    }

    /// Interpolated surface radius at azimuth `theta` (radians) and `height` (eq. 8-10).
    pub fn radius_at(&self, theta: Real, height: Real) -> Real {
        self.grid.interpolate(theta, height).0
    }
}

impl SurfaceMap for CylinderMap {
    /// `None` when `p`'s height is outside the sampled range.
    #[inline]
    fn lookup(&self, p: &Point) -> Option<MapSample> {
        let d = p - self.frame.origin;
        let h = d.dot(&self.frame.axis);
        if !(h >= self.heights.0 && h <= self.heights.1) {
            return None;
        }
        let x = d.dot(&self.frame.reference);
        let y = d.dot(&self.frame.side());
        let rp = (x * x + y * y).sqrt();
        let theta = y.atan2(x);
        let (rq, nrm) = self.grid.interpolate(theta, h);
        let radial = if rp > 0.0 {
            (self.frame.reference * x + self.frame.side() * y) / rp
        } else {
            self.frame.reference
        };
        let q = self.frame.origin + self.frame.axis * h + radial * rq;
        Some(sample(p, &q, nrm, radial, rp < rq))
    }
}

impl CylinderMap {
    /// Cylindrical coordinates `(radius, azimuth, height)` of `p` in the map's frame.
    pub fn to_cylindrical(&self, p: &Point) -> (Real, Real, Real) {
        let d = p - self.frame.origin;
        let h = d.dot(&self.frame.axis);
        let x = d.dot(&self.frame.reference);
        let y = d.dot(&self.frame.side());
        ((x * x + y * y).sqrt(), y.atan2(x), h)
    }
}
