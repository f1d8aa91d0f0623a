//! `hair hierarchy`: builds the strip / cluster / strand-group hierarchy of the Ward & Lin
//! benchmark head (a procedural stand-in: 9,350 strands of six control points) and reports its
//! node counts per kind and level, its memory and its build time.

use anyhow::Context;
use hair::lod::{Hierarchy, HierarchyParams, LodState, MinGroup, test_heads};
use serde::Serialize;

/// Arguments of `hair hierarchy`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Strands on the procedural head.
    #[arg(long, default_value_t = 9350)]
    pub strands: usize,
    /// Seed of the procedural head.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Width of a root strip across the scalp (m).
    #[arg(long)]
    pub strip_width: Option<f32>,
    /// Extent of a row of root strips down the scalp (m).
    #[arg(long)]
    pub strip_depth: Option<f32>,
    /// Strips split until narrower than this (m).
    #[arg(long)]
    pub strip_width_min: Option<f32>,
    /// Clusters split until their radius is under this (m).
    #[arg(long)]
    pub cluster_radius_min: Option<f32>,
    /// Minimum strands in a finest group where hair is least viewable (the nape).
    #[arg(long)]
    pub min_group_coarse: Option<u32>,
    /// Minimum strands in a finest group where hair is most viewable (parting, face).
    #[arg(long)]
    pub min_group_fine: Option<u32>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct LevelRow {
    level: u8,
    kind: &'static str,
    nodes: u32,
}

#[derive(Serialize)]
struct Report {
    strands: u32,
    control_points: f32,
    nodes: u32,
    root_strips: u32,
    root_clusters: u32,
    root_strand_groups: u32,
    finest_skeletons: u32,
    strands_per_finest_skeleton: f64,
    strips: u32,
    clusters: u32,
    strand_groups: u32,
    max_level: u8,
    levels: Vec<LevelRow>,
    bytes: usize,
    bytes_per_strand: f64,
    state_bytes_per_strand: f64,
    build_ms: f64,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut params = HierarchyParams::default();
    if let Some(v) = args.strip_width {
        params.root_strip_width = v;
    }
    if let Some(v) = args.strip_depth {
        params.root_strip_depth = v;
    }
    if let Some(v) = args.strip_width_min {
        params.strip_width_min = v;
    }
    if let Some(v) = args.cluster_radius_min {
        params.cluster_radius_min = v;
    }
    if let MinGroup::Regional { fine, coarse, .. } = &mut params.min_group {
        if let Some(v) = args.min_group_fine {
            *fine = v;
        }
        if let Some(v) = args.min_group_coarse {
            *coarse = v;
        }
    }
    let style = test_heads::ward_lin_head(args.strands, args.seed);
    let start = std::time::Instant::now();
    let h = Hierarchy::build(&style, &params).context("building the hierarchy")?;
    let build_ms = start.elapsed().as_secs_f64() * 1e3;
    let s = h.stats();
    let state = LodState::new(&h);
    let state_bytes = (state.d_theta.len() * 8 * size_of::<f32>() + state.count.len() * 2) as f64;
    let report = Report {
        strands: s.strands,
        control_points: s.control_points,
        nodes: s.nodes,
        root_strips: s.root_strips,
        root_clusters: s.root_clusters,
        root_strand_groups: s.root_strand_groups,
        finest_skeletons: s.finest_skeletons,
        strands_per_finest_skeleton: round3(s.strands_per_finest_skeleton()),
        strips: s.strips,
        clusters: s.clusters,
        strand_groups: s.strand_groups,
        max_level: s.max_level,
        levels: s
            .per_level
            .iter()
            .map(|l| LevelRow {
                level: l.level,
                kind: l.kind.name(),
                nodes: l.nodes,
            })
            .collect(),
        bytes: s.bytes,
        bytes_per_strand: round3(s.bytes_per_strand()),
        state_bytes_per_strand: round3(state_bytes / f64::from(s.strands.max(1))),
        build_ms: round3(build_ms),
    };
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
        return Ok(());
    }
    println!(
        "{} strands, {:.1} control points each: {} nodes, {} levels",
        report.strands,
        report.control_points,
        report.nodes,
        u32::from(report.max_level) + 1
    );
    println!(
        "coarsest: {} root strips; {} root clusters; {} root strand groups; finest: {} skeletons ({:.2} strands each)",
        report.root_strips,
        report.root_clusters,
        report.root_strand_groups,
        report.finest_skeletons,
        report.strands_per_finest_skeleton
    );
    println!("{:>5}  {:<13} {:>7}", "level", "kind", "nodes");
    for l in &report.levels {
        println!("{:>5}  {:<13} {:>7}", l.level, l.kind, l.nodes);
    }
    println!(
        "memory: {} bytes, {:.1} bytes per strand (hierarchy); {:.1} bytes per strand (per-node state)",
        report.bytes, report.bytes_per_strand, report.state_bytes_per_strand
    );
    println!("build: {:.2} ms", report.build_ms);
    Ok(())
}

fn round3(x: f64) -> f64 {
    (x * 1e3).round() / 1e3
}
