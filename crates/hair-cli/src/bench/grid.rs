//! `hair bench grid`: build and pair search of the localization grid on a head-sized shell of
//! hair, beside a parry3d BVH of the segments' bounding boxes measured in the same run.

use std::time::Instant;

use hair::ssv::Point;
use hair_grid::test_scenes::head_shell;
use hair_grid::{Grid, GridConfig, Kernel, PairSet, Section};
use parry3d::bounding_volume::Aabb;
use parry3d::math::Vec3;
use parry3d::partitioning::{Bvh, BvhBuildStrategy, BvhWorkspace};
use rayon::prelude::*;

/// Arguments of `hair bench grid`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Number of hair segments in the scene.
    #[arg(long, default_value_t = 300_000)]
    pub segments: usize,
    /// Segments per strand (about 1 cm each).
    #[arg(long, default_value_t = 30)]
    pub per_strand: usize,
    /// Cell size in metres; 0 uses the grid's default (the mean segment length).
    #[arg(long, default_value_t = 0.0)]
    pub cell_size: f32,
    /// Timed repetitions (the median is reported).
    #[arg(long, default_value_t = 7)]
    pub repeat: usize,
    /// Segments in the brute-force agreement check.
    #[arg(long, default_value_t = 20_000)]
    pub brute_force: usize,
    /// Skip the parry3d peer (for profiling the grid alone).
    #[arg(long)]
    pub skip_peer: bool,
    /// Random seed of the scene.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn to_aabb(grid: &Grid, i: usize) -> Aabb {
    let (lo, hi) = grid.aabb(i).unwrap_or((Point::origin(), Point::origin()));
    Aabb::new(Vec3::new(lo.x, lo.y, lo.z), Vec3::new(hi.x, hi.y, hi.z))
}

/// Whether the peer keeps the pair: the same neighbour rule and exact test as the grid.
fn keep(grid: &Grid, sections: &[Section], i: u32, j: u32) -> bool {
    let (a, b) = (&sections[i as usize], &sections[j as usize]);
    let skip = grid.config().skip_neighbours;
    if a.skeleton == b.skeleton && a.segment.abs_diff(b.segment) <= skip {
        return false;
    }
    a.shape.distance(&b.shape) <= grid.config().margin
}

fn norm_pairs(mut v: Vec<[u32; 2]>) -> Vec<[u32; 2]> {
    for p in &mut v {
        if p[0] > p[1] {
            p.swap(0, 1);
        }
    }
    v.sort_unstable();
    v
}

/// The peer, sequential: parry's BVH built over the boxes, then its tree-against-itself
/// traversal, then the exact test.
fn peer_bvtt(grid: &Grid, sections: &[Section], aabbs: &[Aabb]) -> Vec<[u32; 2]> {
    let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, aabbs);
    let mut ws = BvhWorkspace::default();
    let mut out = Vec::new();
    bvh.traverse_bvtt_single_tree::<false>(&mut ws, &mut |i, j| {
        if keep(grid, sections, i, j) {
            out.push([i, j]);
        }
    });
    out
}

/// The peer, parallel: parry's BVH, then one box query per leaf on all threads.
fn peer_queries(grid: &Grid, sections: &[Section], aabbs: &[Aabb]) -> Vec<[u32; 2]> {
    let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, aabbs);
    aabbs
        .par_iter()
        .enumerate()
        .flat_map_iter(|(i, b)| {
            let i = i as u32;
            bvh.intersect_aabb(b)
                .filter(move |&j| j > i && keep(grid, sections, i, j))
                .map(move |j| [i, j])
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Brute force over all pairs of `sections`: the exact-overlap pairs.
fn brute_force(grid: &Grid, sections: &[Section]) -> Vec<[u32; 2]> {
    let n = sections.len() as u32;
    (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            let (ai, bi) = grid.aabb(i as usize).unwrap_or_default();
            (i + 1..n)
                .filter(move |&j| {
                    let (aj, bj) = grid.aabb(j as usize).unwrap_or_default();
                    // The box test is a shortcut only: a pair whose boxes are apart cannot overlap.
                    ai.x <= bj.x
                        && aj.x <= bi.x
                        && ai.y <= bj.y
                        && aj.y <= bi.y
                        && ai.z <= bj.z
                        && aj.z <= bi.z
                        && keep(grid, sections, i, j)
                })
                .map(move |j| [i, j])
                .collect::<Vec<_>>()
        })
        .collect()
}

/// Runs the benchmark with `kernel` (one the processor lacks runs the widest narrower one, and
/// the output names the kernel that ran).
pub fn run(args: Args, kernel: Kernel) -> anyhow::Result<()> {
    let sections = head_shell(args.segments, args.per_strand, args.seed);
    let config = GridConfig {
        cell_size: (args.cell_size > 0.0).then_some(args.cell_size),
        kernel,
        ..GridConfig::default()
    };
    let mut grid = Grid::new(config.clone());
    if kernel != Kernel::Auto && grid.kernel() != kernel {
        eprintln!(
            "note: this processor cannot run the {kernel} kernel; running {}",
            grid.kernel()
        );
    }
    let mut pairs = PairSet::new();
    // Warm-up: buffers grow to the scene.
    grid.rebuild(&sections)?;
    grid.overlapping_pairs(&mut pairs);
    let repeat = args.repeat.max(1);
    let (mut build, mut search, mut total) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..repeat {
        let t0 = Instant::now();
        grid.rebuild(&sections)?;
        let b = ms(t0);
        let t1 = Instant::now();
        grid.overlapping_pairs(&mut pairs);
        let p = ms(t1);
        build.push(b);
        search.push(p);
        total.push(b + p);
    }
    let (build_ms, pairs_ms, total_ms) =
        (median(&mut build), median(&mut search), median(&mut total));
    let mut candidates = PairSet::new();
    grid.candidate_pairs(&mut candidates);
    let n_pairs = pairs.len();
    let ours = norm_pairs(pairs.to_vec());

    // Peer: boxes are the grid's own (same margin and slack), built in the timed region.
    let peer_reps = if args.skip_peer { 0 } else { repeat.min(3) };
    let (mut seq, mut par) = (Vec::new(), Vec::new());
    let mut peer_pairs = Vec::new();
    for _ in 0..peer_reps {
        let t = Instant::now();
        let aabbs: Vec<Aabb> = (0..grid.len()).map(|i| to_aabb(&grid, i)).collect();
        peer_pairs = peer_bvtt(&grid, &sections, &aabbs);
        seq.push(ms(t));
        let t = Instant::now();
        let aabbs: Vec<Aabb> = (0..grid.len())
            .into_par_iter()
            .map(|i| to_aabb(&grid, i))
            .collect();
        let q = peer_queries(&grid, &sections, &aabbs);
        par.push(ms(t));
        if norm_pairs(q) != norm_pairs(peer_pairs.clone()) {
            anyhow::bail!("parry's two traversals disagree");
        }
    }
    if args.skip_peer {
        seq.push(f64::NAN);
        par.push(f64::NAN);
        peer_pairs = ours.clone();
    }
    let (peer_seq_ms, peer_par_ms) = (median(&mut seq), median(&mut par));
    let peer_ms = peer_seq_ms.min(peer_par_ms);
    let peer_pairs = norm_pairs(peer_pairs);
    let identical = peer_pairs == ours;

    // Brute force on a subset: the segments nearest to a point at the back of the head (a dense
    // patch), in their original order.
    let subset_n = args.brute_force.min(sections.len());
    let focus = Point::new(0.0, -0.05, -0.12);
    let mut by_distance: Vec<(f32, usize)> = sections
        .iter()
        .enumerate()
        .map(|(i, s)| ((s.shape.center() - focus).norm(), i))
        .collect();
    by_distance.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut chosen: Vec<usize> = by_distance[..subset_n].iter().map(|p| p.1).collect();
    chosen.sort_unstable();
    let subset: Vec<Section> = chosen.iter().map(|&i| sections[i]).collect();
    let subset = &subset[..];
    let mut sub_grid = Grid::new(config);
    sub_grid.rebuild(subset)?;
    let mut sub_pairs = PairSet::new();
    sub_grid.overlapping_pairs(&mut sub_pairs);
    let mut sub_cand = PairSet::new();
    sub_grid.candidate_pairs(&mut sub_cand);
    let brute = norm_pairs(brute_force(&sub_grid, subset));
    let sub_ours = norm_pairs(sub_pairs.to_vec());
    let cand: std::collections::BTreeSet<[u32; 2]> = sub_cand.iter().collect();
    let cand_unique = cand.len() == sub_cand.len();
    let agrees = brute == sub_ours && cand_unique && brute.iter().all(|p| cand.contains(p));

    let threads = rayon::current_num_threads();
    let ratio = peer_ms / total_ms;
    let pairs_per_s = n_pairs as f64 / (total_ms * 1e-3);
    if args.json {
        let v = serde_json::json!({
            "segments": sections.len(),
            "threads": threads,
            "kernel": grid.kernel().name(),
            "cell_size_m": grid.cell_size(),
            "cells": grid.cell_count(),
            "entries": grid.entry_count(),
            "candidates": candidates.len(),
            "build_ms": build_ms,
            "pairs_ms": pairs_ms,
            "total_ms": total_ms,
            "pairs": n_pairs,
            "pairs_per_s": pairs_per_s,
            "peer": "parry3d 0.31 Bvh (binned) of the segments' AABBs + the same exact test; faster of traverse_bvtt_single_tree (1 thread) and per-leaf intersect_aabb (all threads)",
            "peer_bvtt_ms": peer_seq_ms,
            "peer_queries_ms": peer_par_ms,
            "peer_ms": peer_ms,
            "peer_pairs": peer_pairs.len(),
            "ratio": ratio,
            "identical_pairs": identical,
            "brute_force_segments": subset_n,
            "brute_force_pairs": brute.len(),
            "agrees_with_brute_force": agrees,
        });
        println!("{v}");
    } else {
        let inst: usize = grid.cells().map(|(_, s)| s.len() * (s.len() - 1) / 2).sum();
        let maxm = grid.cells().map(|(_, s)| s.len()).max().unwrap_or(0);
        println!("pair instances in cells: {inst}, largest cell {maxm}");
        println!(
            "grid: {} segments, {} threads, {} kernels, cell {:.4} m, {} cells, {} entries",
            sections.len(),
            threads,
            grid.kernel(),
            grid.cell_size(),
            grid.cell_count(),
            grid.entry_count()
        );
        println!(
            "build {build_ms:.2} ms, pairs {pairs_ms:.2} ms, total {total_ms:.2} ms: {n_pairs} pairs ({} candidates), {:.1} M pairs/s",
            candidates.len(),
            pairs_per_s / 1e6
        );
        println!(
            "parry3d BVH: {peer_ms:.2} ms (bvtt {peer_seq_ms:.2}, queries {peer_par_ms:.2}), ratio {ratio:.2}, identical pairs: {identical}"
        );
        println!(
            "brute force on {subset_n} segments: {} pairs, agrees: {agrees}",
            brute.len()
        );
    }
    if !identical {
        anyhow::bail!("the grid and the BVH found different pair sets");
    }
    Ok(())
}
