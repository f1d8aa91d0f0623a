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

mod body;
pub mod bvh;
mod contact;
mod cylinder_map;
mod distance;
mod distance_batch;
mod error;
pub mod fit;
pub mod query;
mod ray;
mod shape;
mod sphere_map;
mod surface_map;
#[doc(hidden)]
pub mod test_meshes;

pub use body::{Body, BodyPart, PartMap};
pub use bvh::{Bvh, ContactBatch, MeshClosest, MeshContact};
pub use contact::Contact;
pub use cylinder_map::{CylinderMap, CylinderMapConfig};
pub use distance::{
    distance_lss_lss, distance_lss_rss, distance_pss_lss, distance_pss_pss, distance_pss_rss,
    distance_rss_rss,
};
pub use distance_batch::distance_lss_lss_batch;
pub use error::SsvError;
pub use fit::{fit_lss, fit_rss, fit_rss_triangles};
pub use ray::RayHit;
pub use shape::{AXIS_TOLERANCE, Lss, Pss, Rss, Ssv};
pub use sphere_map::{SphereMap, SphereMapConfig};
pub use surface_map::{MapFrame, MapSample, SurfaceMap};

/// Scalar type of the crate.
pub type Real = f32;
/// A point in 3-D.
pub type Point = nalgebra::Point3<Real>;
/// A vector in 3-D.
pub type Vector = nalgebra::Vector3<Real>;
