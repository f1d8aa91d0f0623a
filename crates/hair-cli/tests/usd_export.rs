//! `hair run SCENE --usd FILE.usda` through the binary: the stage and the positions beside it
//! are what they claim (the `.npy` shape is frames x points x 3, the stage holds one animated
//! `BasisCurves` prim with one time sample per frame and the same points), and a second run
//! keeps both files unless `--replace` is given.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hair-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `hair run wind --frames 3 --threads 2 --out DIR/run` with `extra` arguments.
fn run_wind(dir: &Path, extra: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hair"))
        .args(["run", "wind", "--frames", "3", "--threads", "2", "--out"])
        .arg(dir.join("run"))
        .args(extra)
        .output()
        .expect("the hair binary runs")
}

/// The `.npy` header's shape and the float32 values after the header.
fn read_npy(path: &Path) -> (Vec<usize>, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00", "{}", path.display());
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let dict = std::str::from_utf8(&bytes[10..10 + len]).unwrap();
    assert!(dict.contains("'descr': '<f4'"), "{dict}");
    let shape = dict
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .unwrap();
    let shape = shape
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().unwrap())
        .collect();
    let data = bytes[10 + len..]
        .chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    (shape, data)
}

/// The stage's metadata value for `key`, its curve vertex counts and its points' time samples
/// (time code, coordinates read as USD reads `point3f` text: a double, then narrowed).
struct Stage {
    text: String,
    counts: Vec<usize>,
    samples: Vec<(f64, Vec<f32>)>,
}

impl Stage {
    fn read(path: &Path) -> Self {
        let text = std::fs::read_to_string(path).unwrap();
        let mut counts = Vec::new();
        let mut samples = Vec::new();
        let mut in_points = false;
        for line in text.lines().map(str::trim) {
            if in_points {
                if line == "}" {
                    in_points = false;
                    continue;
                }
                let (time, value) = line.split_once(": ").unwrap();
                let values = value
                    .split(|c: char| "[](), ".contains(c))
                    .filter(|s| !s.is_empty())
                    .map(|s| s.parse::<f64>().unwrap() as f32)
                    .collect();
                samples.push((time.parse().unwrap(), values));
            } else if let Some(v) = line.strip_prefix("int[] curveVertexCounts = ") {
                counts = v
                    .trim_matches(|c| c == '[' || c == ']')
                    .split(", ")
                    .map(|n| n.parse().unwrap())
                    .collect();
            } else if line == "point3f[] points.timeSamples = {" {
                in_points = true;
            }
        }
        Self {
            text,
            counts,
            samples,
        }
    }

    fn meta(&self, key: &str) -> &str {
        self.text
            .lines()
            .find_map(|l| l.trim().strip_prefix(&format!("{key} = ")))
            .unwrap_or_else(|| panic!("no `{key}` in the stage"))
            .trim()
    }
}

#[test]
fn usd_export_is_what_it_claims_and_an_existing_file_is_kept() {
    let dir = temp_dir("usd");
    let usd = dir.join("out").join("wind.usda");
    let npy = dir.join("out").join("wind.npy");
    let out = run_wind(&dir, &["--usd", usd.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // The positions beside the stage, with its stem: 3 frames of every drawn point.
    let (shape, values) = read_npy(&npy);
    let stage = Stage::read(&usd);
    let points: usize = stage.counts.iter().sum();
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("run/summary.json")).unwrap()).unwrap();
    assert_eq!(shape, [3, points, 3]);
    assert_eq!(values.len(), 3 * points * 3);
    assert_eq!(
        stage.counts.len() as u64,
        summary["strands"].as_u64().unwrap()
    );
    assert_eq!(points as u64, summary["render_vertices"].as_u64().unwrap());

    // One animated BasisCurves prim: a time sample per frame, time code k + 1 after frame k.
    assert_eq!(stage.text.matches("def BasisCurves").count(), 1);
    assert!(stage.text.contains("def Mesh \"Body\""));
    assert!(stage.text.contains("uniform token type = \"linear\""));
    assert!(stage.text.contains("float[] widths = ["));
    let times: Vec<f64> = stage.samples.iter().map(|s| s.0).collect();
    assert_eq!(times, [1.0, 2.0, 3.0]);
    assert_eq!(stage.meta("upAxis"), "\"Y\"");
    assert_eq!(stage.meta("metersPerUnit"), "1");
    assert_eq!(stage.meta("timeCodesPerSecond"), "60");
    assert_eq!(stage.meta("startTimeCode"), "1");
    assert_eq!(stage.meta("endTimeCode"), "3");
    // The stage's points are the positions file's, to the bit.
    for (k, (_, sample)) in stage.samples.iter().enumerate() {
        let frame = &values[k * points * 3..(k + 1) * points * 3];
        assert_eq!(sample.len(), frame.len());
        let differ = sample
            .iter()
            .zip(frame)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(differ, 0, "frame {k}: {differ} values differ");
    }
    // The strands moved: the samples are frames, not one frame repeated.
    assert_ne!(stage.samples[0].1, stage.samples[2].1);

    // A second run keeps both files, names the one it refused and the flag, and leaves nothing
    // behind; the simulation is not even started.
    let (usd_bytes, npy_bytes) = (std::fs::read(&usd).unwrap(), std::fs::read(&npy).unwrap());
    let again = run_wind(&dir, &["--usd", usd.to_str().unwrap()]);
    assert!(!again.status.success());
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(
        err.contains(&*usd.display().to_string()) && err.contains("--replace"),
        "{err}"
    );
    // `--positions` names another file, but the stage still exists.
    let other = dir.join("other.npy");
    let again = run_wind(
        &dir,
        &[
            "--usd",
            usd.to_str().unwrap(),
            "--positions",
            other.to_str().unwrap(),
        ],
    );
    assert!(!again.status.success());
    assert!(!other.exists());
    assert_eq!(std::fs::read(&usd).unwrap(), usd_bytes);
    assert_eq!(std::fs::read(&npy).unwrap(), npy_bytes);
    let mut names: Vec<String> = std::fs::read_dir(dir.join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["wind.npy", "wind.usda"]);

    // With --replace it writes over them: the same scene and seed give the same files.
    let replaced = run_wind(&dir, &["--usd", usd.to_str().unwrap(), "--replace"]);
    assert!(
        replaced.status.success(),
        "{}",
        String::from_utf8_lossy(&replaced.stderr)
    );
    assert_eq!(std::fs::read(&usd).unwrap(), usd_bytes);
    assert_eq!(std::fs::read(&npy).unwrap(), npy_bytes);
    let _ = std::fs::remove_dir_all(&dir);
}
