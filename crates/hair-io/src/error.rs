//! The error type of the crate.

use crate::Lost;
use thiserror::Error;

/// What went wrong reading or writing a file; every variant names the file.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum IoError {
    /// The operating system refused.
    #[error("{file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// The system's message.
        message: String,
    },
    /// The extension names no format we know.
    #[error("{file}: unknown format `.{extension}` (expected .tfx or .hair)")]
    UnknownFormat {
        /// The file.
        file: String,
        /// The extension found.
        extension: String,
    },
    /// The file is not of the format it claims.
    #[error("{file}: bad magic: {message}")]
    BadMagic {
        /// The file.
        file: String,
        /// What was expected and found.
        message: String,
    },
    /// The file ends before the data its header announces.
    #[error("{file}: truncated: {what} needs bytes {start}..{end} but the file has {len}")]
    Truncated {
        /// The file.
        file: String,
        /// Which block.
        what: &'static str,
        /// First byte needed.
        start: u64,
        /// One past the last byte needed.
        end: u64,
        /// File length.
        len: u64,
    },
    /// A header field is out of range.
    #[error("{file}: header field `{field}` = {value}: {expected}")]
    BadHeader {
        /// The file.
        file: String,
        /// The field.
        field: &'static str,
        /// Its value.
        value: u64,
        /// What is allowed.
        expected: &'static str,
    },
    /// A value in the data is NaN or infinite.
    #[error("{file}: strand {strand}, point {point}: `{field}` is not finite")]
    NonFinite {
        /// The file.
        file: String,
        /// The strand.
        strand: usize,
        /// The point within the strand.
        point: usize,
        /// Which value.
        field: &'static str,
    },
    /// The strands cannot be written in this format.
    #[error("{file}: cannot write: {message}")]
    Unwritable {
        /// The file.
        file: String,
        /// Why.
        message: String,
    },
    /// A strand has fewer than two points.
    #[error("{file}: strand {strand} has {count} points; at least 2 are needed")]
    ShortStrand {
        /// The file (`<memory>` for strands built in code).
        file: String,
        /// The strand.
        strand: usize,
        /// Its point count.
        count: usize,
    },
    /// The OBJ file is malformed or its mesh is unusable.
    #[error("{file}: {message}")]
    Obj {
        /// The file.
        file: String,
        /// What is wrong (with the line where the parser gives one).
        message: String,
    },
    /// An OBJ face refers to a vertex the file does not have.
    #[error(
        "{file}:{line}: face {face} (`{text}`): vertex index {index} is out of range \
         (the file has {vertices} vertices, numbered from 1)"
    )]
    ObjFaceIndex {
        /// The file.
        file: String,
        /// The line (from 1).
        line: usize,
        /// The face, counting the file's faces from 1.
        face: usize,
        /// The face's line as written.
        text: String,
        /// The index as written.
        index: i64,
        /// The file's vertex count.
        vertices: usize,
    },
    /// A header count disagrees with the count the data gives.
    #[error("{file}: header field `{field}` = {header}, but {counted} sum to {found}")]
    CountMismatch {
        /// The file.
        file: String,
        /// The header field.
        field: &'static str,
        /// The header's value.
        header: u64,
        /// The count found.
        found: u64,
        /// What was counted.
        counted: &'static str,
    },
    /// Strands built in code whose arrays disagree (lengths, offsets).
    #[error("{file}: inconsistent strands: {message}")]
    Inconsistent {
        /// The file being written (`<memory>` when none).
        file: String,
        /// What disagrees.
        message: String,
    },
    /// Writing would drop something the strands hold; the lossy writer drops it on request.
    #[error(
        "{file}: not written: the format cannot hold {}; a lossy write drops them",
        list(lost)
    )]
    WouldLose {
        /// The file.
        file: String,
        /// What would be lost.
        lost: Vec<Lost>,
    },
    /// The output file exists and was not to be replaced.
    #[error("{file}: exists; not replaced (ask for it to be replaced, or write elsewhere)")]
    Exists {
        /// The file.
        file: String,
    },
    /// A value given to a writer before any frame (counts, widths, the body) is unusable.
    #[error("{file}: `{field}`[{index}]: {message}")]
    BadInput {
        /// The file being written.
        file: String,
        /// Which input.
        field: &'static str,
        /// Which element of it.
        index: usize,
        /// What is wrong.
        message: String,
    },
    /// A frame's point is NaN or infinite; nothing of the frame was written.
    #[error("{file}: frame {frame}: point {point} (curve {curve}): `{field}` is not finite")]
    NonFiniteFrame {
        /// The file being written.
        file: String,
        /// The frame, counting from 0 in the order written.
        frame: usize,
        /// The point, indexing the frame's points.
        point: usize,
        /// The curve the point belongs to.
        curve: usize,
        /// Which value.
        field: &'static str,
    },
    /// A frame cannot be written as given (its size, its time code, its body pose); nothing of
    /// it was written.
    #[error("{file}: frame {frame}: {message}")]
    BadFrame {
        /// The file being written.
        file: String,
        /// The frame, counting from 0 in the order written.
        frame: usize,
        /// What is wrong.
        message: String,
    },
}

fn list(lost: &[Lost]) -> String {
    lost.iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("; ")
}
