//! Hair geometry: skeleton curves subdivided with Catmull-Rom splines, strand groups expanded to
//! strands at fixed random offsets in their cross-section, and every curve turned into ribbon
//! vertices that the vertex stage widens toward the viewer (GPU and CPU alike).

use crate::RenderError;
use crate::scene::{Point, Real, RenderScene, StrandPoint, Vector, invalid};

/// Ribbon kind: a single fibre, widened to the minimum width with its opacity scaled down.
pub(crate) const KIND_STRAND: f32 = 0.0;
/// Ribbon kind: a cluster tube, seen as a camera-facing ribbon of the tube's diameter.
pub(crate) const KIND_CLUSTER: f32 = 1.0;
/// Ribbon kind: a strip, a flat patch with the generated hair texture across its width.
pub(crate) const KIND_STRIP: f32 = 2.0;

/// Texels across the generated hair texture of strips.
pub const HAIR_TEXTURE_TEXELS: usize = 64;

/// One side of one point of a ribbon: the vertex stage moves it by `side * width` across.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "gpu", derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct RibbonVertex {
    /// Centre-line position.
    pub position: [f32; 3],
    /// -1 or +1: which edge of the ribbon.
    pub side: f32,
    /// Unit tangent toward the tip.
    pub tangent: [f32; 3],
    /// True half-width (fibre or tube radius, strip half-width), metres.
    pub half_width: f32,
    /// Fixed width direction of strips; zero for camera-facing ribbons.
    pub fixed_side: [f32; 3],
    /// Opacity scale of the ribbon in the shadow maps.
    pub opacity: f32,
    /// Colour.
    pub color: [f32; 3],
    /// Wetness in `[0, 1]`.
    pub wetness: f32,
    /// Noise in `[-1, 1]` for the secondary highlight shift.
    pub noise: f32,
    /// Texture coordinate across strips (0 on one edge, 1 on the other).
    pub tex_u: f32,
    /// Ribbon kind (strand, cluster, strip).
    pub kind: f32,
    /// Padding.
    pub pad: f32,
}

/// A body vertex.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "gpu", derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct BodyVertex {
    /// Position.
    pub position: [f32; 3],
    /// Padding.
    pub pad0: f32,
    /// Unit normal.
    pub normal: [f32; 3],
    /// Padding.
    pub pad1: f32,
}

/// A scene turned into vertex and index arrays, shared by the GPU and CPU paths.
#[derive(Clone, Debug, Default)]
pub struct PreparedScene {
    /// Ribbon vertices, two per curve point.
    pub hair_vertices: Vec<RibbonVertex>,
    /// Triangle list over `hair_vertices`, two triangles per segment.
    pub hair_indices: Vec<u32>,
    /// Body vertices.
    pub body_vertices: Vec<BodyVertex>,
    /// Triangle list over `body_vertices`.
    pub body_indices: Vec<u32>,
    /// Number of rendered curve points (after subdivision and group expansion).
    pub curve_points: usize,
    /// Number of rendered curve segments.
    pub segments: usize,
}

/// Catmull-Rom subdivision of a polyline: `subdivisions` segments per input segment, passing
/// through every input point; radius, colour and wetness are interpolated linearly.
pub fn subdivide_catmull_rom(points: &[StrandPoint], subdivisions: u32) -> Vec<StrandPoint> {
    let n = points.len();
    let k = subdivisions.max(1) as usize;
    if n < 2 || k == 1 {
        return points.to_vec();
    }
    let control: Vec<Point> = points.iter().map(|p| p.position).collect();
    let mut out = Vec::with_capacity((n - 1) * k + 1);
    // The curve gives the positions in order: point `j` of segment `i` at `i * k + j`.
    crate::follow::catmull_rom_each(&control, k, |position| {
        let at = out.len();
        let (i, j) = ((at / k).min(n - 1), at % k);
        let (a, b) = (&points[i], &points[(i + 1).min(n - 1)]);
        let t = j as Real / k as Real;
        let lerp = |x: Real, y: Real| x + (y - x) * t;
        out.push(StrandPoint {
            position,
            radius: lerp(a.radius, b.radius),
            color: [
                lerp(a.color[0], b.color[0]),
                lerp(a.color[1], b.color[1]),
                lerp(a.color[2], b.color[2]),
            ],
            wetness: lerp(a.wetness, b.wetness),
        });
    });
    out
}

/// Unit tangents of a polyline by central differences (one-sided at the ends); a zero-length
/// stretch keeps the previous tangent.
pub fn tangents(points: &[StrandPoint]) -> Vec<Vector> {
    let n = points.len();
    let mut out = Vec::with_capacity(n);
    let mut last = -Vector::y();
    for i in 0..n {
        let a = points[i.saturating_sub(1)].position;
        let b = points[(i + 1).min(n - 1)].position;
        let d = b - a;
        let len = d.norm();
        if len > 1e-12 {
            last = d / len;
        }
        out.push(last);
    }
    out
}

/// A vector perpendicular to the unit vector `t`.
pub(crate) fn any_perpendicular(t: &Vector) -> Vector {
    let axis = if t.x.abs() < 0.9 {
        Vector::x()
    } else {
        Vector::y()
    };
    t.cross(&axis).normalize()
}

/// A deterministic hash of two integers to `[0, 1)`.
pub fn hash01(a: u64, b: u64) -> Real {
    let mut x = a
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(b.wrapping_mul(0xC2B2_AE3D_27D4_EB4F))
        .wrapping_add(0x1656_67B1_9E37_79F9);
    x ^= x >> 33;
    x = x.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    x ^= x >> 33;
    x = x.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    x ^= x >> 33;
    (x >> 40) as Real / (1u64 << 24) as Real
}

/// The generated hair texture of strips: coverage across the strip's width, in `[0, 1]`, made of
/// thin fibres at fixed random positions.
pub fn hair_texture() -> [f32; HAIR_TEXTURE_TEXELS] {
    let mut tex = [0.0f32; HAIR_TEXTURE_TEXELS];
    for fibre in 0..28u64 {
        let centre = hash01(fibre, 1) * HAIR_TEXTURE_TEXELS as Real;
        let width = 0.6 + 1.2 * hash01(fibre, 2);
        let strength = 0.55 + 0.45 * hash01(fibre, 3);
        for (i, t) in tex.iter_mut().enumerate() {
            let d = (i as Real + 0.5 - centre) / width;
            *t += strength * (-d * d).exp();
        }
    }
    for t in &mut tex {
        *t = t.min(1.0);
    }
    tex
}

struct Builder<'a> {
    prepared: &'a mut PreparedScene,
    curve_id: u64,
}

impl Builder<'_> {
    /// Appends one curve as a ribbon.
    fn push_curve(
        &mut self,
        points: &[StrandPoint],
        fixed_side: Option<&[Vector]>,
        kind: f32,
        opacity: f32,
    ) {
        let id = self.curve_id;
        self.curve_id += 1;
        if points.len() < 2 {
            return;
        }
        let tan = tangents(points);
        let out = &mut *self.prepared;
        let base = out.hair_vertices.len() as u32;
        for (i, (sp, t)) in points.iter().zip(&tan).enumerate() {
            let noise = hash01(id, i as u64) * 2.0 - 1.0;
            let side_dir = match fixed_side {
                Some(normals) => {
                    let s = t.cross(&normals[i]);
                    let l = s.norm();
                    if l > 1e-9 { s / l } else { Vector::zeros() }
                }
                None => Vector::zeros(),
            };
            for side in [-1.0f32, 1.0] {
                out.hair_vertices.push(RibbonVertex {
                    position: sp.position.coords.into(),
                    side,
                    tangent: (*t).into(),
                    half_width: sp.radius,
                    fixed_side: side_dir.into(),
                    opacity,
                    color: sp.color,
                    wetness: sp.wetness.clamp(0.0, 1.0),
                    noise,
                    tex_u: 0.5 + 0.5 * side,
                    kind,
                    pad: 0.0,
                });
            }
        }
        for s in 0..points.len() as u32 - 1 {
            let a0 = base + 2 * s;
            let (a1, b0, b1) = (a0 + 1, a0 + 2, a0 + 3);
            out.hair_indices
                .extend_from_slice(&[a0, a1, b0, a1, b1, b0]);
        }
        out.curve_points += points.len();
        out.segments += points.len() - 1;
    }
}

/// Parallel-transport frames along a curve with the given unit tangents.
fn transport_frames(tan: &[Vector]) -> Vec<(Vector, Vector)> {
    let mut out = Vec::with_capacity(tan.len());
    let Some(t0) = tan.first() else {
        return out;
    };
    let mut n1 = any_perpendicular(t0);
    for (i, t) in tan.iter().enumerate() {
        if i > 0 {
            // Remove the component along the new tangent and renormalise.
            let v = n1 - t * t.dot(&n1);
            n1 = if v.norm() > 1e-9 {
                v.normalize()
            } else {
                any_perpendicular(t)
            };
        }
        out.push((n1, t.cross(&n1)));
    }
    out
}

/// Validates the scene and turns it into ribbon and body vertices.
pub fn prepare(scene: &RenderScene, subdivisions: u32) -> Result<PreparedScene, RenderError> {
    scene.validate()?;
    let mut prepared = PreparedScene::default();
    let mut b = Builder {
        prepared: &mut prepared,
        curve_id: 0,
    };
    for s in &scene.strands {
        let pts = subdivide_catmull_rom(&s.points, subdivisions);
        b.push_curve(&pts, None, KIND_STRAND, 1.0);
    }
    for (gi, g) in scene.groups.iter().enumerate() {
        let skel = subdivide_catmull_rom(&g.skeleton, subdivisions);
        if skel.len() < 2 {
            continue;
        }
        let frames = transport_frames(&tangents(&skel));
        for s in 0..g.strand_count {
            let u1 = hash01(g.seed ^ (gi as u64).rotate_left(32), 2 * u64::from(s));
            let u2 = hash01(g.seed ^ (gi as u64).rotate_left(32), 2 * u64::from(s) + 1);
            let (r, th) = (u1.sqrt(), std::f32::consts::TAU * u2);
            let (a, c) = (r * th.cos(), r * th.sin());
            let pts: Vec<StrandPoint> = skel
                .iter()
                .zip(&frames)
                .map(|(sp, (n1, n2))| StrandPoint {
                    position: sp.position + (n1 * a + n2 * c) * sp.radius,
                    radius: g.strand_radius,
                    ..*sp
                })
                .collect();
            b.push_curve(&pts, None, KIND_STRAND, 1.0);
        }
    }
    for c in &scene.clusters {
        let pts = subdivide_catmull_rom(&c.skeleton, subdivisions);
        b.push_curve(&pts, None, KIND_CLUSTER, 1.0);
    }
    for (i, s) in scene.strips.iter().enumerate() {
        if s.normals.len() != s.skeleton.len() {
            return Err(invalid(
                format!("strip {i}"),
                "needs one normal per skeleton point",
            ));
        }
        let pts = subdivide_catmull_rom(&s.skeleton, subdivisions);
        // Normals follow the subdivision by nearest control point.
        let k = subdivisions.max(1) as usize;
        let normals: Vec<Vector> = (0..pts.len())
            .map(|j| s.normals[((j + k / 2) / k).min(s.normals.len() - 1)])
            .collect();
        b.push_curve(&pts, Some(&normals), KIND_STRIP, 1.0);
    }
    if let Some(body) = &scene.body {
        prepared.body_vertices = body
            .positions
            .iter()
            .zip(&body.normals)
            .map(|(p, n)| {
                let n = if n.norm() > 0.0 { n.normalize() } else { *n };
                BodyVertex {
                    position: p.coords.into(),
                    pad0: 0.0,
                    normal: n.into(),
                    pad1: 0.0,
                }
            })
            .collect();
        prepared.body_indices = body.triangles.iter().flatten().copied().collect();
    }
    if prepared.hair_vertices.len() > u32::MAX as usize / 2 {
        return Err(invalid(
            "scene",
            "too many hair vertices for 32-bit indices",
        ));
    }
    Ok(prepared)
}
