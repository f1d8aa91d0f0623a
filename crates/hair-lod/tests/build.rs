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
    assert!(
        (100..=120).contains(&s.root_strips),
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
