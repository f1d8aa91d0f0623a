//! `hair-grid`: the localization grid of the hair simulation (Ward & Lin 2003 §5.3; Ward,
//! Galoppo & Lin, *Interactive Virtual Hair Salon*, §4.3-4.4).
//!
//! A sparse uniform grid, rebuilt every step in O(n) and in parallel, that finds hair-hair pairs,
//! the cells where hair meets the body, the sections a salon tool acts on, and the cells that can
//! stop being simulated.
//!
//! | item | what it offers |
//! |---|---|
//! | [`Grid`], [`GridConfig`], [`Section`] | insert hair sections (LSS / RSS / PSS from `hair-ssv`); cell size = mean segment length by default; each section covers exactly the cells its core reaches, grown by its radius |
//! | [`Grid::candidate_pairs`], [`Grid::overlapping_pairs`], [`PairSet`] | unique hair-hair candidate pairs (each reported once, optionally skipping same-skeleton neighbours), and the exact-overlap pairs by `hair-ssv` distance |
//! | [`BodyGrid`], [`Grid::body_cells`], [`BodyCells`] | body triangles inserted once; cells holding both hair and body, with their triangles |
//! | [`InfluenceVolume`], [`Cone`], [`Grid::sections_in`], [`Grid::cells_touched_by`] | tool volumes (cone for water, spray, mousse, dryer, grab; triangle for scissors): cells first, then the exact test |
//! | [`Activity`], [`ActivityConfig`], [`ActivityInput`], [`CellState`] | active and dormant cells; frozen sections; the skeletons to integrate this step |
//! | [`CellKey`] | integer cell coordinates on the global lattice, packed into ordered `u64` keys |
//! | [`GridError`] | every failure on untrusted input (non-finite coordinates, bad cell size, too many cells) |
//!
//! Output orders are deterministic: the same input gives the same cells, sections and pairs in the
//! same order for any number of rayon threads. No hashing with random state is used: cells are
//! sorted by their keys.
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
mod pairs;

pub use activity::{Activity, ActivityConfig, ActivityInput, CellActivity, CellState};
pub use body::{BodyCells, BodyGrid};
pub use cell_key::{CellKey, LATTICE_HALF};
pub use error::GridError;
pub use grid::{Grid, GridConfig, Section};
pub use influence::{Cone, InfluenceVolume};
pub use pairs::PairSet;

pub use hair_ssv::{Point, Real, Ssv, Vector};
