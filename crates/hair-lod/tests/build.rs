//! Building the hierarchy: the benchmark head's counts, structure invariants, determinism and
//! bad input.

mod common;

use common::*;
use hair_lod::*;
use proptest::prelude::*;

#[test]
fn ward_lin_head_lands_near_the_papers_counts() {
    let style = test_heads::ward_lin_head(9350, 1);
    let h = Hierarchy::build(&style, &HierarchyParams::default()).unwrap();
    let s = h.stats();
    assert_eq!(s.strands, 9350);
    assert_eq!(s.control_points, 6.0);
    // The strips at the top of the head, whose strands fall away from it on every side, are
    // split by direction (`MAX_STRAND_SPREAD_DEGREES`): a few trees more than the paper's strips.
    assert!(
        (100..=125).contains(&s.root_strips),
        "{} root strips",
        s.root_strips
    );
    assert!(
        (300..=360).contains(&s.root_clusters),
        "{} root clusters",
        s.root_clusters
    );
    assert!(
        (3300..=3850).contains(&s.finest_skeletons),
        "{} finest",
        s.finest_skeletons
    );
    assert!(
        s.bytes_per_strand() < 150.0,
        "{} bytes per strand",
        s.bytes_per_strand()
    );
    let total: u32 = s.per_level.iter().map(|l| l.nodes).sum();
    assert_eq!(total, s.nodes);
    check_structure(&style, &h);
}

#[test]
fn minimum_group_is_finer_at_the_top_and_front_than_at_the_nape() {
    let style = test_heads::ward_lin_head(9350, 1);
    let h = Hierarchy::build(&style, &HierarchyParams::default()).unwrap();
    let (mut top, mut nape) = ((0.0, 0), (0.0, 0));
    for v in 0..h.node_count() as u32 {
        if !h.is_leaf(v) {
            continue;
        }
        let root = h.rest_points(v)[0];
        let m = f64::from(h.strand_count(v));
        if root.y > 0.08 {
            top = (top.0 + m, top.1 + 1);
        } else if root.y < 0.03 && root.z < 0.0 {
            nape = (nape.0 + m, nape.1 + 1);
        }
    }
    let (top_mean, nape_mean) = (top.0 / f64::from(top.1), nape.0 / f64::from(nape.1));
    assert!(
        top_mean < nape_mean,
        "strands per finest skeleton: top {top_mean}, nape {nape_mean}"
    );
    assert!(
        nape_mean >= 3.5,
        "nape groups hold about five strands: {nape_mean}"
    );
}

#[test]
fn single_strand_leaves_are_their_strands() {
    let (style, h) = small_head(400, 3);
    let mut checked = 0;
    for v in 0..h.node_count() as u32 {
        if h.is_leaf(v) && h.strand_count(v) == 1 {
            let s = &style.strands[h.strands(v)[0] as usize];
            for (a, b) in h.rest_points(v).iter().zip(&s.points) {
                assert!((a - b).norm() < 1e-5, "{a} vs {b}");
            }
            checked += 1;
        }
    }
    assert!(checked > 0);
}

/// A crown whorl: roots on a cap of a 0.1 m sphere around its top, each strand straight and
/// combed radially away from the top, lifted off the scalp as procedural hair is (a tangent
/// plus 0.35 of the normal), 0.3 m long.
fn crown_whorl(strands: usize) -> Hairstyle {
    let mut rng = test_heads::SplitMix64::new(5);
    let mut out = Vec::with_capacity(strands);
    for _ in 0..strands {
        let polar = 0.3 * rng.unit().sqrt();
        let azimuth = std::f64::consts::TAU * rng.unit();
        let normal = Vector::new(
            (polar.sin() * azimuth.cos()) as f32,
            polar.cos() as f32,
            (polar.sin() * azimuth.sin()) as f32,
        );
        let root = Point::from(normal * 0.1);
        let away = Vector::new(azimuth.cos() as f32, 0.0, azimuth.sin() as f32);
        let tangent = (away - normal * normal.dot(&away)).normalize();
        let dir = (normal * 0.35 + tangent).normalize();
        let frame = nalgebra::Rotation3::rotation_between(&Vector::z(), &dir).unwrap();
        let points = (0..10)
            .map(|k| root + dir * (0.3 * k as f32 / 9.0))
            .collect();
        out.push(Strand {
            root,
            frame,
            points,
        });
    }
    Hairstyle { strands: out }
}

/// Issue 40's stray loops: strands combed apart at the crown shared one skeleton, the mean of
/// them, a stub standing off the scalp; each strand was drawn at its offset in the skeleton's
/// frames, as long as the strand, and swung over the crown when the skeleton fell. Every node
/// must stand for its strands: no strand more than twice the tree spread from its node's chord
/// (a tree's strands within the spread of their mean, a node's mean inside that cone), and the
/// node's rest skeleton nearly as long, root to tip, as the strands.
#[test]
fn strands_combed_apart_at_the_crown_do_not_share_a_skeleton() {
    let style = crown_whorl(300);
    let h = Hierarchy::build(&style, &HierarchyParams::default()).unwrap();
    check_structure(&style, &h);
    let chord = |p: &[Point]| p[p.len() - 1] - p[0];
    for v in 0..h.node_count() as u32 {
        let rest = h.rest_points(v);
        let node = chord(&rest);
        let spread = if h.parent(v).is_none() {
            MAX_STRAND_SPREAD_DEGREES
        } else {
            2.0 * MAX_STRAND_SPREAD_DEGREES
        };
        for &s in h.strands(v) {
            let c = chord(&style.strands[s as usize].points);
            let angle = f64::from(c.angle(&node).to_degrees());
            assert!(
                angle <= spread + 0.1,
                "node {v} ({:?}, {} strands): strand {s} runs {angle:.0} degrees from its skeleton",
                h.kind(v),
                h.strand_count(v)
            );
        }
        let cos = MAX_STRAND_SPREAD_DEGREES.to_radians().cos() as f32;
        assert!(
            node.norm() >= 0.3 * cos - 1e-4,
            "node {v} ({:?}, {} strands): its skeleton reaches {:.3} m of the strands' 0.3 m",
            h.kind(v),
            h.strand_count(v),
            node.norm()
        );
    }
}

#[test]
fn building_twice_gives_the_same_hierarchy() {
    let style = test_heads::ward_lin_head(2000, 9);
    let a = Hierarchy::build(&style, &HierarchyParams::default()).unwrap();
    let b = Hierarchy::build(&style, &HierarchyParams::default()).unwrap();
    assert_eq!(a, b);
}

#[test]
fn coincident_roots_terminate_and_partition() {
    let mut style = test_heads::ward_lin_head(50, 2);
    let first = style.strands[0].clone();
    for s in style.strands.iter_mut() {
        *s = first.clone();
    }
    let h = Hierarchy::build(
        &style,
        &HierarchyParams {
            min_group: MinGroup::Uniform(1),
            ..Default::default()
        },
    )
    .unwrap();
    check_structure(&style, &h);
    assert_eq!(h.leaf_of_strands().len(), 50);
}

#[test]
fn empty_hairstyle_is_an_error() {
    let err = Hierarchy::build(&Hairstyle::default(), &HierarchyParams::default()).unwrap_err();
    assert_eq!(err, LodError::EmptyHairstyle);
}

#[test]
fn short_strand_is_named() {
    let mut style = test_heads::ward_lin_head(10, 1);
    style.strands[7].points.truncate(1);
    let err = Hierarchy::build(&style, &HierarchyParams::default()).unwrap_err();
    assert_eq!(
        err,
        LodError::TooFewPoints {
            strand: 7,
            count: 1
        }
    );
    assert!(err.to_string().contains("strand 7"));
}

#[test]
fn non_finite_root_and_point_are_named() {
    let mut style = test_heads::ward_lin_head(10, 1);
    style.strands[3].root.x = f32::NAN;
    let err = Hierarchy::build(&style, &HierarchyParams::default()).unwrap_err();
    assert_eq!(
        err,
        LodError::NonFiniteRoot {
            strand: 3,
            field: "position"
        }
    );
    let mut style = test_heads::ward_lin_head(10, 1);
    style.strands[4].points[2].z = f32::INFINITY;
    let err = Hierarchy::build(&style, &HierarchyParams::default()).unwrap_err();
    assert_eq!(
        err,
        LodError::NonFinitePoint {
            strand: 4,
            point: 2
        }
    );
}

#[test]
fn thresholds_out_of_order_name_the_parameters() {
    let style = test_heads::ward_lin_head(10, 1);
    let p = HierarchyParams {
        strip_width_min: 0.05,
        ..Default::default()
    };
    match Hierarchy::build(&style, &p).unwrap_err() {
        LodError::ThresholdOrder { lower, upper, .. } => {
            assert_eq!((lower, upper), ("strip_width_min", "root_strip_width"));
        }
        e => panic!("{e}"),
    }
    let p = HierarchyParams {
        cluster_radius_min: 0.02,
        ..Default::default()
    };
    match Hierarchy::build(&style, &p).unwrap_err() {
        LodError::ThresholdOrder { lower, .. } => assert_eq!(lower, "cluster_radius_min"),
        e => panic!("{e}"),
    }
    let p = HierarchyParams {
        min_group: MinGroup::Regional {
            fine: 6,
            coarse: 2,
            toward: Vector::y(),
        },
        ..Default::default()
    };
    match Hierarchy::build(&style, &p).unwrap_err() {
        LodError::ThresholdOrder { lower, .. } => assert_eq!(lower, "min_group.fine"),
        e => panic!("{e}"),
    }
    let p = HierarchyParams {
        root_strip_depth: f32::NAN,
        ..Default::default()
    };
    match Hierarchy::build(&style, &p).unwrap_err() {
        LodError::InvalidParameter { name, .. } => assert_eq!(name, "root_strip_depth"),
        e => panic!("{e}"),
    }
    let p = HierarchyParams {
        min_group: MinGroup::Uniform(0),
        ..Default::default()
    };
    assert!(matches!(
        Hierarchy::build(&style, &p),
        Err(LodError::InvalidParameter {
            name: "min_group",
            ..
        })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn random_hairstyles_build_sound_hierarchies(style in hairstyle(), uniform in 1u32..4) {
        let params = HierarchyParams {
            root_strip_width: 0.03,
            root_strip_depth: 0.03,
            strip_width_min: 0.012,
            cluster_radius_min: 0.005,
            min_group: MinGroup::Uniform(uniform),
        };
        let h = Hierarchy::build(&style, &params).unwrap();
        check_structure(&style, &h);
        prop_assert_eq!(h.strand_total(), style.strands.len());
        let again = Hierarchy::build(&style, &params).unwrap();
        prop_assert_eq!(h, again);
    }
}
