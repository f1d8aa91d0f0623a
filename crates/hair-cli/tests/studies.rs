//! `hair stability`, `hair accuracy` and `hair bench dynamics` through the `hair` binary on small
//! sweeps: each JSON document lists the second-order steps and the engines' XPBD beside our
//! integrators, with the keys the charts and the perf notes read, and each chart is written.

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;

/// Runs `hair ARGS`, asserting success; its standard output.
fn hair(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_hair"))
        .args(args)
        .output()
        .expect("the hair binary runs");
    assert!(
        out.status.success(),
        "hair {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&dir).expect("a scratch directory");
    dir
}

fn read_json(path: &PathBuf) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).expect("the JSON file")).expect("JSON")
}

fn is_png(path: &PathBuf) -> bool {
    std::fs::read(path).is_ok_and(|b| b.starts_with(b"\x89PNG\r\n\x1a\n"))
}

/// The entry of `integrators` named `name`.
fn method<'a>(doc: &'a Value, name: &str) -> &'a Value {
    doc["integrators"]
        .as_array()
        .expect("an integrators array")
        .iter()
        .find(|m| m["name"] == name)
        .unwrap_or_else(|| panic!("no integrator `{name}`"))
}

/// The methods every study compares: the coupled steps of each order and the engines' XPBD.
const COMPARED: [&str; 5] = [
    "implicit_coupled",
    "implicit_ros2",
    "implicit_ros3",
    "implicit_bdf2",
    "xpbd",
];

#[test]
fn stability_maps_the_second_order_steps_and_xpbd() {
    let dir = out_dir("stability");
    let (json, png) = (dir.join("s.json"), dir.join("s.png"));
    hair(&[
        "stability",
        "--json",
        json.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--k-min-log10",
        "-4",
        "--decades",
        "0",
        "--k-per-decade",
        "1",
    ]);
    let doc = read_json(&json);
    for name in COMPARED {
        let m = method(&doc, name);
        let cells = m["cells"].as_array().expect("cells");
        assert_eq!(cells.len(), 11, "{name}: one stiffness x 11 steps");
        let stable = cells.iter().filter(|c| c["stable"] == true).count();
        let gaining = cells
            .iter()
            .filter(|c| c["energy_grew"] == true && c["non_finite_at"].is_null())
            .count();
        assert_eq!(m["stable_cells"], stable, "{name}");
        assert_eq!(m["energy_gaining_cells"], gaining, "{name}");
    }
    // A soft strand: XPBD stays finite at every step, as the L-stable steps do.
    let xpbd = method(&doc, "xpbd")["cells"].as_array().unwrap();
    assert!(
        xpbd.iter().all(|c| c["non_finite_at"].is_null()),
        "{xpbd:?}"
    );
    assert!(is_png(&png));
}

#[test]
fn accuracy_runs_xpbd_at_a_hundredth_and_on_the_elastica() {
    let dir = out_dir("accuracy");
    let (json, png) = (dir.join("a.json"), dir.join("a.png"));
    hair(&[
        "accuracy",
        "--json",
        json.to_str().unwrap(),
        "--png",
        png.to_str().unwrap(),
        "--reference-dt",
        "1e-3",
        "--repeat",
        "1",
        "--steps-per-second",
        "100",
        "--segments",
        "8",
    ]);
    let doc = read_json(&json);
    for name in COMPARED {
        let runs = method(&doc, name)["runs"].as_array().expect("runs");
        let run = runs
            .iter()
            .find(|r| r["dt"].as_f64() == Some(0.01))
            .unwrap_or_else(|| panic!("{name}: no run at dt = 0.01"));
        let e = run["rms_tip_error_m"].as_f64().expect("a finite run");
        // The tip stays within the strand's reach of the reference tip: 2 L apart at most.
        assert!(e > 0.0 && e < 0.5, "{name}: {e}");
        assert!(run["cost_ms_per_sim_s"].as_f64().unwrap() > 0.0);
    }
    let rows = doc["elastica"].as_array().expect("elastica rows");
    for model in ["chain", "local", "xpbd"] {
        for alpha in [1.0, 10.0, 100.0] {
            let row = rows
                .iter()
                .find(|r| r["model"] == model && r["alpha"].as_f64() == Some(alpha))
                .unwrap_or_else(|| panic!("no elastica row for {model} at alpha {alpha}"));
            // The tip sags below the clamp and stays within the strand's length of it.
            let (x, y) = (
                row["tip_x_over_l"].as_f64().unwrap(),
                row["tip_y_over_l"].as_f64().unwrap(),
            );
            assert!(
                y > 0.0 && x.hypot(y) <= 1.0 + 1e-3,
                "{model} {alpha}: {x}, {y}"
            );
        }
    }
    assert!(is_png(&png));
}

#[test]
fn bench_dynamics_measures_the_coupled_steps_and_xpbd_in_one_run() {
    let out = hair(&[
        "bench",
        "dynamics",
        "--json",
        "--skeletons",
        "16",
        "--batch-seconds",
        "0.01",
        "--only",
        "implicit_coupled",
        "--only",
        "implicit_ros2",
        "--only",
        "implicit_ros3",
        "--only",
        "implicit_bdf2",
        "--only",
        "xpbd",
    ]);
    let doc: Value = serde_json::from_str(&out).expect("one JSON object");
    for key in COMPARED {
        let rate = doc[key]["node_steps_per_s"].as_f64();
        assert!(rate.is_some_and(|r| r > 0.0), "{key}: {doc}");
        assert_eq!(doc[key]["non_finite_steps"], 0, "{key}");
    }
    for key in [
        "implicit_bdf2_cost_over_implicit_coupled",
        "implicit_ros3_cost_over_implicit_coupled",
    ] {
        let cost = doc[key].as_f64();
        assert!(cost.is_some_and(|r| r > 0.0), "{key}: {doc}");
    }
    assert_eq!(doc["config"]["nodes"], 16 * 20);
}
