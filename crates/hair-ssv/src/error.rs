//! The crate's one error type.

use crate::Real;

/// Everything that can go wrong when building shapes, meshes, BVHs and maps from untrusted input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SsvError {
    /// A coordinate, radius or extent is NaN or infinite.
    #[error("{shape}: field `{field}` is not finite")]
    NonFinite {
        /// Which shape (`"Pss"`, `"Lss"`, `"Rss"`).
        shape: &'static str,
        /// Which field (`"center"`, `"radius"`, ...).
        field: &'static str,
    },
    /// A radius is negative.
    #[error("{shape}: field `radius` is {radius}, must be >= 0")]
    NegativeRadius {
        /// Which shape.
        shape: &'static str,
        /// The offending radius.
        radius: Real,
    },
    /// An RSS extent is negative.
    #[error("Rss: field `extents[{index}]` is {value}, must be >= 0")]
    NegativeExtent {
        /// 0 or 1.
        index: usize,
        /// The offending extent.
        value: Real,
    },
    /// The two RSS axes are not unit length or not orthogonal (tolerance 1e-4).
    #[error(
        "Rss: field `axes` is not orthonormal (|axes[0]| = {len0}, |axes[1]| = {len1}, axes[0].axes[1] = {dot})"
    )]
    AxesNotOrthonormal {
        /// Length of `axes[0]`.
        len0: Real,
        /// Length of `axes[1]`.
        len1: Real,
        /// Dot product of the two axes.
        dot: Real,
    },
    /// A mesh has no triangles.
    #[error("mesh: no triangles")]
    EmptyMesh,
    /// A mesh vertex has a NaN or infinite coordinate.
    #[error("mesh: vertex {vertex} is not finite")]
    NonFiniteVertex {
        /// Index of the vertex.
        vertex: usize,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error(
        "mesh: triangle {triangle} refers to vertex {index}, but there are {vertex_count} vertices"
    )]
    IndexOutOfRange {
        /// Index of the triangle.
        triangle: usize,
        /// The out-of-range vertex index.
        index: u32,
        /// Number of vertices in the mesh.
        vertex_count: usize,
    },
    /// A triangle has (near) zero area: repeated or collinear vertices.
    #[error("mesh: triangle {triangle} is degenerate (area {area})")]
    DegenerateTriangle {
        /// Index of the triangle.
        triangle: usize,
        /// Its area.
        area: Real,
    },
    /// A fitting routine got no points.
    #[error("{what}: input is empty")]
    EmptyInput {
        /// Which routine.
        what: &'static str,
    },
    /// A fitting routine got a non-finite point.
    #[error("{what}: point {index} is not finite")]
    NonFinitePoint {
        /// Which routine.
        what: &'static str,
        /// Index of the point.
        index: usize,
    },
    /// A map's resolution or frame is unusable.
    #[error("{map}: {reason}")]
    InvalidMap {
        /// Which map (`"CylinderMap"`, `"SphereMap"`).
        map: &'static str,
        /// What is wrong.
        reason: String,
    },
}
