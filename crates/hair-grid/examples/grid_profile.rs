//! Profiling driver for the grid: the `hair bench grid` scene (300,000 segments of about 1 cm,
//! radius 0.5 mm, on a head-sized shell, seed 1), rebuilt and searched for overlapping pairs a
//! given number of times after one warm-up.
//!
//! `cargo run --release -p hair-grid --example grid_profile -- [build|pairs|candidates|both]
//! [repeat] [cell size]` prints the fastest and median times and hashes of the cells, the candidate pairs and the
//! overlapping pairs (in order), so that a change can be checked to leave them identical.
//! Instruction counts of one rebuild (or one pair search): run it under
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind` with `build 1` and `build 3` (or `pairs`);
//! half the difference of the two totals is the cost of one. `candidates` times the pair search
//! without the exact test ([`Grid::candidate_pairs`]), so that the exact test's share is the
//! difference.
use std::time::Instant;

use hair_grid::{Grid, GridConfig, PairSet, Section};
use hair_ssv::{Lss, Point, Ssv, Vector};

struct Rng(u64);
impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn unit(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.unit()
    }
}

fn head_scene(segments: usize, per_strand: usize, seed: u64) -> Vec<Section> {
    let strands = segments.div_ceil(per_strand);
    let mut rng = Rng(seed);
    let mut out = Vec::new();
    let down = Vector::new(0.0, -1.0, 0.0);
    for s in 0..strands {
        let n = loop {
            let v = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let l = v.norm();
            if l > 1e-3 && l <= 1.0 {
                let v = v / l;
                let face = v.z > 0.3 && v.y < 0.5;
                if v.y > -0.2 && !face {
                    break v;
                }
            }
        };
        let layer = 0.1 + rng.range(0.001, 0.03);
        let mut p = Point::from(n * 0.1);
        let mut dir = (n * 0.8 + down * 0.2).normalize();
        let stiff = rng.range(0.1, 0.3);
        let mut left = per_strand.min(segments - out.len());
        let mut k = 0u32;
        while left > 0 {
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
                dir = (q - p).normalize();
            }
            out.push(Section {
                skeleton: s as u32,
                segment: k,
                shape: Ssv::Line(Lss::new(p, q, 0.0005)),
            });
            p = q;
            k += 1;
            left -= 1;
        }
    }
    out
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map(String::as_str).unwrap_or("both");
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    let secs = head_scene(300_000, 30, 1);
    // Optional third argument: the cell size in metres (default: the mean segment length).
    let cell_size: Option<f32> = args.get(3).and_then(|s| s.parse().ok());
    let mut grid = Grid::new(GridConfig {
        cell_size,
        ..GridConfig::default()
    });
    let mut pairs = PairSet::new();
    grid.rebuild(&secs).unwrap();
    grid.overlapping_pairs(&mut pairs);
    let (mut tb, mut tp) = (Vec::new(), Vec::new());
    for _ in 0..reps {
        if mode == "build" || mode == "both" {
            let t = Instant::now();
            grid.rebuild(&secs).unwrap();
            tb.push(t.elapsed().as_secs_f64() * 1e3);
        }
        if mode == "candidates" {
            let t = Instant::now();
            grid.candidate_pairs(&mut pairs);
            tp.push(t.elapsed().as_secs_f64() * 1e3);
            grid.overlapping_pairs(&mut pairs);
        } else if mode != "build" {
            let t = Instant::now();
            grid.overlapping_pairs(&mut pairs);
            tp.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    tb.sort_by(f64::total_cmp);
    tp.sort_by(f64::total_cmp);
    let mut h = 0u64;
    for p in pairs.iter() {
        h = h
            .wrapping_mul(0x100000001b3)
            .wrapping_add(u64::from(p[0]) << 32 | u64::from(p[1]));
    }
    let mut cand = PairSet::new();
    grid.candidate_pairs(&mut cand);
    let mut hc = 0u64;
    for p in cand.iter() {
        hc = hc
            .wrapping_mul(0x100000001b3)
            .wrapping_add(u64::from(p[0]) << 32 | u64::from(p[1]));
    }
    let mut hcell = 0u64;
    for (k, s) in grid.cells() {
        hcell = hcell
            .wrapping_mul(31)
            .wrapping_add((k.x as u64) << 40 ^ (k.y as u64) << 20 ^ k.z as u64);
        for &i in s {
            hcell = hcell.wrapping_mul(31).wrapping_add(u64::from(i));
        }
    }
    println!(
        "build min {:.1} med {:.1} | pairs min {:.1} med {:.1} | pairs {} cand {} entries {} cells {} hash {:x} {:x} {:x}",
        tb.first().unwrap_or(&0.0),
        tb.get(tb.len() / 2).unwrap_or(&0.0),
        tp.first().unwrap_or(&0.0),
        tp.get(tp.len() / 2).unwrap_or(&0.0),
        pairs.len(),
        cand.len(),
        grid.entry_count(),
        grid.cell_count(),
        h,
        hc,
        hcell
    );
}
