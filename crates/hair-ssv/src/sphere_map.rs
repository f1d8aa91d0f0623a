//! A spherical collision table for the top of the head, where the cylinder of Kurihara et al.
//! 1993 §3.1 meets the surface at grazing angles: the same bilinear lookup (eq. 8-10) and nearest
//! point (eq. 11), on an azimuth x polar-angle grid around a centre.

use crate::surface_map::{Grid, sample};
use crate::{Bvh, MapFrame, MapSample, Point, Real, SsvError, SurfaceMap};

/// Sampling of a [`SphereMap`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereMapConfig {
    /// Samples around the axis.
    pub azimuth_samples: usize,
    /// Samples of the polar angle from the axis, over `[0, max_polar]`.
    pub polar_samples: usize,
    /// Largest polar angle covered, radians (`pi` covers the whole sphere).
    pub max_polar: Real,
    /// Rays start this far from the centre and travel inwards, metres.
    pub max_radius: Real,
}

impl Default for SphereMapConfig {
    fn default() -> Self {
        Self {
            azimuth_samples: 64,
            polar_samples: 32,
            max_polar: 1.2,
            max_radius: 0.3,
        }
    }
}

/// A spherical collision table for one body part (a cap around the frame's axis).
#[derive(Clone, Debug, PartialEq)]
pub struct SphereMap {
    frame: MapFrame,
    max_polar: Real,
    grid: Grid,
}

impl SphereMap {
    /// Samples the mesh in `bvh` by casting a ray towards the centre at every grid node.
    pub fn build(bvh: &Bvh, frame: MapFrame, config: &SphereMapConfig) -> Result<Self, SsvError> {
        let bad = |reason: String| SsvError::InvalidMap {
            map: "SphereMap",
            reason,
        };
        let (m, n) = (config.azimuth_samples, config.polar_samples);
        if m < 3 || n < 2 {
            return Err(bad(format!("needs at least 3 x 2 samples, got {m} x {n}")));
        }
        let mp = config.max_polar;
        if !(mp.is_finite() && mp > 0.0 && mp <= std::f32::consts::PI) {
            return Err(bad(format!("field `max_polar` ({mp}) must be in (0, pi]")));
        }
        if !(config.max_radius.is_finite() && config.max_radius > 0.0) {
            return Err(bad(format!(
                "field `max_radius` ({}) must be positive",
                config.max_radius
            )));
        }
        let dv = mp / (n - 1) as Real;
        let grid = Grid::cast(bvh, (m, n), (0.0, dv), config.max_radius, |i, j| {
            let (sp, cp) = (dv * j as Real).sin_cos();
            let dir =
                frame.radial(std::f32::consts::TAU * i as Real / m as Real) * sp + frame.axis * cp;
            (frame.origin, dir)
        });
        Ok(Self {
            frame,
            max_polar: mp,
            grid,
        })
    }

    /// The map's frame.
    pub fn frame(&self) -> &MapFrame {
        &self.frame
    }

    /// Interpolated surface radius at azimuth `theta` and polar angle `polar` (radians).
    pub fn radius_at(&self, theta: Real, polar: Real) -> Real {
        self.grid.interpolate(theta, polar).0
    }
}

impl SurfaceMap for SphereMap {
    /// `None` when `p`'s polar angle is beyond the cap.
    #[inline]
    fn lookup(&self, p: &Point) -> Option<MapSample> {
        let d = p - self.frame.origin;
        let rp = d.norm();
        let (x, y, z) = (
            d.dot(&self.frame.reference),
            d.dot(&self.frame.side()),
            d.dot(&self.frame.axis),
        );
        let polar = (x * x + y * y).sqrt().atan2(z);
        if polar > self.max_polar {
            return None;
        }
        let theta = y.atan2(x);
        let (rq, nrm) = self.grid.interpolate(theta, polar);
        let dir = if rp > 0.0 { d / rp } else { self.frame.axis };
        let q = self.frame.origin + dir * rq;
        Some(sample(p, &q, nrm, dir, rp < rq))
    }
}
