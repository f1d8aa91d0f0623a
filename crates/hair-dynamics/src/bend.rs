//! The bend parameterisation: a rotation vector `(x, y, 0)` in the parent segment's frame.
//!
//! Kurihara et al. (§2) and Ward & Lin (§3) describe a segment by a zenith angle and an azimuth
//! relative to its parent. The azimuth is undefined when the segment is straight, which is exactly
//! the rest pose of straight hair. We instead rotate the parent frame by the rotation vector
//! `w = (x, y, 0)`: a bend about the parent's two normal axes, with no twist component. It is
//! smooth everywhere below a fold-back of 180 degrees, exact for large bends, and propagating frames
//! this way is parallel transport along the polyline (see `docs/dynamics.md`).

use nalgebra::{Matrix3, RealField, Vector3};

/// Rotation, and the two columns of the left Jacobian, of the bend `(x, y)`.
///
/// The columns map `(dx/dt, dy/dt)` to the angular velocity of the child frame relative to the
/// parent frame, expressed in the parent frame.
#[derive(Clone, Copy, Debug)]
pub struct Bend<T: RealField + Copy> {
    /// Child frame in the parent frame.
    pub rotation: Matrix3<T>,
    /// Angular-velocity axis of the `x` coordinate, in the parent frame.
    pub axis_x: Vector3<T>,
    /// Angular-velocity axis of the `y` coordinate, in the parent frame.
    pub axis_y: Vector3<T>,
}

impl<T: RealField + Copy> Bend<T> {
    /// Evaluates the bend `(x, y)`.
    #[inline]
    pub fn new(x: T, y: T) -> Self {
        let a2 = x * x + y * y;
        // s = sin a / a, c = (1 - cos a) / a^2, e = (a - sin a) / a^3, with series near zero where
        // the closed forms cancel catastrophically.
        let (s, c, e) = if a2 < T::from_f64(1e-4).unwrap_or_else(T::zero) {
            let one = T::one();
            let s = one - a2 / T::from_f64(6.0).unwrap_or(one)
                + a2 * a2 / T::from_f64(120.0).unwrap_or(one);
            let c = T::from_f64(0.5).unwrap_or(one) - a2 / T::from_f64(24.0).unwrap_or(one)
                + a2 * a2 / T::from_f64(720.0).unwrap_or(one);
            let e = one / T::from_f64(6.0).unwrap_or(one) - a2 / T::from_f64(120.0).unwrap_or(one);
            (s, c, e)
        } else {
            let a = a2.sqrt();
            let (sin, cos) = a.sin_cos();
            (sin / a, (T::one() - cos) / a2, (a - sin) / (a2 * a))
        };
        let one = T::one();
        let cxy = c * x * y;
        let rotation = Matrix3::new(
            one - c * y * y,
            cxy,
            s * y,
            cxy,
            one - c * x * x,
            -s * x,
            -s * y,
            s * x,
            one - c * a2,
        );
        let exy = e * x * y;
        let axis_x = Vector3::new(one - e * y * y, exy, -c * y);
        let axis_y = Vector3::new(exy, one - e * x * x, c * x);
        Self {
            rotation,
            axis_x,
            axis_y,
        }
    }
}

/// The bend `(x, y)` that turns the unit tangent `parent` into the unit tangent `child`, both
/// given in the parent frame's coordinates where the parent tangent is `+z`.
///
/// `child` is expressed in the parent frame. A child pointing straight back (a fold of 180
/// degrees) has no unique bend; the bend about the parent's x axis is returned.
#[inline]
pub fn bend_between<T: RealField + Copy>(child: &Vector3<T>) -> (T, T) {
    // The rotation from +z to `child` about the axis z x child = (-cy, cx, 0).
    let sin_a = (child.x * child.x + child.y * child.y).sqrt();
    let cos_a = child.z;
    let angle = sin_a.atan2(cos_a);
    if sin_a <= T::default_epsilon() {
        if cos_a >= T::zero() {
            return (T::zero(), T::zero());
        }
        return (T::pi(), T::zero());
    }
    let f = angle / sin_a;
    (-child.y * f, child.x * f)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bend_rotation_is_orthonormal_and_matches_inverse() {
        for &(x, y) in &[
            (0.0, 0.0),
            (1e-4, -2e-4),
            (0.3, 0.1),
            (-1.2, 0.7),
            (2.5, -0.4),
        ] {
            let b = Bend::<f64>::new(x, y);
            let r = b.rotation;
            assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
            assert!((r.determinant() - 1.0).abs() < 1e-12);
            let t = r.column(2).into_owned();
            let (bx, by) = bend_between(&t);
            assert!(
                (bx - x).abs() < 1e-9 && (by - y).abs() < 1e-9,
                "{x} {y} -> {bx} {by}"
            );
        }
    }

    #[test]
    fn jacobian_columns_match_finite_differences() {
        let (x, y) = (0.7_f64, -0.4_f64);
        let b = Bend::new(x, y);
        let h = 1e-6;
        for (k, axis) in [(0, b.axis_x), (1, b.axis_y)] {
            let (dx, dy) = if k == 0 { (h, 0.0) } else { (0.0, h) };
            let rp = Bend::new(x + dx, y + dy).rotation;
            let rm = Bend::new(x - dx, y - dy).rotation;
            // dR/dq R^T = [omega]x
            let w = (rp - rm) / (2.0 * h) * b.rotation.transpose();
            let omega = Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
            assert!((omega - axis).norm() < 1e-6, "{omega} vs {axis}");
        }
    }
}
