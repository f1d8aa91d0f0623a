//! `hair-grid`: the localization grid of the hair simulation.
//!
//! A sparse uniform grid, rebuilt every step in O(n) and in parallel, that finds the hair-hair
//! pairs, the cells where hair meets the body, the sections a salon tool acts on, and the cells
//! that can stop being simulated. It implements:
//!
//! - Ward & Lin 2003, *Adaptive Grouping and Subdivision for Simulating Hair Dynamics*, §5.3:
//!   the uniform grid of hair sections (cell size = mean segment length), candidate pairs of
//!   sections sharing a cell, then the exact swept-sphere-volume test;
//! - Ward, Galoppo & Lin, *Interactive Virtual Hair Salon*, §4.3-4.4, simulation localization:
//!   active and dormant cells from the sections entering, leaving and moving, and the influence
//!   volumes of the salon tools (cones; a triangle for scissors), cells first, then the exact
//!   test.
//!
//! | item | what it offers |
//! |---|---|
//! | [`Grid`], [`GridConfig`], [`Section`] | insert hair sections (LSS / RSS / PSS from `hair-ssv`); each section covers exactly the cells its core reaches, grown by its radius |
//! | [`Grid::candidate_pairs`], [`Grid::overlapping_pairs`], [`PairSet`] | unique hair-hair candidate pairs (each once, optionally skipping same-skeleton neighbours), and the exact-overlap pairs |
//! | [`Grid::overlapping_pairs_by_rank`], [`Grid::search_order`] | the same pairs by position in the search's order, for data laid out in it |
//! | [`Kernel`], [`GridConfig::kernel`], [`Grid::kernel`] | the instruction set of the search (AVX-512, AVX2 or baseline; [`Kernel::Auto`] picks the widest): the same results, different times |
//! | [`BodyGrid`], [`Grid::body_cells`], [`BodyCells`] | body triangles inserted once; cells holding both hair and body, with their triangles |
//! | [`InfluenceVolume`], [`Cone`], [`Grid::sections_in`], [`Grid::cells_touched_by`] | tool volumes: the sections and cells they reach |
//! | [`Activity`], [`ActivityConfig`], [`ActivityInput`], [`CellState`] | active and dormant cells; frozen sections; the skeletons to integrate this step |
//! | [`CellKey`] | integer cell coordinates on the global lattice, packed into ordered `u64` keys |
//! | [`GridError`] | every failure on untrusted input (non-finite coordinates, bad cell size, too many cells, a kernel the processor lacks) |
//! | `test_scenes` (feature `test-support`) | the seeded head-sized shell of hair that the benches and `hair bench grid` measure |
//!
//! Output orders are deterministic: the same input gives the same cells, sections and pairs in
//! the same order for any number of threads and with every kernel (cells are sorted by key; no
//! hashing with random state). How the rebuild and the search are built, and what each step of
//! their design was measured to cost, is in `docs/perf/grid.md`.
//!
//! ```
//! use hair_grid::{Grid, GridConfig, PairSet, Section};
//! use hair_ssv::{Lss, Point, Ssv};
//!
//! // Two strands of three 1 cm segments, 0.5 mm apart at the tips.
//! let strand = |x: f32, lean: f32| -> Vec<Point> {
//!     (0..4).map(|k| Point::new(x + lean * k as f32, -0.01 * k as f32, 0.0)).collect()
//! };
//! let mut sections = Vec::new();
//! for (s, nodes) in [strand(0.0, 0.0), strand(0.0024, -0.0005)].iter().enumerate() {
//!     for (k, w) in nodes.windows(2).enumerate() {
//!         let shape = Ssv::Line(Lss::new(w[0], w[1], 0.0005));
//!         sections.push(Section { skeleton: s as u32, segment: k as u32, shape });
//!     }
//! }
//! let mut grid = Grid::new(GridConfig::default());
//! grid.rebuild(&sections)?;
//! assert!((grid.cell_size() - 0.01).abs() < 1e-3); // mean segment length
//!
//! let mut pairs = PairSet::new();
//! grid.overlapping_pairs(&mut pairs);
//! // Only the last segments of the two strands overlap; neighbours on a strand are skipped.
//! assert_eq!(pairs.to_vec(), vec![[2, 5]]);
//! # Ok::<(), hair_grid::GridError>(())
//! ```

mod activity;
mod body;
mod cell_key;
mod cover;
mod error;
mod grid;
mod influence;
mod kernel;
mod pairs;
#[cfg(any(test, feature = "test-support"))]
pub mod test_scenes;

pub use activity::{Activity, ActivityConfig, ActivityInput, CellActivity, CellState};
pub use body::{BodyCells, BodyGrid};
pub use cell_key::{CellKey, LATTICE_HALF};
pub use error::GridError;
pub use grid::{Grid, GridConfig, Section};
pub use influence::{Cone, InfluenceVolume};
pub use kernel::Kernel;
pub use pairs::PairSet;

pub use hair_ssv::{Point, Real, Ssv, Vector};
