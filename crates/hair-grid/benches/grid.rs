//! Criterion benches of the grid: rebuild and pair search on the seeded head-sized shell of hair
//! that `hair bench grid` measures ([`hair_grid::test_scenes::head_shell`]).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use hair_grid::test_scenes::head_shell;
use hair_grid::{Grid, GridConfig, PairSet};

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("grid");
    group.sample_size(10);
    for &n in &[30_000usize, 300_000] {
        let sections = head_shell(n, 30, 1);
        let mut grid = Grid::new(GridConfig::default());
        let mut pairs = PairSet::new();
        group.bench_function(format!("rebuild/{n}"), |b| {
            b.iter(|| grid.rebuild(black_box(&sections)))
        });
        if grid.rebuild(&sections).is_err() {
            return;
        }
        group.bench_function(format!("candidate_pairs/{n}"), |b| {
            b.iter(|| {
                grid.candidate_pairs(&mut pairs);
                black_box(pairs.len())
            })
        });
        group.bench_function(format!("overlapping_pairs/{n}"), |b| {
            b.iter(|| {
                grid.overlapping_pairs(&mut pairs);
                black_box(pairs.len())
            })
        });
    }
    // Build plus exact pair search on the full scene at other cell sizes; at 3 cm the cells
    // hold hundreds of sections each and are searched as sweeps.
    let sections = head_shell(300_000, 30, 1);
    for cell in [0.005f32, 0.0075, 0.01, 0.03] {
        let mut grid = Grid::new(GridConfig {
            cell_size: Some(cell),
            ..GridConfig::default()
        });
        let mut pairs = PairSet::new();
        group.bench_function(format!("build_and_pairs/cell_{cell}"), |b| {
            b.iter(|| {
                let _ = grid.rebuild(black_box(&sections));
                grid.overlapping_pairs(&mut pairs);
                black_box(pairs.len())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
