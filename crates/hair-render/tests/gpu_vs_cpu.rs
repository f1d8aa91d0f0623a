//! The GPU path against the CPU reference on the same scenes: mean absolute difference at most
//! 2/255 and 99th percentile at most 16/255; the images are written on failure.

#![cfg(feature = "gpu")]

mod common;

use hair_render::*;

fn settings() -> RenderSettings {
    RenderSettings {
        width: 384,
        height: 384,
        shadow: ShadowSettings {
            map_size: 256,
            ..ShadowSettings::default()
        },
        ..RenderSettings::default()
    }
}

/// A scene with every representation: strands, strand groups, clusters, strips, some wet hair.
fn mixed_scene() -> RenderScene {
    let mut scene = test_scenes::head_scene(800, 5);
    for (i, s) in scene.strands.iter_mut().enumerate().take(200) {
        for p in &mut s.points {
            p.wetness = (i % 3) as f32 * 0.5;
        }
    }
    let skeleton = |x: f32, r: f32| -> Vec<StrandPoint> {
        (0..6)
            .map(|k| {
                StrandPoint::new(
                    Point::new(x, 0.09 - 0.05 * k as f32, -0.1 - 0.01 * k as f32),
                    r,
                    [0.5, 0.3, 0.1],
                )
            })
            .collect()
    };
    scene.groups.push(StrandGroup {
        skeleton: skeleton(-0.06, 0.01),
        strand_count: 60,
        strand_radius: 0.0001,
        seed: 3,
    });
    scene.clusters.push(Cluster {
        skeleton: skeleton(0.0, 0.006),
    });
    let strip = skeleton(0.06, 0.012);
    let normals = vec![Vector::z(); strip.len()];
    scene.strips.push(Strip {
        skeleton: strip,
        normals,
    });
    scene
}

fn check(name: &str, scene: &RenderScene, settings: &RenderSettings) {
    let Some(gpu) = common::gpu(name) else {
        return;
    };
    let g = gpu.render_to_image(scene, settings).unwrap();
    let c = CpuRenderer.render_to_image(scene, settings).unwrap();
    common::assert_close(name, &g, &c);
}

#[test]
fn gpu_matches_cpu_reference_head_with_shadows() {
    check(
        "head_shadows",
        &test_scenes::head_scene(2500, 2),
        &settings(),
    );
}

#[test]
fn gpu_matches_cpu_reference_without_shadows() {
    let s = RenderSettings {
        shadows: false,
        ..settings()
    };
    check("head_no_shadows", &test_scenes::head_scene(1500, 4), &s);
}

#[test]
fn gpu_matches_cpu_reference_groups_clusters_strips_wet() {
    check("mixed", &mixed_scene(), &settings());
}

#[test]
fn shadows_darken_the_body_under_the_hair() {
    let scene = test_scenes::head_scene(1500, 9);
    let lit = CpuRenderer
        .render_to_image(
            &scene,
            &RenderSettings {
                shadows: false,
                ..settings()
            },
        )
        .unwrap();
    let shadowed = CpuRenderer.render_to_image(&scene, &settings()).unwrap();
    let mean = |img: &RgbaImage| {
        img.pixels()
            .map(|p| f64::from(p.0[0]) + f64::from(p.0[1]))
            .sum::<f64>()
            / img.len() as f64
    };
    assert!(
        mean(&shadowed) < mean(&lit) - 1.0,
        "self-shadowing should darken the image: {} vs {}",
        mean(&shadowed),
        mean(&lit)
    );
}
