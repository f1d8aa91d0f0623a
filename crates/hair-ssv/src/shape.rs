//! The swept sphere volumes of Ward & Lin 2003 §5.1: a core (point, segment, rectangle) grown by a
//! radius.

use crate::{Point, Real, SsvError, Vector};

/// Tolerance on the RSS axes' length and orthogonality accepted by [`Rss::try_new`].
pub const AXIS_TOLERANCE: Real = 1e-4;

fn finite_point(p: &Point) -> bool {
    p.x.is_finite() && p.y.is_finite() && p.z.is_finite()
}

fn finite_vector(v: &Vector) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

fn check_radius(shape: &'static str, radius: Real) -> Result<(), SsvError> {
    if !radius.is_finite() {
        return Err(SsvError::NonFinite {
            shape,
            field: "radius",
        });
    }
    if radius < 0.0 {
        return Err(SsvError::NegativeRadius { shape, radius });
    }
    Ok(())
}

/// Point swept sphere: a ball.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pss {
    /// Centre.
    pub center: Point,
    /// Radius (>= 0).
    pub radius: Real,
}

impl Pss {
    /// A PSS from trusted input.
    #[inline]
    pub fn new(center: Point, radius: Real) -> Self {
        Self { center, radius }
    }

    /// A PSS from untrusted input: finite centre, finite radius >= 0.
    pub fn try_new(center: Point, radius: Real) -> Result<Self, SsvError> {
        if !finite_point(&center) {
            return Err(SsvError::NonFinite {
                shape: "Pss",
                field: "center",
            });
        }
        check_radius("Pss", radius)?;
        Ok(Self { center, radius })
    }

    /// Axis-aligned bounds `(min, max)` including the radius.
    #[inline]
    pub fn aabb(&self) -> (Point, Point) {
        let r = Vector::repeat(self.radius);
        (self.center - r, self.center + r)
    }
}

/// Line swept sphere: a capsule around the segment `a`-`b`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lss {
    /// First end of the core segment.
    pub a: Point,
    /// Second end of the core segment.
    pub b: Point,
    /// Radius (>= 0).
    pub radius: Real,
}

impl Lss {
    /// An LSS from trusted input. `a == b` is allowed (a ball).
    #[inline]
    pub fn new(a: Point, b: Point, radius: Real) -> Self {
        Self { a, b, radius }
    }

    /// An LSS from untrusted input: finite ends, finite radius >= 0.
    pub fn try_new(a: Point, b: Point, radius: Real) -> Result<Self, SsvError> {
        if !finite_point(&a) {
            return Err(SsvError::NonFinite {
                shape: "Lss",
                field: "a",
            });
        }
        if !finite_point(&b) {
            return Err(SsvError::NonFinite {
                shape: "Lss",
                field: "b",
            });
        }
        check_radius("Lss", radius)?;
        Ok(Self { a, b, radius })
    }

    /// Axis-aligned bounds `(min, max)` including the radius.
    #[inline]
    pub fn aabb(&self) -> (Point, Point) {
        let r = Vector::repeat(self.radius);
        (self.a.inf(&self.b) - r, self.a.sup(&self.b) + r)
    }
}

/// Rectangle swept sphere: the rectangle `origin + s*axes[0] + t*axes[1]`, `s` in
/// `[0, extents[0]]`, `t` in `[0, extents[1]]`, grown by `radius`. `origin` is a corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rss {
    /// A corner of the rectangle.
    pub origin: Point,
    /// Two orthonormal edge directions.
    pub axes: [Vector; 2],
    /// Edge lengths along `axes[0]` and `axes[1]` (>= 0; zero gives a segment or a point).
    pub extents: [Real; 2],
    /// Radius (>= 0).
    pub radius: Real,
}

impl Rss {
    /// An RSS from trusted input (the axes must be orthonormal).
    #[inline]
    pub fn new(origin: Point, axes: [Vector; 2], extents: [Real; 2], radius: Real) -> Self {
        Self {
            origin,
            axes,
            extents,
            radius,
        }
    }

    /// An RSS from untrusted input: finite fields, orthonormal axes (within
    /// [`AXIS_TOLERANCE`]), extents and radius >= 0.
    pub fn try_new(
        origin: Point,
        axes: [Vector; 2],
        extents: [Real; 2],
        radius: Real,
    ) -> Result<Self, SsvError> {
        if !finite_point(&origin) {
            return Err(SsvError::NonFinite {
                shape: "Rss",
                field: "origin",
            });
        }
        if !finite_vector(&axes[0]) || !finite_vector(&axes[1]) {
            return Err(SsvError::NonFinite {
                shape: "Rss",
                field: "axes",
            });
        }
        for (index, &value) in extents.iter().enumerate() {
            if !value.is_finite() {
                return Err(SsvError::NonFinite {
                    shape: "Rss",
                    field: "extents",
                });
            }
            if value < 0.0 {
                return Err(SsvError::NegativeExtent { index, value });
            }
        }
        check_radius("Rss", radius)?;
        let len0 = axes[0].norm();
        let len1 = axes[1].norm();
        let dot = axes[0].dot(&axes[1]);
        if (len0 - 1.0).abs() > AXIS_TOLERANCE
            || (len1 - 1.0).abs() > AXIS_TOLERANCE
            || dot.abs() > AXIS_TOLERANCE
        {
            return Err(SsvError::AxesNotOrthonormal { len0, len1, dot });
        }
        Ok(Self {
            origin,
            axes,
            extents,
            radius,
        })
    }

    /// Unit normal of the rectangle's plane, `axes[0] x axes[1]`.
    #[inline]
    pub fn normal(&self) -> Vector {
        self.axes[0].cross(&self.axes[1])
    }

    /// The four corners, in order around the rectangle starting at `origin`.
    #[inline]
    pub fn corners(&self) -> [Point; 4] {
        let e0 = self.axes[0] * self.extents[0];
        let e1 = self.axes[1] * self.extents[1];
        [
            self.origin,
            self.origin + e0,
            self.origin + e0 + e1,
            self.origin + e1,
        ]
    }

    /// Centre of the rectangle.
    #[inline]
    pub fn center(&self) -> Point {
        self.origin
            + self.axes[0] * (0.5 * self.extents[0])
            + self.axes[1] * (0.5 * self.extents[1])
    }

    /// Axis-aligned bounds `(min, max)` including the radius.
    #[inline]
    pub fn aabb(&self) -> (Point, Point) {
        let e0 = self.axes[0] * self.extents[0];
        let e1 = self.axes[1] * self.extents[1];
        let half = (e0.abs() + e1.abs()) * 0.5;
        let c = self.origin + (e0 + e1) * 0.5;
        let r = Vector::repeat(self.radius);
        (c - half - r, c + half + r)
    }
}

/// Any of the three swept sphere volumes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ssv {
    /// A point swept sphere.
    Point(Pss),
    /// A line swept sphere.
    Line(Lss),
    /// A rectangle swept sphere.
    Rect(Rss),
}

impl Ssv {
    /// Radius of the volume.
    #[inline]
    pub fn radius(&self) -> Real {
        match self {
            Ssv::Point(p) => p.radius,
            Ssv::Line(l) => l.radius,
            Ssv::Rect(r) => r.radius,
        }
    }

    /// Axis-aligned bounds `(min, max)` including the radius.
    #[inline]
    pub fn aabb(&self) -> (Point, Point) {
        match self {
            Ssv::Point(p) => p.aabb(),
            Ssv::Line(l) => l.aabb(),
            Ssv::Rect(r) => r.aabb(),
        }
    }

    /// A representative interior point of the core (centre, segment midpoint, rectangle centre).
    #[inline]
    pub fn center(&self) -> Point {
        match self {
            Ssv::Point(p) => p.center,
            Ssv::Line(l) => nalgebra::center(&l.a, &l.b),
            Ssv::Rect(r) => r.center(),
        }
    }
}

impl From<Pss> for Ssv {
    fn from(v: Pss) -> Self {
        Ssv::Point(v)
    }
}

impl From<Lss> for Ssv {
    fn from(v: Lss) -> Self {
        Ssv::Line(v)
    }
}

impl From<Rss> for Ssv {
    fn from(v: Rss) -> Self {
        Ssv::Rect(v)
    }
}
