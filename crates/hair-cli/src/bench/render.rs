//! `hair bench render`: frame time of the hair renderer with the 16 opacity shadow maps against
//! the same frame unshadowed, on the salon paper's 304 K-vertex geometry.

use anyhow::Context;
use hair_render::{CpuRenderer, GpuRenderer, OSM_MAPS, RenderScene, RenderSettings, test_scenes};
use std::time::Instant;

/// Arguments of `hair bench render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Frames timed for each variant (after one warm-up frame).
    #[arg(long, default_value_t = 3)]
    pub frames: usize,
    /// Image width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 640)]
    pub height: u32,
    /// Side of the opacity shadow maps in texels.
    #[arg(long, default_value_t = 512)]
    pub map_size: u32,
    /// Use the CPU reference even when an adapter exists.
    #[arg(long)]
    pub cpu: bool,
}

fn time_frames(
    frames: usize,
    mut render: impl FnMut() -> Result<(), hair_render::RenderError>,
) -> anyhow::Result<f64> {
    render().context("warm-up frame")?;
    let t = Instant::now();
    for _ in 0..frames.max(1) {
        render()?;
    }
    Ok(t.elapsed().as_secs_f64() * 1e3 / frames.max(1) as f64)
}

/// Runs the suite.
pub fn run(args: Args) -> anyhow::Result<()> {
    let scene: RenderScene = test_scenes::bench_scene();
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        subdivisions: test_scenes::BENCH_SUBDIVISIONS,
        shadow: hair_render::ShadowSettings {
            map_size: args.map_size,
            ..Default::default()
        },
        ..RenderSettings::default()
    };
    let unshadowed = RenderSettings {
        shadows: false,
        ..settings.clone()
    };
    let prepared = hair_render::geometry::prepare(&scene, settings.subdivisions)?;
    let gpu = if args.cpu {
        None
    } else {
        match GpuRenderer::new() {
            Ok(g) => Some(g),
            Err(e) if std::env::var("HAIR_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
                return Err(e).context("HAIR_REQUIRE_GPU=1");
            }
            Err(e) => {
                eprintln!("no GPU adapter ({e}); timing the CPU reference");
                None
            }
        }
    };
    let (adapter, ms_shadow, ms_plain) = match &gpu {
        Some(g) => (
            format!("gpu: {}", g.adapter_name()),
            time_frames(args.frames, || {
                g.render_to_image(&scene, &settings).map(drop)
            })?,
            time_frames(args.frames, || {
                g.render_to_image(&scene, &unshadowed).map(drop)
            })?,
        ),
        None => (
            "cpu reference".to_string(),
            time_frames(args.frames, || {
                CpuRenderer.render_to_image(&scene, &settings).map(drop)
            })?,
            time_frames(args.frames, || {
                CpuRenderer.render_to_image(&scene, &unshadowed).map(drop)
            })?,
        ),
    };
    let ratio = ms_shadow / ms_plain;
    let report = serde_json::json!({
        "suite": "render",
        "adapter": adapter,
        "vertices": prepared.curve_points,
        "segments": prepared.segments,
        "strands": scene.strands.len(),
        "osm_maps": OSM_MAPS,
        "width": args.width,
        "height": args.height,
        "map_size": args.map_size,
        "frames": args.frames,
        "ms_per_frame": ms_shadow,
        "ms_no_shadow": ms_plain,
        "ratio": ratio,
        "goal_ratio": 2.0,
        "meets_goal": ratio <= 2.0,
    });
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("adapter:        {adapter}");
        println!(
            "geometry:       {} vertices, {} segments, {} strands",
            prepared.curve_points,
            prepared.segments,
            scene.strands.len()
        );
        println!(
            "image:          {}x{}, {OSM_MAPS} opacity maps of {}^2",
            args.width, args.height, args.map_size
        );
        println!("with shadows:   {ms_shadow:.1} ms/frame");
        println!("no shadows:     {ms_plain:.1} ms/frame");
        println!("ratio:          {ratio:.2} (goal <= 2)");
    }
    Ok(())
}
