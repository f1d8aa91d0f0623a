//! Selection and transitions on the Ward & Lin benchmark head (9,350 strands).

use criterion::{Criterion, criterion_group, criterion_main};
use hair_lod::*;
use std::hint::black_box;

struct Setup {
    h: Hierarchy,
    visible: Vec<bool>,
    distance: Vec<f32>,
    speed: Vec<f32>,
    activity: Vec<Activity>,
}

fn setup() -> Setup {
    let style = test_heads::ward_lin_head(9350, 1);
    let h = Hierarchy::build(&style, &HierarchyParams::default()).expect("benchmark head");
    let n = h.node_count();
    let mut rng = test_heads::SplitMix64::new(42);
    let visible = (0..n).map(|_| rng.unit() < 0.9).collect();
    let distance = (0..n).map(|_| (0.3 + 4.0 * rng.unit()) as f32).collect();
    let speed = (0..n).map(|_| (2.0 * rng.unit()) as f32).collect();
    let activity = (0..n)
        .map(|_| match rng.next_u64() % 10 {
            0 => Activity::Tool,
            1..=4 => Activity::Dormant,
            _ => Activity::Moving,
        })
        .collect();
    Setup {
        h,
        visible,
        distance,
        speed,
        activity,
    }
}

fn bench(c: &mut Criterion) {
    let s = setup();
    let h = &s.h;
    let inputs = NodeInputs {
        visible: &s.visible,
        distance: &s.distance,
        speed: &s.speed,
        activity: &s.activity,
    };
    let params = SelectParams::default();
    let mut group = c.benchmark_group("lod_9350");
    group.bench_function("build", |b| {
        let style = test_heads::ward_lin_head(9350, 1);
        b.iter(|| Hierarchy::build(black_box(&style), &HierarchyParams::default()))
    });
    let finest = Front::finest(h);
    let mut plan = Plan::default();
    group.bench_function("select_finest_front", |b| {
        b.iter(|| {
            select_into(
                h,
                black_box(&finest),
                black_box(&inputs),
                &params,
                &mut plan,
            )
        })
    });
    let coarsest = Front::coarsest(h);
    group.bench_function("select_coarsest_front", |b| {
        b.iter(|| {
            select_into(
                h,
                black_box(&coarsest),
                black_box(&inputs),
                &params,
                &mut plan,
            )
        })
    });
    // Transitions: one level down everywhere from the root strips, and back up.
    let near = vec![true; h.node_count()];
    let close = vec![0.3f32; h.node_count()];
    let far = vec![100.0f32; h.node_count()];
    let still = vec![0.0f32; h.node_count()];
    let moving = vec![Activity::Moving; h.node_count()];
    let down = NodeInputs {
        visible: &near,
        distance: &close,
        speed: &still,
        activity: &moving,
    };
    let up = NodeInputs {
        distance: &far,
        ..down
    };
    let mut front = Front::coarsest(h);
    let mut state = LodState::new(h);
    let split_plan = select(h, &front, &down, &params).expect("plan");
    apply(
        h,
        &mut front,
        &mut state,
        &split_plan,
        &MergeParams::default(),
    )
    .expect("split");
    let merge_plan = select(h, &front, &up, &params).expect("plan");
    group.bench_function("split_and_merge_all_root_strips", |b| {
        b.iter(|| {
            let mut f = Front::coarsest(h);
            apply(
                h,
                &mut f,
                &mut state,
                black_box(&split_plan),
                &MergeParams::default(),
            )
            .expect("split");
            apply(
                h,
                &mut f,
                &mut state,
                black_box(&merge_plan),
                &MergeParams::default(),
            )
            .expect("merge");
            f
        })
    });
    // Deepest transitions: the finest front merging one level, and the collapse on occlusion.
    let fine = Front::finest(h);
    let mut fine_state = LodState::new(h);
    let fine_merge = select(h, &fine, &up, &params).expect("plan");
    group.bench_function("merge_one_level_from_finest", |b| {
        b.iter(|| {
            let mut f = fine.clone();
            apply(
                h,
                &mut f,
                &mut fine_state,
                black_box(&fine_merge),
                &MergeParams::default(),
            )
            .expect("merge");
            f
        })
    });
    let hidden = vec![false; h.node_count()];
    let occluded = NodeInputs {
        visible: &hidden,
        ..down
    };
    let collapse = select(h, &fine, &occluded, &params).expect("plan");
    group.bench_function("collapse_all_from_finest", |b| {
        b.iter(|| {
            let mut f = fine.clone();
            apply(
                h,
                &mut f,
                &mut fine_state,
                black_box(&collapse),
                &MergeParams::default(),
            )
            .expect("collapse");
            f
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
