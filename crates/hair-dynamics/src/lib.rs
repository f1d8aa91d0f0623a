//! # hair-dynamics
//!
//! Strand skeletons in angle coordinates: the angular hair model of Kurihara, Anjyo & Thalmann
//! (§2), with Ward & Lin's implicit integration (§5.6, Appendix A) and a coupled implicit step
//! that is stable where the papers' step is not.
//!
//! | item | what it is |
//! |---|---|
//! | [`StrandState`] | structure of arrays over every control point of every skeleton |
//! | [`SkeletonDesc`], [`Material`], [`Root`] | a skeleton to add: rest polyline, material profile, attached or free root |
//! | [`Style`], [`style_points`] | straight, wavy and curly rest shapes |
//! | [`Environment`], [`Wind`], [`HeadMotion`], [`ForceField`] | gravity, wind, head motion as fictitious forces, force cones |
//! | [`HeadPoseTrack`], [`TeleportLimits`] | the head's motion estimated from the poses a caller gives; a jump is a teleport |
//! | [`Integrator`], [`TorqueModel`], [`StepSettings`] | seven integrators, local or chain torque |
//! | [`NodeCorrection`], [`VelocityConstraint`] | collision response mapped back to angles |
//! | [`StrandState::sweep_chains`], [`SweepAsk`] | a position constraint applied root to tip, each node tested where the corrections before it put it (the hard body constraint) |
//! | [`Bond`] | hairspray bonds between skeletons, with a break distance |
//! | [`CutPoint`], [`StrandState::cut`], [`StrandState::hold_node`] | salon cuts (the fallen piece becomes a free skeleton) and grabbed control points |
//! | [`mod@reference`] | f64 single-strand reference and the cantilever elastica |
//! | [`XpbdStrands`], [`XpbdSettings`] | the engines' XPBD strand (stretch and bend compliance, substeps, iterations), the charts' peer |
//!
//! ```
//! use hair_dynamics::*;
//! use nalgebra::Rotation3;
//!
//! let mut state = StrandState::new();
//! let frame = Rotation3::identity(); // hair leaves the scalp along +z
//! let points = style_points(Point::origin(), &frame, &Style::Straight, 20, 0.25)?;
//! let id = state.add_skeleton(&SkeletonDesc {
//!     root: Root::Attached { position: Point::origin(), frame },
//!     points,
//!     material: Material::default(),
//! })?;
//! let env = Environment::default(); // gravity along -y
//! let settings = StepSettings { dt: 1.0 / 60.0, ..StepSettings::default() };
//! for _ in 0..120 {
//!     state.step(&env, &settings)?;
//! }
//! let tip = state.positions()[state.nodes(id).end - 1];
//! assert!(tip.y < 0.0, "the strand sags under gravity");
//! # Ok::<(), DynamicsError>(())
//! ```

mod bend;
mod bonds;
mod environment;
mod error;
mod head_track;
mod integrate;
mod polyline;
pub mod reference;
mod response;
mod run;
mod sag_free;
mod salon_ops;
mod state;
mod strand;
mod style;
mod summary;
mod xpbd;

pub use bend::{Bend, bend_between};
pub use bonds::Bond;
pub use environment::{Environment, ForceField, HeadMotion, Wind};
pub use error::DynamicsError;
pub use head_track::{HeadPose, HeadPoseTrack, PoseJump, TeleportLimits};
pub use integrate::{Integrator, LinearSolver, StepReport, StepSettings, TorqueModel};
pub use polyline::resample_polyline;
pub use response::{NodeCorrection, SweepAsk, VelocityConstraint};
pub use salon_ops::{CutPoint, CutResult};
pub use state::{Material, Root, SkeletonDesc, SkeletonId, StrandState};
pub use style::{Style, style_points};
pub use xpbd::{XpbdSettings, XpbdStrands};

/// Scalar of the runtime state.
pub type Real = f32;
/// A vector in the head frame.
pub type Vector = nalgebra::Vector3<Real>;
/// A point in the head frame.
pub type Point = nalgebra::Point3<Real>;
