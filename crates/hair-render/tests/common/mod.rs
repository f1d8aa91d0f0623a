//! Shared helpers of the integration tests.
#![allow(dead_code)]

#[cfg(feature = "gpu")]
use hair_render::GpuRenderer;
use hair_render::{RgbaImage, compare, save_png};

/// The GPU renderer, or `None` (with a note) when there is no adapter; under
/// `HAIR_REQUIRE_GPU=1` a missing adapter fails the test.
#[cfg(feature = "gpu")]
pub fn gpu(test: &str) -> Option<GpuRenderer> {
    match GpuRenderer::new() {
        Ok(g) => Some(g),
        Err(e) => {
            if std::env::var("HAIR_REQUIRE_GPU").is_ok_and(|v| v == "1") {
                panic!("{test}: HAIR_REQUIRE_GPU=1 but {e}");
            }
            eprintln!("{test}: skipped, {e}");
            None
        }
    }
}

/// Asserts the GPU image is within the statistical tolerance of the CPU reference (mean
/// absolute difference <= 2/255, 99th percentile <= 16/255); writes the actual, reference and
/// difference images on failure.
pub fn assert_close(name: &str, gpu: &RgbaImage, cpu: &RgbaImage) {
    let d = compare::diff(gpu, cpu).expect("same size");
    eprintln!("{name}: {d:?}");
    if d.mean > 2.0 || d.p99 > 16.0 {
        let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("render-failures");
        let _ = save_png(gpu, dir.join(format!("{name}_actual.png")));
        let _ = save_png(cpu, dir.join(format!("{name}_reference.png")));
        let _ = save_png(
            &compare::difference_image(gpu, cpu),
            dir.join(format!("{name}_difference.png")),
        );
        panic!(
            "{name}: GPU differs from the CPU reference: {d:?}; images in {}",
            dir.display()
        );
    }
}
