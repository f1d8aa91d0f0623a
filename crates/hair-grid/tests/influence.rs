//! Influence volumes: the grid's answer equals the exact test over all sections, and the exact
//! cone test agrees with the point-in-cone formula and dense sampling.

mod common;

use common::{lss, point, sections};
use hair_grid::{Cone, Grid, GridConfig, GridError, InfluenceVolume, Section};
use hair_ssv::{Lss, Point, Pss, Ssv, Vector};
use proptest::prelude::*;

fn cone() -> impl Strategy<Value = Cone> {
    (
        point(),
        -1.0f32..1.0,
        -1.0f32..1.0,
        -1.0f32..1.0,
        0.0f32..0.3,
        0.0f32..0.05,
        0.0f32..1.5,
    )
        .prop_filter("axis", |t| t.1.abs() + t.2.abs() + t.3.abs() > 0.1)
        .prop_map(|(apex, x, y, z, length, radius, spread)| Cone {
            apex,
            axis: Vector::new(x, y, z),
            length,
            radius,
            spread,
        })
}

fn volume() -> impl Strategy<Value = InfluenceVolume> {
    prop_oneof![
        3 => cone().prop_map(InfluenceVolume::Cone),
        1 => (point(), point(), point()).prop_map(|(a, b, c)| InfluenceVolume::Triangle([a, b, c])),
    ]
}

fn brute(secs: &[Section], v: &InfluenceVolume) -> Vec<u32> {
    (0..secs.len() as u32)
        .filter(|&i| v.touches(&secs[i as usize].shape))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn grid_membership_equals_the_exact_test(secs in sections(60), v in volume(), cell in prop_oneof![Just(None), Just(Some(0.04f32))]) {
        let mut grid = Grid::new(GridConfig { cell_size: cell, max_cells_per_item: 1 << 20, ..GridConfig::default() });
        // Only zero-length sections: no mean segment length, a documented error.
        let built = grid.rebuild(&secs);
        prop_assume!(!matches!(built, Err(GridError::NonPositiveCellSize { .. })));
        built.unwrap();
        let mut got = Vec::new();
        grid.sections_in(&v, &mut got).unwrap();
        prop_assert_eq!(got, brute(&secs, &v));
    }

    #[test]
    fn points_are_members_exactly_when_inside_the_cone(c in cone(), pts in prop::collection::vec(point(), 1..80)) {
        let secs: Vec<Section> = pts.iter().enumerate().map(|(i, &p)| Section {
            skeleton: i as u32, segment: 0, shape: Ssv::Point(Pss::new(p, 0.0)),
        }).collect();
        let mut grid = Grid::new(GridConfig { cell_size: Some(0.03), ..GridConfig::default() });
        grid.rebuild(&secs).unwrap();
        let mut got = Vec::new();
        grid.sections_in(&InfluenceVolume::Cone(c), &mut got).unwrap();
        let want: Vec<u32> = (0..pts.len() as u32).filter(|&i| c.contains_point(&pts[i as usize])).collect();
        prop_assert_eq!(got, want);
    }

    #[test]
    fn cone_distance_of_a_segment_matches_dense_sampling(c in cone(), s in lss()) {
        let v = InfluenceVolume::Cone(c);
        let d = v.core_distance(&Ssv::Line(Lss::new(s.a, s.b, 0.0)));
        let n = 2000;
        let mut sampled = f32::INFINITY;
        for k in 0..=n {
            let p = s.a + (s.b - s.a) * (k as f32 / n as f32);
            if c.contains_point(&p) {
                // A sample inside: the segment meets the cone.
                prop_assert!(d <= 1e-5, "sample inside but distance {}", d);
            }
            sampled = sampled.min(c.distance_to_point(&p));
        }
        // The minimum over the segment is below every sample, and within the sampling step.
        let step = (s.b - s.a).norm() / n as f32;
        prop_assert!(d <= sampled + 1e-5, "{} > sampled {}", d, sampled);
        prop_assert!(d >= sampled - step - 1e-5, "{} < sampled {} - step", d, sampled);
    }
}

#[test]
fn a_dryer_cone_finds_the_hair_in_front_of_it() {
    // A row of vertical strands along x; the cone points along +x from x = 0.
    let secs: Vec<Section> = (0..20)
        .map(|k| {
            let x = -0.1 + 0.01 * k as f32;
            Section {
                skeleton: k,
                segment: 0,
                shape: Ssv::Line(Lss::new(
                    Point::new(x, -0.05, 0.0),
                    Point::new(x, 0.05, 0.0),
                    0.0005,
                )),
            }
        })
        .collect();
    let mut grid = Grid::new(GridConfig::default());
    grid.rebuild(&secs).unwrap();
    let cone = Cone::from_angle(Point::new(0.0, 0.0, 0.0), Vector::x(), 0.05, 0.3);
    let mut got = Vec::new();
    grid.sections_in(&InfluenceVolume::Cone(cone), &mut got)
        .unwrap();
    assert_eq!(got, (10..=15).collect::<Vec<u32>>());
}

#[test]
fn a_huge_cone_is_clipped_to_the_hair() {
    let secs = [Section {
        skeleton: 0,
        segment: 0,
        shape: Ssv::Line(Lss::new(
            Point::new(0.0, 0.0, 0.0),
            Point::new(0.0, 0.01, 0.0),
            0.0005,
        )),
    }];
    let mut grid = Grid::new(GridConfig::default());
    grid.rebuild(&secs).unwrap();
    let cone = Cone {
        apex: Point::new(0.0, 0.0, -1.0),
        axis: Vector::z(),
        length: 1e6,
        radius: 1e3,
        spread: 10.0,
    };
    let mut got = Vec::new();
    grid.sections_in(&InfluenceVolume::Cone(cone), &mut got)
        .unwrap();
    assert_eq!(got, vec![0]);
}
