//! Transitions: exact split-then-merge, water conservation, cut and bond inheritance, the merge
//! distance and its pulling spring, and the bridge to `hair-dynamics`.

mod common;

use common::*;
use hair_dynamics::{Material, StrandState};
use hair_lod::*;
use proptest::prelude::*;

/// Everything of a node's state, for exact comparison (bit patterns).
fn node_bits(h: &Hierarchy, state: &LodState, v: u32) -> Vec<u32> {
    let s = h.control_point_start(v);
    let n = h.control_points(v);
    let mut out = vec![u32::from(state.count[v as usize])];
    for f in [
        &state.d_theta,
        &state.d_phi,
        &state.omega_theta,
        &state.omega_phi,
        &state.wetness,
        &state.stiffness,
        &state.thickness,
        &state.length,
    ] {
        out.extend(f[s..s + n].iter().map(|x| x.to_bits()));
    }
    out
}

fn fill_random(h: &Hierarchy, state: &mut LodState, v: u32, rng: &mut test_heads::SplitMix64) {
    let s = h.control_point_start(v);
    for j in 1..h.control_points(v) {
        let mut r = || (rng.unit() - 0.5) as f32;
        state.d_theta[s + j] = r();
        state.d_phi[s + j] = r();
        state.omega_theta[s + j] = 3.0 * r();
        state.omega_phi[s + j] = 3.0 * r();
        state.wetness[s + j] = r() + 0.5;
        state.stiffness[s + j] = 1.0 + r();
        state.thickness[s + j] = 1.0 + r();
        state.length[s + j] = 1.0 + 0.5 * r();
    }
}

/// Splits every ancestor of `v`, root first, so that `v` is active.
fn split_down_to(h: &Hierarchy, front: &mut Front, state: &mut LodState, v: u32) {
    let mut path = vec![];
    let mut cur = h.parent(v);
    while let Some(p) = cur {
        path.push(p);
        cur = h.parent(p);
    }
    for p in path.into_iter().rev() {
        split(h, front, state, p).unwrap();
    }
}

/// Splits along a random path from a root strip to an active node with children.
fn walk_down(
    h: &Hierarchy,
    front: &mut Front,
    state: &mut LodState,
    rng: &mut test_heads::SplitMix64,
    depth: u64,
) -> u32 {
    let mut v = h.tree_root((rng.next_u64() % h.tree_count() as u64) as u32);
    for _ in 0..depth {
        // Only into children that have children themselves, so that the walk ends on a node
        // that can be split (not a leaf under a split parent, which the caller must reject).
        let inner: Vec<u32> = h.children(v).filter(|&c| !h.is_leaf(c)).collect();
        if h.is_leaf(v) || inner.is_empty() {
            break;
        }
        split(h, front, state, v).unwrap();
        v = inner[(rng.next_u64() % inner.len() as u64) as usize];
    }
    v
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn split_then_merge_restores_the_parent_exactly(seed in any::<u64>(), depth in 0u64..8, bond in any::<bool>()) {
        let (_, h) = small_head(300, seed % 5);
        let mut rng = test_heads::SplitMix64::new(seed);
        let mut front = Front::coarsest(&h);
        let mut state = LodState::new(&h);
        let v = walk_down(&h, &mut front, &mut state, &mut rng, depth);
        // Only a tree of one node ends the walk on a leaf.
        prop_assume!(!h.is_leaf(v) && front.is_active(v));
        fill_random(&h, &mut state, v, &mut rng);
        if bond {
            let other = h.tree_root((h.tree_of(v) + 1) % h.tree_count() as u32);
            if front.is_active(other) && other != v {
                add_bond(&h, &front, &mut state, LodBond { a: BondEnd { node: v, point: 3 }, b: BondEnd { node: other, point: 2 }, rest: 0.01, stiffness: 5.0, break_distance: 0.05 }).unwrap();
            }
        }
        let before = node_bits(&h, &state, v);
        let bonds = state.bonds.clone();
        let water = state.total_water(&h, &front);
        split(&h, &mut front, &mut state, v).unwrap();
        for c in h.children(v) {
            prop_assert!(front.is_active(c));
        }
        let check = merge_check(&h, &front, &state, v, &MergeParams::default()).unwrap();
        prop_assert_eq!(check, MergeCheck::Ready { gap: 0.0 });
        merge(&h, &mut front, &mut state, v).unwrap();
        prop_assert_eq!(node_bits(&h, &state, v), before);
        prop_assert_eq!(&state.bonds, &bonds);
        prop_assert_eq!(state.total_water(&h, &front), water);
    }

    #[test]
    fn water_is_conserved_by_any_splits_and_merges(seed in any::<u64>(), ops in prop::collection::vec(any::<u64>(), 1..60)) {
        let (_, h) = small_head(250, seed % 3);
        let mut rng = test_heads::SplitMix64::new(seed);
        let mut front = Front::coarsest(&h);
        let mut state = LodState::new(&h);
        for t in 0..h.tree_count() as u32 {
            fill_random(&h, &mut state, h.tree_root(t), &mut rng);
        }
        let mut water = state.total_water(&h, &front);
        for op in ops {
            let active: Vec<u32> = front.active_nodes().collect();
            let v = active[(op % active.len() as u64) as usize];
            if op % 3 != 0 && !h.is_leaf(v) {
                split(&h, &mut front, &mut state, v).unwrap();
                // Wet one child more, as a tool would, and account for the water added.
                let kid = h.children(v).start;
                let add = (op >> 32) as f32 / u32::MAX as f32;
                state.wetness[h.control_point_start(kid) + 1] += add;
                water += f64::from(h.strand_count(kid)) * f64::from(add);
            } else if let Some(p) = h.parent(v)
                && h.children(p).all(|c| front.is_active(c))
            {
                merge(&h, &mut front, &mut state, p).unwrap();
            }
            front.active_of_strands(&h).unwrap();
            let mean = water / h.strand_total() as f64;
            let now = state.total_water(&h, &front) / h.strand_total() as f64;
            prop_assert!((now - mean).abs() <= 1e-5 * mean.abs().max(1e-3), "mean wetness {} -> {}", mean, now);
        }
    }

    #[test]
    fn water_is_conserved_when_children_differ(seed in any::<u64>()) {
        let (_, h) = small_head(250, seed % 3);
        let mut rng = test_heads::SplitMix64::new(seed);
        // A parent whose children stand for different numbers of strands.
        let uneven: Vec<u32> = (0..h.node_count() as u32)
            .filter(|&v| {
                let k = h.children(v);
                k.len() >= 2 && k.clone().any(|c| h.strand_count(c) != h.strand_count(k.start))
            })
            .collect();
        prop_assume!(!uneven.is_empty());
        let p = uneven[(rng.next_u64() % uneven.len() as u64) as usize];
        let mut front = Front::coarsest(&h);
        let mut state = LodState::new(&h);
        split_down_to(&h, &mut front, &mut state, p);
        split(&h, &mut front, &mut state, p).unwrap();
        for c in h.children(p) {
            fill_random(&h, &mut state, c, &mut rng);
        }
        let water = state.total_water(&h, &front);
        merge(&h, &mut front, &mut state, p).unwrap();
        let after = state.total_water(&h, &front);
        prop_assert!((after - water).abs() <= 1e-5 * water.abs().max(1e-3), "{} -> {}", water, after);
    }
}

#[test]
fn a_cut_passes_to_every_child_and_uneven_cuts_never_merge() {
    let (_, h) = small_head(300, 1);
    let mut front = Front::coarsest(&h);
    let mut state = LodState::new(&h);
    let root = h.tree_root(0);
    let other = h.tree_root(1);
    add_bond(
        &h,
        &front,
        &mut state,
        LodBond {
            a: BondEnd {
                node: root,
                point: 5,
            },
            b: BondEnd {
                node: other,
                point: 5,
            },
            rest: 0.0,
            stiffness: 1.0,
            break_distance: 1.0,
        },
    )
    .unwrap();
    add_bond(
        &h,
        &front,
        &mut state,
        LodBond {
            a: BondEnd {
                node: root,
                point: 2,
            },
            b: BondEnd {
                node: other,
                point: 2,
            },
            rest: 0.0,
            stiffness: 1.0,
            break_distance: 1.0,
        },
    )
    .unwrap();
    cut(&h, &front, &mut state, root, 4, 0.5).unwrap();
    assert_eq!(
        state.bonds.len(),
        1,
        "the bond past the cut goes with the cut hair"
    );
    let last = h.control_point_start(root) + 3;
    assert_eq!(state.length[last], 0.5);
    split(&h, &mut front, &mut state, root).unwrap();
    for c in h.children(root) {
        assert_eq!(
            state.count[c as usize], 4,
            "every child loses the same trailing points"
        );
        assert_eq!(state.length[h.control_point_start(c) + 3], 0.5);
    }
    // Cut one child further: the children now differ and never merge.
    let kid = h.children(root).start;
    if h.children(root).len() >= 2 {
        cut(&h, &front, &mut state, kid, 3, 1.0).unwrap();
        assert_eq!(
            merge_check(&h, &front, &state, root, &MergeParams::default()).unwrap(),
            MergeCheck::CountMismatch
        );
        assert!(merge(&h, &mut front, &mut state, root).is_err());
        let plan = Plan {
            merges: vec![root],
            ..Plan::default()
        };
        let report = apply(&h, &mut front, &mut state, &plan, &MergeParams::default()).unwrap();
        assert_eq!(report.refused, 1);
        assert!(!front.is_active(root));
        // Cut the others the same way: then they merge, with the common count.
        for c in h.children(root).skip(1) {
            cut(&h, &front, &mut state, c, 3, 1.0).unwrap();
        }
        merge(&h, &mut front, &mut state, root).unwrap();
        assert_eq!(state.count[root as usize], 3);
    }
    assert!(cut(&h, &front, &mut state, other, 1, 1.0).is_err());
    assert!(cut(&h, &front, &mut state, other, 3, 0.0).is_err());
}

#[test]
fn bonds_pass_to_every_child_and_back_to_the_parent() {
    let (_, h) = small_head(300, 2);
    let mut front = Front::coarsest(&h);
    let mut state = LodState::new(&h);
    // Two trees whose roots split in two or more (not every tree's does: a few strands split
    // off by direction at the top of the head make a tree of their own).
    let mut splitting = (0..h.tree_count() as u32)
        .map(|t| h.tree_root(t))
        .filter(|&r| h.children(r).len() >= 2);
    let (p, q) = (splitting.next().unwrap(), splitting.next().unwrap());
    let bond = LodBond {
        a: BondEnd { node: p, point: 4 },
        b: BondEnd { node: q, point: 3 },
        rest: 0.01,
        stiffness: 2.0,
        break_distance: 0.03,
    };
    add_bond(&h, &front, &mut state, bond).unwrap();
    split(&h, &mut front, &mut state, p).unwrap();
    let kids: Vec<u32> = h.children(p).collect();
    assert_eq!(state.bonds.len(), kids.len());
    for (b, c) in state.bonds.iter().zip(&kids) {
        assert_eq!(b.a, BondEnd { node: *c, point: 4 });
        assert_eq!(b.b, bond.b);
    }
    split(&h, &mut front, &mut state, q).unwrap();
    assert_eq!(
        state.bonds.len(),
        kids.len() * h.children(q).len(),
        "both ends split: every pair"
    );
    merge(&h, &mut front, &mut state, q).unwrap();
    merge(&h, &mut front, &mut state, p).unwrap();
    assert_eq!(state.bonds, vec![bond]);
    // Bonds made between siblings: at the same point they vanish into the parent, at different
    // points they stay as one bond on it.
    split(&h, &mut front, &mut state, p).unwrap();
    let kids: Vec<u32> = h.children(p).collect();
    if kids.len() >= 2 {
        add_bond(
            &h,
            &front,
            &mut state,
            LodBond {
                a: BondEnd {
                    node: kids[0],
                    point: 2,
                },
                b: BondEnd {
                    node: kids[1],
                    point: 2,
                },
                ..bond
            },
        )
        .unwrap();
        add_bond(
            &h,
            &front,
            &mut state,
            LodBond {
                a: BondEnd {
                    node: kids[0],
                    point: 1,
                },
                b: BondEnd {
                    node: kids[1],
                    point: 3,
                },
                ..bond
            },
        )
        .unwrap();
        merge(&h, &mut front, &mut state, p).unwrap();
        assert!(state.bonds.contains(&LodBond {
            a: BondEnd { node: p, point: 1 },
            b: BondEnd { node: p, point: 3 },
            ..bond
        }));
        assert_eq!(state.bonds.len(), 2);
    }
    // Bonds only join active nodes.
    let inactive = h.children(p).start;
    assert!(
        add_bond(
            &h,
            &front,
            &mut state,
            LodBond {
                a: BondEnd {
                    node: inactive,
                    point: 1
                },
                ..bond
            }
        )
        .is_err()
    );
}

#[test]
fn far_children_wait_near_ones_are_pulled_in_then_merge() {
    let (_, h) = small_head(300, 3);
    let mut front = Front::coarsest(&h);
    let mut state = LodState::new(&h);
    let p = (0..h.tree_count() as u32)
        .map(|t| h.tree_root(t))
        .find(|&r| h.children(r).len() == 2)
        .unwrap();
    split(&h, &mut front, &mut state, p).unwrap();
    let kids: Vec<u32> = h.children(p).collect();
    let params = MergeParams::default();
    // Far apart: one child bent by a radian.
    let s = h.control_point_start(kids[0]);
    state.d_theta[s + 1] = 1.0;
    assert!(matches!(
        try_merge(&h, &mut front, &mut state, p, &params).unwrap(),
        MergeCheck::TooFar { .. }
    ));
    assert!(!front.is_active(p));
    // Close: a few hundredths of a radian. The spring pulls it in over a few steps.
    state.d_theta[s + 1] = 0.03;
    let mut steps = 0;
    let mut last_gap = f32::INFINITY;
    loop {
        match try_merge(&h, &mut front, &mut state, p, &params).unwrap() {
            MergeCheck::Pull { gap } => {
                assert!(gap < last_gap);
                last_gap = gap;
            }
            MergeCheck::Ready { .. } => break,
            other => panic!("{other:?}"),
        }
        steps += 1;
        assert!(steps < 20);
    }
    assert!(steps >= 1, "pulled before merging");
    assert!(front.is_active(p));
}

#[test]
fn motion_crosses_to_hair_dynamics_and_back() {
    let (_, h) = small_head(200, 4);
    let mut state = LodState::new(&h);
    let v = h.children(h.tree_root(0)).start;
    let s = h.control_point_start(v);
    state.d_theta[s + 2] = 0.1;
    state.d_phi[s + 3] = -0.2;
    state.omega_phi[s + 1] = 0.7;
    let mut strands = StrandState::new();
    let id = strands
        .add_skeleton(&h.skeleton_desc(v, Material::default()))
        .unwrap();
    // At rest the skeleton sits on the node's rest points.
    for (a, b) in strands.positions()[strands.nodes(id)]
        .iter()
        .zip(h.rest_points(v))
    {
        assert!((a - b).norm() < 1e-5);
    }
    state.write_motion(&h, v, &mut strands, id).unwrap();
    let mut back = LodState::new(&h);
    back.read_motion(&h, v, &strands, id).unwrap();
    for j in 0..h.control_points(v) {
        assert!((back.d_theta[s + j] - state.d_theta[s + j]).abs() < 1e-6);
        assert!((back.d_phi[s + j] - state.d_phi[s + j]).abs() < 1e-6);
        assert_eq!(back.omega_phi[s + j], state.omega_phi[s + j]);
    }
}

/// A groom made its own rest holds every skeleton at its groomed angles with rest angles bent
/// against gravity, by a different sag on each node. A split writes each child at its own
/// groom plus the parent's motion (none here), not at its rest plus the parent's sag: without
/// `hold_groom` the children would jump by the difference of the sags.
#[test]
fn a_split_keeps_each_childs_groom_when_the_rest_holds_it_up() {
    let (_, h) = small_head(200, 4);
    let mut strands = StrandState::new();
    for v in 0..h.node_count() as u32 {
        strands
            .add_skeleton(&h.skeleton_desc(v, Material::default()))
            .unwrap();
    }
    let groom = strands.theta().to_vec();
    for v in 0..h.node_count() as u32 {
        let nodes = strands.nodes(hair_dynamics::SkeletonId(v));
        for (j, i) in nodes.enumerate() {
            strands.rest_theta_mut()[i] -= 0.01 * (1 + v % 7) as f32 * j as f32;
        }
    }
    let v = (0..h.node_count() as u32)
        .find(|&v| h.children(v).len() > 1)
        .expect("a node with children");
    let (root, kids) = (h.tree_root(h.tree_of(v)), h.children(v));
    let split_from = |held: bool, strands: &mut StrandState| {
        let (mut front, mut lod) = (Front::coarsest(&h), LodState::new(&h));
        if held {
            lod.hold_groom(&h, strands).unwrap();
        }
        let id = hair_dynamics::SkeletonId(root);
        lod.read_motion(&h, root, strands, id).unwrap();
        split_down_to(&h, &mut front, &mut lod, v);
        split(&h, &mut front, &mut lod, v).unwrap();
        let mut worst: f32 = 0.0;
        for c in kids.clone() {
            let id = hair_dynamics::SkeletonId(c);
            lod.write_motion(&h, c, strands, id).unwrap();
            for i in strands.nodes(id) {
                worst = worst.max((strands.theta()[i] - groom[i]).abs());
            }
        }
        worst
    };
    let held = split_from(true, &mut strands.clone());
    let unheld = split_from(false, &mut strands.clone());
    assert!(held < 1e-6, "children off their groom by {held} rad");
    assert!(unheld > 0.01, "without hold_groom only {unheld} rad off");
}

#[test]
fn operations_on_the_wrong_nodes_are_errors() {
    let (_, h) = small_head(200, 5);
    let mut front = Front::coarsest(&h);
    let mut state = LodState::new(&h);
    let leaf = (0..h.node_count() as u32).find(|&v| h.is_leaf(v)).unwrap();
    assert!(split(&h, &mut front, &mut state, leaf).is_err(), "inactive");
    assert!(matches!(
        split(&h, &mut front, &mut state, u32::MAX),
        Err(LodError::UnknownNode { .. })
    ));
    let root = h.tree_root(0);
    assert!(
        merge(&h, &mut front, &mut state, root).is_err(),
        "children not active"
    );
    let other = Hierarchy::build(
        &test_heads::ward_lin_head(50, 1),
        &HierarchyParams::default(),
    )
    .unwrap();
    assert!(matches!(
        split(&other, &mut front, &mut state, 0),
        Err(LodError::Mismatch { .. })
    ));
}
