//! Profiling driver for the grid: the `hair bench grid` scene
//! ([`hair_grid::test_scenes::head_shell`]: 300,000 segments of about 1 cm, radius 0.5 mm, on a
//! head-sized shell, seed 1), rebuilt and searched for overlapping pairs a given number of times
//! after one warm-up.
//!
//! `cargo run --release -p hair-grid --example grid_profile -- [build|pairs|candidates|both]
//! [repeat] [cell size]` prints the fastest and median times and hashes of the cells, the
//! candidate pairs and the overlapping pairs (in order), so that a change can be checked to leave
//! them identical. Instruction counts of one rebuild (or one pair search): run it under
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind` with `build 1` and `build 3` (or `pairs`);
//! half the difference of the two totals is the cost of one (valgrind has no AVX-512: it counts
//! the AVX2 kernels, and `perf` times the AVX-512 ones). `candidates` times the pair search
//! without the exact test ([`Grid::candidate_pairs`]), so that the exact test's share is the
//! difference. With `HAIR_GRID_SECTIONS=FILE` it profiles the sections in `FILE` instead (per
//! section, little endian: `a`, `b` and the radius as 7 `f32`, then skeleton and segment as 2
//! `u32`), for instance a simulation's sections at one step (the root crate's
//! `examples/grid_sections.rs` writes them). `HAIR_GRID_KERNEL=avx512|avx2|baseline` runs that
//! kernel ([`GridConfig::kernel`]; unset: the widest this processor has), so that one machine
//! measures all of them; the kernel run is printed first. `docs/perf/grid.md` records what was
//! measured with it.
use std::time::Instant;

use hair_grid::test_scenes::head_shell;
use hair_grid::{Grid, GridConfig, Kernel, PairSet};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map(String::as_str).unwrap_or("both");
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(5);
    // HAIR_GRID_SECTIONS: a file of sections (per section 7 f32 a, b, radius and 2 u32 skeleton,
    // segment, little endian) to profile instead of the head shell.
    let secs = match std::env::var("HAIR_GRID_SECTIONS") {
        Ok(path) => {
            let bytes = std::fs::read(path).expect("sections file");
            let word = |k: usize| {
                [
                    bytes[4 * k],
                    bytes[4 * k + 1],
                    bytes[4 * k + 2],
                    bytes[4 * k + 3],
                ]
            };
            (0..bytes.len() / 36)
                .map(|i| {
                    let f = |j: usize| f32::from_le_bytes(word(9 * i + j));
                    hair_grid::Section {
                        skeleton: u32::from_le_bytes(word(9 * i + 7)),
                        segment: u32::from_le_bytes(word(9 * i + 8)),
                        shape: hair_grid::Ssv::Line(hair_ssv::Lss::new(
                            hair_grid::Point::new(f(0), f(1), f(2)),
                            hair_grid::Point::new(f(3), f(4), f(5)),
                            f(6),
                        )),
                    }
                })
                .collect()
        }
        Err(_) => head_shell(300_000, 30, 1),
    };
    // Optional third argument: the cell size in metres (default: the mean segment length).
    let cell_size: Option<f32> = args.get(3).and_then(|s| s.parse().ok());
    let kernel = match std::env::var("HAIR_GRID_KERNEL") {
        Ok(name) => Kernel::from_name(name.trim()).expect("HAIR_GRID_KERNEL names a kernel"),
        Err(_) => Kernel::Auto,
    };
    let mut grid = Grid::try_new(GridConfig {
        cell_size,
        kernel,
        ..GridConfig::default()
    })
    .expect("this processor runs the kernel");
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
        "{} | build min {:.1} med {:.1} | pairs min {:.1} med {:.1} | pairs {} cand {} entries {} cells {} hash {:x} {:x} {:x}",
        grid.kernel(),
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
