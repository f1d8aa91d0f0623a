//! Golden state hashes: every built-in scene at its own LOD policy, `wardlin` at `fine` and
//! `adaptive`, and `scenes/strands10k.ron`, each for a fixed number of frames, compared with
//! the hash `hair run SCENE --frames N` prints (`state_hash` in `summary.json`).
//!
//! Pinned at the rest-on-the-first-frame change (`sag_free` on by default: the groom made its
//! own rest); the values before it, pinned from `hair run` at 85ecbcd, are what a scene with
//! `sag_free: false` still gives, bit for bit.
//!
//! A refactor keeps these bit for bit. A change that moves results on purpose updates them in a
//! commit of its own that says which change moved them and by how much.

use hair::{LodPolicy, Scene, Simulation};

/// Runs `frames` frames of a scene (built-in name or path) at `policy` (its own when `None`) on
/// two threads and returns the final state hash as `hair run` prints it.
fn hash_after(scene: &str, policy: Option<LodPolicy>, frames: u32) -> String {
    let loaded = Scene::load(scene).expect("scene loads");
    let policy = policy.unwrap_or(loaded.scene.lod);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    pool.install(|| {
        let mut sim = Simulation::new(&loaded, policy).expect("scene builds");
        for _ in 0..frames * loaded.scene.substeps {
            sim.step().expect("step");
        }
        format!("{:016x}", sim.state_hash())
    })
}

/// Checks each `(scene, policy, frames, hash)` and reports every mismatch at once.
fn check(cases: &[(&str, Option<LodPolicy>, u32, &str)]) {
    let mut wrong = Vec::new();
    for &(scene, policy, frames, want) in cases {
        let got = hash_after(scene, policy, frames);
        if got != want {
            wrong.push(format!(
                "{scene} {policy:?} {frames} frames: {got}, pinned {want}"
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "golden hashes moved:\n{}",
        wrong.join("\n")
    );
}

#[test]
fn builtin_scenes_at_their_own_policy() {
    check(&[
        ("wind", None, 60, "a70f2f355a4862e6"),
        ("shake", None, 60, "1216ad97309505bd"),
        ("torus", None, 60, "771990ef09d3cec6"),
        ("zoom", None, 60, "658b6b2052471ab8"),
        ("bristles", None, 60, "1a88bce2cf4bc2a7"),
        ("sintel", None, 60, "2901a1b63fc37ee5"),
    ]);
}

#[test]
fn salon_session_with_every_tool() {
    // 600 frames: water, two cuts (fallen pieces), spray bonds, mousse, dryer and grab.
    check(&[("salon", None, 600, "498e0983c3486f8d")]);
}

#[test]
fn wardlin_fine_and_adaptive() {
    check(&[
        ("wardlin", Some(LodPolicy::Fine), 60, "995a651510c92975"),
        ("wardlin", Some(LodPolicy::Adaptive), 60, "e870b43debc5e1cc"),
    ]);
}

#[test]
fn strands10k_five_frames() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/strands10k.ron");
    check(&[(path, Some(LodPolicy::Fine), 5, "e1f13f009165377b")]);
}
