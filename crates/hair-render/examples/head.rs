//! Renders the procedural head with hanging hair to PNG, on the GPU when an adapter exists and
//! always with the CPU reference, and prints how far the two differ.
//!
//! `cargo run --release -p hair-render --example head -- [OUT_DIR] [STRANDS]`

use hair_render::{CpuRenderer, RenderSettings, Renderer, compare, save_png, test_scenes};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = args.next().unwrap_or_else(|| "out/render-example".into());
    let strands: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(4000);
    let scene = test_scenes::head_scene(strands, 3);
    let settings = RenderSettings {
        width: 640,
        height: 640,
        ..RenderSettings::default()
    };
    let t = std::time::Instant::now();
    let cpu = CpuRenderer.render_to_image(&scene, &settings)?;
    println!("cpu reference: {:.0} ms", t.elapsed().as_secs_f64() * 1e3);
    save_png(&cpu, format!("{out}/head_cpu.png"))?;
    let renderer = Renderer::new();
    println!("renderer: {}", renderer.describe());
    if !matches!(renderer, Renderer::Cpu(_)) {
        let t = std::time::Instant::now();
        let gpu = renderer.render_to_image(&scene, &settings)?;
        println!("gpu: {:.0} ms", t.elapsed().as_secs_f64() * 1e3);
        save_png(&gpu, format!("{out}/head_gpu.png"))?;
        save_png(
            &compare::difference_image(&gpu, &cpu),
            format!("{out}/head_diff.png"),
        )?;
        if let Some(d) = compare::diff(&gpu, &cpu) {
            println!("gpu vs cpu: {d:?}");
        }
    }
    let unshadowed = CpuRenderer.render_to_image(
        &scene,
        &RenderSettings {
            shadows: false,
            ..settings
        },
    )?;
    save_png(&unshadowed, format!("{out}/head_cpu_noshadow.png"))?;
    println!("wrote {out}/");
    Ok(())
}
