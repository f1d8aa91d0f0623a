//! # hair-lod
//!
//! Levels of detail for hair, after Ward & Lin 2003 (§4 hierarchy, §6 runtime selection, split
//! and merge) and Ward, Galoppo & Lin's virtual hair salon (§4.4 activity, §6.6 inheritance of
//! styling properties).
//!
//! | item | what it is |
//! |---|---|
//! | [`Hairstyle`], [`Strand`] | the input: roots, root frames and points of every strand |
//! | [`Hierarchy::build`], [`HierarchyParams`], [`HierarchySpec`], [`MinGroup`] | the precomputed strip / cluster / strand-group forest (binary strip trees, quad-tree clusters and strand groups) |
//! | [`Hierarchy`], [`NodeKind`], [`HierarchyStats`] | per node: kind, level, parent, children, strands, width or radius, offsets from the parent per control point; counts and bytes |
//! | [`select`], [`SelectParams`], [`NodeInputs`], [`Activity`], [`Front`], [`Plan`] | the pure per-step decision: visibility, distance, speed and activity against per-level intervals |
//! | [`apply`], [`split`], [`merge`], [`try_merge`], [`merge_check`], [`MergeParams`] | transitions that carry motion and properties |
//! | [`LodState`], [`LodBond`], [`cut`], [`add_bond`] | per-node motion (bend from rest, angular velocities) and properties (wetness, stiffness, thickness, length, cut, bonds) |
//! | [`inherit_edits`], [`InheritScratch`] | edits of active nodes carried to every level, any layout |
//! | [`AdaptiveLod`], [`AdaptiveSettings`], [`View`], [`BodyDepth`] | the `adaptive` policy over a strand state: visibility (view cone, the body's depth image), held speeds and hidden-step counts (hysteresis), one selection and transition per step |
//! | [`test_heads`] | a procedural stand-in for the Ward & Lin benchmark head |
//!
//! ## The model
//!
//! - **Hierarchy.** Root strips tile the scalp and split in two across their width until
//!   narrower than `strip_width_min`; each finest strip becomes a root cluster (a node of its
//!   own with the same strands), which splits into quadrants until its radius is under
//!   `cluster_radius_min`; each finest cluster becomes a root strand group, which splits into
//!   non-empty quadrants, each with the tightest circle around its strands, down to single
//!   strands or the region's minimum group size. Every node of a tree has the tree's
//!   control-point count and stores its rest skeleton as an offset per control point from its
//!   parent's. Nodes are structure-of-arrays with `u32` indices and `f32` geometry
//!   ([`HierarchyStats::bytes_per_strand`]).
//! - **Selection** is a pure function: a tree whose root strip is not visible collapses to it;
//!   visible again, it goes straight back down to the level its inputs ask for; otherwise every
//!   active node moves at most one level per step, splitting when its distance or speed (or a
//!   tool) asks for more detail and merging when all its siblings ask for less.
//! - **State.** Transitions work on [`LodState`], not on `hair_dynamics::StrandState`: motion is
//!   kept as the bend *away from rest* plus angular velocities, so a child inherits the parent's
//!   numbers unchanged and a merge of untouched children restores them bit for bit. The facade
//!   gives each active node a skeleton from [`Hierarchy::skeleton_desc`] and moves motion across
//!   with [`LodState::write_motion`] and [`LodState::read_motion`]; it scales the node's spring
//!   constants, radius and rest lengths by `stiffness`, `thickness` and `length`, and gives it
//!   `strand_count * wetness` of water.
//! - **Water** is conserved: children inherit wetness (an intensive quantity), and a parent takes
//!   the strand-weighted mean, so [`LodState::total_water`] is unchanged by splits and merges
//!   (up to f32 rounding of the mean).
//!
//! ```
//! use hair_lod::*;
//!
//! let style = test_heads::ward_lin_head(500, 7);
//! let h = Hierarchy::build(&style, &HierarchyParams::default())?;
//! let mut front = Front::coarsest(&h);
//! let mut state = LodState::new(&h);
//! state.wetness.iter_mut().for_each(|w| *w = 0.5);
//! let water = state.total_water(&h, &front);
//!
//! // A close, fast-moving head: every node asks for more detail, one level per step.
//! let n = h.node_count();
//! let (visible, distance, speed) = (vec![true; n], vec![0.3; n], vec![2.0; n]);
//! let activity = vec![Activity::Moving; n];
//! let inputs = NodeInputs { visible: &visible, distance: &distance, speed: &speed, activity: &activity };
//! for _ in 0..=h.max_level() {
//!     let plan = select(&h, &front, &inputs, &SelectParams::default())?;
//!     apply(&h, &mut front, &mut state, &plan, &MergeParams::default())?;
//! }
//! assert_eq!(front, Front::finest(&h));
//! assert!((state.total_water(&h, &front) - water).abs() < 1e-9 * water);
//!
//! // Out of view: the whole head drops to its root strips in one step.
//! let hidden = vec![false; n];
//! let inputs = NodeInputs { visible: &hidden, ..inputs };
//! let plan = select(&h, &front, &inputs, &SelectParams::default())?;
//! apply(&h, &mut front, &mut state, &plan, &MergeParams::default())?;
//! assert_eq!(front.active_count(), h.tree_count());
//! # Ok::<(), LodError>(())
//! ```

mod adaptive;
mod build;
mod error;
mod hairstyle;
mod hierarchy;
mod inherit;
mod select;
mod state;
pub mod test_heads;
mod transition;

pub use adaptive::{
    AdaptiveLod, AdaptiveSettings, BODY_DEPTH_SIZE, BodyDepth, HIDDEN_AFTER, HIDDEN_BEHIND,
    OccluderMesh, SPEED_HOLD, View,
};
pub use build::{HierarchyParams, HierarchySpec, MAX_STRAND_SPREAD_DEGREES, MinGroup};
pub use error::LodError;
pub use hairstyle::{Hairstyle, Strand};
pub use hierarchy::{Hierarchy, HierarchyStats, LevelCount, NO_PARENT, NodeKind};
pub use inherit::{InheritScratch, add_bond, cut, inherit_edits};
pub use select::{
    Activity, Front, MERGE_MARGIN, NodeInputs, Plan, SelectParams, rendered, select, select_into,
};
pub use state::{BondEnd, LodBond, LodState};
pub use transition::{
    MergeCheck, MergeParams, TransitionReport, apply, merge, merge_check, split, try_merge,
};

pub use hair_dynamics::{Point, Real, Vector};
