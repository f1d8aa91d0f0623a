//! Selection: the per-level rule, purity, one level per step, occlusion jumps, and the
//! partition of strands among active nodes.

mod common;

use common::*;
use hair_lod::*;
use proptest::prelude::*;

#[test]
fn desired_level_follows_distance_speed_and_activity() {
    let p = SelectParams::default();
    let m = 9;
    assert_eq!(p.desired_level(m, 100.0, 0.0, Activity::Moving), 0);
    assert_eq!(p.desired_level(m, 0.0, 0.0, Activity::Moving), m);
    assert_eq!(p.desired_level(m, 100.0, 100.0, Activity::Moving), m);
    assert_eq!(
        p.desired_level(m, 100.0, 100.0, Activity::Dormant),
        0,
        "dormant hair asks nothing by speed"
    );
    assert_eq!(p.desired_level(m, 100.0, 0.0, Activity::Tool), m);
    // Linear interpolation: halfway in distance is halfway down.
    let mid = 0.5 * (p.distance_finest + p.distance_coarsest);
    assert_eq!(p.desired_level(8, mid, 0.0, Activity::Moving), 4);
    // The stricter wins.
    let far_fast = p.desired_level(m, 3.0, 1.0, Activity::Moving);
    assert_eq!(
        far_fast,
        p.desired_level(m, 3.0, 0.0, Activity::Moving)
            .max(p.desired_level(m, 100.0, 1.0, Activity::Moving))
    );
    let mut last = m;
    for k in 0..50 {
        let l = p.desired_level(m, k as f32 * 0.1, 0.0, Activity::Moving);
        assert!(l <= last, "farther never asks for more detail");
        last = l;
    }
}

#[test]
fn bad_selection_inputs_are_errors() {
    let (_, h) = small_head(200, 1);
    let front = Front::coarsest(&h);
    let inputs = Inputs::uniform(&h, true, 1.0, 0.0);
    let p = SelectParams {
        distance_finest: 5.0,
        ..Default::default()
    };
    assert!(matches!(
        select(&h, &front, &inputs.view(), &p),
        Err(LodError::ThresholdOrder {
            lower: "distance_finest",
            ..
        })
    ));
    let p = SelectParams {
        speed_finest: 0.0,
        ..Default::default()
    };
    assert!(matches!(
        select(&h, &front, &inputs.view(), &p),
        Err(LodError::ThresholdOrder {
            lower: "speed_coarsest",
            ..
        })
    ));
    let short = vec![true; 3];
    let bad = NodeInputs {
        visible: &short,
        ..inputs.view()
    };
    assert!(matches!(
        select(&h, &front, &bad, &SelectParams::default()),
        Err(LodError::InputLength {
            name: "visible",
            ..
        })
    ));
}

#[test]
fn a_parent_merges_only_when_every_child_asks() {
    let (_, h) = small_head(300, 2);
    let mut front = Front::finest(&h);
    let mut state = LodState::new(&h);
    let mut inputs = Inputs::uniform(&h, true, 100.0, 0.0);
    // Pick a parent with several children; keep one child close to the viewer.
    let parent = (0..h.node_count() as u32)
        .find(|&v| h.children(v).len() >= 2 && h.children(v).all(|c| h.is_leaf(c)))
        .unwrap();
    let kid = h.children(parent).start;
    inputs.distance[kid as usize] = 0.0;
    let plan = select(&h, &front, &inputs.view(), &SelectParams::default()).unwrap();
    assert!(!plan.merges.contains(&parent));
    inputs.distance[kid as usize] = 100.0;
    let plan = select(&h, &front, &inputs.view(), &SelectParams::default()).unwrap();
    assert!(plan.merges.contains(&parent));
    apply(&h, &mut front, &mut state, &plan, &MergeParams::default()).unwrap();
    assert!(front.is_active(parent));
}

/// Hysteresis: children whose inputs ask for a level less than `MERGE_MARGIN` below their own
/// do not merge (their parent would split again at once); half a level further they do. The
/// split side has no band: a node splits as soon as its inputs ask for more.
#[test]
fn children_merge_only_when_clearly_below_their_level() {
    let (_, h) = small_head(300, 2);
    let front = Front::finest(&h);
    let p = SelectParams::default();
    let m = f32::from(h.max_level());
    let parent = (0..h.node_count() as u32)
        .find(|&v| h.children(v).len() >= 2 && h.children(v).all(|c| h.is_leaf(c)))
        .unwrap();
    let level = f32::from(h.level(h.children(parent).start));
    // The distance at which the selection's level variable is `x` levels.
    let at = |x: f32| p.distance_coarsest - (p.distance_coarsest - p.distance_finest) * x / m;
    for (x, merges) in [(level - 0.3, false), (level - 0.7, true)] {
        let mut inputs = Inputs::uniform(&h, true, 100.0, 0.0);
        for c in h.children(parent) {
            inputs.distance[c as usize] = at(x);
        }
        assert!(
            p.desired_level(h.max_level(), at(x), 0.0, Activity::Moving)
                < h.level(h.children(parent).start)
        );
        let plan = select(&h, &front, &inputs.view(), &p).unwrap();
        assert_eq!(
            plan.merges.contains(&parent),
            merges,
            "children at {x} levels"
        );
    }
    // A node splits as soon as its inputs ask for the next level.
    let coarse = Front::coarsest(&h);
    let root = h.tree_root(0);
    let mut inputs = Inputs::uniform(&h, true, 100.0, 0.0);
    inputs.distance[root as usize] = at(f32::from(h.level(root)) + 1.1);
    let plan = select(&h, &coarse, &inputs.view(), &p).unwrap();
    assert!(plan.splits.contains(&root));
}

#[test]
fn occlusion_jumps_to_the_root_strip_and_back() {
    let (_, h) = small_head(600, 4);
    let mut front = Front::finest(&h);
    let mut state = LodState::new(&h);
    let params = SelectParams::default();
    let hidden = Inputs::uniform(&h, false, 0.3, 0.0);
    let plan = select(&h, &front, &hidden.view(), &params).unwrap();
    assert_eq!(plan.collapses.len(), h.tree_count());
    apply(&h, &mut front, &mut state, &plan, &MergeParams::default()).unwrap();
    assert_eq!(front.active_count(), h.tree_count());
    assert!(front.active_nodes().all(|v| h.parent(v).is_none()));
    assert!((0..h.tree_count() as u32).all(|t| front.is_hidden(t)));
    for v in front.active_nodes() {
        assert!(
            !rendered(&h, &front, &hidden.view(), v),
            "hidden hair is not drawn"
        );
    }
    // Visible again and close: straight back to the finest level in one step.
    let close = Inputs::uniform(&h, true, 0.3, 0.0);
    let plan = select(&h, &front, &close.view(), &params).unwrap();
    assert_eq!(plan.restores.len(), h.tree_count());
    apply(&h, &mut front, &mut state, &plan, &MergeParams::default()).unwrap();
    assert_eq!(front, Front::finest(&h));
    // A moderately far viewer: back to the level the distance asks for.
    let mut front = Front::coarsest(&h);
    let plan = select(&h, &front, &hidden.view(), &params).unwrap();
    apply(&h, &mut front, &mut state, &plan, &MergeParams::default()).unwrap();
    let mid = Inputs::uniform(&h, true, 2.0, 0.0);
    let plan = select(&h, &front, &mid.view(), &params).unwrap();
    apply(&h, &mut front, &mut state, &plan, &MergeParams::default()).unwrap();
    let want = params.desired_level(h.max_level(), 2.0, 0.0, Activity::Moving);
    for v in front.active_nodes() {
        assert!(
            h.level(v) == want || h.is_leaf(v) && h.level(v) < want,
            "node {v} at {} wants {want}",
            h.level(v)
        );
    }
}

#[test]
fn selection_is_pure() {
    let (_, h) = small_head(400, 5);
    let front = Front::finest(&h);
    let inputs = Inputs::uniform(&h, true, 1.7, 0.4);
    let a = select(&h, &front, &inputs.view(), &SelectParams::default()).unwrap();
    let b = select(&h, &front, &inputs.view(), &SelectParams::default()).unwrap();
    assert_eq!(a, b);
}

/// One step of random inputs: per tree visibility, per node distance and speed, some tools.
fn step_inputs() -> impl Strategy<Value = (u64, f32, f32, f32)> {
    (any::<u64>(), 0.1f32..0.9, 0.0f32..5.0, 0.0f32..2.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    #[test]
    fn one_level_per_step_except_by_occlusion(seed in any::<u64>(), steps in prop::collection::vec(step_inputs(), 1..25)) {
        let (_, h) = small_head(350, seed % 7);
        let mut front = Front::coarsest(&h);
        let mut state = LodState::new(&h);
        let params = SelectParams::default();
        for (s, p_visible, base_distance, base_speed) in steps {
            let mut rng = test_heads::SplitMix64::new(s);
            let mut inputs = Inputs::uniform(&h, true, base_distance, base_speed);
            for t in 0..h.tree_count() as u32 {
                let vis = rng.unit() < f64::from(p_visible);
                for v in h.tree_nodes(t) {
                    inputs.visible[v as usize] = vis && rng.unit() < 0.95;
                    inputs.distance[v as usize] = base_distance * (0.5 + rng.unit() as f32);
                    inputs.speed[v as usize] = base_speed * rng.unit() as f32;
                    inputs.activity[v as usize] = match rng.next_u64() % 20 { 0 => Activity::Tool, 1..=5 => Activity::Dormant, _ => Activity::Moving };
                }
                inputs.visible[h.tree_root(t) as usize] = vis;
            }
            let before = strand_levels(&h, &front);
            let was_hidden: Vec<bool> = (0..h.tree_count() as u32).map(|t| front.is_hidden(t)).collect();
            let plan = select(&h, &front, &inputs.view(), &params).unwrap();
            apply(&h, &mut front, &mut state, &plan, &MergeParams::default()).unwrap();
            let after = strand_levels(&h, &front);
            let leaf = h.leaf_of_strands();
            for (s, (&b, &a)) in before.iter().zip(&after).enumerate() {
                let t = h.tree_of(leaf[s]);
                let occluded = !inputs.visible[h.tree_root(t) as usize];
                if occluded {
                    prop_assert_eq!(a, 0, "an occluded tree sits at its root strip");
                } else if !was_hidden[t as usize] {
                    prop_assert!(a.abs_diff(b) <= 1, "strand {} moved from level {} to {}", s, b, a);
                }
            }
        }
    }
}
