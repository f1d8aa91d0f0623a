//! `hair render-check`: renders the procedural head on the GPU and with the CPU reference and
//! reports how far they differ (mean absolute difference <= 2/255, 99th percentile <= 16/255).

use anyhow::Context;
use hair_render::{CpuRenderer, GpuRenderer, RenderSettings, compare, save_png, test_scenes};
use std::path::PathBuf;

/// Arguments of `hair render-check`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print JSON.
    #[arg(long)]
    pub json: bool,
    /// Image width in pixels.
    #[arg(long, default_value_t = 512)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 512)]
    pub height: u32,
    /// Hanging strands in the scene (10 control points, 3 subdivisions each).
    #[arg(long, default_value_t = 3000)]
    pub strands: usize,
    /// Where the actual, reference and difference images go (always written on failure).
    #[arg(long, default_value = "out/render-check")]
    pub out: PathBuf,
    /// Write the images even when the check passes.
    #[arg(long)]
    pub save: bool,
}

const MEAN_TOL: f64 = 2.0;
const P99_TOL: f64 = 16.0;

/// Runs the check.
pub fn run(args: Args) -> anyhow::Result<()> {
    let scene = test_scenes::head_scene(args.strands, 2);
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        ..RenderSettings::default()
    };
    let gpu = match GpuRenderer::new() {
        Ok(g) => g,
        Err(e) => {
            if std::env::var("HAIR_REQUIRE_GPU").is_ok_and(|v| v == "1") {
                return Err(e).context("HAIR_REQUIRE_GPU=1");
            }
            let msg =
                format!("no GPU adapter ({e}): only the CPU reference exists, nothing to compare");
            if args.json {
                println!(
                    "{}",
                    serde_json::json!({ "adapter": null, "renderer": "cpu reference", "skipped": msg })
                );
            } else {
                println!("{msg}");
            }
            return Ok(());
        }
    };
    let actual = gpu.render_to_image(&scene, &settings)?;
    let reference = CpuRenderer.render_to_image(&scene, &settings)?;
    let d = compare::diff(&actual, &reference).context("image sizes differ")?;
    let pass = d.mean <= MEAN_TOL && d.p99 <= P99_TOL;
    if !pass || args.save {
        save_png(&actual, args.out.join("actual.png"))?;
        save_png(&reference, args.out.join("reference.png"))?;
        save_png(
            &compare::difference_image(&actual, &reference),
            args.out.join("difference.png"),
        )?;
    }
    let prepared = hair_render::geometry::prepare(&scene, settings.subdivisions)?;
    if args.json {
        let report = serde_json::json!({
            "adapter": gpu.adapter_name(),
            "renderer": "gpu",
            "width": args.width,
            "height": args.height,
            "segments": prepared.segments,
            "mean_abs_diff_255": d.mean,
            "p99_255": d.p99,
            "max_255": d.max,
            "fraction_over_16": d.frac_over_16,
            "tolerance": { "mean_abs_diff_255": MEAN_TOL, "p99_255": P99_TOL },
            "pass": pass,
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        println!("adapter:        {}", gpu.adapter_name());
        println!(
            "scene:          {} segments at {}x{}",
            prepared.segments, args.width, args.height
        );
        println!("mean |diff|:    {:.3}/255 (tolerance {MEAN_TOL})", d.mean);
        println!("99th pct:       {:.1}/255 (tolerance {P99_TOL})", d.p99);
        println!("max:            {:.0}/255", d.max);
        println!("result:         {}", if pass { "pass" } else { "FAIL" });
    }
    if !pass {
        anyhow::bail!(
            "GPU differs from the CPU reference; images in {}",
            args.out.display()
        );
    }
    Ok(())
}
