//! Salon operations on the state: cuts conserve length, mass and water and keep the curl; a held
//! node never passes its reach and lengths are kept.

mod support;

use hair_dynamics::*;
use proptest::prelude::*;
use support::*;

fn curly(n: usize) -> (StrandState, SkeletonId) {
    one_strand(
        Style::Curly {
            radius: 0.01,
            pitch: 0.04,
        },
        n,
        0.3,
        frame_along(-Vector::y()),
        Material::default(),
    )
}

fn totals(state: &StrandState, ids: &[SkeletonId]) -> (f64, f64, f64) {
    let mut l = 0.0;
    let mut m = 0.0;
    let mut w = 0.0;
    for &id in ids {
        l += f64::from(state.skeleton_length(id));
        for i in state.nodes(id) {
            m += f64::from(state.mass()[i]);
            w += f64::from(state.wetness()[i]);
        }
    }
    (l, m, w)
}

fn wet(state: &mut StrandState, id: SkeletonId) {
    for (k, i) in state.nodes(id).enumerate() {
        state.wetness_mut()[i] = 1e-4 * (1 + k % 3) as Real;
    }
}

#[test]
fn a_cut_conserves_length_mass_and_water_and_keeps_the_curl() {
    let (mut state, id) = curly(16);
    wet(&mut state, id);
    let before = totals(&state, &[id]);
    let positions: Vec<Point> = state.positions()[state.nodes(id)].to_vec();
    let rest_theta: Vec<Real> = state.rest_theta()[state.nodes(id)].to_vec();
    let at = CutPoint { segment: 7, t: 0.4 }
        .snapped(&state.length()[state.nodes(id)], 1e-3)
        .expect("a cut in the middle");
    let res = state.cut(id, at, true).unwrap();
    let fallen = res.fallen.expect("a piece falls");
    assert_eq!(res.kept, 8);
    assert!(state.nodes(fallen).len() >= 2 && state.nodes(id).len() >= 2);
    let after = totals(&state, &[id, fallen]);
    assert!(
        (before.0 - after.0).abs() < 1e-6,
        "length {before:?} {after:?}"
    );
    assert!(
        (before.1 - after.1).abs() < 1e-9,
        "mass {before:?} {after:?}"
    );
    assert!(
        (before.2 - after.2).abs() < 1e-9,
        "water {before:?} {after:?}"
    );
    // S1 ends and S2 starts at the same point, on the original segment.
    let end = state.positions()[state.nodes(id).end - 1];
    let start = state.positions()[state.nodes(fallen).start];
    assert!((end - start).norm() < 1e-5);
    let expect = positions[6] + (positions[7] - positions[6]) * 0.4;
    assert!((end - expect).norm() < 1e-5, "{end} vs {expect}");
    // The fallen piece sits where the hair was, with the same rest angles (the curl).
    let f = state.nodes(fallen);
    for j in 1..f.len() {
        let p = state.positions()[f.start + j];
        assert!((p - positions[7 + j - 1]).norm() < 1e-4, "node {j}");
        if j >= 2 {
            assert_eq!(state.rest_theta()[f.start + j], rest_theta[7 + j - 1]);
        }
    }
    assert!(state.is_free(fallen));
}

#[test]
fn a_cut_at_the_root_leaves_a_stub_and_at_the_tip_cuts_nothing() {
    let (state, id) = curly(8);
    let len = &state.length()[state.nodes(id)];
    let root = CutPoint { segment: 1, t: 0.0 }.snapped(len, 1e-3).unwrap();
    assert_eq!(root.segment, 1);
    assert!(root.t > 0.0 && root.t < 1.0);
    let tip = CutPoint {
        segment: 7,
        t: 0.9999,
    }
    .snapped(len, 1e-3);
    assert_eq!(tip, None);
    let node = CutPoint {
        segment: 4,
        t: 1e-5,
    }
    .snapped(len, 1e-3)
    .unwrap();
    assert_eq!(node, CutPoint { segment: 3, t: 1.0 });
    let mut s = state.clone();
    let res = s.cut(id, root, true).unwrap();
    assert_eq!(res.kept, 2);
    assert_eq!(s.nodes(res.fallen.unwrap()).len(), 8);
}

#[test]
fn a_falling_piece_steps_without_error() {
    let (mut state, id) = curly(12);
    let res = state
        .cut(id, CutPoint { segment: 5, t: 0.5 }, true)
        .unwrap();
    let fallen = res.fallen.unwrap();
    let y0 = state.root_position(fallen).y;
    let settings = StepSettings::default();
    for _ in 0..60 {
        state.step(&Environment::default(), &settings).unwrap();
    }
    let y1 = state.root_position(fallen).y;
    assert!(y1 < y0 - 1.0, "the piece falls: {y0} -> {y1}");
    let total: Real = state.skeleton_length(fallen);
    assert!(total > 0.0 && total.is_finite());
}

#[test]
fn bonds_on_the_fallen_part_follow_it() {
    let (mut state, a) = curly(10);
    let frame = frame_along(-Vector::y());
    let points = style_points(
        Point::new(0.01, 0.0, 0.0),
        &frame,
        &Style::Straight,
        10,
        0.3,
    )
    .unwrap();
    let b = state
        .add_skeleton(&SkeletonDesc {
            root: Root::Attached {
                position: Point::new(0.01, 0.0, 0.0),
                frame,
            },
            points,
            material: Material::default(),
        })
        .unwrap();
    let na = state.nodes(a).start + 8;
    let nb = state.nodes(b).start + 8;
    let dist = (state.positions()[na] - state.positions()[nb]).norm();
    state
        .add_bond(Bond {
            a: na as u32,
            b: nb as u32,
            rest: dist,
            stiffness: 1.0,
            break_distance: 0.05,
        })
        .unwrap();
    let res = state.cut(a, CutPoint { segment: 4, t: 0.5 }, true).unwrap();
    let f = res.fallen.unwrap();
    let bond = state.bonds()[0];
    let moved = state.nodes(f).start + 1 + (8 - res.first_source);
    assert!(bond.a as usize == moved || bond.b as usize == moved);
    // Without a spawned piece, the bond on the removed tail goes.
    let mut s = state.clone();
    s.cut(b, CutPoint { segment: 3, t: 1.0 }, false).unwrap();
    assert!(s.bonds().is_empty());
}

#[test]
fn a_held_node_never_passes_its_reach_and_keeps_lengths() {
    let (mut state, id) = curly(12);
    let lengths: Vec<Real> = state.length()[state.nodes(id)].to_vec();
    let j = 6;
    let reach: Real = lengths[1..=j].iter().sum();
    let mut scratch = Vec::new();
    // Within reach: the node gets there.
    let near = Point::new(0.03, -0.05, 0.02);
    let got = state.hold_node(id, j, near, &mut scratch).unwrap();
    assert!((got - near).norm() < 1e-4, "{got} vs {near}");
    // Far away: it stops at its reach, towards the target.
    let far = Point::new(2.0, 1.0, 0.0);
    let got = state.hold_node(id, j, far, &mut scratch).unwrap();
    let root = state.root_position(id);
    assert!((got - root).norm() <= reach * (1.0 + 1e-4));
    assert!((got - root).norm() >= reach * 0.99);
    let p = &state.positions()[state.nodes(id)];
    for i in 1..p.len() {
        assert!(
            ((p[i] - p[i - 1]).norm() - lengths[i]).abs() < 1e-5,
            "segment {i}"
        );
    }
    assert!(state.hold_node(id, 0, near, &mut scratch).is_err());
    assert!(state.hold_node(id, 12, near, &mut scratch).is_err());
}

proptest! {
    #[test]
    fn every_cut_conserves_length_and_water_and_leaves_two_points(
        n in 2usize..24,
        seg in 1usize..24,
        t in 0.0f32..=1.0,
        min in prop_oneof![Just(0.0f32), 1e-4f32..0.05],
        spawn in any::<bool>(),
    ) {
        let (mut state, id) = curly(n);
        wet(&mut state, id);
        let before = totals(&state, &[id]);
        let len = state.length()[state.nodes(id)].to_vec();
        let Some(at) = (CutPoint { segment: seg, t }).snapped(&len, min) else {
            return Ok(());
        };
        let res = state.cut(id, at, spawn).unwrap();
        prop_assert!(state.nodes(id).len() >= 2);
        let mut ids = vec![id];
        if let Some(f) = res.fallen {
            prop_assert!(state.nodes(f).len() >= 2);
            for i in state.nodes(f).skip(1) {
                prop_assert!(state.length()[i] > 0.0);
            }
            ids.push(f);
            let after = totals(&state, &ids);
            prop_assert!((before.0 - after.0).abs() < 1e-5);
            prop_assert!((before.2 - after.2).abs() < 1e-8);
        }
        for p in state.positions() {
            prop_assert!(p.coords.iter().all(|c| c.is_finite()));
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    /// A bond is present exactly while its nodes are within the break distance at the end of
    /// each step: it breaks at its distance and not before.
    #[test]
    fn bonds_break_at_their_distance_and_not_before(
        pull in 1e-3f32..2e-2,
        stretch in 2e-3f32..3e-2,
        stiffness in 0.0f32..0.5,
    ) {
        let frame = frame_along(-Vector::y());
        let mut state = StrandState::new();
        let mut ids = Vec::new();
        for x in [0.0f32, 0.004] {
            let root = Point::new(x, 0.0, 0.0);
            let points = style_points(root, &frame, &Style::Straight, 8, 0.2).unwrap();
            ids.push(state.add_skeleton(&SkeletonDesc {
                root: Root::Attached { position: root, frame },
                points,
                material: Material::default(),
            }).unwrap());
        }
        let (a, b) = (state.nodes(ids[0]).end - 1, state.nodes(ids[1]).end - 1);
        let rest = (state.positions()[a] - state.positions()[b]).norm();
        state.add_bond(Bond { a: a as u32, b: b as u32, rest, stiffness, break_distance: rest + stretch }).unwrap();
        // Pull the tips apart along x.
        state.external_force_mut()[a] = Vector::new(-pull, 0.0, 0.0);
        state.external_force_mut()[b] = Vector::new(pull, 0.0, 0.0);
        let settings = StepSettings::default();
        let env = no_gravity();
        let mut broke = false;
        for _ in 0..240 {
            let report = state.step(&env, &settings).unwrap();
            let d = (state.positions()[a] - state.positions()[b]).norm();
            if state.bonds().is_empty() {
                if !broke {
                    prop_assert_eq!(report.bonds_broken, 1);
                    prop_assert!(d > rest + stretch, "broke early at {} (limit {})", d, rest + stretch);
                }
                broke = true;
            } else {
                prop_assert!(d <= rest + stretch, "still bonded at {} past {}", d, rest + stretch);
            }
        }
    }
}
