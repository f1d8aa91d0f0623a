//! Strands that follow skeletons: parallel-transport frames along a polyline (each the minimal
//! rotation from the one before), and Catmull-Rom curves through control points. A simulator
//! places each rendered strand at fixed offsets in its skeleton's frames and draws the curve
//! through them (Ward & Lin §3: skeletons are the base curves, strands are built around them).

use crate::{Point, Real};
use nalgebra::Matrix3;

/// Rendered strands around skeletons, with their output polylines (world frame).
#[derive(Clone, Debug, Default)]
pub struct RenderGeometry {
    /// Subdivisions per skeleton segment (1 = the control points themselves).
    pub subdivisions: usize,
    /// Output: strand `s` occupies `positions[offsets[s]..offsets[s + 1]]`.
    pub offsets: Vec<u32>,
    /// Output positions (m, world).
    pub positions: Vec<Point>,
}

impl RenderGeometry {
    /// Lays out `strands` strands of `verts` vertices each: the offsets rewritten, the
    /// positions grown or shrunk to fit (their buffers reused).
    pub(crate) fn lay_out(&mut self, strands: usize, verts: usize) {
        self.offsets.clear();
        self.offsets
            .extend((0..=strands as u32).map(|s| s * verts as u32));
        self.positions.resize(strands * verts, Point::origin());
    }

    /// Number of output vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of rendered strands.
    pub fn strand_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The output polyline of strand `s`.
    pub fn strand(&self, s: usize) -> &[Point] {
        &self.positions[self.offsets[s] as usize..self.offsets[s + 1] as usize]
    }
}

/// Parallel-transport frames along a polyline, starting from `first`.
pub fn transport_frames(points: &[Point], first: &Matrix3<Real>, out: &mut Vec<Matrix3<Real>>) {
    out.clear();
    out.resize(points.len(), Matrix3::identity());
    transport_frames_into(points, first, out);
}

/// [`transport_frames`] into a slice: frame `k` of the polyline into `out[k]`, for as many
/// points as `out` holds.
pub fn transport_frames_into(points: &[Point], first: &Matrix3<Real>, out: &mut [Matrix3<Real>]) {
    let mut frame = *first;
    for (k, o) in out.iter_mut().enumerate().take(points.len()) {
        if k > 0 {
            // The same minimal rotation between tangents as the strand kinematics uses.
            if let Some(t) = (points[k] - points[k - 1]).try_normalize(1e-12) {
                frame *= minimal_rotation(&(frame.transpose() * t));
            }
        }
        *o = frame;
    }
}

/// The rotation that turns `+z` into the direction of `t` about `z x t` (the minimal rotation
/// between tangents of angular strand kinematics), written without its angle. With `k = 1 / (1 + t_z)` for the unit `t`, Rodrigues' formula
/// gives `[[1 - k tx^2, -k tx ty, tx], [-k tx ty, 1 - k ty^2, ty], [-tx, -ty, tz]]`: no arctangent
/// and no sine or cosine, which were most of the cost of the render frames. For `t_z < 0`, `k` is
/// taken as `(1 - t_z) / (tx^2 + ty^2)`, the same for a unit vector but without the cancellation
/// in `1 + t_z`; a fold straight back takes the bend's own form. `t` is normalised first: a
/// tangent seen from a frame that has drifted from orthonormal is not quite unit, and near a
/// fold the two forms of `k` then disagree (the bend, from an angle and an axis, never sees the
/// length), so frames would compound the error down a long strand.
#[inline]
pub fn minimal_rotation(t: &nalgebra::Vector3<Real>) -> Matrix3<Real> {
    let t = t / t.norm();
    let side = t.x * t.x + t.y * t.y;
    let k = if t.z >= 0.0 {
        1.0 / (1.0 + t.z)
    } else if side > 1e-12 {
        (1.0 - t.z) / side
    } else {
        // Folded straight back: a half turn about x.
        return Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
    };
    let kxy = -k * t.x * t.y;
    Matrix3::new(
        1.0 - k * t.x * t.x,
        kxy,
        t.x,
        kxy,
        1.0 - k * t.y * t.y,
        t.y,
        -t.x,
        -t.y,
        t.z,
    )
}

/// Catmull-Rom through `control` with `sub` points per segment, into `out` (appended).
pub fn catmull_rom(control: &[Point], sub: usize, out: &mut Vec<Point>) {
    catmull_rom_each(control, sub, |p| out.push(p));
}

/// [`catmull_rom`] into a slice, from its start; points past its end are dropped.
pub fn catmull_rom_into(control: &[Point], sub: usize, out: &mut [Point]) {
    let mut slots = out.iter_mut();
    catmull_rom_each(control, sub, |p| {
        if let Some(o) = slots.next() {
            *o = p;
        }
    });
}

/// The points of the Catmull-Rom curve through `control`, `sub` per segment, in order.
pub fn catmull_rom_each(control: &[Point], sub: usize, mut emit: impl FnMut(Point)) {
    let n = control.len();
    if n < 2 || sub <= 1 {
        control.iter().for_each(|&p| emit(p));
        return;
    }
    for i in 0..n - 1 {
        let p0 = if i == 0 {
            control[0] + (control[0] - control[1])
        } else {
            control[i - 1]
        };
        let p1 = control[i];
        let p2 = control[i + 1];
        let p3 = if i + 2 < n {
            control[i + 2]
        } else {
            p2 + (p2 - p1)
        };
        for k in 0..sub {
            let t = k as Real / sub as Real;
            let t2 = t * t;
            let t3 = t2 * t;
            let c = p1.coords * 2.0
                + (p2.coords - p0.coords) * t
                + (p0.coords * 2.0 - p1.coords * 5.0 + p2.coords * 4.0 - p3.coords) * t2
                + (p1.coords * 3.0 - p0.coords - p2.coords * 3.0 + p3.coords) * t3;
            emit(Point::from(c * 0.5));
        }
    }
    emit(control[n - 1]);
}
