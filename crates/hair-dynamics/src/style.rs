//! Rest shapes: straight, wavy and curly skeletons of `n` points and length `L`.
//!
//! Ward & Lin §3 (Fig. 3b): the style of a skeleton is its set of rest angles. We build the rest
//! polyline from style parameters and read the rest angles off it (see [`crate::SkeletonDesc`]).

use crate::error::{finite, non_negative};
use crate::{DynamicsError, Point, Real, Vector};
use nalgebra::Rotation3;

/// The shape of a skeleton at rest, in its root frame (hair leaves the scalp along +z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Style {
    /// A straight line along +z.
    Straight,
    /// A planar wave across +x: `x = amplitude * sin(2 pi s / period)`.
    Wavy {
        /// Amplitude (m).
        amplitude: Real,
        /// Wavelength along the strand (m).
        period: Real,
    },
    /// A helix around an axis along +z: curl radius and pitch (rise per turn).
    Curly {
        /// Curl radius (m).
        radius: Real,
        /// Rise per turn (m).
        pitch: Real,
    },
}

/// Rest polyline of `n` points with total length close to `length` (root first, head frame).
///
/// Points are spaced at equal arc length on the styled curve, so every segment has length
/// `length / (n - 1)` up to the chord-versus-arc difference of tight curls.
pub fn style_points(
    root: Point,
    frame: &Rotation3<Real>,
    style: &Style,
    n: usize,
    length: Real,
) -> Result<Vec<Point>, DynamicsError> {
    if n < 2 {
        return Err(DynamicsError::TooFewPoints {
            skeleton: 0,
            count: n,
        });
    }
    non_negative("style.length", length)?;
    if length == 0.0 {
        return Err(DynamicsError::OutOfRange {
            name: "style.length",
            value: 0.0,
            expected: "> 0",
        });
    }
    let curve: Box<dyn Fn(Real) -> Vector> = match *style {
        Style::Straight => Box::new(|s| Vector::new(0.0, 0.0, s)),
        Style::Wavy { amplitude, period } => {
            finite("style.amplitude", amplitude)?;
            positive("style.period", period)?;
            // Parameterised by height; resampled by arc length below.
            Box::new(move |z| {
                Vector::new(
                    amplitude * (core::f32::consts::TAU * z / period).sin(),
                    0.0,
                    z,
                )
            })
        }
        Style::Curly { radius, pitch } => {
            non_negative("style.radius", radius)?;
            positive("style.pitch", pitch)?;
            let turn = (core::f32::consts::TAU * radius).hypot(pitch);
            // Parameter u is arc length: angle = 2 pi u / turn.
            Box::new(move |u| {
                let a = core::f32::consts::TAU * u / turn;
                Vector::new(radius * (a.cos() - 1.0), radius * a.sin(), pitch * u / turn)
            })
        }
    };
    // Dense samples, then equal-arc-length resampling.
    let samples = 64 * (n - 1);
    let mut dense: Vec<Vector> = Vec::with_capacity(samples + 1);
    let mut arc = Vec::with_capacity(samples + 1);
    // Over-sample the parameter so the curve is long enough for any style.
    let span = match *style {
        Style::Wavy { amplitude, period } => {
            let slope = core::f32::consts::TAU * amplitude.abs() / period;
            length * (1.0 + slope * slope).sqrt()
        }
        _ => length,
    };
    let mut total = 0.0;
    for k in 0..=samples {
        let p = curve(span * k as Real / samples as Real);
        if let Some(last) = dense.last() {
            total += (p - *last).norm();
        }
        dense.push(p);
        arc.push(total);
    }
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for i in 0..n {
        let target = length * i as Real / (n - 1) as Real;
        while j + 1 < dense.len() && arc[j + 1] < target {
            j += 1;
        }
        let local = if j + 1 < dense.len() {
            let (a0, a1) = (arc[j], arc[j + 1]);
            let t = if a1 > a0 {
                ((target - a0) / (a1 - a0)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            dense[j] + (dense[j + 1] - dense[j]) * t
        } else {
            // The curve ran out (arc shorter than asked): continue straight along the last tangent.
            let last = dense[dense.len() - 1];
            let dir = (last - dense[dense.len() - 2])
                .try_normalize(1e-12)
                .unwrap_or_else(Vector::z);
            last + dir * (target - arc[arc.len() - 1])
        };
        out.push(root + frame * local);
    }
    Ok(out)
}

fn positive(name: &'static str, v: Real) -> Result<(), DynamicsError> {
    finite(name, v)?;
    if v > 0.0 {
        Ok(())
    } else {
        Err(DynamicsError::OutOfRange {
            name,
            value: f64::from(v),
            expected: "> 0",
        })
    }
}
