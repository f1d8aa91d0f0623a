//! The one error type of the crate.

/// Everything that can go wrong while preparing or rendering a scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// A point of a strand, group, cluster or strip is not finite.
    #[error("{kind} {index}: point {point} is not finite ({field})")]
    NonFinite {
        /// What holds the point: `strand`, `group`, `cluster`, `strip` or `body`.
        kind: &'static str,
        /// Index of the strand (or group, cluster, strip) in its list of the scene.
        index: usize,
        /// Index of the point within it.
        point: usize,
        /// Which field is bad (`position`, `radius`, `wetness`, ...).
        field: &'static str,
    },
    /// A field of the input is out of its valid range or inconsistent.
    #[error("{what}: {reason}")]
    InvalidInput {
        /// Which part of the input (for example `body.triangles[3]`).
        what: String,
        /// Why it is rejected.
        reason: String,
    },
    /// The image (or window) size is zero or beyond what the device supports.
    #[error("image size {width}x{height} is invalid: {reason}")]
    InvalidSize {
        /// Requested width in pixels.
        width: u32,
        /// Requested height in pixels.
        height: u32,
        /// Why it is rejected (zero, or the device limit).
        reason: String,
    },
    /// No GPU adapter could be found for the requested backends.
    #[error("no GPU adapter found: {0}")]
    NoAdapter(String),
    /// The device could not be created or was lost.
    #[error("GPU device error: {0}")]
    Device(String),
    /// Reading the rendered image back from the GPU failed.
    #[error("GPU readback failed: {0}")]
    Readback(String),
    /// Writing an image file failed.
    #[error("writing {path}: {reason}")]
    Image {
        /// The file being written.
        path: String,
        /// The underlying error.
        reason: String,
    },
}
