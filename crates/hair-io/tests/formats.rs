//! Round trips, the Sintel asset, and malformed files.

use hair_io::{IoError, Strands, cyhair, obj, tfx};
use proptest::prelude::*;
use std::path::PathBuf;

fn sintel(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/sintel")
        .join(name)
}

fn polylines(uniform: bool) -> impl Strategy<Value = Vec<Vec<[f32; 3]>>> {
    let point = (-10.0f32..10.0, -10.0f32..10.0, -10.0f32..10.0).prop_map(|(x, y, z)| [x, y, z]);
    (2usize..40).prop_flat_map(move |per| {
        let len = if uniform { per..per + 1 } else { 2..40 };
        prop::collection::vec(prop::collection::vec(point.clone(), len), 1..20)
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn hair_round_trip(lines in polylines(false), with_extras in any::<bool>()) {
        let mut s = Strands::from_polylines(lines).unwrap();
        if with_extras {
            let n = s.points.len();
            s.thickness = Some((0..n).map(|i| i as f32 * 0.5).collect());
            s.transparency = Some((0..n).map(|i| 1.0 / (i as f32 + 1.0)).collect());
            s.colors = Some((0..n).map(|i| [i as f32, 0.5, 0.25]).collect());
        }
        let back = cyhair::from_bytes(&cyhair::to_bytes(&s), "t.hair").unwrap();
        prop_assert_eq!(back, s);
    }

    #[test]
    fn tfx_round_trip(lines in polylines(true)) {
        let s = Strands::from_polylines(lines).unwrap();
        let back = tfx::from_bytes(&tfx::to_bytes(&s, "t.tfx").unwrap(), "t.tfx").unwrap();
        prop_assert_eq!(back.points, s.points);
        prop_assert_eq!(back.offsets, s.offsets);
    }

    /// Any truncation of a valid file is an error, never a panic.
    #[test]
    fn truncated_files_are_errors(lines in polylines(true), cut in 0.0f64..1.0) {
        let s = Strands::from_polylines(lines).unwrap();
        for bytes in [cyhair::to_bytes(&s), tfx::to_bytes(&s, "t.tfx").unwrap()] {
            let keep = ((bytes.len() as f64) * cut) as usize;
            let short = &bytes[..keep.min(bytes.len() - 1)];
            prop_assert!(cyhair::from_bytes(short, "t").is_err());
            prop_assert!(tfx::from_bytes(short, "t").is_err());
        }
    }

    /// Random bytes never panic the readers.
    #[test]
    fn garbage_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let _ = cyhair::from_bytes(&bytes, "g.hair");
        let _ = tfx::from_bytes(&bytes, "g.tfx");
    }
}

#[test]
fn sintel_hair_loads() {
    let s = hair_io::read_strands(&sintel("sintel_hair.tfx")).unwrap();
    assert_eq!(s.strand_count(), 228);
    assert!(s.iter().all(|strand| strand.len() == 32));
    let mesh = obj::read(&sintel("sintel.obj")).unwrap();
    assert_eq!(mesh.vertices.len(), 3046);
    assert_eq!(mesh.triangles.len(), 5952);
}

#[test]
fn malformed_files_name_the_problem() {
    let s = Strands::from_polylines(vec![vec![[0.0; 3], [1.0, 0.0, 0.0]]; 3]).unwrap();
    let mut bytes = cyhair::to_bytes(&s);
    bytes[0] = b'X';
    assert!(matches!(
        cyhair::from_bytes(&bytes, "bad.hair"),
        Err(IoError::BadMagic { .. })
    ));

    // A point count that overruns the file.
    let mut bytes = cyhair::to_bytes(&s);
    bytes[8..12].copy_from_slice(&1_000_000u32.to_le_bytes());
    let err = cyhair::from_bytes(&bytes, "overrun.hair").unwrap_err();
    assert!(err.to_string().contains("overrun.hair"), "{err}");

    // A strand count that overruns the file: the segments block is truncated.
    let mut bytes = cyhair::to_bytes(&s);
    bytes[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(
        cyhair::from_bytes(&bytes, "t.hair"),
        Err(IoError::Truncated {
            what: "segments",
            ..
        })
    ));

    // A NaN point is named by strand and point.
    let mut bytes = tfx::to_bytes(&s, "t.tfx").unwrap();
    let at = 160 + 16 + 4; // strand 0, point 1, y
    bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    let err = tfx::from_bytes(&bytes, "nan.tfx").unwrap_err();
    assert!(
        matches!(
            err,
            IoError::NonFinite {
                strand: 0,
                point: 1,
                ..
            }
        ),
        "{err}"
    );

    // Unequal strands cannot be written as .tfx.
    let uneven = Strands::from_polylines(vec![
        vec![[0.0; 3], [1.0, 0.0, 0.0]],
        vec![[0.0; 3], [1.0; 3], [2.0; 3]],
    ])
    .unwrap();
    assert!(matches!(
        tfx::to_bytes(&uneven, "u.tfx"),
        Err(IoError::Unwritable { .. })
    ));

    // An unknown extension, a missing file, a broken OBJ.
    assert!(matches!(
        hair_io::read_strands(std::path::Path::new("x.abc")),
        Err(IoError::Io { .. } | IoError::UnknownFormat { .. })
    ));
    let dir = std::env::temp_dir().join(format!("hair-io-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad_obj = dir.join("bad.obj");
    std::fs::write(&bad_obj, "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    assert!(obj::read(&bad_obj).is_err());
    let empty_obj = dir.join("empty.obj");
    std::fs::write(&empty_obj, "v 0 0 0\n").unwrap();
    assert!(obj::read(&empty_obj).is_err());
}

/// A written file is complete and leaves nothing beside it; a write that cannot be made (no
/// such directory, or strands the format cannot hold) leaves the existing file as it was.
#[test]
fn writes_are_whole_or_nothing() {
    let dir = std::env::temp_dir().join(format!("hair-io-write-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let s = Strands::from_polylines(vec![vec![[0.0; 3], [1.0, 0.0, 0.0]]; 3]).unwrap();
    for name in ["a.hair", "a.tfx"] {
        hair_io::write_strands(&dir.join(name), &s).unwrap();
        assert_eq!(
            hair_io::read_strands(&dir.join(name)).unwrap().points,
            s.points
        );
    }
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["a.hair", "a.tfx"]);
    let uneven = Strands::from_polylines(vec![
        vec![[0.0; 3], [1.0, 0.0, 0.0]],
        vec![[0.0; 3], [1.0; 3], [2.0; 3]],
    ])
    .unwrap();
    let before = std::fs::read(dir.join("a.tfx")).unwrap();
    assert!(hair_io::write_strands(&dir.join("a.tfx"), &uneven).is_err());
    assert_eq!(std::fs::read(dir.join("a.tfx")).unwrap(), before);
    assert!(hair_io::write_strands(&dir.join("missing").join("b.hair"), &s).is_err());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}
