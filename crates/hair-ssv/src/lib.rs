//! `hair-ssv`: swept sphere volumes (Ward & Lin 2003 §5), exact distances and contacts between
//! them and against triangle meshes.
//!
//! | item | what it is |
//! |---|---|
//! | [`Pss`], [`Lss`], [`Rss`], [`Ssv`] | point, line and rectangle swept spheres |
//! | [`Ssv::distance`], [`Ssv::contact`], `distance_*` | signed distance, contact between any two |
//! | [`query`] | closest-point kernels: point, segment, rectangle, triangle |
//!
//! ```
//! use hair_ssv::{Lss, Point, Ssv};
//! let a = Ssv::Line(Lss::new(Point::new(0.0, 0.0, 0.0), Point::new(1.0, 0.0, 0.0), 0.1));
//! let b = Ssv::Line(Lss::new(Point::new(0.5, 0.15, -1.0), Point::new(0.5, 0.15, 1.0), 0.1));
//! assert!((a.distance(&b) - (-0.05)).abs() < 1e-6);
//! let c = a.contact(&b).unwrap();
//! assert!((c.depth - 0.05).abs() < 1e-6);
//! ```

mod contact;
mod distance;
mod error;
pub mod query;
mod shape;

pub use contact::Contact;
pub use distance::{
    distance_lss_lss, distance_lss_rss, distance_pss_lss, distance_pss_pss, distance_pss_rss,
    distance_rss_rss,
};
pub use error::SsvError;
pub use shape::{AXIS_TOLERANCE, Lss, Pss, Rss, Ssv};

/// Scalar type of the crate.
pub type Real = f32;
/// A point in 3-D.
pub type Point = nalgebra::Point3<Real>;
/// A vector in 3-D.
pub type Vector = nalgebra::Vector3<Real>;
