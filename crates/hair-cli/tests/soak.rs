//! `hair soak`: the built binary under random salon tool use (its global allocator counts the
//! allocations, so the test runs the binary rather than the library).

use std::process::Command;

/// Runs `hair soak salon --steps N --seed S --json` and returns its JSON report and whether the
/// command succeeded.
fn soak(steps: u64, seed: u64) -> (serde_json::Value, bool) {
    let out = Command::new(env!("CARGO_BIN_EXE_hair"))
        .args(["soak", "salon", "--json", "--threads", "2"])
        .args(["--steps", &steps.to_string(), "--seed", &seed.to_string()])
        .output()
        .expect("the hair binary runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report = serde_json::from_str(&stdout).unwrap_or_else(|e| {
        panic!(
            "not one JSON object ({e}):\n{stdout}\nstderr:\n{}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    (report, out.status.success())
}

fn number(report: &serde_json::Value, field: &str) -> f64 {
    report[field]
        .as_f64()
        .unwrap_or_else(|| panic!("`{field}` is not a number in {report:#}"))
}

/// Every check of a soak report, with the events that must have been fired.
fn check(report: &serde_json::Value, passed: bool, steps: u64) {
    assert_eq!(number(report, "steps"), steps as f64);
    assert_eq!(number(report, "non_finite"), 0.0, "{report:#}");
    assert!(report["first_non_finite"].is_null(), "{report:#}");
    let (pen, tol) = (
        number(report, "max_penetration_m"),
        number(report, "tolerance_m"),
    );
    assert!(
        pen.is_finite() && pen <= tol,
        "penetration {pen} m over {tol} m"
    );
    assert_eq!(
        number(report, "allocations_after_warmup"),
        0.0,
        "{report:#}"
    );
    let ratio = number(report, "max_energy_ratio");
    assert!(ratio.is_finite() && ratio >= 1.0, "energy ratio {ratio}");
    // Every tool was pressed and released at least once, and the camera moved.
    let tools = report["events"]["tools"].as_object().expect("tools");
    assert_eq!(tools.len(), 6, "{tools:?}");
    for (tool, counts) in tools {
        for action in ["press", "move", "release"] {
            assert!(
                counts[action].as_u64().unwrap_or(0) > 0,
                "{tool} never had a {action}: {counts}"
            );
        }
    }
    assert!(report["events"]["camera"].as_u64().unwrap_or(0) > 0);
    // The tools acted: hair was cut, wetted and bonded.
    let salon = &report["salon"];
    assert!(salon["cuts"].as_u64().unwrap_or(0) > 0, "{salon}");
    assert!(salon["bonds_made"].as_u64().unwrap_or(0) > 0, "{salon}");
    assert!(passed, "the command failed: {report:#}");
}

#[test]
fn salon_soak_of_2000_steps_stays_finite_inside_tolerance_and_allocation_free() {
    let (report, passed) = soak(2000, 1);
    check(&report, passed, 2000);
}

/// A different seed is a different session (the seed reaches the events); the same seed the
/// same one.
#[test]
fn the_seed_decides_the_session() {
    let (a, _) = soak(60, 1);
    let (b, _) = soak(60, 1);
    let (c, _) = soak(60, 2);
    assert_eq!(a["state_hash"], b["state_hash"]);
    assert_eq!(a["events"], b["events"]);
    assert_ne!(a["state_hash"], c["state_hash"]);
}

/// The long soak: `cargo test --release -p hair-cli --test soak -- --ignored` (figures in
/// `docs/perf/soak.md`).
#[test]
#[ignore = "100,000 steps: about 40 minutes in release on two busy cores"]
fn salon_soak_of_100000_steps() {
    let (report, passed) = soak(100_000, 1);
    check(&report, passed, 100_000);
}
