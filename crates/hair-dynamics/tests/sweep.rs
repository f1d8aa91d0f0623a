//! `StrandState::sweep_chains`: one correction is `apply_corrections`, repeated sweeps leave
//! every node above a floor with its segment lengths kept, the thread count changes nothing, and
//! bad chains or targets give typed errors.

mod support;

use hair_dynamics::*;
use proptest::prelude::*;
use support::*;

/// Strands hanging from roots spread along x at height `y0`, each along its own direction in
/// the x-y plane (tilted by `tilt` radians from straight down) with a style.
fn hanging(roots: &[(Real, Real)], n: usize, length: Real, style: Style) -> StrandState {
    let roots: Vec<(Point, Vector, Style)> = roots
        .iter()
        .enumerate()
        .map(|(k, &(y0, tilt))| {
            let root = Point::new(0.05 * k as Real, y0, 0.0);
            (root, Vector::new(tilt.sin(), -tilt.cos(), 0.0), style)
        })
        .collect();
    strands(&roots, n, length)
}

/// Where a node below the floor `y = floor` goes: onto its sphere about its parent a hair above
/// the floor (rounding in the refit must not bring it back under) where the sphere reaches
/// that high, else straight above its parent.
fn onto_floor(ask: &SweepAsk<'_>, floor: Real) -> Option<Point> {
    if ask.at.y >= floor - 1e-6 {
        return None;
    }
    let a = *ask.parent?;
    let len = (ask.at - a).norm();
    let rise = floor + 1e-6 - a.y;
    if rise >= len {
        return Some(a + Vector::y() * len);
    }
    let side = Vector::new(ask.at.x - a.x, 0.0, ask.at.z - a.z);
    let side = side.try_normalize(1e-9).unwrap_or_else(Vector::x);
    Some(a + side * (len * len - rise * rise).max(0.0).sqrt() + Vector::y() * rise)
}

fn every_chain(state: &StrandState) -> Vec<[u32; 2]> {
    (0..state.skeleton_count() as u32).map(|s| [s, 1]).collect()
}

fn bits(state: &StrandState) -> Vec<u32> {
    let p = state
        .positions()
        .iter()
        .flat_map(|p| p.coords.iter().copied());
    let v = state.velocities().iter().flat_map(|v| v.iter().copied());
    p.chain(v)
        .chain(state.theta().iter().copied())
        .chain(state.phi().iter().copied())
        .map(f32::to_bits)
        .collect()
}

fn style(curl: u8) -> Style {
    match curl {
        0 => Style::Straight,
        1 => Style::Wavy {
            amplitude: 0.01,
            period: 0.07,
        },
        _ => Style::Curly {
            radius: 0.008,
            pitch: 0.03,
        },
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// A sweep whose one correction moves node `j` to a target is, bit for bit,
    /// `apply_corrections` with that correction: the same refit, and the nodes after it asked
    /// about (and left) where the refit put them.
    #[test]
    fn one_correction_swept_is_apply_corrections(
        curl in 0u8..3,
        n in 3usize..12,
        pick in 0.0f64..1.0,
        delta in prop::array::uniform3(-0.02f32..0.02),
        omega in prop::collection::vec(-3.0f32..3.0, 24),
    ) {
        let mut a = hanging(&[(0.0, 0.3), (0.0, -0.2)], n, 0.2, style(curl));
        for (i, w) in a.omega_theta_mut().iter_mut().enumerate() {
            *w = omega[i % omega.len()];
        }
        for (i, w) in a.omega_phi_mut().iter_mut().enumerate() {
            *w = -omega[(i + 7) % omega.len()];
        }
        for s in 0..2 {
            a.refresh_positions(SkeletonId(s));
        }
        let mut b = hanging(&[(0.0, 0.3), (0.0, -0.2)], n, 0.2, style(curl));
        b.omega_theta_mut().copy_from_slice(a.omega_theta());
        b.omega_phi_mut().copy_from_slice(a.omega_phi());
        for s in 0..2 {
            b.refresh_positions(SkeletonId(s));
        }
        let r = a.nodes(SkeletonId(1));
        let j = r.start + 1 + ((pick * (n - 1) as f64) as usize).min(n - 2);
        let delta = Vector::new(delta[0], delta[1], delta[2]);
        let target = a.positions()[j] + delta;
        a.apply_corrections(&[NodeCorrection { node: j as u32, delta }]).unwrap();
        let mut out = vec![0u8; b.node_count()];
        let mut moved = vec![0; 2];
        b.sweep_chains(&every_chain(&b), &mut out, &mut moved, |ask, asked| {
            *asked += 1;
            (ask.node == j && !ask.moved).then_some(target)
        })
        .unwrap();
        prop_assert_eq!(bits(&a), bits(&b));
        prop_assert_eq!(moved, vec![u32::MAX, j as u32]);
        // Every node of both chains but the roots was asked about once.
        for s in 0..2 {
            let r = b.nodes(SkeletonId(s));
            prop_assert_eq!(out[r.start], 0);
            prop_assert!(out[r.start + 1..r.end].iter().all(|&k| k == 1), "{:?}", out);
        }
    }

    /// Strands hanging into a floor: repeated sweeps (each from its chains' first moved node)
    /// end with every node on or above the floor, every segment its length, and the strands
    /// that never reached the floor untouched.
    #[test]
    fn sweeps_lift_every_node_onto_the_floor(
        roots in prop::collection::vec((0.12f32..0.3, -1.2f32..1.2), 1..8),
        curl in 0u8..3,
        n in 3usize..16,
        floor in -0.25f32..0.1,
    ) {
        let mut state = hanging(&roots, n, 0.3, style(curl));
        let before = state.positions().to_vec();
        let mut chains = every_chain(&state);
        let mut out = vec![(); state.node_count()];
        let mut sweeps = 0;
        while !chains.is_empty() {
            prop_assert!(sweeps < 64, "still moving after {} sweeps", sweeps);
            let mut moved = vec![0; chains.len()];
            state
                .sweep_chains(&chains, &mut out, &mut moved, |ask, _| onto_floor(ask, floor))
                .unwrap();
            chains = chains
                .iter()
                .zip(&moved)
                .filter(|&(_, &m)| m != u32::MAX)
                .map(|(&[s, _], &m)| [s, m - state.nodes(SkeletonId(s)).start as u32])
                .collect();
            sweeps += 1;
        }
        let p = state.positions();
        for s in 0..state.skeleton_count() {
            let r = state.nodes(SkeletonId(s as u32));
            let touched = before[r.clone()].iter().any(|q| q.y < floor);
            for i in r.start + 1..r.end {
                prop_assert!(p[i].y >= floor - 1e-5, "node {} at y {} under {}", i, p[i].y, floor);
                prop_assert!(((p[i] - p[i - 1]).norm() - state.length()[i]).abs() < 1e-5);
                if !touched {
                    prop_assert_eq!(p[i], before[i]);
                }
            }
        }
    }
}

/// The same sweep on one thread and on two gives the same bits.
#[test]
fn a_sweep_does_not_depend_on_the_thread_count() {
    let roots: Vec<(Real, Real)> = (0..200)
        .map(|k| {
            (
                0.05 + 0.1 * ((k * 37 % 11) as Real / 11.0),
                (k % 13) as Real * 0.15 - 0.9,
            )
        })
        .collect();
    let run = |threads: usize| {
        on_threads(threads, || {
            let mut state = hanging(&roots, 12, 0.3, style(2));
            let chains = every_chain(&state);
            let mut out = vec![(); state.node_count()];
            let mut moved = vec![0; chains.len()];
            state
                .sweep_chains(&chains, &mut out, &mut moved, |ask, _| onto_floor(ask, 0.0))
                .unwrap();
            assert!(moved.iter().filter(|&&m| m != u32::MAX).count() > 100);
            (bits(&state), moved)
        })
    };
    assert_eq!(run(1), run(2));
}

/// Chains out of order, a node past a skeleton's end, outputs of the wrong length and a
/// non-finite target are typed errors; the state stays finite.
#[test]
fn bad_chains_and_targets_are_errors() {
    let mut state = hanging(&[(0.0, 0.0), (0.0, 0.5)], 6, 0.2, Style::Straight);
    let mut out = vec![(); state.node_count()];
    let mut moved = vec![0; 2];
    let none = |_: &SweepAsk<'_>, _: &mut ()| None;
    let err = state
        .sweep_chains(&[[1, 1], [0, 1]], &mut out, &mut moved, none)
        .unwrap_err();
    assert!(
        matches!(err, DynamicsError::UnknownSkeleton { skeleton: 0 }),
        "{err}"
    );
    let err = state
        .sweep_chains(&[[0, 1], [0, 2]], &mut out, &mut moved, none)
        .unwrap_err();
    assert!(
        matches!(err, DynamicsError::UnknownSkeleton { skeleton: 0 }),
        "{err}"
    );
    let err = state
        .sweep_chains(&[[0, 6], [1, 1]], &mut out, &mut moved, none)
        .unwrap_err();
    assert!(
        matches!(err, DynamicsError::UnknownNode { node: 6, .. }),
        "{err}"
    );
    let err = state
        .sweep_chains(&[[0, 1], [2, 1]], &mut out, &mut moved, none)
        .unwrap_err();
    assert!(
        matches!(err, DynamicsError::UnknownSkeleton { skeleton: 2 }),
        "{err}"
    );
    let err = state
        .sweep_chains(&[[0, 1]], &mut out, &mut moved, none)
        .unwrap_err();
    assert!(matches!(err, DynamicsError::UnknownNode { .. }), "{err}");
    let before = bits(&state);
    let err = state
        .sweep_chains(&[[0, 1], [1, 1]], &mut out, &mut moved, |ask, _| {
            (ask.node == 9).then_some(Point::new(0.0, Real::NAN, 0.0))
        })
        .unwrap_err();
    assert!(
        matches!(
            err,
            DynamicsError::InvalidNode {
                skeleton: 1,
                node: 3,
                ..
            }
        ),
        "{err}"
    );
    assert_eq!(bits(&state), before, "a non-finite target is not applied");
    assert_eq!(moved, [u32::MAX, u32::MAX]);
}
