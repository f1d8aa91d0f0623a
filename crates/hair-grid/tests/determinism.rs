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
