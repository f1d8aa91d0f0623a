//! Issue #41, part 5: converting keeps what the user made, or says what it would lose; errors
//! say where. The `.hair` files here are written by hand from the format's description.

use hair_io::{IoError, Lost, Strands, cyhair, obj, tfx};
use std::path::PathBuf;

fn sintel(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../assets/sintel")
        .join(name)
}

fn temp_dir(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hair-io-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A `.hair` header field by field: magic, strand count, point count, array bits, default
/// segments, default thickness, transparency, colour, 88 bytes of text.
#[allow(clippy::too_many_arguments)]
fn hair_header(
    strands: u32,
    points: u32,
    bits: u32,
    segments: u32,
    thickness: f32,
    transparency: f32,
    color: [f32; 3],
    text: &[u8],
) -> Vec<u8> {
    let mut out = b"HAIR".to_vec();
    for v in [strands, points, bits, segments] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for f in [thickness, transparency, color[0], color[1], color[2]] {
        out.extend_from_slice(&f.to_le_bytes());
    }
    let mut info = [0u8; 88];
    info[..text.len()].copy_from_slice(text);
    out.extend_from_slice(&info);
    assert_eq!(out.len(), 128);
    out
}

fn f32s(values: impl IntoIterator<Item = f32>) -> Vec<u8> {
    values.into_iter().flat_map(f32::to_le_bytes).collect()
}

/// Two strands of three points (two segments each), points only.
fn two_strand_points() -> Vec<u8> {
    f32s((0..6).flat_map(|i| [i as f32 * 0.5, -(i as f32), 0.25]))
}

/// A file with no segments array (default 2 segments), no thickness, transparency or colour
/// arrays, and defaults of its own: read and written back, it is the same file, byte for byte.
#[test]
fn hair_to_hair_keeps_header_defaults_and_array_flags() {
    let mut file = hair_header(2, 6, 2, 2, 0.25, 0.125, [0.2, 0.3, 0.4], b"made by hand");
    file.extend(two_strand_points());
    let strands = cyhair::from_bytes(&file, "hand.hair").unwrap();
    assert_eq!(strands.thickness, None);
    assert_eq!(cyhair::to_bytes(&strands), file);
    let dir = temp_dir("keep-defaults");
    let path = dir.join("out.hair");
    hair_io::write_strands(&path, &strands).unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), file);

    // With a segments array, a thickness array and a colour array (bits 0, 1, 2, 4) and the
    // transparency left to its default.
    let mut file = hair_header(2, 6, 1 | 2 | 4 | 16, 0, 3.0, 0.5, [1.0; 3], b"");
    file.extend([2u16, 2].iter().flat_map(|s| s.to_le_bytes()));
    file.extend(two_strand_points());
    file.extend(f32s((0..6).map(|i| 0.1 * i as f32)));
    file.extend(f32s((0..18).map(|i| i as f32 / 18.0)));
    let strands = cyhair::from_bytes(&file, "arrays.hair").unwrap();
    assert_eq!(cyhair::to_bytes(&strands), file);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Sintel's TressFX file pins every root (w = 0) and frees the rest (w = 1). Through `.hair`,
/// which has no such field, and back, every w is as it was: a strand set read from `.hair`
/// pins its roots, and that is what the `.tfx` writer writes.
#[test]
fn tfx_to_hair_and_back_keeps_root_pins() {
    let original = std::fs::read(sintel("sintel_hair.tfx")).unwrap();
    let strands = tfx::from_bytes(&original, "sintel_hair.tfx").unwrap();
    let dir = temp_dir("keep-pins");
    let hair = dir.join("sintel.hair");
    hair_io::write_strands(&hair, &strands).unwrap();
    let via_hair = hair_io::read_strands(&hair).unwrap();
    let back = tfx::to_bytes(&via_hair, "back.tfx").unwrap();
    let w_of = |bytes: &[u8]| -> Vec<f32> {
        let at = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let n = 228 * 32;
        (0..n)
            .map(|i| {
                let o = at + i * 16 + 12;
                f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap())
            })
            .collect()
    };
    let (before, after) = (w_of(&original), w_of(&back));
    assert!(
        before
            .iter()
            .enumerate()
            .all(|(i, &w)| w == if i % 32 == 0 { 0.0 } else { 1.0 })
    );
    assert_eq!(after, before);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Pins `.hair` cannot hold (here a second pinned point) are not dropped silently: the write is
/// refused and says what would be lost, and the lossy writer drops them only when asked.
#[test]
fn hair_refuses_pins_it_cannot_hold() {
    let mut bytes = std::fs::read(sintel("sintel_hair.tfx")).unwrap();
    let w1 = 160 + 16 + 12; // strand 0, point 1, w
    bytes[w1..w1 + 4].copy_from_slice(&0.0f32.to_le_bytes());
    let strands = tfx::from_bytes(&bytes, "two-pins.tfx").unwrap();
    let dir = temp_dir("refuse-pins");
    let path = dir.join("two-pins.hair");
    let err = hair_io::write_strands(&path, &strands).unwrap_err();
    let message = err.to_string();
    assert!(message.contains("two-pins.hair"), "{message}");
    assert!(message.contains("pins"), "{message}");
    assert!(message.contains("strand 0, point 1"), "{message}");
    assert!(!path.exists());
    let lost = hair_io::write_strands_lossy(&path, &strands).unwrap();
    assert_eq!(
        lost,
        [Lost::Pins {
            strand: 0,
            point: 1,
            value: 0.0
        }]
    );
    assert!(path.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `.tfx` has no room for colours, transparency, thickness along a strand or a `.hair` file's
/// text; writing one that carries them is refused with the list.
#[test]
fn tfx_refuses_what_it_cannot_hold() {
    let mut file = hair_header(2, 6, 1 | 2 | 4 | 16, 0, 1.0, 0.5, [0.5; 3], b"a note");
    file.extend([2u16, 2].iter().flat_map(|s| s.to_le_bytes()));
    file.extend(two_strand_points());
    file.extend(f32s((0..6).map(|i| 0.1 * i as f32)));
    file.extend(f32s((0..18).map(|i| i as f32 / 18.0)));
    let strands = cyhair::from_bytes(&file, "rich.hair").unwrap();
    let dir = temp_dir("refuse-tfx");
    let err = hair_io::write_strands(&dir.join("rich.tfx"), &strands).unwrap_err();
    let IoError::WouldLose { lost, .. } = &err else {
        panic!("{err}");
    };
    assert_eq!(
        lost,
        &[
            Lost::ThicknessAlongStrand { strand: 0 },
            Lost::Default {
                field: "transparency"
            },
            Lost::Array { field: "colour" },
            Lost::HeaderText,
        ]
    );
    assert!(!dir.join("rich.tfx").exists());
    // A default thickness with no array is not lost: .tfx gets it per strand.
    let mut file = hair_header(2, 6, 2, 2, 0.25, 0.0, [0.5; 3], b"");
    file.extend(two_strand_points());
    let strands = cyhair::from_bytes(&file, "thin.hair").unwrap();
    hair_io::write_strands(&dir.join("thin.tfx"), &strands).unwrap();
    let back = hair_io::read_strands(&dir.join("thin.tfx")).unwrap();
    assert_eq!(back.thickness, Some(vec![0.25; 6]));
    let _ = std::fs::remove_dir_all(&dir);
}

/// An OBJ face that names a vertex the file lacks is reported by file, line and face.
#[test]
fn obj_face_index_out_of_range_names_file_line_and_face() {
    let dir = temp_dir("obj-face");
    let path = dir.join("bad.obj");
    let text = "# a quad and a bad triangle\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n\
                f 1 2 3 4\nf 1 3 9\n";
    std::fs::write(&path, text).unwrap();
    let message = obj::read(&path).unwrap_err().to_string();
    assert!(message.contains("bad.obj:7:"), "{message}");
    assert!(message.contains("face 2"), "{message}");
    assert!(message.contains("`f 1 3 9`"), "{message}");
    assert!(message.contains("index 9"), "{message}");
    // Relative indices count back from the last vertex read.
    std::fs::write(&path, "v 0 0 0\nv 1 0 0\nf -1 -2 -3\nv 0 1 0\n").unwrap();
    let message = obj::read(&path).unwrap_err().to_string();
    assert!(
        message.contains("bad.obj:3:") && message.contains("face 1"),
        "{message}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A `.hair` header whose point count disagrees with its segments gives both numbers.
#[test]
fn hair_count_mismatch_gives_header_count_and_sum_found() {
    let mut file = hair_header(2, 100, 1 | 2, 0, 1.0, 0.0, [0.5; 3], b"");
    file.extend([2u16, 2].iter().flat_map(|s| s.to_le_bytes()));
    file.extend(two_strand_points());
    let message = cyhair::from_bytes(&file, "count.hair")
        .unwrap_err()
        .to_string();
    assert!(message.contains("count.hair"), "{message}");
    assert!(message.contains("`point_count` = 100"), "{message}");
    assert!(message.contains("sum to 6"), "{message}");
}

/// Strands built by hand with arrays that disagree are refused, not written (nor a panic).
#[test]
fn inconsistent_strands_are_refused_not_written() {
    let mut s = Strands::from_polylines(vec![vec![[0.0; 3], [1.0, 0.0, 0.0]]; 2]).unwrap();
    s.thickness = Some(vec![1.0; 3]);
    let dir = temp_dir("inconsistent");
    for name in ["a.hair", "a.tfx"] {
        let message = hair_io::write_strands(&dir.join(name), &s)
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("`thickness` has 3 values for 4 points"),
            "{message}"
        );
    }
    s.thickness = None;
    s.offsets = vec![0, 3, 2];
    assert!(hair_io::write_strands(&dir.join("b.hair"), &s).is_err());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    let _ = std::fs::remove_dir_all(&dir);
}
