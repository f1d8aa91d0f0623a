//! Closest points between a point and a triangle.

use super::{Closest, point_segment};
use crate::Point;

/// Closest points between the point `p` and the triangle `tri`.
///
/// The point projects onto the plane when it lies over the triangle (signs of three edge
/// cross products, which stay well conditioned for slivers and at large coordinates); otherwise
/// the closest point is on an edge. A degenerate triangle (collinear or repeated vertices) is
/// handled as its edges.
#[inline]
pub fn point_triangle(p: &Point, tri: &[Point; 3]) -> Closest {
    let [a, b, c] = tri;
    let ab = b - a;
    let ac = c - a;
    let n = ab.cross(&ac);
    let nn = n.norm_squared();
    let ap = p - a;
    if nn > 0.0 {
        let bp = p - b;
        let cp = p - c;
        let over = ab.cross(&ap).dot(&n) >= 0.0
            && (c - b).cross(&bp).dot(&n) >= 0.0
            && (a - c).cross(&cp).dot(&n) >= 0.0;
        if over {
            let q = p - n * (n.dot(&ap) / nn);
            if q.coords.iter().all(|x| x.is_finite()) {
                return Closest::from_points(*p, q);
            }
        }
    }
    point_segment(p, a, b)
        .min(point_segment(p, b, c))
        .min(point_segment(p, c, a))
}
