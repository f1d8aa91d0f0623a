//! The error type of the crate.

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
}
