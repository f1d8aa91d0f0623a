//! The USD export and the positions file: read back by a small reader of the layout the writer
//! documents, exact to the bit; bad values refused by frame and point; existing files kept.

use hair_io::usda::{BodyPose, UpAxis, UsdStage, UsdaWriter};
use hair_io::{Existing, IoError, Mesh, npy::NpyPointsWriter, obj};
use proptest::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// What the reader finds in a `.usda` file written by [`UsdaWriter`].
#[derive(Debug, Default)]
struct Usda {
    meta: HashMap<String, String>,
    curve_type: String,
    wrap: String,
    counts: Vec<u32>,
    widths: Vec<f32>,
    interpolation: String,
    samples: Vec<(f64, Vec<[f32; 3]>)>,
    body_points: Vec<[f32; 3]>,
    body_face_counts: Vec<u32>,
    body_indices: Vec<u32>,
    poses: Vec<(f64, Vec<f64>)>,
}

/// Numbers of a bracketed list; `float` and `point3f` text is read as USD reads it: a double,
/// then narrowed.
fn numbers(text: &str) -> Vec<f64> {
    text.split(|c: char| "[](), ".contains(c))
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f64>().unwrap_or_else(|e| panic!("`{s}`: {e}")))
        .collect()
}

fn points(text: &str) -> Vec<[f32; 3]> {
    let n = numbers(text);
    assert_eq!(n.len() % 3, 0, "{text}");
    n.chunks_exact(3)
        .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32])
        .collect()
}

fn after<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.trim().strip_prefix(key).map(str::trim)
}

fn read_usda(path: &Path) -> Usda {
    let text = std::fs::read_to_string(path).unwrap();
    let mut u = Usda::default();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("#usda 1.0"));
    assert_eq!(lines.next(), Some("("));
    for line in lines.by_ref() {
        if line == ")" {
            break;
        }
        let (k, v) = line.split_once(" = ").unwrap();
        u.meta.insert(k.trim().into(), v.trim().into());
    }
    let mut in_points = false;
    let mut in_poses = false;
    while let Some(line) = lines.next() {
        let t = line.trim();
        if in_points || in_poses {
            if t == "}" {
                (in_points, in_poses) = (false, false);
                continue;
            }
            let (time, value) = t.split_once(": ").unwrap();
            let time: f64 = time.parse().unwrap();
            let value = value.strip_suffix(',').unwrap();
            if in_points {
                u.samples.push((time, points(value)));
            } else {
                u.poses.push((time, numbers(value)));
            }
        } else if let Some(v) = after(t, "uniform token type =") {
            u.curve_type = v.trim_matches('"').into();
        } else if let Some(v) = after(t, "uniform token wrap =") {
            u.wrap = v.trim_matches('"').into();
        } else if let Some(v) = after(t, "int[] curveVertexCounts =") {
            u.counts = numbers(v).into_iter().map(|x| x as u32).collect();
        } else if let Some(v) = after(t, "float[] widths =") {
            u.widths = numbers(v.strip_suffix(" (").unwrap())
                .into_iter()
                .map(|x| x as f32)
                .collect();
            let next = lines.next().unwrap();
            u.interpolation = after(next, "interpolation =")
                .unwrap()
                .trim_matches('"')
                .into();
        } else if t == "point3f[] points.timeSamples = {" {
            in_points = true;
        } else if t == "matrix4d xformOp:transform.timeSamples = {" {
            in_poses = true;
        } else if let Some(v) = after(t, "int[] faceVertexCounts =") {
            u.body_face_counts = numbers(v).into_iter().map(|x| x as u32).collect();
        } else if let Some(v) = after(t, "int[] faceVertexIndices =") {
            u.body_indices = numbers(v).into_iter().map(|x| x as u32).collect();
        } else if let Some(v) = after(t, "point3f[] points =") {
            u.body_points = points(v);
        }
    }
    u
}

/// The `.npy` header's shape and the float32 data after it.
fn read_npy(path: &Path) -> (Vec<usize>, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..8], b"\x93NUMPY\x01\x00");
    let len = u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    assert_eq!((10 + len) % 64, 0);
    let dict = std::str::from_utf8(&bytes[10..10 + len]).unwrap();
    assert!(
        dict.ends_with('\n') && dict.contains("'descr': '<f4'"),
        "{dict}"
    );
    let shape = dict
        .split("'shape': (")
        .nth(1)
        .unwrap()
        .split(')')
        .next()
        .unwrap();
    let shape = shape
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let data = bytes[10 + len..]
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes(b.try_into().unwrap()))
        .collect();
    (shape, data)
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hair-io-usd-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn triangle() -> Mesh {
    Mesh {
        vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2]],
    }
}

/// Coordinates with the degenerate cases in: zeros of both signs, subnormals, the extremes,
/// the one value whose shortest text fails through a double, and ordinary metres.
fn coordinate() -> impl Strategy<Value = f32> {
    prop_oneof![
        Just(0.0f32),
        Just(-0.0f32),
        Just(f32::MIN_POSITIVE),
        Just(f32::from_bits(1)),
        Just(f32::MAX),
        Just(f32::MIN),
        Just(f32::from_bits(0x15ae_43fd)),
        Just(1e-5f32),
        Just(1e9f32),
        -1.0f32..1.0,
        any::<f32>().prop_filter("finite", |x| x.is_finite()),
    ]
}

/// Frames as (time code, points).
type Frames = Vec<(f64, Vec<[f32; 3]>)>;

/// Curves (0 to 5, of 2 to 6 points), 0 to 4 frames of them, and increasing time codes.
fn animation() -> impl Strategy<Value = (Vec<u32>, Frames)> {
    prop::collection::vec(2u32..7, 0..6).prop_flat_map(|counts| {
        let n: usize = counts.iter().map(|&c| c as usize).sum();
        let frame = prop::collection::vec([coordinate(), coordinate(), coordinate()], n..=n);
        let frames = prop::collection::vec((1e-3f64..10.0, frame), 0..5);
        (Just(counts), -100.0f64..100.0, frames).prop_map(|(counts, start, frames)| {
            let mut t = start;
            let frames = frames
                .into_iter()
                .map(|(dt, points)| {
                    t += dt;
                    (t, points)
                })
                .collect();
            (counts, frames)
        })
    })
}

fn bits(points: &[[f32; 3]]) -> Vec<[u32; 3]> {
    points.iter().map(|p| p.map(f32::to_bits)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Any finite frames come back bit for bit, with their time codes, counts and metadata; the
    /// positions file holds the same values.
    #[test]
    fn any_finite_frames_round_trip_exactly((counts, frames) in animation(), body in any::<bool>()) {
        let dir = temp_dir("prop");
        let (usd, npy) = (dir.join("a.usda"), dir.join("a.npy"));
        let stage = UsdStage { up_axis: UpAxis::Z, meters_per_unit: 0.01, time_codes_per_second: 30.0 };
        let mesh = triangle();
        let mut w = UsdaWriter::create(&usd, &stage, body.then_some(&mesh), &counts, &[0.002], Existing::Replace).unwrap();
        let mut p = NpyPointsWriter::create(&npy, &counts, Existing::Replace).unwrap();
        for (t, points) in &frames {
            w.write_frame(*t, points.iter().copied()).unwrap();
            p.write_frame(points.iter().copied()).unwrap();
        }
        w.finish().unwrap();
        p.finish().unwrap();
        let u = read_usda(&usd);
        prop_assert_eq!(&u.counts, &counts);
        prop_assert_eq!(u.samples.len(), frames.len());
        for ((t, got), (want_t, want)) in u.samples.iter().zip(&frames) {
            prop_assert_eq!(t.to_bits(), want_t.to_bits());
            prop_assert_eq!(bits(got), bits(want));
        }
        prop_assert_eq!(&u.meta["upAxis"], "\"Z\"");
        prop_assert_eq!(&u.meta["metersPerUnit"], "0.01");
        prop_assert_eq!(&u.meta["timeCodesPerSecond"], "30");
        let first = frames.first().map_or(0.0, |f| f.0);
        let last = frames.last().map_or(0.0, |f| f.0);
        prop_assert_eq!(u.meta["startTimeCode"].parse::<f64>().unwrap(), first);
        prop_assert_eq!(u.meta["endTimeCode"].parse::<f64>().unwrap(), last);
        prop_assert_eq!(u.body_points.len(), if body { 3 } else { 0 });
        let (shape, data) = read_npy(&npy);
        let n: usize = counts.iter().map(|&c| c as usize).sum();
        prop_assert_eq!(shape, vec![frames.len(), n, 3]);
        let want: Vec<u32> = frames.iter().flat_map(|f| f.1.iter().flatten()).map(|x| x.to_bits()).collect();
        prop_assert_eq!(data.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), want);
        prop_assert_eq!(files_in(&dir), ["a.npy", "a.usda"]);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A NaN or infinity anywhere is refused with its frame and point, nothing of that frame is
    /// written, and the writers go on.
    #[test]
    fn non_finite_points_are_refused_naming_frame_and_point(
        (counts, frames) in animation().prop_filter("a point", |(c, f)| !c.is_empty() && !f.is_empty()),
        pick in any::<prop::sample::Index>(),
        axis in 0usize..3,
        bad in prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)],
    ) {
        let dir = temp_dir("nonfinite");
        let (usd, npy) = (dir.join("b.usda"), dir.join("b.npy"));
        let mut w = UsdaWriter::create(&usd, &UsdStage::default(), None, &counts, &[0.001], Existing::Replace).unwrap();
        let mut p = NpyPointsWriter::create(&npy, &counts, Existing::Replace).unwrap();
        let (t0, good) = &frames[0];
        w.write_frame(*t0, good.iter().copied()).unwrap();
        p.write_frame(good.iter().copied()).unwrap();
        let point = pick.index(good.len());
        let mut broken = good.clone();
        broken[point][axis] = bad;
        let curve = counts.iter().scan(0u32, |acc, &c| { *acc += c; Some(*acc) })
            .position(|end| point < end as usize).unwrap();
        let usd_err = w.write_frame(t0 + 1.0, broken.iter().copied()).unwrap_err();
        let npy_err = p.write_frame(broken.iter().copied()).unwrap_err();
        for err in [&usd_err, &npy_err] {
            let is_expected = matches!(
                err,
                IoError::NonFiniteFrame { frame: 1, point: pt, curve: c, .. } if *pt == point && *c == curve
            );
            prop_assert!(is_expected, "{}", err);
            let message = err.to_string();
            prop_assert!(message.contains(&format!("frame 1: point {point} (curve {curve})")), "{}", message);
        }
        w.write_frame(t0 + 2.0, good.iter().copied()).unwrap();
        p.write_frame(good.iter().copied()).unwrap();
        w.finish().unwrap();
        p.finish().unwrap();
        let u = read_usda(&usd);
        prop_assert_eq!(u.samples.len(), 2);
        prop_assert_eq!(u.samples[1].0, t0 + 2.0);
        prop_assert_eq!(read_npy(&npy).0[0], 2);
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// The file's text, line by line, for a small stage: the layout the module documents.
#[test]
fn usda_layout_is_as_documented() {
    let dir = temp_dir("golden");
    let path = dir.join("g.usda");
    let stage = UsdStage {
        time_codes_per_second: 24.0,
        ..UsdStage::default()
    };
    let mut w = UsdaWriter::create(
        &path,
        &stage,
        Some(&triangle()),
        &[2, 3],
        &[0.001, 0.002],
        Existing::Keep,
    )
    .unwrap();
    let frame = |dx: f32| {
        [
            [dx, 0.0, 0.0],
            [dx, -0.1, 0.0],
            [0.5, 0.0, 1e-7],
            [0.5, -0.1, 0.0],
            [0.5, -0.2, 0.0],
        ]
    };
    let pose = |tx: f32| BodyPose {
        rotation: [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [tx, 2.0, 3.0],
    };
    w.write_frame_posed(1.0, frame(0.0), &pose(0.0)).unwrap();
    w.write_frame_posed(2.5, frame(0.25), &pose(1.0)).unwrap();
    w.finish().unwrap();
    let want = r#"#usda 1.0
(
    defaultPrim = "Hair"
    doc = "Hair strands and body written by hair-io"
    metersPerUnit = 1
    upAxis = "Y"
    timeCodesPerSecond = 24
    framesPerSecond = 24
    startTimeCode = 1                               
    endTimeCode = 2.5                             
)

def Xform "Hair"
{
    def BasisCurves "Strands" (
        doc = "The drawn strands: polylines subdivided along Catmull-Rom curves, exact as linear curves"
    )
    {
        uniform token type = "linear"
        uniform token wrap = "nonperiodic"
        int[] curveVertexCounts = [2, 3]
        float[] widths = [0.001, 0.002] (
            interpolation = "uniform"
        )
        point3f[] points.timeSamples = {
            1: [(0, 0, 0), (0, -0.1, 0), (0.5, 0, 1e-7), (0.5, -0.1, 0), (0.5, -0.2, 0)],
            2.5: [(0.25, 0, 0), (0.25, -0.1, 0), (0.5, 0, 1e-7), (0.5, -0.1, 0), (0.5, -0.2, 0)],
        }
    }

    def Mesh "Body"
    {
        uniform token subdivisionScheme = "none"
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]
        matrix4d xformOp:transform.timeSamples = {
            1: ( (0, 1, 0, 0), (-1, 0, 0, 0), (0, 0, 1, 0), (0, 2, 3, 1) ),
            2.5: ( (0, 1, 0, 0), (-1, 0, 0, 0), (0, 0, 1, 0), (1, 2, 3, 1) ),
        }
        uniform token[] xformOpOrder = ["xformOp:transform"]
    }
}
"#;
    let got = std::fs::read_to_string(&path).unwrap();
    for (i, (g, w)) in got.lines().zip(want.lines()).enumerate() {
        assert_eq!(g, w, "line {}", i + 1);
    }
    assert_eq!(got, want);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A file the user has is never replaced unless asked: not when the writer is created, and not
/// when one appears while it runs. Nothing is left beside it.
#[test]
fn existing_file_is_not_overwritten() {
    let dir = temp_dir("existing");
    let path = dir.join("mine.usda");
    std::fs::write(&path, "mine").unwrap();
    let create =
        |existing| UsdaWriter::create(&path, &UsdStage::default(), None, &[2], &[0.001], existing);
    let err = create(Existing::Keep).err().unwrap();
    assert!(matches!(err, IoError::Exists { .. }), "{err}");
    assert!(err.to_string().contains("mine.usda"), "{err}");
    let npy = dir.join("mine.npy");
    std::fs::write(&npy, "mine too").unwrap();
    assert!(matches!(
        NpyPointsWriter::create(&npy, &[2], Existing::Keep),
        Err(IoError::Exists { .. })
    ));
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "mine");

    // Created while the path was free, finished after the user wrote a file there.
    std::fs::remove_file(&path).unwrap();
    let mut w = create(Existing::Keep).unwrap();
    w.write_frame(0.0, [[0.0; 3], [1.0; 3]]).unwrap();
    std::fs::write(&path, "mine, meanwhile").unwrap();
    assert!(matches!(w.finish(), Err(IoError::Exists { .. })));
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "mine, meanwhile");

    // Asked to replace it, it does.
    let mut w = create(Existing::Replace).unwrap();
    w.write_frame(0.0, [[0.0; 3], [1.0; 3]]).unwrap();
    w.finish().unwrap();
    assert_eq!(read_usda(&path).samples.len(), 1);
    assert_eq!(files_in(&dir), ["mine.npy", "mine.usda"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A writer dropped before it finishes (a run that failed) leaves no file at all.
#[test]
fn unfinished_writers_leave_nothing() {
    let dir = temp_dir("unfinished");
    let mut w = UsdaWriter::create(
        &dir.join("x.usda"),
        &UsdStage::default(),
        None,
        &[2],
        &[0.001],
        Existing::Keep,
    )
    .unwrap();
    w.write_frame(0.0, [[0.0; 3], [1.0; 3]]).unwrap();
    let mut p = NpyPointsWriter::create(&dir.join("x.npy"), &[2], Existing::Keep).unwrap();
    p.write_frame([[0.0; 3], [1.0; 3]]).unwrap();
    assert_eq!(files_in(&dir).len(), 2, "the partial files");
    drop((w, p));
    assert!(files_in(&dir).is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Inputs that would make a malformed stage are refused by name before anything is written,
/// and frames that do not fit are refused by frame.
#[test]
fn malformed_inputs_are_refused_by_name() {
    let dir = temp_dir("malformed");
    let path = dir.join("m.usda");
    let create = |stage: &UsdStage, body: Option<&Mesh>, counts: &[u32], widths: &[f32]| {
        UsdaWriter::create(&path, stage, body, counts, widths, Existing::Keep)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    let ok = UsdStage::default();
    let msg = create(&ok, None, &[2, 1], &[0.001]);
    assert!(
        msg.contains("`curve_vertex_counts`[1]: 1 vertices"),
        "{msg}"
    );
    let msg = create(&ok, None, &[2, 2], &[0.001, 0.002, 0.003]);
    assert!(
        msg.contains("`widths`") && msg.contains("3 widths"),
        "{msg}"
    );
    let msg = create(&ok, None, &[2, 2], &[0.001, -1.0]);
    assert!(msg.contains("`widths`[1]: -1"), "{msg}");
    let msg = create(&ok, None, &[2], &[f32::NAN]);
    assert!(msg.contains("`widths`[0]"), "{msg}");
    let bad_stage = UsdStage {
        time_codes_per_second: 0.0,
        ..UsdStage::default()
    };
    let msg = create(&bad_stage, None, &[2], &[0.001]);
    assert!(msg.contains("`time_codes_per_second`"), "{msg}");
    let mut mesh = triangle();
    mesh.triangles.push([0, 1, 3]);
    let msg = create(&ok, Some(&mesh), &[2], &[0.001]);
    assert!(msg.contains("`body.triangles`[1]"), "{msg}");
    let mut mesh = triangle();
    mesh.vertices[2][1] = f32::INFINITY;
    let msg = create(&ok, Some(&mesh), &[2], &[0.001]);
    assert!(msg.contains("`body.vertices`[2]"), "{msg}");
    assert!(files_in(&dir).is_empty());

    let mut w = UsdaWriter::create(
        &path,
        &ok,
        Some(&triangle()),
        &[2],
        &[0.001],
        Existing::Keep,
    )
    .unwrap();
    let two = [[0.0; 3], [1.0; 3]];
    let frame_err = |r: Result<(), IoError>| r.unwrap_err().to_string();
    let msg = frame_err(w.write_frame(0.0, [[0.0; 3]]));
    assert!(
        msg.contains("frame 0: 1 points, but the curves have 2"),
        "{msg}"
    );
    let msg = frame_err(w.write_frame(0.0, [[0.0; 3]; 3]));
    assert!(msg.contains("frame 0: more than the 2 points"), "{msg}");
    let msg = frame_err(w.write_frame(f64::NAN, two));
    assert!(msg.contains("time code NaN is not finite"), "{msg}");
    w.write_frame(1.0, two).unwrap();
    let msg = frame_err(w.write_frame(1.0, two));
    assert!(
        msg.contains("frame 1: time code 1 does not follow"),
        "{msg}"
    );
    let msg = frame_err(w.write_frame_posed(2.0, two, &BodyPose::IDENTITY));
    assert!(
        msg.contains("every frame gives the body's pose or none"),
        "{msg}"
    );
    w.finish().unwrap();
    let u = read_usda(&path);
    assert_eq!(u.samples.len(), 1);
    assert!(u.poses.is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Sintel's bust and guide hair, in metres, swaying for 48 frames with the body turning: the
/// export `scripts/check_usd.py` is run on (the paths are printed; they stay in the target
/// directory's tmp).
#[test]
fn sintel_export_reads_back() {
    let assets = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../assets/sintel");
    let hair = hair_io::read_strands(&assets.join("sintel_hair.tfx")).unwrap();
    let mut body = obj::read(&assets.join("sintel.obj")).unwrap();
    for v in &mut body.vertices {
        *v = v.map(|c| c * 0.01);
    }
    let counts: Vec<u32> = hair.iter().map(|s| s.len() as u32).collect();
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("usd-check");
    std::fs::create_dir_all(&dir).unwrap();
    let (usd, npy) = (dir.join("sintel.usda"), dir.join("sintel.npy"));
    let stage = UsdStage::default();
    let mut w = UsdaWriter::create(
        &usd,
        &stage,
        Some(&body),
        &counts,
        &[0.0015],
        Existing::Replace,
    )
    .unwrap();
    let mut p = NpyPointsWriter::create(&npy, &counts, Existing::Replace).unwrap();
    let frames = 48;
    let mut kept = Vec::new();
    for f in 0..frames {
        let angle = 0.3 * (f as f32 * 0.2).sin();
        let (s, c) = angle.sin_cos();
        let pose = BodyPose {
            rotation: [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]],
            translation: [0.0, 0.0, 0.0],
        };
        let frame: Vec<[f32; 3]> = hair
            .points
            .iter()
            .map(|q| {
                let q = q.map(|x| x * 0.01);
                [c * q[0] + s * q[2], q[1], -s * q[0] + c * q[2]]
            })
            .collect();
        w.write_frame_posed(f64::from(f), frame.iter().copied(), &pose)
            .unwrap();
        p.write_frame(frame.iter().copied()).unwrap();
        if f == 0 || f == frames / 2 || f == frames - 1 {
            kept.push(frame);
        }
    }
    w.finish().unwrap();
    p.finish().unwrap();
    println!("wrote {} and {}", usd.display(), npy.display());
    let u = read_usda(&usd);
    assert_eq!(u.counts, counts);
    assert_eq!(u.samples.len(), frames as usize);
    assert_eq!(u.poses.len(), frames as usize);
    assert_eq!(u.body_points.len(), 3046);
    assert_eq!(u.body_indices.len(), 5952 * 3);
    assert_eq!(u.body_face_counts, vec![3; 5952]);
    assert_eq!(
        (u.curve_type.as_str(), u.wrap.as_str()),
        ("linear", "nonperiodic")
    );
    assert_eq!(
        (u.widths.as_slice(), u.interpolation.as_str()),
        (&[0.0015f32][..], "constant")
    );
    for (k, f) in [0, frames / 2, frames - 1].into_iter().enumerate() {
        assert_eq!(bits(&u.samples[f as usize].1), bits(&kept[k]));
    }
    let (shape, _) = read_npy(&npy);
    assert_eq!(shape, vec![frames as usize, 228 * 32, 3]);
}
