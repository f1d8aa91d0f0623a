//! # hair-render
//!
//! Interactive hair rendering after Ward, Galoppo & Lin's *Interactive Virtual Hair Salon* (§5):
//! strands drawn as camera-facing ribbons, self-shadowed with 16 opacity shadow maps written in
//! one pass into four `Rgba16Float` targets, and shaded with Kajiya-Kay diffuse plus two shifted
//! specular highlights. Input is plain data, so any simulator can use it; a CPU reference of the
//! same maths validates the GPU path and serves when there is no adapter.
//!
//! | item | what it is |
//! |---|---|
//! | [`RenderScene`], [`Camera`], [`Light`], [`BodyMesh`] | plain-data input |
//! | [`Strand`], [`StrandGroup`], [`Cluster`], [`Strip`], [`StrandPoint`] | hair as polylines with per-point radius, colour and wetness; groups of strands, tubes, textured strips |
//! | [`RenderSettings`], [`ShadowSettings`], [`ShadingParams`] | image size, subdivision, shadow and shading constants |
//! | [`Renderer`] | GPU when an adapter exists, else the CPU reference; `render_to_image` |
//! | `GpuRenderer` (feature `gpu`, on by default) | wgpu: headless `render_to_image`, `render_to_view` for a window surface, `opacity_maps` |
//! | [`CpuRenderer`] | the CPU reference (rayon): `render_to_image`, `opacity_maps` |
//! | [`OpacityMaps`], [`OsmPlanes`], [`hat_weights`] | the 16 maps, their planes and the hat reconstruction |
//! | [`mod@geometry`] | Catmull-Rom subdivision, strand groups, ribbon vertices |
//! | [`follow`] | strands that follow skeletons: transport frames, Catmull-Rom curves through control points, [`follow::RenderGeometry`] |
//! | [`guides`] | rendered strands that follow the three nearest guides with barycentric weights |
//! | [`mod@shading`] | the two-highlight hair model on the CPU |
//! | `stage` (feature `stage`) | the `hair` simulation's render stage: drawn strands around its skeletons, guides' followers |
//! | [`compare`] | image statistics for GPU/CPU comparisons |
//! | `test_scenes` (feature `test-support`) | a procedural head with hanging hair for tests, benches and demos |
//!
//! Without the `gpu` feature the crate is the CPU reference, the scene types and the geometry,
//! with no GPU stack in its dependencies.
//!
//! ## Method notes
//!
//! - The light is directional; the maps are orthographic over the scene's bounds seen from it.
//!   Plane `n` of 16 lies at `near + (n + 1) * spacing` with `spacing` the hair's depth extent
//!   over 16, so every map holds information and the front of the hair (depth `near`) has
//!   opacity zero; a fragment adds its opacity to the maps whose plane lies behind it.
//! - Transmittance is `exp(-opacity)` (Kim & Neumann). A fibre narrower than a texel (or a
//!   pixel) is drawn `min_width_px` wide with its opacity scaled by the width ratio, so thin hair
//!   casts proportionally light shadows instead of being missed by the rasteriser.
//! - §5.3's push-back is one plane spacing by default, so a lit fibre never samples its own
//!   opacity; a single strand under the light is fully lit (tested).
//! - The body's shadow map is the depth attachment of the same pass, read with a `LessEqual`
//!   comparison sampler at texel centres (GLSL cannot `textureLoad` a depth texture); both maps
//!   are filtered bilinearly by hand so the CPU reference computes exactly the same taps.
//! - The CPU reference rasterises like GPUs do (pixel centres, 1/256-pixel vertex snapping,
//!   top-left rule, perspective-correct varyings) and rounds opacity sums to 16-bit floats like
//!   the `Rgba16Float` targets, so GPU and CPU images agree to a fraction of a level on average.
//!
//! ```
//! use hair_render::{CpuRenderer, Point, RenderScene, RenderSettings, Strand, StrandPoint};
//!
//! // One brown strand hanging through the middle of the default camera's view.
//! let points = (0..8)
//!     .map(|k| StrandPoint::new(Point::new(0.0, 0.1 - 0.03 * k as f32, 0.0), 0.004, [0.4, 0.25, 0.1]))
//!     .collect();
//! let scene = RenderScene {
//!     strands: vec![Strand { points }],
//!     background: [0.2, 0.2, 0.25],
//!     ..RenderScene::default()
//! };
//! let settings = RenderSettings { width: 64, height: 64, ..RenderSettings::default() };
//! let image = CpuRenderer.render_to_image(&scene, &settings)?;
//! assert_eq!(image.dimensions(), (64, 64));
//! // The corner shows the background; a column of pixels, the strand.
//! let background = [51, 51, 64, 255];
//! assert_eq!(image.get_pixel(0, 0).0, background);
//! assert!(image.pixels().filter(|p| p.0 != background).count() >= 16);
//! # Ok::<(), hair_render::RenderError>(())
//! ```

pub mod compare;
mod cpu;
mod error;
pub mod follow;
mod frame;
pub mod geometry;
#[cfg(feature = "gpu")]
mod gpu;
pub mod guides;
mod osm;
mod scene;
pub mod shading;
#[cfg(feature = "stage")]
pub mod stage;
#[cfg(feature = "test-support")]
pub mod test_scenes;

pub use cpu::CpuRenderer;
pub use error::RenderError;
pub use frame::{Globals, camera_view_proj, perspective_zero_to_one};
#[cfg(feature = "gpu")]
pub use gpu::{GpuRenderer, osm_shader_source, shade_shader_source};
pub use image::{self, RgbaImage};
pub use osm::{
    LightFrame, OSM_MAPS, OpacityMaps, OsmPlanes, ShadowSettings, contributes, f16_to_f32,
    hat_weights, opacity_at, round_f16,
};
pub use scene::{
    BodyMesh, Camera, Cluster, Light, Point, Real, RenderScene, RenderSettings, Rgb, Strand,
    StrandGroup, StrandPoint, Strip, Vector,
};
pub use shading::ShadingParams;
#[cfg(feature = "gpu")]
pub use wgpu;

/// A renderer: the GPU when an adapter exists (and the `gpu` feature is on), otherwise the CPU
/// reference.
#[derive(Debug)]
#[non_exhaustive]
pub enum Renderer {
    /// wgpu on the adapter found.
    #[cfg(feature = "gpu")]
    Gpu(Box<GpuRenderer>),
    /// The CPU reference.
    Cpu(CpuRenderer),
}

impl Renderer {
    /// The GPU renderer if an adapter and device can be had, otherwise the CPU reference.
    pub fn new() -> Self {
        #[cfg(feature = "gpu")]
        if let Ok(g) = GpuRenderer::new() {
            return Self::Gpu(Box::new(g));
        }
        Self::Cpu(CpuRenderer)
    }

    /// The GPU renderer, or the error explaining why there is none.
    #[cfg(feature = "gpu")]
    pub fn gpu() -> Result<Self, RenderError> {
        Ok(Self::Gpu(Box::new(GpuRenderer::new()?)))
    }

    /// The GPU renderer: [`RenderError::NoAdapter`], since the crate is built without its `gpu`
    /// feature.
    #[cfg(not(feature = "gpu"))]
    pub fn gpu() -> Result<Self, RenderError> {
        Err(RenderError::NoAdapter(
            "hair-render was built without its `gpu` feature".into(),
        ))
    }

    /// Which path renders: `gpu: <adapter> (<backend>)` or `cpu reference`.
    pub fn describe(&self) -> String {
        match self {
            #[cfg(feature = "gpu")]
            Self::Gpu(g) => format!("gpu: {}", g.adapter_name()),
            Self::Cpu(_) => "cpu reference".into(),
        }
    }

    /// Renders a scene to an RGBA image.
    pub fn render_to_image(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
    ) -> Result<RgbaImage, RenderError> {
        match self {
            #[cfg(feature = "gpu")]
            Self::Gpu(g) => g.render_to_image(scene, settings),
            Self::Cpu(c) => c.render_to_image(scene, settings),
        }
    }
}

impl Default for Renderer {
    fn default() -> Self {
        Self::new()
    }
}

/// Writes an image as PNG, creating the parent directory.
pub fn save_png(image: &RgbaImage, path: impl AsRef<std::path::Path>) -> Result<(), RenderError> {
    let path = path.as_ref();
    let err = |e: &dyn std::fmt::Display| RenderError::Image {
        path: path.display().to_string(),
        reason: e.to_string(),
    };
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| err(&e))?;
    }
    image.save(path).map_err(|e| err(&e))
}
