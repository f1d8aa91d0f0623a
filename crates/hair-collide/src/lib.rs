//! # hair-collide
//!
//! Collision stages for angular strands ([`hair_dynamics::StrandState`]): each a struct that
//! owns its scratch buffers and has one method over explicit inputs, so a pipeline (or a
//! strand solver of your own) calls them between integration steps.
//!
//! | item | what it is |
//! |---|---|
//! | [`CollisionSettings`] | every setting of both stages, with documented defaults; [`CollisionSettings::validate`] |
//! | [`BodyConstraint`], [`BodyReport`] | the hard body constraint: nodes out of a [`hair_ssv::MeshBody`] root to tip, approach velocity removed with friction, a depenetration ramp for hair that starts inside |
//! | [`HairHairModel`], [`VolumeSettings`] | the choice of hair-hair model (`Volume`, `Pairs`, `Off`) and the volume model's settings |
//! | [`HairHairStage`], [`HairHairReport`] | the hair-hair stage: the chosen model behind one call |
//! | [`HairVolume`], [`Lattice`], [`VolumeReport`] | hair as a volume: mass and momentum on a dense grid, friction toward its velocity, a push out of over-dense places; the same bits on any thread count |
//! | [`HairPairs`], [`Sections`], [`PushCombine`], [`PairsReport`] | the papers' hair-hair model: exact swept-sphere pairs from a [`hair_grid::Grid`], near-parallel ones share velocity, crossing ones are pushed apart |
//! | [`Localization`] | active and dormant skeletons from the grid's cell activity |
//! | [`CollideError`] | the one error type |
//!
//! ```
//! use hair_collide::{BodyConstraint, CollisionSettings};
//! use hair_dynamics::{Material, Point, Root, SkeletonDesc, StrandState, Style, style_points};
//! use hair_ssv::{MeshBody, wrinkled_torus};
//! use nalgebra::{Rotation3, Vector3};
//!
//! // A ring-shaped body, and a strand hanging straight down through its tube.
//! let (vertices, triangles) = wrinkled_torus(Point::new(0.0, -0.1, 0.0), 0.1, 0.03, 0, 0.0, 48, 16);
//! let body = MeshBody::new(vertices, triangles)?;
//! let frame = Rotation3::from_axis_angle(&Vector3::x_axis(), std::f32::consts::FRAC_PI_2);
//! let root = Point::new(0.1, 0.0, 0.0);
//! let mut state = StrandState::new();
//! state.add_skeleton(&SkeletonDesc {
//!     root: Root::Attached { position: root, frame },
//!     points: style_points(root, &frame, &Style::Straight, 12, 0.2)?,
//!     material: Material::default(),
//! })?;
//! // No ramp: everything comes out at once.
//! let settings = CollisionSettings { depenetration_steps: 0, ..CollisionSettings::default() };
//! let mut constraint = BodyConstraint::new();
//! let report = constraint.apply(&mut state, &body, &[0], 0, &settings)?;
//! assert!(report.contacts > 0);
//! assert!(report.max_penetration <= settings.tolerance);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Papers: Kurihara, Anjyo & Thalmann (1993) §4, the reaction constraint (here positional,
//! root to tip); Ward & Lin (2003) §5.4, hair-hair response between swept sphere volumes;
//! Ward, Galoppo & Lin, simulation localization (§4.3); Petrovic, Henne & Anderson (2005) §3,
//! hair as a volume.

mod body;
mod error;
mod hair_hair;
mod localization;
mod model;
mod pairs;
mod part;
mod rest;
mod settings;
mod support;
mod volume;

pub use body::{BodyConstraint, BodyReport, PartMotion};
pub use error::CollideError;
pub use hair_hair::{HairHairReport, HairHairStage};
pub use localization::Localization;
pub use model::{HairHairModel, VolumeSettings};
pub use pairs::{HairPairs, PairsReport, PushCombine, Sections};
pub use part::BodyPart;
pub use rest::{GroomRestReport, make_groom_rest};
pub use settings::{CollisionSettings, SettingsError};
pub use support::{BodySupport, SUPPORT_REACH};
pub use volume::{HairVolume, Lattice, VolumeReport};
