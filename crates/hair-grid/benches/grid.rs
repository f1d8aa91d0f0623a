//! Criterion benches of the grid: rebuild and pair search on a seeded head-sized shell of hair.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use hair_grid::{Grid, GridConfig, PairSet, Section};
use hair_ssv::{Lss, Point, Ssv, Vector};

/// SplitMix64.
struct Rng(u64);

impl Rng {
    fn unit(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
}

/// Strands rooted on the upper part of a 10 cm sphere, lying on it in layers and hanging below,
/// in segments of about 1 cm with a 0.5 mm radius.
fn head_scene(segments: usize, per_strand: usize, seed: u64) -> Vec<Section> {
    let mut rng = Rng(seed);
    let mut out = Vec::with_capacity(segments);
    let down = Vector::new(0.0, -1.0, 0.0);
    let mut s = 0u32;
    while out.len() < segments {
        let n = loop {
            let v = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let l = v.norm();
            if l > 1e-3 && l <= 1.0 {
                let v = v / l;
                if v.y > -0.2 && !(v.z > 0.3 && v.y < 0.5) {
                    break v;
                }
            }
        };
        let layer = 0.1 + rng.range(0.001, 0.03);
        let mut p = Point::from(n * 0.1);
        let mut dir = (n * 0.8 + down * 0.2).normalize();
        let stiff = rng.range(0.1, 0.3);
        for k in 0..per_strand.min(segments - out.len()) {
            let noise = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            dir = (dir * (1.0 - stiff) + down * stiff + noise * 0.08).normalize();
            let mut q = p + dir * 0.01 * rng.range(0.9, 1.1);
            let r = q.coords.norm();
            if r < layer {
                q = Point::from(q.coords * (layer / r));
            }
            out.push(Section {
                skeleton: s,
                segment: k as u32,
                shape: Ssv::Line(Lss::new(p, q, 0.0005)),
            });
            p = q;
        }
        s += 1;
    }
    out
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("grid");
    group.sample_size(10);
    for &n in &[30_000usize, 300_000] {
        let sections = head_scene(n, 30, 1);
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
    // Build plus exact pair search on the full scene at other cell sizes.
    let sections = head_scene(300_000, 30, 1);
    for cell in [0.005f32, 0.0075, 0.01] {
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
