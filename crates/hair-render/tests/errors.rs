//! Bad input: empty scenes, non-finite points, zero and oversized images.

mod common;

use hair_render::*;

fn small() -> RenderSettings {
    RenderSettings {
        width: 32,
        height: 24,
        ..RenderSettings::default()
    }
}

fn is_background(img: &RgbaImage, bg: [f32; 3]) -> bool {
    let want = bg.map(|c| (c * 255.0 + 0.5) as u8);
    img.pixels().all(|p| p.0[..3] == want)
}

#[test]
fn empty_scene_renders_the_background() {
    let scene = RenderScene::default();
    let img = CpuRenderer.render_to_image(&scene, &small()).unwrap();
    assert_eq!(img.dimensions(), (32, 24));
    assert!(is_background(&img, scene.background));
    #[cfg(feature = "gpu")]
    if let Some(gpu) = common::gpu("empty_scene_renders_the_background") {
        let img = gpu.render_to_image(&scene, &small()).unwrap();
        assert!(is_background(&img, scene.background));
    }
}

#[test]
fn single_point_and_empty_strands_draw_nothing() {
    let mut scene = RenderScene::default();
    scene.strands.push(Strand::default());
    scene.strands.push(Strand {
        points: vec![StrandPoint::new(Point::origin(), 0.001, [1.0; 3])],
    });
    let img = CpuRenderer.render_to_image(&scene, &small()).unwrap();
    assert!(is_background(&img, scene.background));
}

#[test]
fn non_finite_point_is_rejected_naming_the_strand() {
    let mut scene = test_scenes::head_scene(10, 1);
    scene.strands[7].points[3].position.y = f32::NAN;
    let err = CpuRenderer.render_to_image(&scene, &small()).unwrap_err();
    match &err {
        RenderError::NonFinite {
            kind, index, point, ..
        } => assert_eq!((*kind, *index, *point), ("strand", 7, 3)),
        other => panic!("unexpected {other:?}"),
    }
    assert!(err.to_string().contains("strand 7"), "{err}");
    scene.strands[7].points[3].position.y = 0.0;
    scene.strands[2].points[0].radius = f32::INFINITY;
    let err = CpuRenderer.render_to_image(&scene, &small()).unwrap_err();
    assert!(err.to_string().contains("strand 2"), "{err}");
    #[cfg(feature = "gpu")]
    if let Some(gpu) = common::gpu("non_finite_point_is_rejected") {
        assert!(matches!(
            gpu.render_to_image(&scene, &small()),
            Err(RenderError::NonFinite { index: 2, .. })
        ));
    }
}

#[test]
fn zero_size_is_an_error() {
    let scene = test_scenes::head_scene(10, 1);
    let s = RenderSettings {
        width: 0,
        ..small()
    };
    assert!(matches!(
        CpuRenderer.render_to_image(&scene, &s),
        Err(RenderError::InvalidSize { .. })
    ));
    let s = RenderSettings {
        shadow: ShadowSettings {
            map_size: 0,
            ..ShadowSettings::default()
        },
        ..small()
    };
    assert!(matches!(
        CpuRenderer.render_to_image(&scene, &s),
        Err(RenderError::InvalidSize { .. })
    ));
}

#[cfg(feature = "gpu")]
#[test]
fn size_beyond_the_adapter_limit_is_an_error_not_a_device_loss() {
    let Some(gpu) = common::gpu("size_beyond_the_adapter_limit") else {
        return;
    };
    let max = gpu.device().limits().max_texture_dimension_2d;
    let scene = test_scenes::head_scene(10, 1);
    let s = RenderSettings {
        width: max + 1,
        ..small()
    };
    let err = gpu.render_to_image(&scene, &s).unwrap_err();
    assert!(matches!(err, RenderError::InvalidSize { .. }), "{err}");
    let s = RenderSettings {
        shadow: ShadowSettings {
            map_size: max + 1,
            ..ShadowSettings::default()
        },
        ..small()
    };
    assert!(gpu.render_to_image(&scene, &s).is_err());
    // The device still works.
    let img = gpu.render_to_image(&scene, &small()).unwrap();
    assert_eq!(img.dimensions(), (32, 24));
}

#[test]
fn bad_body_and_camera_are_errors() {
    let mut scene = test_scenes::head_scene(10, 1);
    if let Some(b) = scene.body.as_mut() {
        b.triangles.push([0, 1, u32::MAX]);
    }
    let err = CpuRenderer.render_to_image(&scene, &small()).unwrap_err();
    assert!(err.to_string().contains("body.triangles"), "{err}");
    let mut scene = test_scenes::head_scene(10, 1);
    scene.camera.target = scene.camera.eye;
    assert!(CpuRenderer.render_to_image(&scene, &small()).is_err());
}
