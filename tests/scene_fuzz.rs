//! Any scene text gives a scene or a typed error, never a panic; any scene that builds steps to a
//! finite state or stops with a typed error. Scenes are made by replacing one number of a small
//! scene that sets most fields with a value a user could type (zero, negative, tiny, huge, NaN,
//! infinite), or by cutting the text short. `HAIR_FUZZ_CASES=3000 cargo test -p hair --test
//! scene_fuzz` searches longer.

use hair::{LodPolicy, Scene, Simulation};
use proptest::prelude::*;

/// Small scenes (a few hundred strands on a coarse head, or on the torus) that set most fields,
/// tools included.
const BASES: [&str; 2] = [
    r#"Scene(
    name: "fuzz-head",
    seed: 3,
    frames: 10,
    frame_rate: 60.0,
    substeps: 2,
    lod: Adaptive,
    localization: true,
    body: Head(resolution: 24),
    hairstyle: Procedural((strands: 150, length: 0.2, points: 6, style: Wavy(amplitude: 0.01, period: 0.1),
        scalp_min_height: 0.01, scalp_max_forward: 0.06, parting_width: 0.005, strand_radius: 0.0015)),
    dynamics: (linear_density: 0.01, bending_stiffness: 2e-6, tip_stiffness_ratio: 0.3, damping: 2e-6,
        tip_damping_ratio: 0.3, radius: 0.002, gravity: (0.0, -9.81, 0.0)),
    collision: (friction: 0.3, parallel_angle: 0.3, tolerance: 0.001, depenetration_steps: 4),
    hierarchy: (root_strip_width: 0.0265, root_strip_depth: 0.026, strip_width_min: 0.013,
        cluster_radius_min: 0.01, min_group_fine: 1, min_group_coarse: 5),
    adaptive: (distance_finest: 0.5, distance_coarsest: 4.0, speed_coarsest: 0.05, speed_finest: 1.5,
        merge_distance: 0.02),
    camera: (keys: [(time: 0.0, eye: (0.0, 0.05, 0.6), target: (0.0, -0.05, 0.0)),
        (time: 1.0, eye: (0.0, 0.3, 3.0), target: (0.0, -0.05, 0.0))], fov_degrees: 40.0),
    wind: (direction: (0.0, 0.0, -1.0), speed: 3.0, gust: 0.3, gust_frequency: 0.7, turbulence: 0.2,
        turbulence_scale: 0.08, drag: 2e-4),
    head_motion: Shake(axis: (0.0, 1.0, 0.0), amplitude_degrees: 20.0, frequency: 1.0),
    tools: (events: [
        (time: 0.0, tool: Water, action: Press, pose: (position: (0.0, 0.2, 0.2), direction: (0.0, -1.0, -0.5), up: (0.0, 1.0, 0.0)),
            strength: 1.0, reach: 0.3, angle: 0.35),
        (time: 0.05, tool: Scissors, action: Press, pose: (position: (0.0, -0.1, -0.15), direction: (1.0, 0.0, 0.0), up: (0.0, 1.0, 0.0)),
            reach: 0.2, angle: 0.3),
        (time: 0.08, tool: Grab, action: Press, pose: (position: (0.1, 0.0, -0.1), direction: (0.0, 0.0, -1.0), up: (0.0, 1.0, 0.0)),
            path: [(time: 0.12, pose: (position: (0.2, 0.0, -0.2), direction: (0.0, 0.0, -1.0), up: (0.0, 1.0, 0.0)))]),
    ]),
)"#,
    r#"Scene(
    name: "fuzz-torus",
    seed: 5,
    body: Torus(center: (0.0, -0.2, 0.0), major: 0.16, minor: 0.05, wrinkles: 12, depth: 0.15),
    hairstyle: Procedural((strands: 120, length: 0.3, points: 8, style: Straight, scalp_min_height: 0.02)),
    collision: (method: Bvh, friction: 0.5),
    head_motion: Shake(axis: (0.0, 1.0, 0.0), amplitude_degrees: 30.0, frequency: 0.5),
)"#,
];

/// What a user might type in place of a number.
const VALUES: [&str; 16] = [
    "0", "0.0", "-0.0", "-1", "-1.0", "1e-30", "-1e-30", "1e30", "-1e30", "1e38", "inf", "-inf",
    "NaN", "3", "0.5", "65",
];

/// The byte ranges of the numbers in `text` (digits with an optional sign, point and exponent).
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts =
            b[i].is_ascii_digit() || (b[i] == b'-' && i + 1 < b.len() && b[i + 1].is_ascii_digit());
        // Not inside a name such as `min_group_fine` or `v2`.
        let inside_word = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
        if starts && !inside_word {
            let start = i;
            i += 1;
            while i < b.len()
                && (b[i].is_ascii_digit()
                    || b[i] == b'.'
                    || b[i] == b'e'
                    || (b[i] == b'-' && b[i - 1] == b'e'))
            {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

/// A scene made in memory, its relative paths (none here) read from the working directory.
fn loaded(scene: Scene) -> hair::scene::LoadedScene {
    hair::scene::LoadedScene {
        source: format!("{}.ron", scene.name),
        scene,
        base_dir: std::path::PathBuf::from("."),
    }
}

/// Builds and steps `text`; panics (failing the property) only on a panic inside the library or
/// a non-finite state after a step that returned `Ok`.
fn exercise(text: &str) {
    let Ok(scene) = Scene::from_ron(text, "fuzz.ron") else {
        return;
    };
    let loaded = loaded(scene);
    for policy in [LodPolicy::Fine, LodPolicy::Adaptive] {
        let Ok(mut sim) = Simulation::new(&loaded, policy) else {
            continue;
        };
        for _ in 0..6 {
            if sim.step().is_err() {
                break;
            }
            let state = sim.state();
            assert!(
                state
                    .positions()
                    .iter()
                    .all(|p| p.coords.iter().all(|c| c.is_finite())),
                "a step returned Ok with a non-finite position"
            );
            assert!(
                sim.render_geometry()
                    .positions
                    .iter()
                    .all(|p| p.coords.iter().all(|c| c.is_finite())),
                "a step returned Ok with a non-finite render point"
            );
        }
    }
}

proptest! {
    // 96 cases in the suite; `HAIR_FUZZ_CASES=3000` for a longer search.
    #![proptest_config(ProptestConfig {
        cases: std::env::var("HAIR_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(96),
        ..ProptestConfig::default()
    })]

    #[test]
    fn one_number_replaced_gives_a_scene_or_an_error(
        base in 0..BASES.len(),
        pick in any::<prop::sample::Index>(),
        value in 0..VALUES.len(),
    ) {
        let text = BASES[base];
        let spans = numbers(text);
        let (start, end) = spans[pick.index(spans.len())];
        let mutated = format!("{}{}{}", &text[..start], VALUES[value], &text[end..]);
        // Where the number was, for the report of a failure.
        let line = text[..start].lines().count();
        let context = &text[start.saturating_sub(30)..end];
        eprintln!("scene {base}, line {line}: ...{context} -> {}", VALUES[value]);
        exercise(&mutated);
    }

    #[test]
    fn a_text_cut_short_gives_an_error(base in 0..BASES.len(), cut in any::<prop::sample::Index>()) {
        let text = BASES[base];
        // Cut before the closing parenthesis: what is left is never a whole scene.
        let at = cut.index(text.trim_end().len() - 1);
        if text.is_char_boundary(at) {
            prop_assert!(Scene::from_ron(&text[..at], "cut.ron").is_err());
        }
    }
}

/// The bases themselves build and step (or the properties above would test only errors).
#[test]
fn the_bases_simulate() {
    for text in BASES {
        let loaded = loaded(Scene::from_ron(text, "base.ron").expect("base scene parses"));
        let mut sim = Simulation::new(&loaded, LodPolicy::Fine).expect("base scene builds");
        for _ in 0..6 {
            sim.step().expect("base scene steps");
        }
        assert!(numbers(text).len() > 15, "the base sets many numbers");
    }
}
