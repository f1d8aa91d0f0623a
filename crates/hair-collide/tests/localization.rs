//! Localization: hair creeping slower than a cell per step stays simulated; hair at rest
//! freezes.

use hair_collide::{Localization, Sections};
use hair_dynamics::{Material, Root, SkeletonDesc, SkeletonId, StrandState};
use hair_grid::{ActivityConfig, Grid, GridConfig};
use hair_ssv::{Point, Real, Vector};
use nalgebra::Rotation3;

const DT: Real = 1.0 / 60.0;

/// Two hanging strands of 8 segments of 9 mm, 20 cm apart, every node clear of the 5 cm
/// cells' faces: motion within a cell crosses none.
fn two_strands() -> StrandState {
    let mut state = StrandState::new();
    for x in [0.025, 0.225] {
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

/// Runs `seconds` of updates; strand 0's tip creeps sideways at `speed` (m/s) by setting its
/// shape (no velocity), strand 1 stays still. Returns, per update, whether each is frozen.
fn creep(speed: Real, seconds: Real) -> Vec<[bool; 2]> {
    let mut state = two_strands();
    let front = [0u32, 1];
    let mut sections = Sections::default();
    let mut grid = Grid::new(GridConfig {
        cell_size: Some(0.05),
        ..GridConfig::default()
    });
    let mut loc = Localization::new(ActivityConfig::default());
    let start: Vec<Point> = state.positions()[state.nodes(SkeletonId(0))].to_vec();
    let mut out = Vec::new();
    let steps = (seconds / DT).round() as usize;
    for step in 0..steps {
        // Strand 0 bends ever so slightly: its tip moves `speed * DT` a step, well inside a cell.
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
        loc.update(&mut state, &grid, &sections, &front, DT, &[])
            .expect("valid input");
        out.push([loc.frozen()[0], loc.frozen()[1]]);
    }
    out
}

#[test]
fn hair_creeping_within_its_cells_is_never_frozen_and_still_hair_is() {
    // 5 mm/s: 0.08 mm a step, so over a second the tip never leaves its 5 cm cell; the speed
    // alone must keep it simulated.
    let frozen = creep(5e-3, 1.5);
    assert!(
        frozen.iter().all(|f| !f[0]),
        "the creeping strand froze at update {:?}",
        frozen.iter().position(|f| f[0])
    );
    // The still strand, in cells of its own, goes dormant after `dormant_after` (0.5 s).
    let first = frozen
        .iter()
        .position(|f| f[1])
        .expect("still hair freezes");
    assert!(
        (first as Real * DT - 0.5).abs() < 0.05,
        "froze after {first} updates"
    );
    // Far below the speed threshold (1 mm/s), the creep counts as rest.
    assert!(creep(1e-4, 1.5).last().expect("updates")[0]);
}
