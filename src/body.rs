//! Bodies the hair grows on and collides with: the procedural head and shoulders, a wrinkled
//! torus (Ward & Lin's brushing scene), or an OBJ file; each with its SSV BVH and, for the
//! procedural head, Kurihara's cylinder and sphere tables.

use crate::HairError;
use crate::scene::BodySpec;
use hair_ssv::{Bvh, Point, Real, Vector};
use std::f32::consts::TAU;
use std::path::Path;

/// Hair within this distance of the body (m) gets an exact query; radii above it are clamped.
pub const NEAR_MARGIN: Real = 0.02;

/// A body mesh in the head frame (m) with its collision structures.
#[derive(Clone, Debug)]
pub struct BodyModel {
    /// Vertices (m, head frame).
    pub vertices: Vec<Point>,
    /// Outward-wound triangles.
    pub triangles: Vec<[u32; 3]>,
    /// The SSV BVH over the triangles.
    pub bvh: Bvh,
    /// Cylinder and sphere tables, where the body has them (the procedural head).
    pub maps: Option<hair_ssv::Body>,
    /// Coarse voxels around the body: which need an exact query at all.
    pub near: NearField,
}

/// A voxel grid over the body's bounds (grown by a margin) marking the cells whose centre lies
/// within half a diagonal plus the margin of the surface, or inside. A point in any other cell is
/// farther than the margin from the body, so the exact query can be skipped.
#[derive(Clone, Debug, Default)]
pub struct NearField {
    min: Point,
    cell: Real,
    dims: [usize; 3],
    near: Vec<bool>,
}

impl NearField {
    /// Builds the field for points up to `margin` away from the surface.
    pub fn build(body: &BodyModel, margin: Real) -> Self {
        use rayon::prelude::*;
        let (mut lo, mut hi) = (
            Point::from(Vector::repeat(Real::MAX)),
            Point::from(Vector::repeat(Real::MIN)),
        );
        for v in &body.vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        let pad = Vector::repeat(2.0 * margin);
        lo -= pad;
        hi += pad;
        let ext = hi - lo;
        // About 40,000 cells whatever the body's size.
        let cell = (ext.x * ext.y * ext.z / 40_000.0).cbrt().max(1e-4);
        let dims = [
            (ext.x / cell).ceil() as usize + 1,
            (ext.y / cell).ceil() as usize + 1,
            (ext.z / cell).ceil() as usize + 1,
        ];
        let reach = 0.5 * cell * 3f32.sqrt() + margin;
        let near = (0..dims[0] * dims[1] * dims[2])
            .into_par_iter()
            .map(|k| {
                let (x, y, z) = (
                    k % dims[0],
                    (k / dims[0]) % dims[1],
                    k / (dims[0] * dims[1]),
                );
                let c = lo + Vector::new(x as Real + 0.5, y as Real + 0.5, z as Real + 0.5) * cell;
                body.signed_distance(&c).is_none_or(|(d, _, _)| d <= reach)
            })
            .collect();
        Self {
            min: lo,
            cell,
            dims,
            near,
        }
    }

    /// Whether `p` may lie within the margin of the body (or inside it).
    #[inline]
    pub fn is_near(&self, p: &Point) -> bool {
        if self.near.is_empty() {
            return true;
        }
        let q = (p - self.min) / self.cell;
        if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0) {
            return false;
        }
        let (x, y, z) = (q.x as usize, q.y as usize, q.z as usize);
        if x >= self.dims[0] || y >= self.dims[1] || z >= self.dims[2] {
            return false;
        }
        self.near[x + self.dims[0] * (y + self.dims[1] * z)]
    }
}

impl BodyModel {
    /// Builds the body a scene asks for; `None` for `BodySpec::None`.
    pub fn from_spec(spec: &BodySpec, base_dir: &Path) -> Result<Option<Self>, HairError> {
        let (vertices, triangles, maps_wanted) = match spec {
            BodySpec::None => return Ok(None),
            BodySpec::Head { resolution } => {
                let (v, t) = hair_ssv::test_meshes::head_and_shoulders(*resolution as usize);
                (v, t, true)
            }
            BodySpec::Torus {
                center,
                major,
                minor,
                wrinkles,
                depth,
            } => {
                let (v, t) = wrinkled_torus(
                    Point::from(*center),
                    *major,
                    *minor,
                    *wrinkles,
                    *depth,
                    96,
                    32,
                );
                (v, t, false)
            }
            BodySpec::Obj {
                path,
                scale,
                offset,
            } => {
                let mesh = hair_io::obj::read(&base_dir.join(path))?;
                let off = Vector::from(*offset);
                let v = mesh
                    .vertices
                    .iter()
                    .map(|p| Point::from(Vector::from(*p) * *scale + off))
                    .collect();
                (v, mesh.triangles, false)
            }
        };
        let bvh = Bvh::new(&vertices, &triangles)?;
        let maps = if maps_wanted {
            Some(hair_ssv::test_meshes::head_and_shoulders_body(&bvh, 64)?)
        } else {
            None
        };
        let mut body = Self {
            vertices,
            triangles,
            bvh,
            maps,
            near: NearField::default(),
        };
        body.near = NearField::build(&body, NEAR_MARGIN);
        Ok(Some(body))
    }

    /// Signed distance of a point to the surface (negative inside) with the outward normal and the
    /// closest surface point, by the exact BVH query.
    pub fn signed_distance(&self, p: &Point) -> Option<(Real, Vector, Point)> {
        let pss = hair_ssv::Ssv::Point(hair_ssv::Pss::new(*p, 0.0));
        let hit = self.bvh.closest(&pss)?;
        let q = hit.closest.on_b;
        let tri = self.bvh.triangle(hit.triangle as usize)?;
        let face = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
        let d = p - q;
        let dist = d.norm();
        // Outside when on the outward side of the closest triangle's face.
        let outside = d.dot(&face) >= 0.0;
        let normal = if dist > 1e-9 {
            if outside { d / dist } else { -d / dist }
        } else {
            face.try_normalize(1e-20).unwrap_or_else(Vector::y)
        };
        Some((if outside { dist } else { -dist }, normal, q))
    }
}

/// A torus in the xz plane with `wrinkles` ridges around the ring, `depth` of the tube radius.
pub fn wrinkled_torus(
    center: Point,
    major: Real,
    minor: Real,
    wrinkles: u32,
    depth: Real,
    around: usize,
    tube: usize,
) -> (Vec<Point>, Vec<[u32; 3]>) {
    let mut v = Vec::with_capacity(around * tube);
    for i in 0..around {
        let u = TAU * i as Real / around as Real;
        let r_tube = minor * (1.0 + depth * (wrinkles as Real * u).sin());
        for j in 0..tube {
            let w = TAU * j as Real / tube as Real;
            let ring = major + r_tube * w.cos();
            v.push(center + Vector::new(ring * u.cos(), r_tube * w.sin(), ring * u.sin()));
        }
    }
    let mut t = Vec::with_capacity(2 * around * tube);
    let idx = |i: usize, j: usize| ((i % around) * tube + (j % tube)) as u32;
    for i in 0..around {
        for j in 0..tube {
            // Wound so the normal points out of the tube.
            t.push([idx(i, j), idx(i, j + 1), idx(i + 1, j)]);
            t.push([idx(i + 1, j), idx(i, j + 1), idx(i + 1, j + 1)]);
        }
    }
    (v, t)
}
