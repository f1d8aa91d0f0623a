//! Every built-in scene frames its hair: each drawn strand point projects inside the image
//! (square, as `hair run --render` draws by default) and in front of the camera, on the first
//! frame and after the hair has moved. Scenes without a camera get one fitted to the body and
//! the hair ([`hair::scene::CameraSpec::fit`]).

use hair::render::{camera_view_proj, scene_of};
use hair::scene::BUILTIN;
use hair::{LodPolicy, Scene, Simulation};
use nalgebra::Vector4;

/// The share of the image's half-width a point may use: a strand exactly at the edge would be
/// cut by its own ribbon's width.
const INSIDE: f32 = 0.98;

/// The drawn points of `sim` outside the image, as `(strand, point, ndc x, ndc y)`.
fn outside(sim: &Simulation) -> Vec<(usize, usize, f32, f32)> {
    let render = scene_of(sim);
    let view_proj = camera_view_proj(&render, 1.0);
    let mut out = Vec::new();
    for (s, strand) in render.strands.iter().enumerate() {
        for (i, p) in strand.points.iter().enumerate() {
            let q = view_proj * Vector4::new(p.position.x, p.position.y, p.position.z, 1.0);
            let (x, y) = (q.x / q.w, q.y / q.w);
            if q.w <= 0.0 || x.abs() > INSIDE || y.abs() > INSIDE {
                out.push((s, i, x, y));
            }
        }
    }
    out
}

/// Why `name` does not frame its hair at `frames`, if it does not.
fn check(name: &str, frames: &[u32]) -> Option<String> {
    let loaded = Scene::load(name).expect("scene loads");
    let mut sim = Simulation::new(&loaded, loaded.scene.lod).expect("scene builds");
    let mut done = 0;
    for &frame in frames {
        while done < frame * loaded.scene.substeps {
            sim.step().expect("step");
            done += 1;
        }
        if scene_of(&sim).strands.is_empty() {
            return Some(format!("{name}: nothing drawn"));
        }
        let out = outside(&sim);
        if !out.is_empty() {
            return Some(format!(
                "{name} frame {frame}: {} drawn points outside the image, e.g. {:?}",
                out.len(),
                &out[..out.len().min(4)]
            ));
        }
    }
    None
}

#[test]
fn every_built_in_scene_frames_its_hair() {
    let failures: Vec<String> = BUILTIN
        .iter()
        .filter_map(|(name, _)| check(name, &[0, 20]))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_scene_without_a_camera_gets_a_three_quarter_front_view() {
    let mut loaded = Scene::load("sintel").expect("scene loads");
    loaded.scene.camera = hair::scene::CameraSpec::default();
    let sim = Simulation::new(&loaded, LodPolicy::Fine).expect("scene builds");
    assert!(outside(&sim).is_empty());
    let key = &sim.scene().camera.keys[0];
    let eye = nalgebra::Vector3::from(key.eye) - nalgebra::Vector3::from(key.target);
    // Sintel faces +z: the eye is in front of the face, to her left, a little above.
    assert!(
        eye.z > 0.0 && eye.x > 0.0 && eye.y > 0.0,
        "three-quarter front: {eye:?}"
    );
}

#[test]
fn camera_fit_in_a_scene_file_frames_the_hair() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/wind.ron");
    let text = std::fs::read_to_string(path).expect("wind.ron");
    let fit: String = text
        .lines()
        .map(|l| {
            if l.trim_start().starts_with("camera:") {
                "    camera: Fit,".to_string()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert_ne!(fit, text, "wind.ron states a camera");
    let scene = Scene::from_ron(&fit, "wind-fit").expect("camera: Fit parses");
    assert!(scene.camera.keys.is_empty());
    let loaded = hair::LoadedScene {
        scene,
        base_dir: std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes")),
        source: "wind-fit".into(),
    };
    let sim = Simulation::new(&loaded, LodPolicy::Fine).expect("scene builds");
    assert_eq!(sim.scene().camera.keys.len(), 1);
    assert!(outside(&sim).is_empty());
    // A path still parses as before.
    assert!(
        !Scene::from_ron(&text, "wind")
            .expect("parses")
            .camera
            .keys
            .is_empty()
    );
}
