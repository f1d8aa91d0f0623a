//! NumPy `.npy` (format 1.0): the frames' points as one little-endian float32 array of shape
//! `[frames, points, 3]`, streamed frame by frame, so a script can check an export against the
//! exact values the simulation drew.
//!
//! The header's frame count is written as a fixed-width field and filled in by
//! [`NpyPointsWriter::finish`].

use crate::IoError;
use crate::frames::CurveLayout;
use crate::partial::{Existing, PartialFile};
use std::path::Path;

/// Header length (magic, version, length field and the padded dictionary): a multiple of 64,
/// long enough for any frame count.
const HEADER: usize = 128;

/// Streams frames of points to a `.npy` file; written beside its destination and moved there
/// by [`finish`](Self::finish), refusing frames as [`UsdaWriter`](crate::usda::UsdaWriter) does.
pub struct NpyPointsWriter {
    out: PartialFile,
    layout: CurveLayout,
    frames: usize,
    bytes: Vec<u8>,
}

impl NpyPointsWriter {
    /// Opens `path` for frames of the curves with these vertex counts (each at least 2).
    /// Refuses an existing `path` unless `existing` is [`Existing::Replace`].
    pub fn create(
        path: &Path,
        curve_vertex_counts: &[u32],
        existing: Existing,
    ) -> Result<Self, IoError> {
        let name = path.display().to_string();
        let layout = CurveLayout::new(curve_vertex_counts, &name)?;
        let mut out = PartialFile::create(path, existing)?;
        out.write(&header(0, layout.points()))?;
        Ok(Self {
            out,
            layout,
            frames: 0,
            bytes: Vec::new(),
        })
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Appends one frame's points, in the order of the curves.
    pub fn write_frame(
        &mut self,
        points: impl IntoIterator<Item = [f32; 3]>,
    ) -> Result<(), IoError> {
        let mut bytes = std::mem::take(&mut self.bytes);
        bytes.clear();
        let checked = self
            .layout
            .check_frame(&self.out.name, self.frames, points, |p| {
                for c in p {
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            });
        let written = checked.and_then(|()| self.out.write(&bytes));
        self.bytes = bytes;
        written?;
        self.frames += 1;
        Ok(())
    }

    /// Writes the frame count into the header and moves the file into place.
    pub fn finish(mut self) -> Result<(), IoError> {
        let head = header(self.frames, self.layout.points());
        self.out.patch(0, &head)?;
        self.out.commit()
    }
}

fn header(frames: usize, points: usize) -> Vec<u8> {
    let dict =
        format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({frames}, {points}, 3), }}");
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&((HEADER - 10) as u16).to_le_bytes());
    out.extend_from_slice(dict.as_bytes());
    // Two 20-digit counts and the dictionary fit in 118 bytes with room to spare.
    out.resize(HEADER - 1, b' ');
    out.push(b'\n');
    out
}
