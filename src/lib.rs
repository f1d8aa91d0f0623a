//! # hair
//!
//! Interactive, physically based hair: strands simulated at any level of detail, collided with
//! bodies and with each other. The facade re-exports the layers and composes them into a
//! per-step pipeline driven by scene files or by the caller.
//!
//! | item | what it is |
//! |---|---|
//! | [`dynamics`], [`ssv`], [`grid`], [`lod`], [`io`] | the layers, re-exported |
//! | [`Scene`], [`LoadedScene`] | serde scene data (`scenes/*.ron`, `docs/scene-format.md`) |
//! | [`Simulation`], [`StepStats`] | the per-step pipeline and what each step cost |
//! | [`Simulation::from_groom`], [`Body`], [`Simulation::set_head_pose`] | a simulation built from data and driven by its caller |
//! | [`Simulation::add_body_part`], [`Simulation::set_body_part_pose`], [`BodyPart`] | rigid body parts (neck, torso) the caller poses, colliding as they move |
//! | [`salon`]: [`ToolEvent`], [`ToolScript`], [`Salon`] | salon tools (water, spray, mousse, dryer, grab, scissors) driven by a replayable timeline of events |
//! | [`body_from_spec`] | the scene's body (procedural head, wrinkled torus or OBJ) as a [`ssv::MeshBody`] |
//!
//! Embedded in an engine, with no scene file (`examples/embed.rs` in full): a groom from arrays,
//! the head posed each step (velocities and accelerations are estimated from the poses; a jump
//! beyond [`TeleportLimits`] is a teleport), the torso a separate part posed beside it, the
//! drawn strands borrowed, not copied.
//!
//! ```
//! use hair::{Body, PartId, Scene, Simulation};
//! use nalgebra::{Isometry3, Vector3};
//!
//! let roots = (0..20).map(|i| [0.02 * (i as f32 - 10.0), 0.13, -0.05]);
//! let groom = roots.map(|[x, y, z]| (0..8).map(|k| [x, y, z - 0.03 * k as f32]).collect());
//! let groom = hair::io::Strands::from_polylines(groom.collect())?;
//! let body = Body::HeadNeckTorso { resolution: 16 }; // parts: 0 the neck, 1 the torso
//! let mut sim = Simulation::from_groom(&groom, body, &Scene::default())?;
//! for _ in 0..30 {
//!     let t = sim.time() + sim.dt(); // the pose the head reaches at the end of the step
//!     let turn = Vector3::y() * 0.4 * (6.0 * t).sin();
//!     sim.set_head_pose(Isometry3::new(Vector3::zeros(), turn))?;
//!     let lean = Vector3::x() * 0.1 * (3.0 * t).sin(); // the torso leans, the hair meets it
//!     sim.set_body_part_pose(PartId(1), Isometry3::new(Vector3::zeros(), lean))?;
//!     let stats = sim.step()?;
//!     let tip = sim.render_geometry().strand(0).last().copied(); // a slice into the sim
//!     println!("{:.2} ms, tip {tip:?}", stats.ms_total);
//! }
//! # Ok::<(), hair::HairError>(())
//! ```
//!
//! From a scene file: `Simulation::new(&Scene::load("wind")?, LodPolicy::Fine)?`, then `step`.

pub use hair_collide as collide;
pub use hair_dynamics as dynamics;
pub use hair_grid as grid;
pub use hair_io as io;
pub use hair_lod as lod;
pub use hair_salon as salon;
pub use hair_ssv as ssv;

mod body;
pub mod drivers;
mod embed;
mod error;
pub mod hairstyle;
mod lod_stage;
mod parts;
#[cfg(feature = "render")]
pub mod render;
pub mod scene;
mod simulation;

pub use body::from_spec as body_from_spec;
pub use dynamics::{HeadPose, TeleportLimits};
pub use embed::Body;
pub use error::HairError;
pub use hair_render::stage::RenderGeometry;
pub use parts::{BodyPart, PartId};
pub use salon::{
    Pose, PoseKey, Salon, SalonError, SalonSettings, SalonStats, Tool, ToolAction, ToolEvent,
    ToolScript,
};
pub use scene::{LoadedScene, LodPolicy, Scene};
pub use simulation::{PREFILL_INSIDE, Simulation, StepStats};
