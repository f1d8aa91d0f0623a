//! The facade's own pieces through its public API: the scene's body, the procedural groom, the
//! camera's view and the render stage's frames.

use hair::HairError;
use hair::render::follow::minimal_rotation;
use hair::scene::{BodySpec, LodPolicy, ProceduralHair, Scene, StyleSpec};
use hair::ssv::{Point, Real};
use hair::{Simulation, body_from_spec, hairstyle::procedural};
use nalgebra::{Isometry3, Matrix3, Vector3};
use std::path::Path;

/// An OBJ body with a degenerate triangle is an error naming the file and the triangle.
#[test]
fn a_degenerate_obj_names_its_file_and_triangle() {
    let dir = std::env::temp_dir().join(format!("hair-body-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    std::fs::write(dir.join("tet.obj"), tet).unwrap();
    // The fourth face repeats an edge's vertex: zero area.
    std::fs::write(dir.join("flat.obj"), tet.replace("f 2 3 4", "f 2 3 3")).unwrap();
    let spec = |path: &str| BodySpec::Obj {
        path: path.into(),
        scale: 0.1,
        offset: [0.0; 3],
        close_holes: false,
    };
    assert!(body_from_spec(&spec("tet.obj"), &dir).unwrap().is_some());
    match body_from_spec(&spec("flat.obj"), &dir) {
        Err(HairError::BodyMesh {
            file,
            source: hair_ssv::SsvError::DegenerateTriangle { triangle: 3, .. },
            ..
        }) => assert!(file.ends_with("flat.obj"), "{file}"),
        other => panic!("expected a BodyMesh error, got {:?}", other.err()),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `collision: (method: Maps)` on a body without Kurihara's tables (an OBJ mesh, the torus)
/// used to run the exact query unasked; it is refused when the scene loads, naming the file and
/// the field. The same scene asking for `Bvh`, and `Maps` on the procedural head, load.
#[test]
fn maps_asked_on_a_body_without_tables_is_refused_at_load() {
    let dir = std::env::temp_dir().join(format!("hair-maps-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    std::fs::write(dir.join("tet.obj"), tet).unwrap();
    let obj = "Obj(path: \"tet.obj\", scale: 0.1, offset: (0.0, 0.0, 0.0))";
    let torus = "Torus(center: (0.0, 0.0, 0.0), major: 0.2, minor: 0.05, wrinkles: 3, depth: 0.1)";
    let scene = |body: &str, method: &str| {
        format!("Scene(name: \"m\", body: {body}, collision: (method: {method}))")
    };
    for (body, kind) in [(obj, "Obj"), (torus, "Torus")] {
        let path = dir.join(format!("{kind}.ron"));
        std::fs::write(&path, scene(body, "Maps")).unwrap();
        match Scene::load(path.to_str().unwrap()) {
            Err(HairError::MethodUnavailable {
                file,
                field,
                method,
                body,
            }) => {
                assert_eq!(file, path.display().to_string());
                assert_eq!(field, "collision.method");
                assert_eq!(method, hair::scene::CollisionMethod::Maps);
                assert_eq!(body, kind);
            }
            other => panic!("{kind}: expected MethodUnavailable, got {other:?}"),
        }
        let text = Scene::load(path.to_str().unwrap()).unwrap_err().to_string();
        assert!(
            text.contains(&*path.display().to_string()) && text.contains("collision.method"),
            "{text}"
        );
        std::fs::write(&path, scene(body, "Bvh")).unwrap();
        let loaded = Scene::load(path.to_str().unwrap()).unwrap();
        assert_eq!(
            loaded.scene.collision.method,
            hair::scene::CollisionMethod::Bvh
        );
    }
    let head = scene("Head(resolution: 16)", "Maps");
    assert!(Scene::from_ron(&head, "head.ron").is_ok());
    // No built-in scene asks for the impossible combination.
    for (name, _) in hair::scene::BUILTIN {
        Scene::load(name).unwrap();
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Draped hair keeps the styled segment lengths, and every point past the root lies outside
/// the head body by at least a strand radius (straight hair grown out from the same roots goes
/// in); so does every point of combed wavy and curly hair.
#[test]
fn draped_hair_lies_outside_the_head_with_its_lengths() {
    let body = body_from_spec(&BodySpec::Head { resolution: 64 }, Path::new("."))
        .unwrap()
        .unwrap();
    let spec = |style| ProceduralHair {
        strands: 400,
        length: 0.3,
        points: 12,
        style,
        scalp_min_height: -0.02,
        ..ProceduralHair::default()
    };
    let draped = procedural(&spec(StyleSpec::Draped), 5).unwrap();
    let grown = ProceduralHair {
        combed: false,
        ..spec(StyleSpec::Straight)
    };
    let straight = procedural(&grown, 5).unwrap();
    let radius = ProceduralHair::default().strand_radius;
    let mut straight_inside = 0;
    for (d, s) in draped.strands.iter().zip(&straight.strands) {
        assert_eq!(d.root, s.root);
        for (wd, ws) in d.points.windows(2).zip(s.points.windows(2)) {
            let (ld, ls) = ((wd[1] - wd[0]).norm(), (ws[1] - ws[0]).norm());
            assert!((ld - ls).abs() < 1e-5 * ls, "segment {ld} instead of {ls}");
        }
        for p in &d.points[1..] {
            let (dist, _, _) = body.signed_distance(p).unwrap();
            assert!(
                dist > radius,
                "draped point {p:?} at {dist} m from the body"
            );
        }
        straight_inside += s.points[1..]
            .iter()
            .filter(|p| body.signed_distance(p).is_some_and(|(d, _, _)| d < 0.0))
            .count();
    }
    assert!(
        straight_inside > 0,
        "the straight hair never enters the body"
    );
    let wavy = StyleSpec::Wavy {
        amplitude: 0.012,
        period: 0.1,
    };
    let curly = StyleSpec::Curly {
        radius: 0.01,
        pitch: 0.04,
    };
    for style in [wavy, curly] {
        for strand in procedural(&spec(style), 5).unwrap().strands {
            for p in &strand.points[1..] {
                let (dist, _, _) = body.signed_distance(p).unwrap();
                assert!(
                    dist > radius,
                    "{style:?}: point {p:?} at {dist} m from the body"
                );
            }
        }
    }
}

/// A camera in front of the face sees a point between it and the face, not one behind the
/// head or far to the side; a teleport carries what it sees with the head (the camera keeps
/// its place relative to the head path, as for the adaptive policy).
#[test]
fn the_camera_sees_in_front_of_the_head_and_follows_a_teleport() {
    let mut scene = Scene::load("bristles").expect("built-in scene");
    scene.scene.camera.keys = vec![hair::scene::CameraKey {
        time: 0.0,
        eye: [0.0, 0.05, 0.8],
        target: [0.0, -0.05, 0.0],
    }];
    let mut sim = Simulation::new(&scene, LodPolicy::Fine).expect("scene builds");
    let points = [
        Point::new(0.0, 0.0, 0.3),
        Point::new(0.0, 0.0, -0.3),
        Point::new(1.0, 0.0, 0.5),
        Point::new(2.0, 0.0, 0.3),
    ];
    let mut seen = Vec::new();
    sim.seen_by_camera(&points, &mut seen);
    assert_eq!(seen, [true, false, false, false]);
    sim.teleport(Isometry3::translation(2.0, 0.0, 0.0));
    sim.seen_by_camera(&points, &mut seen);
    assert_eq!(seen, [false, false, false, true]);
}

#[test]
fn the_minimal_rotation_is_the_strands_bend() {
    // Tangents all around the sphere: near +z, near -z (the `(1 - t_z) / side` form) and
    // between; the exact fold, where the bend's own form is taken, is checked below.
    let mut worst: Real = 0.0;
    for i in 0..=40 {
        for j in 0..24 {
            let polar = std::f32::consts::PI * (i as Real / 40.0).min(0.99999);
            let az = std::f32::consts::TAU * j as Real / 24.0;
            let t = Vector3::new(polar.sin() * az.cos(), polar.sin() * az.sin(), polar.cos());
            let (x, y) = hair_dynamics::bend_between(&t);
            let bend = hair_dynamics::Bend::new(x, y).rotation;
            let r = minimal_rotation(&t);
            worst = worst.max((r - bend).abs().max());
            // It turns +z into t, and it is a rotation.
            assert!((r * Vector3::z() - t).norm() < 1e-6, "{t:?}");
            assert!(
                (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-5,
                "{t:?}"
            );
            assert!((r.determinant() - 1.0).abs() < 1e-5, "{t:?}");
        }
    }
    assert!(worst < 2e-6, "largest difference from the bend: {worst}");
    // A tangent that is not quite unit (seen from a frame drifted from orthonormal) still
    // gives a rotation, near a fold too.
    for t in [
        Vector3::new(1e-4, 2e-4, -1.0) * 1.001,
        Vector3::new(0.3, -0.2, -0.9).normalize() * 0.999,
        Vector3::new(0.3, 0.2, 0.9).normalize() * 1.002,
    ] {
        let r = minimal_rotation(&t);
        assert!(
            (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-5,
            "{t:?}"
        );
        assert!((r * Vector3::z() - t.normalize()).norm() < 1e-5, "{t:?}");
    }
    // Folded straight back: the bend's own half turn about x.
    let back = Vector3::new(0.0, 0.0, -1.0);
    let (x, y) = hair_dynamics::bend_between(&back);
    let bend = hair_dynamics::Bend::new(x, y).rotation;
    assert!((minimal_rotation(&back) - bend).abs().max() < 1e-6);
}
