//! Closest points between a rectangle and a triangle: piercing edges, vertices against the other
//! polygon, and edge pairs.

use super::segment_rectangle::pierce_rectangle;
use super::segment_triangle::pierce_triangle;
use super::{Closest, point_rectangle, point_triangle, segment_segment};
use crate::{Point, Rss};

/// Closest points between the core rectangle of `rect` and the triangle `tri`.
#[inline]
pub fn rectangle_triangle(rect: &Rss, tri: &[Point; 3]) -> Closest {
    let c = rect.corners();
    for i in 0..4 {
        if let Some(x) = pierce_triangle(&c[i], &c[(i + 1) & 3], tri) {
            return Closest {
                on_a: x,
                on_b: x,
                dist_sq: 0.0,
            };
        }
    }
    for i in 0..3 {
        if let Some(x) = pierce_rectangle(&tri[i], &tri[(i + 1) % 3], rect) {
            return Closest {
                on_a: x,
                on_b: x,
                dist_sq: 0.0,
            };
        }
    }
    let mut best = point_triangle(&c[0], tri);
    for p in &c[1..] {
        best = best.min(point_triangle(p, tri));
    }
    for p in tri {
        best = best.min(point_rectangle(p, rect).swapped());
    }
    for i in 0..4 {
        for j in 0..3 {
            best = best.min(segment_segment(
                &c[i],
                &c[(i + 1) & 3],
                &tri[j],
                &tri[(j + 1) % 3],
            ));
        }
    }
    best
}
