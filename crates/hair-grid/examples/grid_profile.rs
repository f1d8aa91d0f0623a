//! Times `Grid::rebuild` and `Grid::overlapping_pairs` on the `hair bench grid` scene (a copy of
//! the CLI's head shell) without building the CLI: `cargo run --release -p hair-grid --example
//! grid_profile -- [segments] [repeat] [cell_size] [dump_path]`.

use std::time::Instant;

use hair_grid::{Grid, GridConfig, PairSet, Section};
use hair_ssv::{Lss, Point, Ssv, Vector};

/// SplitMix64, as in the CLI.
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

/// The CLI's head shell: strands on the upper part of a 10 cm sphere, in 1 cm segments of radius
/// 0.5 mm.
fn head_scene(segments: usize, per_strand: usize, seed: u64) -> Vec<Section> {
    let strands = segments.div_ceil(per_strand);
    let mut rng = Rng(seed);
    let mut out = Vec::with_capacity(strands * per_strand);
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

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// CPU time of this process so far, in milliseconds (from `/proc/self/stat`; 0 elsewhere): less
/// sensitive than wall time to other work on the machine.
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit(')').next().unwrap_or("");
    let f: Vec<f64> = after
        .split_whitespace()
        .skip(11)
        .take(2)
        .filter_map(|v| v.parse().ok())
        .collect();
    f.iter().sum::<f64>() * 10.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let segments = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(300_000);
    let repeat = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(7);
    let cell: f32 = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let sections = head_scene(segments, 30, 1);
    let mut grid = Grid::new(GridConfig {
        cell_size: (cell > 0.0).then_some(cell),
        ..GridConfig::default()
    });
    let mut pairs = PairSet::new();
    grid.rebuild(&sections).expect("valid scene");
    grid.overlapping_pairs(&mut pairs);
    let (mut build, mut search, mut total) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..repeat {
        let t0 = Instant::now();
        grid.rebuild(&sections).expect("valid scene");
        let b = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        grid.overlapping_pairs(&mut pairs);
        let p = t1.elapsed().as_secs_f64() * 1e3;
        build.push(b);
        search.push(p);
        total.push(b + p);
    }
    if std::env::var_os("GRID_CPU").is_some() {
        let reps = 20;
        let t = cpu_ms();
        for _ in 0..reps {
            grid.rebuild(&sections).expect("valid scene");
        }
        let b = (cpu_ms() - t) / f64::from(reps);
        let t = cpu_ms();
        for _ in 0..reps {
            grid.overlapping_pairs(&mut pairs);
        }
        let p = (cpu_ms() - t) / f64::from(reps);
        println!(
            "cpu: build {b:.1} ms, pairs {p:.1} ms, total {:.1} ms",
            b + p
        );
    }
    let mut cand = PairSet::new();
    grid.candidate_pairs(&mut cand);
    let mut sorted = pairs.to_vec();
    sorted.sort_unstable();
    // FNV-1a of the sorted pair set, and of the output order.
    let fnv = |v: &[[u32; 2]]| {
        v.iter().flatten().fold(0xcbf2_9ce4_8422_2325u64, |h, &x| {
            (h ^ u64::from(x)).wrapping_mul(0x100_0000_01b3)
        })
    };
    println!(
        "build {:.2} ms, pairs {:.2} ms, total {:.2} ms | cell {:.5} cells {} entries {} candidates {} pairs {} | set {:016x} order {:016x}",
        median(&mut build),
        median(&mut search),
        median(&mut total),
        grid.cell_size(),
        grid.cell_count(),
        grid.entry_count(),
        cand.len(),
        pairs.len(),
        fnv(&sorted),
        fnv(&pairs.to_vec()),
    );
    if let Some(path) = args.get(4) {
        let text: String = sorted
            .iter()
            .map(|p| format!("{} {}\n", p[0], p[1]))
            .collect();
        std::fs::write(path, text).expect("write dump");
    }
}
