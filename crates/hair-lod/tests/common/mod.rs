//! Shared helpers and proptest strategies for the hair-lod tests.
#![allow(dead_code)]

use hair_lod::*;
use nalgebra::{Matrix3, Rotation3};
use proptest::prelude::*;

/// Thresholds for the small test heads (fewer strands than the benchmark, same head size).
pub fn small_params() -> HierarchyParams {
    HierarchyParams::default()
}

/// A small procedural head.
pub fn small_head(strands: usize, seed: u64) -> (Hairstyle, Hierarchy) {
    let style = test_heads::ward_lin_head(strands, seed);
    let h = Hierarchy::build(&style, &small_params()).expect("valid head");
    (style, h)
}

/// Checks every structural invariant of a hierarchy against its hairstyle.
pub fn check_structure(style: &Hairstyle, h: &Hierarchy) {
    let n = h.node_count() as u32;
    // Leaves partition the strands.
    let mut seen = vec![0u32; style.strands.len()];
    for v in 0..n {
        if h.is_leaf(v) {
            for &s in h.strands(v) {
                seen[s as usize] += 1;
            }
        }
    }
    assert!(
        seen.iter().all(|&c| c == 1),
        "every strand in exactly one leaf"
    );
    for t in 0..h.tree_count() as u32 {
        let r = h.tree_root(t);
        assert_eq!(h.parent(r), None);
        assert_eq!(h.level(r), 0);
        assert_eq!(h.kind(r), NodeKind::Strip);
        for v in h.tree_nodes(t) {
            assert_eq!(h.tree_of(v), t);
        }
    }
    for v in 0..n {
        assert!(h.strand_count(v) >= 1);
        assert!(h.size(v).is_finite() && h.size(v) >= 0.0);
        let kids = h.children(v);
        if kids.is_empty() {
            continue;
        }
        // Children tile the parent's strand range.
        let mut cat: Vec<u32> = Vec::new();
        for c in kids.clone() {
            assert_eq!(h.parent(c), Some(v));
            assert_eq!(h.level(c), h.level(v) + 1);
            assert_eq!(h.tree_of(c), h.tree_of(v));
            assert_eq!(
                h.control_points(c),
                h.control_points(v),
                "a child has its parent's control-point count"
            );
            cat.extend_from_slice(h.strands(c));
        }
        assert_eq!(
            &cat[..],
            h.strands(v),
            "children partition the parent's strands"
        );
        match h.kind(v) {
            NodeKind::Strip => {
                assert!(
                    kids.len() == 2 && kids.clone().all(|c| h.kind(c) == NodeKind::Strip)
                        || kids.len() == 1 && h.kind(kids.start) == NodeKind::Cluster
                );
            }
            NodeKind::Cluster => {
                assert!(kids.len() <= 4);
                assert!(
                    kids.clone().all(|c| h.kind(c) == NodeKind::Cluster)
                        || kids.len() == 1 && h.kind(kids.start) == NodeKind::StrandGroup
                );
            }
            NodeKind::StrandGroup => {
                assert!(kids.len() >= 2 && kids.len() <= 4);
                assert!(kids.clone().all(|c| h.kind(c) == NodeKind::StrandGroup));
                for c in kids.clone() {
                    assert!(
                        h.size(c) <= h.size(v) * (1.0 + 1e-5) + 1e-7,
                        "tightest circles shrink"
                    );
                    assert!(h.strand_count(c) < h.strand_count(v));
                }
            }
        }
        if kids.len() == 1 {
            // A change of representation: same strands, zero offsets.
            assert!(h.offsets(kids.start).iter().all(|o| o.norm() < 1e-6));
        }
    }
}

/// Per-node inputs, owned.
#[derive(Clone, Debug)]
pub struct Inputs {
    pub visible: Vec<bool>,
    pub distance: Vec<f32>,
    pub speed: Vec<f32>,
    pub activity: Vec<Activity>,
}

impl Inputs {
    pub fn uniform(h: &Hierarchy, visible: bool, distance: f32, speed: f32) -> Self {
        let n = h.node_count();
        Self {
            visible: vec![visible; n],
            distance: vec![distance; n],
            speed: vec![speed; n],
            activity: vec![Activity::Moving; n],
        }
    }

    pub fn view(&self) -> NodeInputs<'_> {
        NodeInputs {
            visible: &self.visible,
            distance: &self.distance,
            speed: &self.speed,
            activity: &self.activity,
        }
    }
}

/// For every strand, the level of its active node.
pub fn strand_levels(h: &Hierarchy, front: &Front) -> Vec<u8> {
    front
        .active_of_strands(h)
        .expect("every strand in exactly one active node")
        .iter()
        .map(|&v| h.level(v))
        .collect()
}

/// Random hairstyles: roots on part of a sphere (or all at one point), 2 to 8 points per strand,
/// straight or bent strands.
pub fn hairstyle() -> impl Strategy<Value = Hairstyle> {
    (
        1usize..120,
        any::<u64>(),
        2usize..9,
        0.02f32..0.3,
        prop::bool::weighted(0.1),
    )
        .prop_map(|(count, seed, max_points, radius, coincident)| {
            let mut rng = test_heads::SplitMix64::new(seed);
            let strands = (0..count)
                .map(|_| {
                    let (y, a) = if coincident {
                        (0.9, 0.3)
                    } else {
                        (rng.unit(), rng.unit() * std::f64::consts::TAU)
                    };
                    let ring = (1.0f64 - y * y).sqrt();
                    let normal =
                        Vector::new((ring * a.cos()) as f32, y as f32, (ring * a.sin()) as f32)
                            .normalize();
                    let root = Point::from(normal * radius);
                    let x = normal.cross(&Vector::new(0.3, 0.2, 0.9)).normalize();
                    let frame = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[
                        x,
                        normal.cross(&x),
                        normal,
                    ]));
                    let npts = 2 + (rng.next_u64() % (max_points as u64 - 1)) as usize;
                    let mut p = root;
                    let mut points = vec![root];
                    for k in 1..npts {
                        let bend = 0.2 * k as f32 * (rng.unit() as f32);
                        p += (normal + Vector::new(0.0, -bend, 0.0)).normalize() * 0.04;
                        points.push(p);
                    }
                    Strand {
                        root,
                        frame,
                        points,
                    }
                })
                .collect();
            Hairstyle { strands }
        })
}
