//! The composed pipeline on built-in scenes: finite state, bounded penetration after the
//! depenetration ramp, and the same state hash for 1 and 2 threads.

use hair::{LodPolicy, Scene, Simulation};

fn run(name: &str, steps: usize, threads: usize) -> (u64, f64) {
    let scene = Scene::load(name).expect("built-in scene");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("pool");
    pool.install(|| {
        let mut sim = Simulation::new(&scene, LodPolicy::Fine).expect("scene builds");
        let ramp = u64::from(scene.scene.collision.depenetration_steps);
        let mut worst: f64 = 0.0;
        for _ in 0..steps {
            let s = sim.step().expect("step stays finite");
            if s.step >= ramp {
                worst = worst.max(s.max_penetration_m);
            }
        }
        let s = sim.state();
        assert!(
            s.positions()
                .iter()
                .all(|p| p.coords.iter().all(|c| c.is_finite()))
        );
        assert!(
            s.theta()
                .iter()
                .chain(s.phi())
                .chain(s.omega_theta())
                .chain(s.omega_phi())
                .all(|x| x.is_finite())
        );
        assert!(
            sim.render_geometry()
                .positions
                .iter()
                .all(|p| p.coords.iter().all(|c| c.is_finite()))
        );
        (sim.state_hash(), worst)
    })
}

#[test]
fn scenes_are_deterministic_across_thread_counts() {
    for name in ["wind", "torus"] {
        let (h1, _) = run(name, 20, 1);
        let (h2, _) = run(name, 20, 2);
        assert_eq!(h1, h2, "{name}: hash differs between 1 and 2 threads");
    }
}

#[test]
fn sintel_loads_with_its_guide_strands() {
    let scene = Scene::load("sintel").unwrap();
    let sim = Simulation::new(&scene, LodPolicy::Fine).unwrap();
    assert_eq!(sim.render_geometry().strand_count(), 228);
    assert!(sim.body().is_some_and(|b| b.triangles.len() == 5952));
}

#[test]
fn every_scene_file_parses_and_bad_scenes_name_the_field() {
    for (name, _) in hair::scene::BUILTIN {
        Scene::load(name).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
    let err = Scene::from_ron("Scene(frame_rate: -1.0)", "bad.ron")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("bad.ron") && err.contains("frame_rate"),
        "{err}"
    );
    let err = Scene::from_ron("Scene(\n  bogus: 1,\n)", "bad.ron")
        .unwrap_err()
        .to_string();
    assert!(err.contains("bad.ron:2"), "{err}");
    let err = Scene::from_ron("Scene(wind: (speed: inf))", "bad.ron")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("wind.speed") || err.contains("bad.ron"),
        "{err}"
    );
    assert!(Scene::load("no-such-scene").is_err());
}
