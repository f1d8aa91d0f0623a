//! Contacts between overlapping swept sphere volumes, and between a volume and a triangle.

use crate::query::Closest;
use crate::{Point, Real, Ssv, Vector};

/// A contact between two volumes `a` and `b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Penetration depth: sum of the radii minus the core distance (positive when overlapping;
    /// negative for a near miss reported within a margin).
    pub depth: Real,
    /// Unit normal pointing from `a` towards `b`: moving `b` by `depth * normal` separates them.
    pub normal: Vector,
    /// The point of `a`'s surface deepest in the direction of `b` (`core_a + radius_a * normal`).
    pub point_a: Point,
    /// The point of `b`'s surface deepest in the direction of `a` (`core_b - radius_b * normal`).
    pub point_b: Point,
}

impl Contact {
    /// Signed distance of the contact (`-depth`).
    #[inline]
    pub fn distance(&self) -> Real {
        -self.depth
    }

    /// Builds the contact from core closest points, radii and a normal to use when the cores
    /// touch.
    #[inline]
    pub(crate) fn from_closest(
        c: &Closest,
        ra: Real,
        rb: Real,
        fallback: impl FnOnce() -> Vector,
    ) -> Self {
        let dist = c.dist_sq.sqrt();
        let d = c.on_b - c.on_a;
        // Cores closer than rounding (a ten-thousandth of the radii) touch: the direction
        // between their closest points is noise there, and moving along it may not separate them.
        let normal = if dist > 1e-4 * (ra + rb) {
            let n = d / dist;
            if n.x.is_finite() && n.y.is_finite() && n.z.is_finite() {
                n
            } else {
                fallback()
            }
        } else {
            fallback()
        };
        Contact {
            depth: ra + rb - dist,
            normal,
            point_a: c.on_a + normal * ra,
            point_b: c.on_b - normal * rb,
        }
    }
}

/// A unit vector perpendicular to `v`: `v` crossed with the coordinate axis it is least aligned
/// with, normalised; `+z` when `v` is zero or NaN.
///
/// ```
/// use hair_ssv::{Vector, any_perpendicular};
/// let v = Vector::new(0.3, -2.0, 0.5);
/// let p = any_perpendicular(&v);
/// assert!(p.dot(&v).abs() < 1e-6 && (p.norm() - 1.0).abs() < 1e-6);
/// assert_eq!(any_perpendicular(&Vector::zeros()), Vector::z());
/// ```
#[inline]
pub fn any_perpendicular(v: &Vector) -> Vector {
    let candidate = if v.x.abs() <= v.y.abs() && v.x.abs() <= v.z.abs() {
        Vector::x()
    } else if v.y.abs() <= v.z.abs() {
        Vector::y()
    } else {
        Vector::z()
    };
    let p = v.cross(&candidate);
    let n = p.norm();
    if n > 0.0 { p / n } else { Vector::z() }
}

/// Normalises `v`, or returns `None` when it is zero or not finite.
#[inline]
pub(crate) fn try_unit(v: &Vector) -> Option<Vector> {
    let n = v.norm();
    let u = v / n;
    (n > 0.0 && u.x.is_finite() && u.y.is_finite() && u.z.is_finite()).then_some(u)
}

/// Orients `n` so that it points from `from` towards `to` (keeps it on ties).
#[inline]
fn orient(n: Vector, from: &Point, to: &Point) -> Vector {
    if (to - from).dot(&n) < 0.0 { -n } else { n }
}

impl Ssv {
    /// The direction of a feature of the core: segment direction or rectangle normal.
    fn core_direction(&self) -> Option<Vector> {
        match self {
            Ssv::Point(_) => None,
            Ssv::Line(l) => try_unit(&(l.b - l.a)),
            Ssv::Rect(r) => Some(r.normal()),
        }
    }

    /// Normal used when the two cores intersect, so the closest points do not define one:
    /// a rectangle's normal, else the common perpendicular of two segments, else a perpendicular
    /// of the one segment, else `+z`; oriented from `self`'s centre towards `other`'s.
    fn touching_normal(&self, other: &Ssv) -> Vector {
        let (ca, cb) = (self.center(), other.center());
        let n = match (self, other) {
            (Ssv::Rect(r), _) => r.normal(),
            (_, Ssv::Rect(r)) => r.normal(),
            _ => match (self.core_direction(), other.core_direction()) {
                (Some(u), Some(v)) => {
                    try_unit(&u.cross(&v)).unwrap_or_else(|| any_perpendicular(&u))
                }
                (Some(u), None) | (None, Some(u)) => try_unit(&(cb - ca))
                    .filter(|d| d.dot(&u).abs() < 0.999)
                    .map(|d| {
                        try_unit(&(d - u * d.dot(&u))).unwrap_or_else(|| any_perpendicular(&u))
                    })
                    .unwrap_or_else(|| any_perpendicular(&u)),
                (None, None) => try_unit(&(cb - ca)).unwrap_or_else(Vector::z),
            },
        };
        orient(n, &ca, &cb)
    }

    /// The contact with `other` when they overlap or touch (signed distance <= 0).
    #[inline]
    pub fn contact(&self, other: &Ssv) -> Option<Contact> {
        self.contact_within(other, 0.0)
    }

    /// The contact with `other` when their signed distance is at most `margin`.
    #[inline]
    pub fn contact_within(&self, other: &Ssv, margin: Real) -> Option<Contact> {
        let c = self.closest_points(other);
        let reach = self.radius() + other.radius() + margin;
        if reach < 0.0 || c.dist_sq > reach * reach {
            return None;
        }
        Some(Contact::from_closest(
            &c,
            self.radius(),
            other.radius(),
            || self.touching_normal(other),
        ))
    }

    /// The contact with a triangle (as `b`, radius zero) when the signed distance is at most
    /// `margin`. The normal points from the volume towards the triangle; when the core touches
    /// the triangle it is the reverse of the triangle's face normal (counter-clockwise winding),
    /// so `-normal` pushes the volume out along the face.
    #[inline]
    pub fn contact_with_triangle(&self, tri: &[Point; 3], margin: Real) -> Option<Contact> {
        let c = self.closest_to_triangle(tri);
        let reach = self.radius() + margin;
        if reach < 0.0 || c.dist_sq > reach * reach {
            return None;
        }
        Some(self.contact_from_triangle_closest(&c, tri))
    }

    /// The contact with a triangle from already computed closest points.
    #[inline]
    pub(crate) fn contact_from_triangle_closest(&self, c: &Closest, tri: &[Point; 3]) -> Contact {
        Contact::from_closest(c, self.radius(), 0.0, || triangle_fallback(tri))
    }
}

fn triangle_fallback(tri: &[Point; 3]) -> Vector {
    let n = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
    try_unit(&-n).unwrap_or_else(|| any_perpendicular(&(tri[1] - tri[0])))
}
