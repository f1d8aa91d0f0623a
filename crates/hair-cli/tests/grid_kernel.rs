//! `HAIR_GRID_KERNEL` through the `hair` binary: a narrower kernel asked for is the one the
//! grid benchmark names, with the same pairs as the widest one; a name that is no kernel stops
//! every command with an error naming the variable, before any work.

use std::process::Command;

/// `hair bench grid` on a small scene with `HAIR_GRID_KERNEL` set to `kernel` (unset for
/// `None`): its JSON object.
fn bench_grid(kernel: Option<&str>) -> serde_json::Value {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_hair"));
    cmd.args(["bench", "grid", "--json", "--skip-peer"]).args([
        "--segments",
        "6000",
        "--brute-force",
        "2000",
        "--repeat",
        "1",
    ]);
    match kernel {
        Some(k) => cmd.env("HAIR_GRID_KERNEL", k),
        None => cmd.env_remove("HAIR_GRID_KERNEL"),
    };
    let out = cmd.output().expect("the hair binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("one JSON object")
}

#[test]
fn a_narrower_kernel_asked_for_runs_and_finds_the_same_pairs() {
    let widest = bench_grid(None);
    let base = bench_grid(Some("baseline"));
    assert_eq!(base["kernel"], "baseline");
    assert_eq!(base["pairs"], widest["pairs"]);
    assert_eq!(base["candidates"], widest["candidates"]);
    assert_eq!(base["agrees_with_brute_force"], true);
    // Asking for AVX2 never runs something wider; on a processor without it, the baseline.
    let avx2 = bench_grid(Some("avx2"));
    assert!(
        avx2["kernel"] == "avx2" || avx2["kernel"] == "baseline",
        "{}",
        avx2["kernel"]
    );
    assert_eq!(avx2["pairs"], widest["pairs"]);
}

#[test]
fn a_name_that_is_no_kernel_is_an_error_naming_the_variable() {
    let out = Command::new(env!("CARGO_BIN_EXE_hair"))
        .arg("scenes")
        .env("HAIR_GRID_KERNEL", "avx1024")
        .output()
        .expect("the hair binary runs");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("HAIR_GRID_KERNEL") && err.contains("avx1024"),
        "{err}"
    );
    assert!(out.stdout.is_empty(), "no work before the error");
}
