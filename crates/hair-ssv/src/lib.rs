//! `hair-ssv`: swept sphere volumes (Ward & Lin 2003 §5), exact distances and contacts between
//! them and against triangle meshes.
//!
//! | item | what it is |
//! |---|---|
//! | [`Pss`], [`Lss`], [`Rss`], [`Ssv`] | point, line and rectangle swept spheres (`new`, `try_new`, `aabb`) |
//! | [`Ssv::distance`], [`Ssv::closest_points`], [`Ssv::contact`] | signed distance, closest core points, contact between any two |
//! | `distance_*`, [`distance_lss_lss_batch`] | the pairwise distances as free functions; eight-lane batched LSS pairs |
//! | [`query`] | exact closest-point kernels: point, segment, rectangle, triangle |
//! | [`fit_lss`], [`fit_rss`], [`fit_rss_triangles`] | tight volumes around point and triangle sets |
//! | [`Bvh`] | RSS hierarchy over a triangle mesh (points search a four-wide tree of its boxes, with four triangles per exact test): closest triangle, contacts within a margin, rayon batches, ray casts |
//! | [`CylinderMap`], [`SphereMap`], [`Body`] | Kurihara's collision tables: bilinear lookup, inside test, nearest surface point |
//! | [`head`] | the procedural head and shoulders (mesh and collision tables), with its dimensions |
//! | [`any_perpendicular`] | a unit vector perpendicular to any vector, zero included |
//! | `test_meshes` (feature `test-support`) | a seeded generator and samplers for tests and benches |
//! | [`SsvError`] | the one error type |
//!
//! ```
//! use hair_ssv::{Lss, Point, Ssv};
//! let a = Ssv::Line(Lss::new(Point::new(0.0, 0.0, 0.0), Point::new(1.0, 0.0, 0.0), 0.1));
//! let b = Ssv::Line(Lss::new(Point::new(0.5, 0.15, -1.0), Point::new(0.5, 0.15, 1.0), 0.1));
//! assert!((a.distance(&b) - (-0.05)).abs() < 1e-6);
//! let c = a.contact(&b).unwrap();
//! assert!((c.depth - 0.05).abs() < 1e-6);
//!
//! // a BVH over a mesh: every triangle touching a hair segment
//! use hair_ssv::{Bvh, Vector};
//! let vertices = [Point::new(-1.0, 0.0, -1.0), Point::new(1.0, 0.0, -1.0), Point::new(0.0, 0.0, 1.0)];
//! let bvh = Bvh::new(&vertices, &[[0, 2, 1]]).unwrap();
//! let hair = Ssv::Line(Lss::new(Point::new(0.0, 0.005, 0.0), Point::new(0.1, 0.02, 0.0), 0.01));
//! let mut contacts = Vec::new();
//! bvh.contacts(&hair, 0.0, &mut contacts);
//! assert_eq!(contacts.len(), 1);
//! assert!((contacts[0].contact.depth - 0.005).abs() < 1e-6);
//! assert!((contacts[0].contact.normal - (-Vector::y())).norm() < 1e-6); // push out along +y
//! ```

mod body;
pub mod bvh;
mod contact;
mod cylinder_map;
mod distance;
mod distance_batch;
mod distance_field;
mod error;
pub mod fit;
pub mod head;
mod mesh_body;
pub mod query;
mod ray;
pub mod scalp;
mod shape;
mod sphere_map;
mod surface_map;
#[cfg(feature = "test-support")]
pub mod test_meshes;

pub use body::{Body, BodyPart, PartMap};
pub use bvh::{Bvh, ContactBatch, MeshClosest, MeshContact};
pub use contact::{Contact, any_perpendicular};
pub use cylinder_map::{CylinderMap, CylinderMapConfig};
pub use distance::{
    distance_lss_lss, distance_lss_rss, distance_pss_lss, distance_pss_pss, distance_pss_rss,
    distance_rss_rss,
};
pub use distance_batch::{distance_lss_lss_batch, lss_lss_lanes, segment_segment_params_lanes};
pub use distance_field::DistanceField;
pub use error::SsvError;
pub use fit::{fit_lss, fit_rss, fit_rss_triangles};
pub use mesh_body::{
    BodyIdentity, Clearance, CollisionMethod, FIELD_SAMPLES, MeshBody, NEAR_MARGIN, NearField,
    PseudoNormals, cap_holes, is_closed, wrinkled_torus,
};
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
