//! Bad input gives a typed error, never a hang or a panic; body cells agree with brute force.

mod common;

use common::brute_pairs;
use hair_grid::{BodyCells, BodyGrid, Cone, Grid, GridConfig, GridError, InfluenceVolume, Section};
use hair_ssv::{Lss, Point, Ssv, Vector};

fn seg(a: Point, b: Point, r: f32) -> Section {
    Section {
        skeleton: 0,
        segment: 0,
        shape: Ssv::Line(Lss::new(a, b, r)),
    }
}

#[test]
fn a_non_finite_coordinate_names_the_section() {
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.01),
        ..GridConfig::default()
    });
    let good = seg(Point::origin(), Point::new(0.01, 0.0, 0.0), 0.001);
    let bad = seg(Point::new(f32::NAN, 0.0, 0.0), Point::origin(), 0.001);
    let err = grid.rebuild(&[good, good, bad]).unwrap_err();
    assert!(
        matches!(
            err,
            GridError::InvalidShape {
                index: 2,
                field: "a",
                ..
            }
        ),
        "{err}"
    );
    assert!(grid.is_empty());
    let inf = seg(Point::origin(), Point::new(0.0, f32::INFINITY, 0.0), 0.001);
    assert!(matches!(
        grid.rebuild(&[inf]),
        Err(GridError::InvalidShape { field: "b", .. })
    ));
    let neg = seg(Point::origin(), Point::origin(), -1.0);
    assert!(matches!(
        grid.rebuild(&[neg]),
        Err(GridError::InvalidShape {
            field: "radius",
            ..
        })
    ));
    // Same with the default cell size (the mean length is not finite).
    let mut grid = Grid::new(GridConfig::default());
    assert!(matches!(
        grid.rebuild(&[good, inf]),
        Err(GridError::InvalidShape { index: 1, .. })
    ));
}

#[test]
fn a_bad_cell_size_is_an_error() {
    let s = seg(Point::origin(), Point::new(0.01, 0.0, 0.0), 0.001);
    for h in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let mut grid = Grid::new(GridConfig {
            cell_size: Some(h),
            ..GridConfig::default()
        });
        assert!(
            matches!(
                grid.rebuild(&[s]),
                Err(GridError::NonPositiveCellSize { .. })
            ),
            "{h}"
        );
    }
    // All sections of zero length: the mean segment length is zero.
    let p = seg(Point::origin(), Point::origin(), 0.001);
    let mut grid = Grid::new(GridConfig::default());
    assert!(matches!(
        grid.rebuild(&[p, p]),
        Err(GridError::NonPositiveCellSize { .. })
    ));
    let mut grid = Grid::new(GridConfig {
        margin: -1.0,
        ..GridConfig::default()
    });
    assert!(matches!(
        grid.rebuild(&[s]),
        Err(GridError::InvalidMargin { .. })
    ));
}

#[test]
fn a_volume_covering_billions_of_cells_is_an_error_not_a_hang() {
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(1e-4),
        ..GridConfig::default()
    });
    let huge = seg(Point::origin(), Point::new(1.0, 1.0, 1.0), 0.5);
    let err = grid.rebuild(&[huge]).unwrap_err();
    assert!(
        matches!(err, GridError::TooManyCells { index: 0, .. }),
        "{err}"
    );
    let far = seg(Point::new(1e6, 0.0, 0.0), Point::new(1e6, 0.0, 0.0), 0.0);
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.01),
        ..GridConfig::default()
    });
    assert!(matches!(
        grid.rebuild(&[far]),
        Err(GridError::OutsideLattice { axis: 'x', .. })
    ));
    // Sections far apart: the box is sparse, the grid falls back to a comparison sort.
    let a = seg(
        Point::new(-5000.0, 0.0, 0.0),
        Point::new(-5000.0, 0.01, 0.0),
        0.001,
    );
    let b = seg(
        Point::new(5000.0, 3000.0, -5000.0),
        Point::new(5000.0, 3000.01, -5000.0),
        0.001,
    );
    grid.rebuild(&[a, b, a]).unwrap();
    assert_eq!(grid.cell_sections(grid.cell_key(0).unwrap()), &[0, 2]);
    // A bad tool.
    let cone = Cone {
        apex: Point::origin(),
        axis: Vector::zeros(),
        length: 1.0,
        radius: 0.0,
        spread: 0.1,
    };
    let mut out = Vec::new();
    assert!(
        grid.sections_in(&InfluenceVolume::Cone(cone), &mut out)
            .is_err()
    );
}

#[test]
fn body_cells_hold_every_touching_section_and_triangle() {
    // A small "scalp": two triangles in the plane y = 0, and hair crossing it.
    let vertices = vec![
        Point::new(-0.05, 0.0, -0.05),
        Point::new(0.05, 0.0, -0.05),
        Point::new(0.05, 0.0, 0.05),
        Point::new(-0.05, 0.0, 0.05),
    ];
    let tris = [[0u32, 1, 2], [0, 2, 3]];
    let mut secs = Vec::new();
    for k in 0..40u32 {
        let x = -0.06 + 0.003 * k as f32;
        let y = if k % 2 == 0 { 0.0004 } else { 0.02 };
        secs.push(Section {
            skeleton: k,
            segment: 0,
            shape: Ssv::Line(Lss::new(
                Point::new(x, y, -0.01),
                Point::new(x, y + 0.01, 0.01),
                0.0005,
            )),
        });
    }
    let mut grid = Grid::new(GridConfig::default());
    grid.rebuild(&secs).unwrap();
    for body_cell in [grid.cell_size(), 0.023] {
        let body = BodyGrid::new(&vertices, &tris, body_cell, 0.0, 1 << 20).unwrap();
        let mut cells = BodyCells::new();
        grid.body_cells(&body, &mut cells);
        for (i, s) in secs.iter().enumerate() {
            for (t, tri) in tris.iter().enumerate() {
                let tri = tri.map(|v| vertices[v as usize]);
                if s.shape.distance_to_triangle(&tri) <= 0.0 {
                    let found = cells.iter().any(|(c, ts)| {
                        grid.cell_sections_at(c).contains(&(i as u32)) && ts.contains(&(t as u32))
                    });
                    assert!(
                        found,
                        "section {i} touches triangle {t} (body cell {body_cell})"
                    );
                }
            }
        }
    }
    assert!(BodyGrid::new(&vertices, &[[0, 1, 9]], 0.01, 0.0, 100).is_err());
}

/// A section reaching far below the lattice (hair thrown 1e26 m by a huge gravity) is an error
/// naming it; the floor of its far end once overflowed (a panic with overflow checks on).
#[test]
fn a_section_far_below_the_lattice_is_an_error() {
    // The cells of the hair around it (the default would average the thrown length in).
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.01),
        ..GridConfig::default()
    });
    let near = seg(Point::origin(), Point::new(0.01, 0.0, 0.0), 0.001);
    for far in [-1e26f32, 1e26, -3e38] {
        let thrown = seg(Point::origin(), Point::new(far, 0.0, 0.0), 0.001);
        let err = grid.rebuild(&[near, thrown]).unwrap_err();
        assert!(
            matches!(
                err,
                GridError::OutsideLattice {
                    index: 1,
                    axis: 'x',
                    ..
                } | GridError::TooManyCells { index: 1, .. }
            ),
            "{far}: {err}"
        );
    }
}

/// Sections much fatter than long take their mean diameter as the default cell size, so that
/// each covers a few cells; their pairs are still every overlapping pair (brute force).
#[test]
fn fat_sections_take_cells_of_their_diameter() {
    let mut sections = Vec::new();
    for s in 0..20u32 {
        for k in 0..5u32 {
            let x = 0.05 * s as f32;
            let y = -0.01 * k as f32;
            sections.push(Section {
                skeleton: s,
                segment: k,
                shape: Ssv::Line(Lss::new(
                    Point::new(x, y, 0.0),
                    Point::new(x, y - 0.01, 0.0),
                    0.3,
                )),
            });
        }
    }
    let mut grid = Grid::new(GridConfig::default());
    grid.rebuild(&sections).unwrap();
    assert!(
        (grid.cell_size() - 0.6).abs() < 1e-4,
        "{}",
        grid.cell_size()
    );
    let mut pairs = hair_grid::PairSet::new();
    grid.overlapping_pairs(&mut pairs);
    let mut found = pairs.to_vec();
    found.sort_unstable();
    let brute = brute_pairs(&sections, 0.0, 1);
    assert_eq!(found, brute);
}

/// Sections measured in the billions of metres (lengths and radii clamp at 1e9 m each) do not
/// overflow the mean's integer sum: the grid builds or gives an error, never a panic.
#[test]
fn huge_sections_do_not_overflow_the_mean() {
    let mut grid = Grid::new(GridConfig::default());
    let long = seg(Point::origin(), Point::new(3e10, 0.0, 0.0), 0.001);
    let fat = seg(Point::origin(), Point::new(0.01, 0.0, 0.0), 1e30);
    for shape in [long, fat] {
        // A few dozen such sections: 20 x 1e18 nm passes `u64::MAX`.
        match grid.rebuild(&vec![shape; 40]) {
            Ok(()) => assert!(grid.cell_size().is_finite() && grid.cell_size() > 0.0),
            Err(e) => assert!(
                matches!(
                    e,
                    GridError::OutsideLattice { .. } | GridError::TooManyCells { .. }
                ),
                "{e}"
            ),
        }
    }
}
