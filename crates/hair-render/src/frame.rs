//! Per-frame constants shared by the GPU uniforms and the CPU reference: camera and light
//! matrices, opacity map planes, shading constants and the strip texture.

use crate::geometry::{HAIR_TEXTURE_TEXELS, PreparedScene, hair_texture};
use crate::osm::LightFrame;
use crate::scene::{Real, RenderScene, RenderSettings, Vector};
use nalgebra::Matrix4;

/// The uniform block of both passes (layout matches `Globals` in `shaders/common.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "gpu", derive(bytemuck::Pod, bytemuck::Zeroable))]
pub struct Globals {
    /// Camera view-projection, column-major.
    pub cam_view_proj: [f32; 16],
    /// Light view-projection (orthographic), column-major.
    pub light_view_proj: [f32; 16],
    /// Eye position; w: world size of one pixel per metre of view depth.
    pub cam_eye: [f32; 4],
    /// Camera forward axis; w: minimum ribbon half-width in pixels.
    pub cam_forward: [f32; 4],
    /// Unit direction toward the light; w: world size of one shadow texel.
    pub light_dir: [f32; 4],
    /// Light colour; w: 1 with shadows, 0 without.
    pub light_color: [f32; 4],
    /// Ambient colour; w: body shadow bias in light depth units.
    pub ambient: [f32; 4],
    /// x: depth of the hair front, y: plane spacing, z: push back (metres), w: map size.
    pub osm: [f32; 4],
    /// Primary shift, secondary shift, primary exponent, secondary exponent.
    pub spec: [f32; 4],
    /// k1, k2, kd, shift noise amplitude.
    pub spec2: [f32; 4],
    /// Wet darkening, wet sharpening, gamma, unused.
    pub wet: [f32; 4],
    /// Body colour; w: strand opacity.
    pub body_color: [f32; 4],
    /// x: cluster opacity, y..w unused.
    pub misc: [f32; 4],
    /// The strip hair texture, 64 texels.
    pub hair_tex: [[f32; 4]; HAIR_TEXTURE_TEXELS / 4],
}

fn cols(m: &Matrix4<f32>) -> [f32; 16] {
    let mut out = [0.0; 16];
    out.copy_from_slice(m.as_slice());
    out
}

/// Camera view-projection for wgpu's clip space (depth in `[0, 1]`).
pub fn camera_view_proj(scene: &RenderScene, aspect: Real) -> Matrix4<f32> {
    let c = &scene.camera;
    let view = Matrix4::look_at_rh(&c.eye, &c.target, &c.up);
    perspective_zero_to_one(c.fov_y, aspect, c.near, c.far) * view
}

/// Right-handed perspective projection onto wgpu's clip space (depth in `[0, 1]`, near at 0):
/// vertical field of view `fov_y` (rad), width over height `aspect`, clip distances `near` and
/// `far` (m). nalgebra's own maps depth to `[-1, 1]`, OpenGL's convention.
#[rustfmt::skip]
pub fn perspective_zero_to_one(fov_y: Real, aspect: Real, near: Real, far: Real) -> Matrix4<f32> {
    let f = 1.0 / (0.5 * fov_y).tan();
    let (n, fa) = (near, far);
    Matrix4::new(
        f / aspect, 0.0, 0.0, 0.0,
        0.0, f, 0.0, 0.0,
        0.0, 0.0, fa / (n - fa), n * fa / (n - fa),
        0.0, 0.0, -1.0, 0.0,
    )
}

/// Light view-projection: orthographic over the fitted frame, depth in `[0, 1]`.
pub fn light_view_proj(f: &LightFrame) -> Matrix4<f32> {
    let s = 1.0 / f.half_extent;
    let dz = 1.0 / (f.depth_range[1] - f.depth_range[0]);
    let (r, u, w) = (f.right, f.up, f.forward);
    #[rustfmt::skip]
    let m = Matrix4::new(
        r.x * s, r.y * s, r.z * s, -f.centre[0] * s,
        u.x * s, u.y * s, u.z * s, -f.centre[1] * s,
        w.x * dz, w.y * dz, w.z * dz, -f.depth_range[0] * dz,
        0.0, 0.0, 0.0, 1.0,
    );
    m
}

/// Builds the per-frame constants.
pub fn globals(
    scene: &RenderScene,
    prepared: &PreparedScene,
    settings: &RenderSettings,
) -> (Globals, LightFrame) {
    let lf = LightFrame::fit(prepared, &scene.light.direction);
    let aspect = settings.width as Real / settings.height as Real;
    let c = &scene.camera;
    let fwd: Vector = (c.target - c.eye).normalize();
    let pixel_scale = 2.0 * (0.5 * c.fov_y).tan() / settings.height as Real;
    let l = scene.light.direction.normalize();
    let size = settings.shadow.map_size as Real;
    let texel = 2.0 * lf.half_extent / size;
    let sh = &settings.shadow;
    let p = &settings.shading;
    let depth_span = lf.depth_range[1] - lf.depth_range[0];
    let body_color = scene.body.as_ref().map_or([0.8; 3], |b| b.color);
    let tex = hair_texture();
    let mut hair_tex = [[0.0; 4]; HAIR_TEXTURE_TEXELS / 4];
    for (i, t) in tex.iter().enumerate() {
        hair_tex[i / 4][i % 4] = *t;
    }
    let g = Globals {
        cam_view_proj: cols(&camera_view_proj(scene, aspect)),
        light_view_proj: cols(&light_view_proj(&lf)),
        cam_eye: [c.eye.x, c.eye.y, c.eye.z, pixel_scale],
        cam_forward: [fwd.x, fwd.y, fwd.z, 0.5 * settings.min_width_px],
        light_dir: [l.x, l.y, l.z, texel],
        light_color: [
            scene.light.color[0],
            scene.light.color[1],
            scene.light.color[2],
            if settings.shadows { 1.0 } else { 0.0 },
        ],
        ambient: [
            scene.light.ambient[0],
            scene.light.ambient[1],
            scene.light.ambient[2],
            sh.body_bias / depth_span,
        ],
        osm: [
            lf.planes.near,
            lf.planes.spacing,
            sh.push_back * lf.planes.spacing,
            size,
        ],
        spec: [p.primary_shift, p.secondary_shift, p.m1, p.m2],
        spec2: [p.k1, p.k2, p.kd, p.shift_noise],
        wet: [p.wet_darkening, p.wet_sharpening, p.gamma, 0.0],
        body_color: [
            body_color[0],
            body_color[1],
            body_color[2],
            sh.strand_opacity,
        ],
        misc: [sh.cluster_opacity, 0.0, 0.0, 0.0],
        hair_tex,
    };
    (g, lf)
}
