//! Unit tests of the soak's generator and checks.

use super::checks::{NonFinite, first_non_finite};
use super::events::SplitMix64;
use super::*;
use hair::dynamics::SkeletonId;
use hair::scene::{BodySpec, HairstyleSpec};

fn small_salon() -> Simulation {
    let mut loaded = Scene::load("salon").expect("built-in salon");
    loaded.scene.tools.events.clear();
    if let HairstyleSpec::Procedural(p) = &mut loaded.scene.hairstyle {
        p.strands = 40;
    }
    loaded.scene.body = BodySpec::Head { resolution: 12 };
    Simulation::new(&loaded, LodPolicy::Fine).expect("the scene builds")
}

#[test]
fn splitmix_gives_the_reference_stream() {
    // The first outputs of SplitMix64 from seed 0 (Vigna's reference `splitmix64.c`).
    let mut rng = SplitMix64(0);
    assert_eq!(rng.next_u64(), 0xe220_a839_7b1d_cdaf);
    assert_eq!(rng.next_u64(), 0x6e78_9e6a_a1b9_65f4);
}

#[test]
fn a_non_finite_value_anywhere_in_the_state_is_found() {
    let sim = small_salon();
    assert_eq!(first_non_finite(sim.state(), Some(sim.salon())), None);
    let n = sim.state().node_count();
    for (node, value) in [
        (0, f32::NAN),
        (n / 2, f32::INFINITY),
        (n - 1, f32::NEG_INFINITY),
    ] {
        let mut state = sim.state().clone();
        state.omega_phi_mut()[node] = value;
        let found = first_non_finite(&state, None);
        assert_eq!(
            found,
            Some(NonFinite {
                field: "omega_phi",
                node
            })
        );
        let mut state = sim.state().clone();
        state.external_force_mut()[node].y = value;
        let found = first_non_finite(&state, None).map(|f| f.field);
        assert_eq!(found, Some("external_force"));
    }
}

#[test]
fn every_generated_event_is_one_the_script_accepts() {
    let sim = small_salon();
    let hair = HairBox::of(&sim.render_geometry().positions).expect("hair");
    let mut maker = EventMaker::new(7, hair);
    let mut script = hair::ToolScript::default();
    for k in 0..3000 {
        match maker.event(0.01 * k as f32) {
            Ok(event) => {
                maker.took(&event);
                script.events.push(event);
            }
            Err(key) => assert!(key.eye.iter().chain(&key.target).all(|x| x.is_finite())),
        }
    }
    script.validate().expect("a valid script");
    // Every kind came up.
    assert!(
        maker.counts.iter().flatten().all(|&c| c > 0),
        "{:?}",
        maker.counts
    );
    assert!(maker.paths > 0);
}

#[test]
fn the_energy_at_rest_is_the_weight_above_the_lowest_node() {
    let sim = small_salon();
    let g = [0.0, -9.81, 0.0];
    let floor = lowest_height(&sim, g);
    // Lifting the floor by 1 m takes 1 m times the hair's weight from the energy.
    let (state, h) = (sim.state(), sim.hierarchy());
    let weight: f64 = sim
        .front_nodes()
        .iter()
        .flat_map(|&n| state.nodes(SkeletonId(n)).map(move |i| (n, i)))
        .map(|(n, i)| {
            f64::from(h.strand_count(n))
                * f64::from(9.81f32)
                * f64::from(state.mass()[i] + state.wetness()[i])
        })
        .sum();
    let e0 = mechanical_energy(&sim, g, floor);
    let e1 = mechanical_energy(&sim, g, floor + 1.0);
    assert!(e0 > 0.0);
    assert!(
        ((e0 - e1) - weight).abs() <= 1e-9 * weight,
        "{e0} {e1} {weight}"
    );
    // No gravity, at rest: no energy.
    assert_eq!(mechanical_energy(&sim, [0.0; 3], floor), 0.0);
}
