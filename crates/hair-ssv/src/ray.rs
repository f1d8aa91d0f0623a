//! Ray casts against a [`Bvh`]: slab tests on the nodes' boxes, Moller-Trumbore on the
//! triangles. Used to sample the collision tables of Kurihara et al. 1993 §3.1.

use crate::{Bvh, Point, Real, Vector};

/// The first triangle a ray hits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayHit {
    /// Ray parameter of the hit: the point is `origin + t * dir`.
    pub t: Real,
    /// Index of the triangle in the input mesh.
    pub triangle: u32,
    /// Unit face normal of the triangle (counter-clockwise winding).
    pub normal: Vector,
}

#[inline]
fn ray_box(origin: &Point, inv: &Vector, lo: &Point, hi: &Point, max_t: Real) -> bool {
    let mut t0: Real = 0.0;
    let mut t1 = max_t;
    for k in 0..3 {
        let a = (lo[k] - origin[k]) * inv[k];
        let b = (hi[k] - origin[k]) * inv[k];
        // NaN (0 * inf) means the ray lies in the slab's boundary plane: keep the interval
        let (near, far) = if a <= b { (a, b) } else { (b, a) };
        if near > t0 {
            t0 = near;
        }
        if far < t1 {
            t1 = far;
        }
    }
    t0 <= t1
}

#[inline]
fn ray_triangle(origin: &Point, dir: &Vector, tri: &[Point; 3]) -> Option<Real> {
    let e1 = tri[1] - tri[0];
    let e2 = tri[2] - tri[0];
    let p = dir.cross(&e2);
    let det = e1.dot(&p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = origin - tri[0];
    // a little slack on the barycentric tests so that a ray through a shared edge or vertex
    // cannot slip between the triangles by rounding
    const SLACK: Real = 1e-5;
    let u = s.dot(&p) * inv;
    if !(-SLACK..=1.0 + SLACK).contains(&u) {
        return None;
    }
    let q = s.cross(&e1);
    let v = dir.dot(&q) * inv;
    if v < -SLACK || u + v > 1.0 + SLACK {
        return None;
    }
    let t = e2.dot(&q) * inv;
    (t >= 0.0).then_some(t)
}

impl Bvh {
    /// The first triangle hit by the ray `origin + t * dir`, `0 <= t <= max_t` (`dir` need not be
    /// unit; `t` is in units of `dir`). Ties go to the lower triangle index. A ray lying in a
    /// triangle's plane does not hit it.
    pub fn cast_ray(&self, origin: &Point, dir: &Vector, max_t: Real) -> Option<RayHit> {
        let inv = Vector::new(1.0 / dir.x, 1.0 / dir.y, 1.0 / dir.z);
        let mut best: Option<(Real, u32, usize)> = None;
        let mut limit = max_t;
        let mut stack = Vec::with_capacity(64);
        stack.push(0u32);
        while let Some(index) = stack.pop() {
            let node = &self.nodes[index as usize];
            if !ray_box(origin, &inv, &node.lo, &node.hi, limit) {
                continue;
            }
            if node.count > 0 {
                let start = node.first as usize;
                for k in start..start + node.count as usize {
                    if let Some(t) = ray_triangle(origin, dir, &self.tris[k])
                        && t <= limit
                    {
                        let id = self.tri_ids[k];
                        let better = match best {
                            None => true,
                            Some((bt, bid, _)) => t < bt || (t == bt && id < bid),
                        };
                        if better {
                            best = Some((t, id, k));
                            limit = t;
                        }
                    }
                }
            } else {
                stack.push(node.first);
                stack.push(index + 1);
            }
        }
        best.map(|(t, triangle, k)| {
            let tri = &self.tris[k];
            let n = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
            RayHit {
                t,
                triangle,
                normal: n.try_normalize(0.0).unwrap_or_else(Vector::z),
            }
        })
    }
}
