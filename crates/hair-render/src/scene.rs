//! Plain-data input: camera, light, body mesh and hair in its three representations.

use crate::RenderError;
use crate::osm::ShadowSettings;
use crate::shading::ShadingParams;

/// Scalar of the renderer.
pub type Real = f32;
/// A vector in world space (metres).
pub type Vector = nalgebra::Vector3<Real>;
/// A point in world space (metres).
pub type Point = nalgebra::Point3<Real>;
/// A linear RGB colour, each channel in `[0, 1]`.
pub type Rgb = [Real; 3];

/// A perspective pinhole camera.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Position of the eye.
    pub eye: Point,
    /// The point looked at.
    pub target: Point,
    /// Up direction (need not be orthogonal to the view direction).
    pub up: Vector,
    /// Vertical field of view in radians.
    pub fov_y: Real,
    /// Near clip distance in metres.
    pub near: Real,
    /// Far clip distance in metres.
    pub far: Real,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            eye: Point::new(0.0, 0.0, 1.0),
            target: Point::origin(),
            up: Vector::y(),
            fov_y: 0.6,
            near: 0.05,
            far: 20.0,
        }
    }
}

/// A directional light.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Direction from the scene toward the light (normalised when used).
    pub direction: Vector,
    /// Colour and intensity of the light.
    pub color: Rgb,
    /// Ambient light added to every surface, unshadowed.
    pub ambient: Rgb,
}

impl Default for Light {
    fn default() -> Self {
        Self {
            direction: Vector::new(0.4, 1.0, 0.5),
            color: [1.0, 0.97, 0.92],
            ambient: [0.12, 0.12, 0.14],
        }
    }
}

/// A triangle mesh for the body (head, shoulders), shaded simply and casting a depth shadow.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BodyMesh {
    /// Vertex positions.
    pub positions: Vec<Point>,
    /// Vertex normals, one per position.
    pub normals: Vec<Vector>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Diffuse colour of the body.
    pub color: Rgb,
}

/// One control point of a strand, a strand group's skeleton, a cluster or a strip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrandPoint {
    /// Position.
    pub position: Point,
    /// Radius in metres: a strand's fibre radius, a group's or cluster's cross-section radius,
    /// a strip's half-width.
    pub radius: Real,
    /// Hair colour at this point.
    pub color: Rgb,
    /// Wetness in `[0, 1]`: wet hair is darker with a sharper highlight.
    pub wetness: Real,
}

impl StrandPoint {
    /// A dry point of the given position, radius and colour.
    pub fn new(position: Point, radius: Real, color: Rgb) -> Self {
        Self {
            position,
            radius,
            color,
            wetness: 0.0,
        }
    }
}

/// A single rendered strand: a polyline from root to tip (subdivided into a smooth curve).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Strand {
    /// Control points from root to tip.
    pub points: Vec<StrandPoint>,
}

/// A strand group: `strand_count` rendered strands at fixed random offsets in the circular
/// cross-section of radius `skeleton[i].radius`, each following the skeleton.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StrandGroup {
    /// The skeleton from root to tip.
    pub skeleton: Vec<StrandPoint>,
    /// How many strands are drawn.
    pub strand_count: u32,
    /// Fibre radius of each drawn strand, metres.
    pub strand_radius: Real,
    /// Seed of the fixed random offsets.
    pub seed: u64,
}

/// A cluster drawn as a tube of radius `skeleton[i].radius` around its skeleton.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cluster {
    /// The skeleton from root to tip.
    pub skeleton: Vec<StrandPoint>,
}

/// A strip: a flat patch of half-width `skeleton[i].radius` textured with a generated hair
/// texture; its width runs along `cross(tangent, normal)`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Strip {
    /// The skeleton from root to tip.
    pub skeleton: Vec<StrandPoint>,
    /// Surface normal of the strip at each skeleton point.
    pub normals: Vec<Vector>,
}

/// Everything drawn in one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderScene {
    /// The camera.
    pub camera: Camera,
    /// The light.
    pub light: Light,
    /// The body, if any.
    pub body: Option<BodyMesh>,
    /// Individual strands.
    pub strands: Vec<Strand>,
    /// Strand groups.
    pub groups: Vec<StrandGroup>,
    /// Clusters (tubes).
    pub clusters: Vec<Cluster>,
    /// Strips (textured patches).
    pub strips: Vec<Strip>,
    /// Background colour.
    pub background: Rgb,
}

impl Default for RenderScene {
    fn default() -> Self {
        Self {
            camera: Camera::default(),
            light: Light::default(),
            body: None,
            strands: Vec::new(),
            groups: Vec::new(),
            clusters: Vec::new(),
            strips: Vec::new(),
            background: [0.32, 0.36, 0.42],
        }
    }
}

/// How a frame is rendered.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Draw the opacity shadow maps and the body shadow map (off: everything fully lit).
    pub shadows: bool,
    /// Rendered segments per skeleton segment (Catmull-Rom subdivision; 1 keeps the polyline).
    pub subdivisions: u32,
    /// Strands narrower than this many pixels are widened to it, with their opacity scaled down.
    pub min_width_px: Real,
    /// Opacity shadow map settings.
    pub shadow: ShadowSettings,
    /// Shading constants.
    pub shading: ShadingParams,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            shadows: true,
            subdivisions: 3,
            min_width_px: 1.0,
            shadow: ShadowSettings::default(),
            shading: ShadingParams::default(),
        }
    }
}

impl RenderSettings {
    /// Checks the sizes and numbers (not the device limits, which the GPU path checks).
    pub fn validate(&self) -> Result<(), RenderError> {
        if self.width == 0 || self.height == 0 {
            return Err(RenderError::InvalidSize {
                width: self.width,
                height: self.height,
                reason: "a side is zero".into(),
            });
        }
        if self.shadow.map_size == 0 {
            return Err(RenderError::InvalidSize {
                width: self.shadow.map_size,
                height: self.shadow.map_size,
                reason: "the shadow map size is zero".into(),
            });
        }
        if self.subdivisions == 0 || self.subdivisions > 64 {
            return Err(invalid("settings.subdivisions", "must be in 1..=64"));
        }
        if !(self.min_width_px.is_finite() && self.min_width_px >= 0.0) {
            return Err(invalid("settings.min_width_px", "must be finite and >= 0"));
        }
        Ok(())
    }
}

pub(crate) fn invalid(what: impl Into<String>, reason: impl Into<String>) -> RenderError {
    RenderError::InvalidInput {
        what: what.into(),
        reason: reason.into(),
    }
}

pub(crate) fn check_points(
    kind: &'static str,
    index: usize,
    points: &[StrandPoint],
) -> Result<(), RenderError> {
    for (p, sp) in points.iter().enumerate() {
        let bad = |field| RenderError::NonFinite {
            kind,
            index,
            point: p,
            field,
        };
        if !sp.position.coords.iter().all(|c| c.is_finite()) {
            return Err(bad("position"));
        }
        if !sp.radius.is_finite() {
            return Err(bad("radius"));
        }
        if !sp.wetness.is_finite() {
            return Err(bad("wetness"));
        }
        if !sp.color.iter().all(|c| c.is_finite()) {
            return Err(bad("color"));
        }
        if sp.radius < 0.0 {
            return Err(invalid(
                format!("{kind} {index} point {p}"),
                "radius is negative",
            ));
        }
    }
    Ok(())
}

impl RenderScene {
    /// Checks every number of the scene; errors name the strand (group, cluster, strip) and point.
    pub fn validate(&self) -> Result<(), RenderError> {
        let c = &self.camera;
        let cam_ok = c.eye.coords.iter().all(|v| v.is_finite())
            && c.target.coords.iter().all(|v| v.is_finite())
            && c.up.iter().all(|v| v.is_finite())
            && (c.target - c.eye).norm() > 0.0
            && c.up.cross(&(c.target - c.eye)).norm() > 0.0;
        if !cam_ok {
            return Err(invalid(
                "camera",
                "eye, target and up must be finite, distinct and not parallel",
            ));
        }
        if !(c.fov_y.is_finite() && c.fov_y > 0.0 && c.fov_y < 3.1) {
            return Err(invalid("camera.fov_y", "must be in (0, 3.1) radians"));
        }
        if !(c.near.is_finite() && c.far.is_finite() && c.near > 0.0 && c.far > c.near) {
            return Err(invalid("camera.near/far", "need 0 < near < far"));
        }
        let l = &self.light;
        if !(l.direction.iter().all(|v| v.is_finite()) && l.direction.norm() > 0.0) {
            return Err(invalid("light.direction", "must be finite and non-zero"));
        }
        if !l
            .color
            .iter()
            .chain(l.ambient.iter())
            .all(|v| v.is_finite())
        {
            return Err(invalid("light.color/ambient", "must be finite"));
        }
        if let Some(body) = &self.body {
            if body.normals.len() != body.positions.len() {
                return Err(invalid(
                    "body.normals",
                    format!(
                        "{} normals for {} positions",
                        body.normals.len(),
                        body.positions.len()
                    ),
                ));
            }
            for (i, (p, n)) in body.positions.iter().zip(&body.normals).enumerate() {
                if !p.coords.iter().chain(n.iter()).all(|v| v.is_finite()) {
                    return Err(RenderError::NonFinite {
                        kind: "body",
                        index: 0,
                        point: i,
                        field: "position or normal",
                    });
                }
            }
            let n = body.positions.len() as u64;
            for (i, t) in body.triangles.iter().enumerate() {
                if t.iter().any(|&v| u64::from(v) >= n) {
                    return Err(invalid(
                        format!("body.triangles[{i}]"),
                        format!("index out of range (mesh has {n} vertices)"),
                    ));
                }
            }
        }
        for (i, s) in self.strands.iter().enumerate() {
            check_points("strand", i, &s.points)?;
        }
        for (i, g) in self.groups.iter().enumerate() {
            check_points("group", i, &g.skeleton)?;
            if !(g.strand_radius.is_finite() && g.strand_radius >= 0.0) {
                return Err(invalid(
                    format!("group {i}"),
                    "strand_radius must be finite and >= 0",
                ));
            }
        }
        for (i, c) in self.clusters.iter().enumerate() {
            check_points("cluster", i, &c.skeleton)?;
        }
        for (i, s) in self.strips.iter().enumerate() {
            check_points("strip", i, &s.skeleton)?;
            if s.normals.len() != s.skeleton.len() {
                return Err(invalid(
                    format!("strip {i}"),
                    "needs one normal per skeleton point",
                ));
            }
            if let Some(p) = s
                .normals
                .iter()
                .position(|n| !n.iter().all(|v| v.is_finite()))
            {
                return Err(RenderError::NonFinite {
                    kind: "strip",
                    index: i,
                    point: p,
                    field: "normal",
                });
            }
        }
        Ok(())
    }
}
