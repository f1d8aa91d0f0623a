//! Criterion benches of the CPU reference (the GPU path is timed by `hair bench render`):
//! geometry preparation, the opacity-map pass and a full frame on a small seeded scene.

use criterion::{Criterion, criterion_group, criterion_main};
use hair_render::{CpuRenderer, RenderSettings, ShadowSettings, geometry, test_scenes};
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let scene = test_scenes::head_scene(1000, 3);
    let settings = RenderSettings {
        width: 256,
        height: 256,
        shadow: ShadowSettings {
            map_size: 256,
            ..ShadowSettings::default()
        },
        ..RenderSettings::default()
    };
    let mut g = c.benchmark_group("hair-render cpu");
    g.sample_size(10);
    g.bench_function("prepare 1000 strands", |b| {
        b.iter(|| geometry::prepare(black_box(&scene), 3))
    });
    g.bench_function("opacity maps 256^2", |b| {
        b.iter(|| CpuRenderer.opacity_maps(black_box(&scene), &settings))
    });
    g.bench_function("frame 256^2 with shadows", |b| {
        b.iter(|| CpuRenderer.render_to_image(black_box(&scene), &settings))
    });
    g.finish();
}

criterion_group!(render, benches);
criterion_main!(render);
