//! # hair-salon
//!
//! The virtual hair salon's tools (Ward, Galoppo & Lin, *Interactive Virtual Hair Salon*, §3.1,
//! §4.3-4.4, §6) over angular strands: water, hairspray (stiffening and dynamic bonds),
//! mousse, a hair dryer, grab and scissors, driven by a timeline of events that replays bit
//! for bit. Styling properties reach every level of detail through `hair-lod`'s inheritance.
//!
//! | item | what it is |
//! |---|---|
//! | [`ToolScript`], [`ToolEvent`], [`Tool`], [`ToolAction`], [`Pose`], [`PoseKey`] | a styling session as data: tools pressed, moved along paths and released at times |
//! | [`SalonSettings`] | the tools' nominal effects and the cut's limits (SI units) |
//! | [`Salon`], [`SalonInput`], [`SalonStats`] | the stage: each step applies the events due and the pressed tools' effects, and reports water, length, bonds, cuts |
//! | [`FallenPiece`] | hair a cut made: a free skeleton that falls onto the body and the floor |
//! | [`SalonError`], [`ToolError`] | a bad script (naming the event), a stage's failure |
//!
//! ```
//! use hair_salon::{Pose, Tool, ToolAction, ToolEvent, ToolScript};
//!
//! let event = |time, action| ToolEvent {
//!     time,
//!     tool: Tool::Water,
//!     action,
//!     pose: Pose { position: [0.0, 0.1, -0.4], direction: [0.0, 0.0, 1.0], ..Pose::default() },
//!     path: Vec::new(),
//!     strength: 1.0,
//!     reach: 0.35,
//!     angle: 0.45,
//! };
//! // Wet the back of the head for two seconds.
//! let script = ToolScript {
//!     events: vec![event(0.5, ToolAction::Press), event(2.5, ToolAction::Release)],
//!     ..ToolScript::default()
//! };
//! script.validate()?;
//! // A release before its press is refused, naming the event.
//! let backwards = ToolScript { events: vec![event(1.0, ToolAction::Release)], ..script };
//! assert!(backwards.validate().is_err());
//! # Ok::<(), hair_salon::SalonError>(())
//! ```
//!
//! A [`Salon`] is built over a simulation's strand state and LOD hierarchy and stepped after
//! the dynamics; `docs/salon.md` describes each tool's effect.

mod salon;
mod script;

pub use salon::{FallenPiece, Salon, SalonInput, SalonStats};
pub use script::{
    Pose, PoseKey, SalonError, SalonSettings, Tool, ToolAction, ToolError, ToolEvent, ToolScript,
};
