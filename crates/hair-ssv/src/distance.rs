//! Signed distances between swept sphere volumes (Ward & Lin 2003 §5.1, §5.3): the distance
//! between the cores minus both radii.

use crate::query::{
    Closest, point_rectangle, point_segment, point_triangle, rectangle_rectangle,
    rectangle_triangle, segment_rectangle, segment_segment, segment_segment_dist_sq,
    segment_triangle,
};
use crate::{Lss, Point, Pss, Real, Rss, Ssv};

/// Signed distance between two PSS (negative when they overlap).
#[inline]
pub fn distance_pss_pss(a: &Pss, b: &Pss) -> Real {
    (b.center - a.center).norm() - a.radius - b.radius
}

/// Signed distance between a PSS and an LSS.
#[inline]
pub fn distance_pss_lss(a: &Pss, b: &Lss) -> Real {
    point_segment(&a.center, &b.a, &b.b).distance() - a.radius - b.radius
}

/// Signed distance between a PSS and an RSS.
#[inline]
pub fn distance_pss_rss(a: &Pss, b: &Rss) -> Real {
    point_rectangle(&a.center, b).distance() - a.radius - b.radius
}

/// Signed distance between two LSS.
#[inline]
pub fn distance_lss_lss(a: &Lss, b: &Lss) -> Real {
    segment_segment_dist_sq(&a.a, &a.b, &b.a, &b.b).sqrt() - a.radius - b.radius
}

/// Signed distance between an LSS and an RSS.
#[inline]
pub fn distance_lss_rss(a: &Lss, b: &Rss) -> Real {
    segment_rectangle(&a.a, &a.b, b).distance() - a.radius - b.radius
}

/// Signed distance between two RSS.
#[inline]
pub fn distance_rss_rss(a: &Rss, b: &Rss) -> Real {
    rectangle_rectangle(a, b).distance() - a.radius - b.radius
}

impl Ssv {
    /// Closest points between the cores of `self` (`on_a`) and `other` (`on_b`).
    #[inline]
    pub fn closest_points(&self, other: &Ssv) -> Closest {
        match (self, other) {
            (Ssv::Point(a), Ssv::Point(b)) => Closest::from_points(a.center, b.center),
            (Ssv::Point(a), Ssv::Line(b)) => point_segment(&a.center, &b.a, &b.b),
            (Ssv::Point(a), Ssv::Rect(b)) => point_rectangle(&a.center, b),
            (Ssv::Line(a), Ssv::Point(b)) => point_segment(&b.center, &a.a, &a.b).swapped(),
            (Ssv::Line(a), Ssv::Line(b)) => segment_segment(&a.a, &a.b, &b.a, &b.b),
            (Ssv::Line(a), Ssv::Rect(b)) => segment_rectangle(&a.a, &a.b, b),
            (Ssv::Rect(a), Ssv::Point(b)) => point_rectangle(&b.center, a).swapped(),
            (Ssv::Rect(a), Ssv::Line(b)) => segment_rectangle(&b.a, &b.b, a).swapped(),
            (Ssv::Rect(a), Ssv::Rect(b)) => rectangle_rectangle(a, b),
        }
    }

    /// Signed distance to `other`: core distance minus both radii, negative when overlapping.
    #[inline]
    pub fn distance(&self, other: &Ssv) -> Real {
        self.closest_points(other).distance() - self.radius() - other.radius()
    }

    /// Closest points between the core of `self` (`on_a`) and the triangle (`on_b`).
    #[inline]
    pub fn closest_to_triangle(&self, tri: &[Point; 3]) -> Closest {
        match self {
            Ssv::Point(a) => point_triangle(&a.center, tri),
            Ssv::Line(a) => segment_triangle(&a.a, &a.b, tri),
            Ssv::Rect(a) => rectangle_triangle(a, tri),
        }
    }

    /// Signed distance to a triangle: core distance minus the radius.
    #[inline]
    pub fn distance_to_triangle(&self, tri: &[Point; 3]) -> Real {
        self.closest_to_triangle(tri).distance() - self.radius()
    }
}
