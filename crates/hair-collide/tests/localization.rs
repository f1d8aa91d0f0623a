//! Localization: hair creeping slower than a cell per step stays simulated; hair at rest
//! freezes; sections wake each other through their cells only when strands interact; a tool's
//! touch keeps hair awake.

use hair_collide::{Localization, Sections};
use hair_dynamics::{Material, Root, SkeletonDesc, SkeletonId, StrandState};
use hair_grid::{ActivityConfig, Grid, GridConfig};
use hair_ssv::{Point, Real, Vector};
use nalgebra::Rotation3;

const DT: Real = 1.0 / 60.0;

/// Two hanging strands of 8 segments of 9 mm, `gap` apart along x, every node clear of the
/// 5 cm cells' faces: motion within a cell crosses none.
fn two_strands(gap: Real) -> StrandState {
    let mut state = StrandState::new();
    for x in [0.02, 0.02 + gap] {
        let root = Point::new(x, -0.02, 0.025);
        let points = (0..9)
            .map(|k| root - Vector::y() * (0.009 * k as Real))
            .collect();
        state
            .add_skeleton(&SkeletonDesc {
                root: Root::Attached {
                    position: root,
                    frame: Rotation3::identity(),
                },
                points,
                material: Material::default(),
            })
            .expect("a valid strand");
    }
    state
}

/// Runs `seconds` of updates of `loc`; strand 0's tip creeps sideways at `speed` (m/s) by
/// setting its shape (no velocity), strand 1 stays still, and the nodes in `touched` are given
/// as a tool's every step. Returns, per update, whether each strand is frozen.
fn creep(
    mut loc: Localization,
    gap: Real,
    speed: Real,
    seconds: Real,
    touched: &[u32],
) -> Vec<[bool; 2]> {
    let mut state = two_strands(gap);
    let front = [0u32, 1];
    let mut sections = Sections::default();
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.05),
        ..GridConfig::default()
    });
    let start: Vec<Point> = state.positions()[state.nodes(SkeletonId(0))].to_vec();
    let mut out = Vec::new();
    let steps = (seconds / DT).round() as usize;
    for step in 0..steps {
        // Strand 0 bends ever so slightly: its tip moves `speed * DT` a step, within its cell.
        let shift = speed * DT * step as Real;
        let bent: Vec<Point> = start
            .iter()
            .enumerate()
            .map(|(k, p)| p + Vector::x() * (shift * k as Real / 8.0))
            .collect();
        if state.is_active(SkeletonId(0)) {
            state
                .set_shape(SkeletonId(0), &bent)
                .expect("finite points");
        }
        sections.build(&state, &front);
        grid.rebuild(&sections.sections).expect("a valid grid");
        loc.update(&mut state, &grid, &sections, &front, DT, touched)
            .expect("valid input");
        out.push([loc.frozen()[0], loc.frozen()[1]]);
    }
    out
}

fn first_frozen(run: &[[bool; 2]], strand: usize) -> Option<Real> {
    run.iter().position(|f| f[strand]).map(|i| i as Real * DT)
}

#[test]
fn hair_creeping_within_its_cells_is_never_frozen_and_still_hair_is() {
    for loc in [
        Localization::new(ActivityConfig::default()),
        Localization::uncoupled(ActivityConfig::default()),
    ] {
        // 1.5 cm/s, over the speed threshold (1 cm/s): 0.25 mm a step, so the speed must keep
        // it simulated. The still strand, 20 cm away, freezes after 0.5 s.
        let run = creep(loc.clone(), 0.2, 1.5e-2, 1.5, &[]);
        assert_eq!(first_frozen(&run, 0), None, "the creeping strand froze");
        let t = first_frozen(&run, 1).expect("still hair freezes");
        assert!((t - 0.5).abs() < 0.05, "froze after {t} s");
        // Far below the speed threshold, the creep counts as rest.
        assert!(creep(loc, 0.2, 1e-4, 1.5, &[]).last().expect("updates")[0]);
    }
}

#[test]
fn a_still_strand_beside_a_moving_one_sleeps_only_when_strands_do_not_interact() {
    // 5 mm apart: the strands share every cell. Strand 0 creeps at 1.5 cm/s, over the speed
    // threshold.
    let coupled = creep(
        Localization::new(ActivityConfig::default()),
        5e-3,
        1.5e-2,
        1.5,
        &[],
    );
    assert_eq!(
        first_frozen(&coupled, 1),
        None,
        "a mover's cell keeps its neighbour awake"
    );
    let apart = creep(
        Localization::uncoupled(ActivityConfig::default()),
        5e-3,
        1.5e-2,
        1.5,
        &[],
    );
    assert_eq!(first_frozen(&apart, 0), None);
    let t = first_frozen(&apart, 1).expect("the still strand sleeps");
    assert!((t - 0.5).abs() < 0.05, "froze after {t} s");
}

#[test]
fn hair_a_tool_touches_stays_awake() {
    // Strand 1's nodes are 9..18; its tip section ends at node 17.
    for loc in [
        Localization::new(ActivityConfig::default()),
        Localization::uncoupled(ActivityConfig::default()),
    ] {
        let run = creep(loc.clone(), 0.2, 0.0, 1.5, &[17]);
        assert_eq!(first_frozen(&run, 1), None, "the touched strand froze");
        assert!(run.last().expect("updates")[0], "the untouched one sleeps");
        // A node outside the state is ignored.
        let run = creep(loc, 0.2, 0.0, 1.5, &[10_000]);
        assert!(run.last().expect("updates")[1]);
    }
}
