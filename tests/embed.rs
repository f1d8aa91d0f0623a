//! The caller-driven API: a head posed each step moves the hair as the scene's keyframed path
//! does, a jump is a teleport, bad input is a typed error that changes nothing, and the
//! `embed` example runs.

use hair::drivers::head_pose;
use hair::io::Strands;
use hair::scene::HeadMotionSpec;
use hair::{Body, HairError, Scene, Simulation};
use nalgebra::{Isometry3, Translation3};

#[allow(dead_code)]
#[path = "../examples/embed.rs"]
mod example;

/// Largest distance between the two simulations' nodes (m).
fn max_distance(a: &Simulation, b: &Simulation) -> f32 {
    let (pa, pb) = (a.state().positions(), b.state().positions());
    assert_eq!(pa.len(), pb.len());
    pa.iter()
        .zip(pb)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f32::max)
}

#[test]
fn a_head_posed_each_step_moves_the_hair_as_the_shake_scenes_keyframes_do() {
    let keyed_scene = Scene::load("shake").expect("shake loads");
    let path = keyed_scene.scene.head_motion.clone();
    assert_ne!(path, HeadMotionSpec::Still);
    let mut still = keyed_scene.clone();
    still.scene.head_motion = HeadMotionSpec::Still;
    let policy = keyed_scene.scene.lod;
    let mut keyed = Simulation::new(&keyed_scene, policy).expect("builds");
    let mut posed = Simulation::new(&still, policy).expect("builds");
    let mut resting = Simulation::new(&still, policy).expect("builds");
    let dt = posed.dt();
    // The path's head is already turning at t = 0: the caller says where it was a step before.
    posed
        .start_head(head_pose(&path, -dt), head_pose(&path, 0.0))
        .expect("finite poses");
    for _ in 0..30 {
        let next = head_pose(&path, posed.time() + posed.dt());
        posed.set_head_pose(next).expect("finite pose");
        posed.step().expect("step");
        keyed.step().expect("step");
        resting.step().expect("step");
    }
    assert_eq!(posed.state_hash(), keyed.state_hash());
    assert!(max_distance(&posed, &keyed) <= 1e-6);
    // The oracle can fail: a head left still ends elsewhere.
    assert!(max_distance(&resting, &keyed) > 1e-3);
    let (a, b) = (posed.render_geometry(), keyed.render_geometry());
    assert_eq!(a.positions, b.positions);
}

#[test]
fn a_jump_beyond_the_limits_carries_the_hair_rigidly() {
    let loaded = Scene::load("wind").expect("wind loads");
    let mut jumped = Simulation::new(&loaded, loaded.scene.lod).expect("builds");
    let mut held = Simulation::new(&loaded, loaded.scene.lod).expect("builds");
    for _ in 0..5 {
        jumped.step().expect("step");
        held.step().expect("step");
    }
    let far = Isometry3::from_parts(Translation3::new(1.0, 0.0, 0.0), Default::default());
    jumped.set_head_pose(far).expect("finite pose");
    jumped.step().expect("step");
    held.step().expect("step");
    // A 1 m jump in one step would whip the hair by 60 m/s; as a teleport the hair's motion
    // relative to the head is the held head's exactly, and it is drawn 1 m along x.
    assert_eq!(jumped.state_hash(), held.state_hash());
    assert_eq!(jumped.head_pose().translation.vector.x, 1.0);
    let (a, b) = (jumped.render_geometry(), held.render_geometry());
    let mut moved = a.positions.iter().zip(&b.positions);
    assert!(moved.all(|(p, q)| ((p - q) - nalgebra::Vector3::x()).norm() < 1e-5));
    // Under a limit of 2 m the same jump is a motion, and whips.
    let mut whipped = Simulation::new(&loaded, loaded.scene.lod).expect("builds");
    let limits = hair::TeleportLimits {
        distance: 2.0,
        angle: 0.5,
    };
    whipped.set_teleport_limits(limits).expect("valid limits");
    for _ in 0..5 {
        whipped.step().expect("step");
    }
    whipped.set_head_pose(far).expect("finite pose");
    whipped.step().expect("step");
    assert!(whipped.kinetic_energy() > 10.0 * held.kinetic_energy());
}

#[test]
fn a_non_finite_pose_is_an_error_and_changes_nothing() {
    let loaded = Scene::load("wind").expect("wind loads");
    let mut sim = Simulation::new(&loaded, loaded.scene.lod).expect("builds");
    let mut clean = Simulation::new(&loaded, loaded.scene.lod).expect("builds");
    sim.step().expect("step");
    clean.step().expect("step");
    let track = sim.head_track().clone();
    let mut bad = Isometry3::identity();
    bad.translation.vector.y = f32::NAN;
    assert!(matches!(
        sim.set_head_pose(bad),
        Err(HairError::Dynamics(_))
    ));
    assert!(sim.start_head(bad, Isometry3::identity()).is_err());
    assert_eq!(sim.head_track(), &track);
    assert_eq!(sim.teleport_offset(), Isometry3::identity());
    sim.step().expect("step");
    clean.step().expect("step");
    assert_eq!(sim.state_hash(), clean.state_hash());
}

#[test]
fn bad_grooms_and_meshes_are_typed_errors() {
    let scene = Scene::default();
    let empty = Strands::from_polylines(Vec::new()).expect("no strands is a valid file");
    let err = Simulation::from_groom(&empty, Body::None, &scene).err();
    assert!(matches!(err, Some(HairError::EmptyGroom)), "{err:?}");
    let line = vec![[0.0, 0.1, 0.0], [0.0, 0.2, 0.0], [0.0, f32::NAN, 0.0]];
    assert!(Strands::from_polylines(vec![line.clone()]).is_err());
    let nan = Strands {
        points: line,
        offsets: vec![0, 3],
        ..Strands::default()
    };
    let err = Simulation::from_groom(&nan, Body::None, &scene).err();
    assert!(matches!(err, Some(HairError::Format(_))), "{err:?}");
    let ok = Strands::from_polylines(example::groom(4, 6, 0.2)).expect("finite");
    let flat = Body::Mesh {
        vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        triangles: vec![[0, 1, 2]],
    };
    let err = Simulation::from_groom(&ok, flat, &scene).err();
    assert!(matches!(err, Some(HairError::BodyMesh { .. })), "{err:?}");
    let out_of_range = Body::Mesh {
        vertices: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 3]],
    };
    let err = Simulation::from_groom(&ok, out_of_range, &scene).err();
    assert!(matches!(err, Some(HairError::BodyMesh { .. })), "{err:?}");
    assert!(Simulation::from_groom(&ok, Body::None, &scene).is_ok());
}

#[test]
fn the_embed_example_runs_and_the_hair_follows_the_head() {
    let mut lines = 0;
    let tip = example::run(0.25, |_| lines += 1).expect("the example runs");
    assert_eq!(lines, 15);
    assert!(tip.iter().all(|x| x.is_finite()));
}
