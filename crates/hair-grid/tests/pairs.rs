//! Completeness and uniqueness of the hair-hair pairs against brute force.

mod common;

use std::collections::BTreeSet;

use common::{brute_pairs, sections};
use hair_grid::test_scenes::wisp;
use hair_grid::{Grid, GridConfig, GridError, PairSet, Section};
use hair_ssv::{Lss, Point, Ssv};
use proptest::prelude::*;

fn check(secs: &[Section], config: GridConfig) -> Result<(), TestCaseError> {
    let mut grid = Grid::new(config.clone());
    let built = grid.rebuild(secs);
    // Only zero-length sections: no mean segment length, a documented error.
    prop_assume!(!matches!(built, Err(GridError::NonPositiveCellSize { .. })));
    built.map_err(|e| TestCaseError::fail(e.to_string()))?;
    let mut cand = PairSet::new();
    grid.candidate_pairs(&mut cand);
    let list = cand.to_vec();
    let set: BTreeSet<[u32; 2]> = list.iter().copied().collect();
    prop_assert_eq!(set.len(), list.len(), "duplicate candidate pairs");
    prop_assert!(list.iter().all(|p| p[0] < p[1]));
    let brute = brute_pairs(secs, config.margin, config.skip_neighbours);
    for p in &brute {
        prop_assert!(set.contains(p), "missing overlapping pair {:?}", p);
    }
    let mut exact = PairSet::new();
    grid.overlapping_pairs(&mut exact);
    // The chunks by index are the pairs in order.
    let by_index: Vec<[u32; 2]> = (0..exact.chunk_count())
        .flat_map(|i| exact.chunk(i).iter().copied())
        .collect();
    prop_assert_eq!(&by_index, &exact.to_vec());
    prop_assert!(exact.chunk(exact.chunk_count()).is_empty());
    let mut got = exact.to_vec();
    got.sort_unstable();
    prop_assert_eq!(got, brute);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn candidates_contain_every_overlapping_pair(secs in sections(60), cell in prop_oneof![Just(None), Just(Some(0.05f32)), Just(Some(0.025f32))]) {
        check(&secs, GridConfig { cell_size: cell, max_cells_per_item: 1 << 20, ..GridConfig::default() })?;
    }

    /// The grid keeps only the lines of the LSS sections (in the pair search's order) and the
    /// shapes of the others: every section must still read back exactly as it was inserted.
    #[test]
    fn every_section_reads_back_as_inserted(secs in sections(60), margin in 0.0f32..0.02) {
        let h = 0.05f32;
        let mut grid = Grid::new(GridConfig { cell_size: Some(h), margin, max_cells_per_item: 1 << 20, ..GridConfig::default() });
        prop_assume!(grid.rebuild(&secs).is_ok());
        let slack = f64::from(margin) * 0.5 + 1e-3 * f64::from(h);
        for (i, s) in secs.iter().enumerate() {
            prop_assert_eq!(grid.shape(i), Some(s.shape), "section {}", i);
            prop_assert_eq!(grid.skeleton(i), Some(s.skeleton));
            prop_assert_eq!(grid.segment(i), Some(s.segment));
            let (lo, hi) = grid.aabb(i).unwrap_or_default();
            let (a, b) = s.shape.aabb();
            for k in 0..3 {
                prop_assert!((f64::from(a[k] - lo[k]) - slack).abs() < 1e-6, "section {} low {}", i, k);
                prop_assert!((f64::from(hi[k] - b[k]) - slack).abs() < 1e-6, "section {} high {}", i, k);
            }
        }
        prop_assert_eq!(grid.shape(secs.len()), None);
        prop_assert_eq!(grid.skeleton(secs.len()), None);
    }

    #[test]
    fn candidates_contain_every_pair_within_the_margin(secs in sections(40), margin in 0.0f32..0.03) {
        check(&secs, GridConfig { cell_size: Some(0.05), margin, skip_neighbours: 0, ..GridConfig::default() })?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(6))]

    #[test]
    fn crowded_cells_keep_every_overlapping_pair(seed in any::<u64>(), strands in 150u32..260, margin in 0.0f32..0.004, skip in 0u32..2) {
        check(&wisp(strands, seed), GridConfig { margin, skip_neighbours: skip, ..GridConfig::default() })?;
    }
}

#[test]
fn touching_segments_on_a_cell_boundary_are_paired() {
    // Two segments along the plane x = 0.05 (a cell boundary), touching exactly.
    let a = Ssv::Line(Lss::new(
        Point::new(0.05, 0.0, 0.0),
        Point::new(0.05, 0.1, 0.0),
        0.01,
    ));
    let b = Ssv::Line(Lss::new(
        Point::new(0.05, 0.05, 0.02),
        Point::new(0.05, 0.05, 0.1),
        0.01,
    ));
    let secs = [
        Section {
            skeleton: 0,
            segment: 0,
            shape: a,
        },
        Section {
            skeleton: 1,
            segment: 0,
            shape: b,
        },
    ];
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.05),
        ..GridConfig::default()
    });
    grid.rebuild(&secs).unwrap();
    let mut pairs = PairSet::new();
    grid.overlapping_pairs(&mut pairs);
    assert_eq!(pairs.to_vec(), vec![[0, 1]]);
}

#[test]
fn a_long_diagonal_segment_covers_far_fewer_cells_than_its_box() {
    let s = Section {
        skeleton: 0,
        segment: 0,
        shape: Ssv::Line(Lss::new(
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 1.0, 1.0),
            0.001,
        )),
    };
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.01),
        ..GridConfig::default()
    });
    grid.rebuild(&[s]).unwrap();
    // The box holds a million cells; the walk about 3 per unit step along the diagonal.
    assert!(grid.entry_count() < 1000, "{}", grid.entry_count());
    assert!(grid.entry_count() >= 100);
}

#[test]
fn neighbours_on_a_skeleton_are_skipped_unless_asked() {
    let nodes: Vec<Point> = (0..4)
        .map(|k| Point::new(0.0, -0.01 * k as f32, 0.0))
        .collect();
    let secs: Vec<Section> = nodes
        .windows(2)
        .enumerate()
        .map(|(k, w)| Section {
            skeleton: 7,
            segment: k as u32,
            shape: Ssv::Line(Lss::new(w[0], w[1], 0.001)),
        })
        .collect();
    let mut grid = Grid::new(GridConfig::default());
    grid.rebuild(&secs).unwrap();
    let mut pairs = PairSet::new();
    grid.overlapping_pairs(&mut pairs);
    assert!(pairs.is_empty());
    grid.set_config(GridConfig {
        skip_neighbours: 0,
        ..GridConfig::default()
    });
    grid.rebuild(&secs).unwrap();
    grid.overlapping_pairs(&mut pairs);
    let mut v = pairs.to_vec();
    v.sort_unstable();
    assert_eq!(v, vec![[0, 1], [1, 2]]);
}
