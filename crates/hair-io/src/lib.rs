//! # hair-io
//!
//! Hair and body file formats, with readers that never panic on bad bytes and name what is wrong,
//! writers that keep what a file said, and an animated export to Pixar's USD.
//!
//! | item | what it reads and writes |
//! |---|---|
//! | [`Strands`] | strand data: points, optional thickness, transparency, colour, TressFX pins, `.hair` header |
//! | [`tfx`] | AMD TressFX `.tfx` (binary, fixed vertices per strand) |
//! | [`cyhair`] | Cem Yuksel's `.hair` (binary, variable segments per strand) |
//! | [`obj`] | Wavefront OBJ bodies as indexed triangles (via `tobj`) |
//! | [`read_strands`], [`write_strands`], [`write_strands_lossy`] | by file extension; [`Lost`] names what a format cannot hold |
//! | [`usda::UsdaWriter`] | USD `.usda`: body `Mesh` and animated `BasisCurves`, streamed frame by frame |
//! | [`npy::NpyPointsWriter`] | NumPy `.npy` float32 `[frames, points, 3]`, streamed, to check an export |
//!
//! ```
//! use hair_io::usda::{UsdStage, UsdaWriter};
//! use hair_io::{Existing, Strands, cyhair};
//!
//! let strands = Strands::from_polylines(vec![
//!     vec![[0.0, 0.0, 0.0], [0.0, -0.1, 0.0], [0.0, -0.2, 0.01]],
//!     vec![[0.01, 0.0, 0.0], [0.01, -0.1, 0.0]],
//! ])?;
//! let back = cyhair::from_bytes(&cyhair::to_bytes(&strands), "inline.hair")?;
//! assert_eq!(back, strands);
//!
//! let path = std::env::temp_dir().join(format!("hair-io-doc-{}.usda", std::process::id()));
//! let counts: Vec<u32> = strands.iter().map(|s| s.len() as u32).collect();
//! let stage = UsdStage { time_codes_per_second: 24.0, ..UsdStage::default() };
//! let mut usd = UsdaWriter::create(&path, &stage, None, &counts, &[0.001], Existing::Keep)?;
//! for frame in 0..3 {
//!     let sway = frame as f32 * 0.01;
//!     usd.write_frame(f64::from(frame), strands.points.iter().map(|p| [p[0] + sway, p[1], p[2]]))?;
//! }
//! usd.finish()?;
//! assert!(std::fs::read_to_string(&path).unwrap().contains("endTimeCode = 2 "));
//! # std::fs::remove_file(&path).unwrap();
//! # Ok::<(), hair_io::IoError>(())
//! ```

pub mod cyhair;
mod error;
mod frames;
pub mod npy;
pub mod obj;
mod partial;
mod strands;
pub mod tfx;
pub mod usda;

pub use error::IoError;
pub use obj::Mesh;
pub use partial::Existing;
pub use strands::{Lost, Strands};

use std::path::Path;

/// Reads strands from a `.tfx` or `.hair` file, chosen by extension.
pub fn read_strands(path: &Path) -> Result<Strands, IoError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| IoError::Io {
        file: name.clone(),
        message: e.to_string(),
    })?;
    match extension(path).as_str() {
        "tfx" => tfx::from_bytes(&bytes, &name),
        "hair" => cyhair::from_bytes(&bytes, &name),
        other => Err(IoError::UnknownFormat {
            file: name,
            extension: other.to_string(),
        }),
    }
}

/// Writes strands to a `.tfx` or `.hair` file, chosen by extension, refusing with
/// [`IoError::WouldLose`] when the format cannot hold something they carry (TressFX pins other
/// than the roots in `.hair`; colours, transparency or thickness along a strand in `.tfx`).
///
/// The file is written whole or not at all: into a temporary file beside it, then renamed over
/// it, so a write that fails (a full disk, say) leaves an existing file as it was.
pub fn write_strands(path: &Path, strands: &Strands) -> Result<(), IoError> {
    let (bytes, lost) = encode(path, strands)?;
    if !lost.is_empty() {
        return Err(IoError::WouldLose {
            file: path.display().to_string(),
            lost,
        });
    }
    write_encoded(path, &bytes)
}

/// As [`write_strands`], but drops what the format cannot hold and returns what was dropped
/// (empty when nothing was), for a caller that asked for it and can say so.
pub fn write_strands_lossy(path: &Path, strands: &Strands) -> Result<Vec<Lost>, IoError> {
    let (bytes, lost) = encode(path, strands)?;
    write_encoded(path, &bytes)?;
    Ok(lost)
}

fn encode(path: &Path, strands: &Strands) -> Result<(Vec<u8>, Vec<Lost>), IoError> {
    let name = path.display().to_string();
    match extension(path).as_str() {
        "tfx" => Ok((tfx::to_bytes(strands, &name)?, tfx::losses(strands))),
        "hair" => cyhair::try_to_bytes(strands, &name),
        other => Err(IoError::UnknownFormat {
            file: name,
            extension: other.to_string(),
        }),
    }
}

fn write_encoded(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    write_whole(path, bytes).map_err(|e| IoError::Io {
        file: path.display().to_string(),
        message: e.to_string(),
    })
}

/// Writes `bytes` to `path` whole or not at all: into a temporary file beside it (hidden, named
/// after it and this process), then renamed over it. A write that fails (a full disk, say)
/// leaves an existing file as it was and removes the temporary one.
pub fn write_whole(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let Some(file_name) = path.file_name() else {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a file name",
        ));
    };
    let mut partial = std::ffi::OsString::from(".");
    partial.push(file_name);
    partial.push(format!(".partial-{}", std::process::id()));
    let partial = path.with_file_name(partial);
    std::fs::write(&partial, bytes)
        .and_then(|()| std::fs::rename(&partial, path))
        .inspect_err(|_| {
            let _ = std::fs::remove_file(&partial);
        })
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}
