//! Closest points between a point and a triangle, by the Voronoi regions of its vertices and
//! edges; the face region projects onto the plane directly, which stays accurate for slivers.

use super::{Closest, point_segment};
use crate::{Point, Real};

#[inline(always)]
fn ratio(num: Real, den: Real) -> Real {
    if den > 0.0 {
        (num / den).max(0.0).min(1.0)
    } else {
        0.0
    }
}

/// Closest points between the point `p` and the triangle `tri`.
///
/// A degenerate triangle (collinear or repeated vertices) is treated as its longest edge.
#[inline]
pub fn point_triangle(p: &Point, tri: &[Point; 3]) -> Closest {
    let [a, b, c] = tri;
    let ab = b - a;
    let ac = c - a;
    let n = ab.cross(&ac);
    let nn = n.norm_squared();
    if nn <= 0.0 {
        return point_segment(p, a, b)
            .min(point_segment(p, b, c))
            .min(point_segment(p, c, a));
    }
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return Closest::from_points(*p, *a);
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return Closest::from_points(*p, *b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return Closest::from_points(*p, a + ab * ratio(d1, d1 - d3));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return Closest::from_points(*p, *c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return Closest::from_points(*p, a + ac * ratio(d2, d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return Closest::from_points(*p, b + (c - b) * ratio(d4 - d3, (d4 - d3) + (d5 - d6)));
    }
    Closest::from_points(*p, p - n * (n.dot(&ap) / nn))
}
