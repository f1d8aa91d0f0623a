//! Opacity shadow map properties, on the CPU reference and (when an adapter exists) the GPU.

mod common;

use hair_render::*;

fn settings(map_size: u32) -> RenderSettings {
    RenderSettings {
        width: 128,
        height: 128,
        shadow: ShadowSettings {
            map_size,
            ..ShadowSettings::default()
        },
        ..RenderSettings::default()
    }
}

fn check_non_decreasing(maps: &OpacityMaps, who: &str) {
    let mut nonzero = 0;
    for (i, t) in maps.opacity.iter().enumerate() {
        for n in 1..OSM_MAPS {
            assert!(
                t[n] >= t[n - 1],
                "{who}: texel {i}: map {n} ({}) < map {} ({})",
                t[n],
                n - 1,
                t[n - 1]
            );
        }
        if t[OSM_MAPS - 1] > 0.0 {
            nonzero += 1;
        }
    }
    assert!(nonzero > 100, "{who}: only {nonzero} texels see hair");
}

#[test]
fn opacity_is_non_decreasing_from_first_map_to_last_cpu() {
    let scene = test_scenes::head_scene(600, 11);
    let maps = CpuRenderer.opacity_maps(&scene, &settings(128)).unwrap();
    check_non_decreasing(&maps, "cpu");
}

#[cfg(feature = "gpu")]
#[test]
fn opacity_is_non_decreasing_from_first_map_to_last_gpu() {
    let Some(gpu) = common::gpu("opacity_is_non_decreasing_gpu") else {
        return;
    };
    let scene = test_scenes::head_scene(600, 11);
    let maps = gpu.opacity_maps(&scene, &settings(128)).unwrap();
    check_non_decreasing(&maps, "gpu");
    // And the GPU maps agree with the CPU's.
    let cpu = CpuRenderer.opacity_maps(&scene, &settings(128)).unwrap();
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (a, b) in maps.opacity.iter().zip(&cpu.opacity) {
        sum += f64::from((a[15] - b[15]).abs());
        n += 1;
    }
    assert!(
        sum / (n as f64) < 0.02,
        "mean |gpu - cpu| of the last map: {}",
        sum / n as f64
    );
}

/// A horizontal strand along x at height `y`, offset `z`.
fn bar(y: f32, z: f32, radius: f32) -> Strand {
    Strand {
        points: (0..9)
            .map(|i| {
                StrandPoint::new(
                    Point::new(-0.1 + 0.025 * i as f32, y, z),
                    radius,
                    [0.4, 0.3, 0.2],
                )
            })
            .collect(),
    }
}

fn two_strand_scene(occluder_z: f32) -> RenderScene {
    RenderScene {
        camera: Camera {
            eye: Point::new(0.0, 0.3, 0.4),
            target: Point::origin(),
            ..Camera::default()
        },
        light: Light {
            direction: Vector::y(),
            ..Light::default()
        },
        // The lit strand at y = 0 and the occluder 5 cm above, or moved aside along z.
        strands: vec![bar(0.0, 0.0, 0.003), bar(0.05, occluder_z, 0.003)],
        ..RenderScene::default()
    }
}

fn shadow_on_lower_strand(maps: &OpacityMaps) -> f32 {
    // Average over a few points along the lower strand's middle.
    (0..5)
        .map(|i| maps.shadow_at(&Point::new(-0.02 + 0.01 * i as f32, 0.0, 0.0)))
        .sum::<f32>()
        / 5.0
}

fn occluder_darkens_and_moving_it_restores(maps_of: impl Fn(&RenderScene) -> OpacityMaps) {
    let above = shadow_on_lower_strand(&maps_of(&two_strand_scene(0.0)));
    let aside = shadow_on_lower_strand(&maps_of(&two_strand_scene(0.08)));
    assert!(
        above > 0.4,
        "a strand between the light and another should shadow it: {above}"
    );
    assert!(
        aside < 0.02,
        "moving the occluder aside should restore the light: {aside}"
    );
    // The occluder itself is lit: the planes are pushed back so it does not shadow itself.
    let maps = maps_of(&two_strand_scene(0.0));
    let own = maps.shadow_at(&Point::new(0.0, 0.05, 0.0));
    assert!(
        own < 0.02,
        "a lit strand darkened by its own opacity: {own}"
    );
}

#[test]
fn strand_between_light_and_another_darkens_it_cpu() {
    occluder_darkens_and_moving_it_restores(|s| {
        CpuRenderer.opacity_maps(s, &settings(128)).unwrap()
    });
}

#[cfg(feature = "gpu")]
#[test]
fn strand_between_light_and_another_darkens_it_gpu() {
    let Some(gpu) = common::gpu("strand_between_light_and_another_darkens_it_gpu") else {
        return;
    };
    occluder_darkens_and_moving_it_restores(|s| gpu.opacity_maps(s, &settings(128)).unwrap());
}

#[test]
fn hat_weights_sum_to_one_between_planes() {
    let planes = OsmPlanes::new(-0.3, 0.5);
    let (first, last) = (planes.depth(0), planes.depth(OSM_MAPS - 1));
    for k in 0..=1000 {
        let z = first + (last - first) * k as f32 / 1000.0;
        let w = hat_weights(&planes, z);
        let sum: f32 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-5, "depth {z}: weights sum to {sum}");
        assert!(w.iter().all(|&x| x >= 0.0));
        assert!(
            w.iter().filter(|&&x| x > 0.0).count() <= 2,
            "hat weights touch two planes"
        );
    }
    // In front of the hair there is no opacity; behind it the last map counts fully.
    assert_eq!(hat_weights(&planes, planes.near).iter().sum::<f32>(), 0.0);
    assert_eq!(hat_weights(&planes, 10.0)[OSM_MAPS - 1], 1.0);
    // Opacity interpolates linearly between bracketing maps.
    let maps: [f32; OSM_MAPS] = std::array::from_fn(|n| n as f32);
    let z = 0.5 * (planes.depth(3) + planes.depth(4));
    assert!((opacity_at(&planes, &maps, z) - 3.5).abs() < 1e-4);
    assert!(contributes(&planes, planes.depth(2) - 1e-4, 2));
    assert!(!contributes(&planes, planes.depth(2) + 1e-4, 2));
}

#[test]
fn round_f16_matches_half_precision() {
    for x in [0.0f32, 1.0, 0.1, 1.0 / 3.0, 1000.3, 6.0e-5, 70000.0, -2.5] {
        let r = round_f16(x);
        let bits = r.to_bits();
        // 10 mantissa bits: the low 13 bits of the f32 mantissa are zero (normal range).
        if r.abs() >= 6.2e-5 {
            assert_eq!(bits & 0x1fff, 0, "{x} -> {r}");
        }
        assert!((r - x).abs() <= x.abs() * 1e-3 + 6e-8 || x.abs() > 65504.0);
    }
    assert_eq!(f16_to_f32(0x3c00), 1.0);
    assert_eq!(f16_to_f32(0xc000), -2.0);
}
