//! # hair
//!
//! Interactive, physically based hair: strands simulated at any level of detail, collided with
//! bodies and with each other. The facade re-exports the layers and composes them into a
//! per-step pipeline driven by scene files.
//!
//! | item | what it is |
//! |---|---|
//! | [`dynamics`], [`ssv`], [`grid`], [`lod`], [`io`] | the layers, re-exported |
//! | [`Scene`], [`LoadedScene`] | serde scene data (`scenes/*.ron`, `docs/scene-format.md`) |
//! | [`Simulation`], [`StepStats`] | the per-step pipeline and what each step cost |
//! | [`salon`]: [`ToolEvent`], [`ToolScript`], [`Salon`] | salon tools (water, spray, mousse, dryer, grab, scissors) driven by a replayable timeline of events |
//! | [`body_from_spec`] | the scene's body (procedural head, wrinkled torus or OBJ) as a [`ssv::MeshBody`] |
//!
//! ```no_run
//! use hair::{LodPolicy, Scene, Simulation};
//!
//! let scene = Scene::load("wind")?;
//! let mut sim = Simulation::new(&scene, LodPolicy::Fine)?;
//! for _ in 0..10 {
//!     let stats = sim.step()?;
//!     assert!(stats.max_penetration_m <= f64::from(scene.scene.collision.tolerance));
//! }
//! # Ok::<(), hair::HairError>(())
//! ```

pub use hair_collide as collide;
pub use hair_dynamics as dynamics;
pub use hair_grid as grid;
pub use hair_io as io;
pub use hair_lod as lod;
pub use hair_salon as salon;
pub use hair_ssv as ssv;

mod body;
pub mod drivers;
mod error;
pub mod hairstyle;
mod lod_stage;
#[cfg(feature = "render")]
pub mod render;
pub mod scene;
mod simulation;

pub use body::from_spec as body_from_spec;
pub use error::HairError;
pub use hair_render::stage::RenderGeometry;
pub use salon::{
    Pose, PoseKey, Salon, SalonError, SalonSettings, SalonStats, Tool, ToolAction, ToolEvent,
    ToolScript,
};
pub use scene::{LoadedScene, LodPolicy, Scene};
pub use simulation::{PREFILL_INSIDE, Simulation, StepStats};
