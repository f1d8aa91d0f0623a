//! The same input gives the same cells and pairs in the same order for 1 and 2 threads, and a
//! rebuilt grid equals a fresh one.

mod common;

use common::{fingerprint, sections};
use hair_grid::{Grid, GridConfig, PairSet, Section};
use hair_ssv::{Lss, Pss, Ssv};
use proptest::prelude::*;

fn run(secs: &[Section], threads: usize) -> (Vec<u64>, Vec<[u32; 2]>, Vec<[u32; 2]>) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut grid = Grid::new(GridConfig {
            cell_size: Some(0.03),
            ..GridConfig::default()
        });
        grid.rebuild(secs).unwrap();
        let mut pairs = PairSet::new();
        grid.candidate_pairs(&mut pairs);
        let cand = pairs.to_vec();
        grid.overlapping_pairs(&mut pairs);
        (fingerprint(&grid), cand, pairs.to_vec())
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]

    #[test]
    fn output_order_does_not_depend_on_thread_count(secs in sections(120)) {
        // Repeat the input, shifted, so that several chunks of work exist.
        let mut many = Vec::new();
        for k in 0..12u32 {
            let shift = hair_ssv::Vector::new(0.5 * k as f32, 0.0, 0.0);
            many.extend(secs.iter().map(|s| {
                let shape = match s.shape {
                    Ssv::Line(l) => Ssv::Line(Lss::new(l.a + shift, l.b + shift, l.radius.min(0.01))),
                    Ssv::Point(p) => Ssv::Point(Pss::new(p.center + shift, p.radius.min(0.01))),
                    Ssv::Rect(mut q) => {
                        q.origin += shift;
                        q.radius = q.radius.min(0.01);
                        Ssv::Rect(q)
                    }
                };
                Section { skeleton: s.skeleton + 1000 * k, segment: s.segment, shape }
            }));
        }
        prop_assert_eq!(run(&many, 1), run(&many, 2));
    }
}

#[test]
fn a_reused_grid_equals_a_fresh_one() {
    use proptest::strategy::{Strategy, ValueTree};
    use proptest::test_runner::TestRunner;
    let mut runner = TestRunner::deterministic();
    let mut grid = Grid::new(GridConfig::default());
    for _ in 0..10 {
        let secs = sections(80).new_tree(&mut runner).unwrap().current();
        let mut fresh = Grid::new(GridConfig::default());
        let a = fresh.rebuild(&secs).is_ok();
        let b = grid.rebuild(&secs).is_ok();
        assert_eq!(a, b);
        if a {
            assert_eq!(fingerprint(&grid), fingerprint(&fresh));
        }
    }
}

/// A scene large enough that the sections are ranked in several blocks: the pair search's order
/// is the same on 1, 2 and 3 threads and is the order by first cell, then by index.
#[test]
fn the_search_order_is_by_first_cell_then_index_on_any_thread_count() {
    let secs = hair_grid::test_scenes::head_shell(60_000, 30, 3);
    let order = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut grid = Grid::new(GridConfig::default());
            grid.rebuild(&secs).unwrap();
            let mut pairs = PairSet::new();
            grid.overlapping_pairs(&mut pairs);
            let keys: Vec<_> = grid.cells().map(|(k, _)| k).collect();
            let mut expected: Vec<(usize, u32)> = (0..secs.len())
                .map(|i| {
                    let first = grid.section_cells(i).next().expect("a cover");
                    let cell = keys.iter().position(|&k| k == first).expect("a cell");
                    (cell, i as u32)
                })
                .collect();
            expected.sort_unstable();
            let expected: Vec<u32> = expected.into_iter().map(|(_, i)| i).collect();
            assert_eq!(grid.search_order(), &expected[..], "{threads} threads");
            (grid.search_order().to_vec(), pairs.to_vec())
        })
    };
    let one = order(1);
    assert_eq!(order(2), one);
    assert_eq!(order(3), one);
}
