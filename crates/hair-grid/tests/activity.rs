//! Active and dormant cells: scripted rest, poke, rest sequences.

use hair_grid::{
    Activity, ActivityConfig, ActivityInput, CellState, Cone, Grid, GridConfig, InfluenceVolume,
    Section,
};
use hair_ssv::{Lss, Point, Ssv, Vector};

/// Two strands of 5 segments, 10 cm apart.
fn strands(offset: f32) -> Vec<Section> {
    let mut out = Vec::new();
    for s in 0..2u32 {
        let x = 0.1 * s as f32;
        for k in 0..5u32 {
            let y0 = -0.01 * k as f32 + if s == 1 { offset } else { 0.0 };
            out.push(Section {
                skeleton: s,
                segment: k,
                shape: Ssv::Line(Lss::new(
                    Point::new(x, y0, 0.0),
                    Point::new(x, y0 - 0.01, 0.0),
                    0.0005,
                )),
            });
        }
    }
    out
}

const DT: f32 = 0.1;

fn config() -> ActivityConfig {
    ActivityConfig {
        dormant_after: 0.35,
        speed_threshold: 1e-3,
        wake_force: 0.01,
    }
}

fn step(
    act: &mut Activity,
    grid: &Grid,
    speeds: &[f32],
    forces: &[f32],
    tools: &[InfluenceVolume],
) {
    act.update(
        grid,
        &ActivityInput {
            dt: DT,
            speeds,
            neighbour_forces: forces,
            tools,
            ..Default::default()
        },
    )
    .unwrap();
    // Invariant: nothing moving is frozen.
    for (i, &v) in speeds.iter().enumerate() {
        if v > act.config().speed_threshold {
            assert!(!act.frozen()[i], "moving section {i} frozen");
        }
    }
}

/// The two strands and a grid of 1 cm cells rebuilt over them.
fn strands_in_cells() -> (Vec<Section>, Grid) {
    let secs = strands(0.0);
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.01),
        ..GridConfig::default()
    });
    grid.rebuild(&secs).unwrap();
    (secs, grid)
}

/// The two strands in 1 cm cells, at rest long enough (0.5 s) for every cell to be dormant.
fn settled() -> (Vec<Section>, Grid, Activity) {
    let (secs, grid) = strands_in_cells();
    let mut act = Activity::new(config());
    let rest = vec![0.0; secs.len()];
    for _ in 0..5 {
        step(&mut act, &grid, &rest, &[], &[]);
    }
    (secs, grid, act)
}

#[test]
fn rest_then_poke_then_rest() {
    let (secs, grid) = strands_in_cells();
    let mut act = Activity::new(config());
    let rest = vec![0.0; secs.len()];
    // New cells start active; 0.35 s of rest (4 steps of 0.1 s) makes them dormant.
    for k in 0..4 {
        step(&mut act, &grid, &rest, &[], &[]);
        assert_eq!(act.skeletons_to_integrate(), &[0, 1], "step {k}");
    }
    step(&mut act, &grid, &rest, &[], &[]);
    assert!(act.frozen().iter().all(|&f| f));
    assert!(act.skeletons_to_integrate().is_empty());
    assert_eq!(act.counts().0, 0);

    // Poke strand 1 with a grab cone: its cells wake, strand 0 stays frozen.
    let tool = InfluenceVolume::Cone(Cone::from_angle(
        Point::new(0.1, -0.025, -0.05),
        Vector::z(),
        0.1,
        0.05,
    ));
    step(&mut act, &grid, &rest, &[], &[tool]);
    assert_eq!(act.skeletons_to_integrate(), &[1]);
    assert!(act.frozen()[..5].iter().all(|&f| f));

    // Strand 1 moves: it stays active whatever the time.
    let mut moving = rest.clone();
    for v in &mut moving[5..] {
        *v = 0.05;
    }
    for _ in 0..10 {
        step(&mut act, &grid, &moving, &[], &[]);
        assert_eq!(act.skeletons_to_integrate(), &[1]);
    }
    // Rest again: dormant after the same delay.
    for _ in 0..3 {
        step(&mut act, &grid, &rest, &[], &[]);
        assert_eq!(act.skeletons_to_integrate(), &[1]);
    }
    step(&mut act, &grid, &rest, &[], &[]);
    assert!(act.skeletons_to_integrate().is_empty());
    assert!(act.cells().iter().all(|c| c.state == CellState::Dormant));
}

#[test]
fn a_section_entering_a_dormant_cell_wakes_it() {
    let (secs, mut grid, mut act) = settled();
    let rest = vec![0.0; secs.len()];
    assert!(act.skeletons_to_integrate().is_empty());
    // Strand 1 slid down by more than a cell (its speed reported as zero: only the entering and
    // leaving count).
    let moved = strands(-0.012);
    grid.rebuild(&moved).unwrap();
    step(&mut act, &grid, &rest, &[], &[]);
    assert_eq!(act.skeletons_to_integrate(), &[1]);
    let entered: u32 = act.cells().iter().map(|c| c.entering).sum();
    assert!(entered > 0);
}

#[test]
fn a_strong_neighbour_force_wakes_a_dormant_cell_and_a_weak_one_does_not() {
    let (secs, grid, mut act) = settled();
    let rest = vec![0.0; secs.len()];
    let mut weak = vec![0.0; secs.len()];
    weak[2] = 0.001;
    step(&mut act, &grid, &rest, &weak, &[]);
    assert!(act.skeletons_to_integrate().is_empty());
    let mut strong = vec![0.0; secs.len()];
    strong[2] = 0.5;
    step(&mut act, &grid, &rest, &strong, &[]);
    assert_eq!(act.skeletons_to_integrate(), &[0]);
    assert!(!act.frozen()[2]);
}

#[test]
fn mismatched_inputs_are_errors_not_panics() {
    let secs = strands(0.0);
    let mut grid = Grid::new(GridConfig::default());
    grid.rebuild(&secs).unwrap();
    let mut act = Activity::new(ActivityConfig::default());
    let short = [0.0f32; 3];
    assert!(
        act.update(
            &grid,
            &ActivityInput {
                dt: DT,
                speeds: &short,
                ..Default::default()
            }
        )
        .is_err()
    );
    let speeds = vec![0.0; secs.len()];
    assert!(
        act.update(
            &grid,
            &ActivityInput {
                dt: f32::NAN,
                speeds: &speeds,
                ..Default::default()
            }
        )
        .is_err()
    );
    assert!(
        act.update(
            &grid,
            &ActivityInput {
                dt: DT,
                speeds: &speeds,
                neighbour_forces: &short,
                ..Default::default()
            }
        )
        .is_err()
    );
    assert!(matches!(
        act.update(
            &grid,
            &ActivityInput {
                dt: DT,
                speeds: &speeds,
                touched_sections: &[secs.len() as u32],
                ..Default::default()
            }
        ),
        Err(hair_grid::GridError::UnknownSection { index: 10, .. })
    ));
}

#[test]
fn a_touched_section_wakes_its_cells_and_no_others() {
    let (secs, grid, mut act) = settled();
    let rest = vec![0.0; secs.len()];
    assert!(act.skeletons_to_integrate().is_empty());
    // Strand 1's tip section is touched: the cells it lies in wake, so it and the section
    // sharing one of them (its neighbour) thaw; strand 0 and strand 1's root stay frozen.
    act.update(
        &grid,
        &ActivityInput {
            dt: DT,
            speeds: &rest,
            touched_sections: &[9],
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(act.skeletons_to_integrate(), &[1]);
    assert!(act.frozen()[..5].iter().all(|&f| f));
    assert!(!act.frozen()[9] && !act.frozen()[8]);
    assert!(
        act.frozen()[5],
        "a section sharing no cell with the touched one stays frozen"
    );
}
