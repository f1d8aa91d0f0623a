//! `inherit_edits`: against a brute-force recursive oracle on random hierarchies, layouts, cut
//! lengths and touched sets; the water it leaves on any front; the denominator with cut
//! children; errors that write nothing; and no new memory once its scratch has grown.

mod common;

use common::small_head;
use core::ops::Range;
use hair_lod::test_heads::SplitMix64;
use hair_lod::*;
use proptest::prelude::*;

/// A hierarchy with per-node ranges into a few fields, and fields full of values.
struct Case {
    h: Hierarchy,
    ranges: Vec<Range<usize>>,
    fields: Vec<Vec<Real>>,
}

impl Case {
    /// Random layout: nodes placed in a shuffled order with gaps between them, each cut to a
    /// random count with probability `cut` (0 included: a node may have no points left). With
    /// `monotone`, a child is never longer than its parent (a cut passes down, as in the salon).
    fn new(strands: usize, seed: u64, fields: usize, cut: f64, monotone: bool) -> Self {
        let (_, h) = small_head(strands, seed % 7);
        let mut rng = SplitMix64::new(seed);
        let n = h.node_count();
        let mut len = vec![0usize; n];
        for v in 0..n as u32 {
            // Parents come before children (breadth-first numbering).
            let full = match h.parent(v) {
                Some(p) if monotone => len[p as usize],
                _ => h.control_points(v),
            };
            len[v as usize] = if rng.unit() < cut {
                (rng.next_u64() % (full as u64 + 1)) as usize
            } else {
                full
            };
        }
        let mut order: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            order.swap(i, (rng.next_u64() % (i as u64 + 1)) as usize);
        }
        let mut ranges = vec![0..0; n];
        let mut end = 0;
        for v in order {
            let start = end + (rng.next_u64() % 3) as usize;
            end = start + len[v as usize];
            ranges[v as usize] = start..end;
        }
        let fields = (0..fields)
            .map(|_| (0..end + 2).map(|_| value(&mut rng)).collect())
            .collect();
        Case { h, ranges, fields }
    }

    /// Calls `inherit_edits` on the case's layout and fields.
    fn inherit(
        &mut self,
        touched: &[u32],
        scratch: &mut InheritScratch,
        changed: &mut Vec<u32>,
    ) -> Result<(), LodError> {
        let ranges = &self.ranges;
        let mut fields: Vec<&mut [Real]> = self.fields.iter_mut().map(|f| &mut f[..]).collect();
        inherit_edits(
            &self.h,
            touched,
            |n| ranges[n as usize].clone(),
            &mut fields,
            scratch,
            changed,
        )
    }

    /// Water of a field over some nodes: strands times the sum of their points' values (f64).
    fn water(&self, field: &[Real], nodes: &[u32]) -> f64 {
        nodes
            .iter()
            .map(|&v| {
                let sum: f64 = field[self.ranges[v as usize].clone()]
                    .iter()
                    .map(|&x| f64::from(x))
                    .sum();
                f64::from(self.h.strand_count(v)) * sum
            })
            .sum()
    }
}

/// A value in [0, 2), a quarter of the time from a few exact ones, so that siblings often agree.
fn value(rng: &mut SplitMix64) -> Real {
    if rng.next_u64().is_multiple_of(4) {
        [0.0, 0.5, 1.0][(rng.next_u64() % 3) as usize]
    } else {
        (2.0 * rng.unit()) as Real
    }
}

/// `count` random nodes, repeats and nodes under one another allowed.
fn any_nodes(h: &Hierarchy, rng: &mut SplitMix64, count: usize) -> Vec<u32> {
    (0..count)
        .map(|_| (rng.next_u64() % h.node_count() as u64) as u32)
        .collect()
}

/// A random front: from each root strip, stop at a node or go on into all its children.
fn random_front(h: &Hierarchy, rng: &mut SplitMix64, stop: f64) -> Vec<u32> {
    let mut out = Vec::new();
    let mut stack: Vec<u32> = (0..h.tree_count() as u32).map(|t| h.tree_root(t)).collect();
    while let Some(v) = stack.pop() {
        if h.is_leaf(v) || rng.unit() < stop {
            out.push(v);
        } else {
            stack.extend(h.children(v));
        }
    }
    out
}

/// The rule written the obvious way: down the trees, a node at or under a touched node takes
/// the shallowest one's values (first `min` points); back up, a node whose subtree holds an
/// edit takes its children's strand-weighted mean (over all the children's strands, a child
/// without the point adding nothing; f64 sums in child order, as the rule states, so results
/// compare bit for bit). Returns the nodes changed, ascending.
fn oracle(case: &mut Case, touched: &[u32]) -> Vec<u32> {
    fn settle(
        case: &mut Case,
        touched: &[u32],
        v: u32,
        source: Option<u32>,
        changed: &mut Vec<u32>,
    ) -> bool {
        let source = source.or(touched.contains(&v).then_some(v));
        let kids = case.h.children(v);
        if let Some(s) = source {
            let (from, to) = (
                case.ranges[s as usize].clone(),
                case.ranges[v as usize].clone(),
            );
            for f in &mut case.fields {
                for j in 0..from.len().min(to.len()) {
                    f[to.start + j] = f[from.start + j];
                }
            }
            changed.push(v);
            for c in kids {
                settle(case, touched, c, Some(s), changed);
            }
            return true;
        }
        let mut edited = false;
        for c in kids.clone() {
            edited |= settle(case, touched, c, None, changed);
        }
        if edited {
            let to = case.ranges[v as usize].clone();
            for f in 0..case.fields.len() {
                for j in 0..to.len() {
                    let (mut sum, mut strands) = (0.0f64, 0.0f64);
                    for c in kids.clone() {
                        let m = f64::from(case.h.strand_count(c));
                        strands += m;
                        let r = &case.ranges[c as usize];
                        if j < r.len() {
                            sum += m * f64::from(case.fields[f][r.start + j]);
                        }
                    }
                    case.fields[f][to.start + j] = (sum / strands) as Real;
                }
            }
            changed.push(v);
        }
        edited
    }
    let mut changed = Vec::new();
    for t in 0..case.h.tree_count() as u32 {
        let root = case.h.tree_root(t);
        settle(case, touched, root, None, &mut changed);
    }
    changed.sort_unstable();
    changed
}

/// Water a node holds after the edit by the copy rule, from the values before it: at or under
/// a touched node (the touched nodes are not under one another), the touched node's values over
/// the points both have (its own past them); above one, the sum of its children's (the mean
/// conserves it when no child is longer); else its own.
fn implied_water(case: &Case, before: &[Real], touched: &[u32], v: u32) -> f64 {
    let h = &case.h;
    let own = case.ranges[v as usize].clone();
    let strands = f64::from(h.strand_count(v));
    if let Some(&s) = touched.iter().find(|&&t| is_under_or_at(h, v, t)) {
        let from = case.ranges[s as usize].clone();
        let sum: f64 = (0..own.len())
            .map(|j| {
                f64::from(if j < from.len() {
                    before[from.start + j]
                } else {
                    before[own.start + j]
                })
            })
            .sum();
        return strands * sum;
    }
    if touched.iter().any(|&t| is_under_or_at(h, t, v)) {
        h.children(v)
            .map(|c| implied_water(case, before, touched, c))
            .sum()
    } else {
        strands * before[own].iter().map(|&x| f64::from(x)).sum::<f64>()
    }
}

fn is_under_or_at(h: &Hierarchy, node: u32, top: u32) -> bool {
    let mut cur = Some(node);
    while let Some(c) = cur {
        if c == top {
            return true;
        }
        cur = h.parent(c);
    }
    false
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn inherit_edits_matches_the_recursive_oracle(
        seed in any::<u64>(),
        strands in 20usize..300,
        fields in 1usize..4,
        cut in prop::sample::select(vec![0.0, 0.3, 1.0]),
        monotone in any::<bool>(),
        touched_count in 0usize..12,
    ) {
        let mut case = Case::new(strands, seed, fields, cut, monotone);
        let mut rng = SplitMix64::new(seed ^ 0x5eed);
        let touched = any_nodes(&case.h, &mut rng, touched_count);
        let mut want = Case { h: case.h.clone(), ranges: case.ranges.clone(), fields: case.fields.clone() };
        let want_changed = oracle(&mut want, &touched);
        let (mut scratch, mut changed) = (InheritScratch::default(), Vec::new());
        case.inherit(&touched, &mut scratch, &mut changed).unwrap();
        for (got, want) in case.fields.iter().zip(&want.fields) {
            let got: Vec<u32> = got.iter().map(|x| x.to_bits()).collect();
            let want: Vec<u32> = want.iter().map(|x| x.to_bits()).collect();
            prop_assert_eq!(got, want);
        }
        let mut sorted = changed.clone();
        sorted.sort_unstable();
        sorted.dedup();
        prop_assert_eq!(sorted.len(), changed.len(), "each changed node once");
        prop_assert_eq!(sorted, want_changed);
    }

    #[test]
    fn water_on_any_front_is_what_the_copy_rule_implies(
        seed in any::<u64>(),
        strands in 20usize..300,
        cut in prop::sample::select(vec![0.0, 0.3]),
        stop in 0.0f64..1.0,
    ) {
        let mut case = Case::new(strands, seed, 1, cut, true);
        // Before the edit every level agrees: each parent the mean of its children.
        let leaves: Vec<u32> = (0..case.h.node_count() as u32).filter(|&v| case.h.is_leaf(v)).collect();
        oracle(&mut case, &leaves);
        let mut rng = SplitMix64::new(seed ^ 0x3a7e);
        // Tools touch part of the front being simulated.
        let touched: Vec<u32> = random_front(&case.h, &mut rng, stop)
            .into_iter()
            .filter(|_| rng.unit() < 0.5)
            .collect();
        let before = case.fields[0].clone();
        let (mut scratch, mut changed) = (InheritScratch::default(), Vec::new());
        case.inherit(&touched, &mut scratch, &mut changed).unwrap();
        for _ in 0..4 {
            let stop = rng.unit();
            let front = random_front(&case.h, &mut rng, stop);
            let got = case.water(&case.fields[0], &front);
            let want: f64 = front.iter().map(|&v| implied_water(&case, &before, &touched, v)).sum();
            prop_assert!((got - want).abs() <= 1e-5 * want.abs().max(1.0), "water {} on the front, {} implied", got, want);
        }
    }

    #[test]
    fn a_second_call_takes_no_new_memory(
        seed in any::<u64>(),
        strands in 20usize..300,
        touched_count in 1usize..12,
    ) {
        let mut case = Case::new(strands, seed, 3, 0.3, false);
        let mut rng = SplitMix64::new(seed ^ 0xa110c);
        let touched = any_nodes(&case.h, &mut rng, touched_count);
        let (mut scratch, mut changed) = (InheritScratch::default(), Vec::new());
        case.inherit(&touched, &mut scratch, &mut changed).unwrap();
        let (bytes, room) = (scratch.memory_bytes(), changed.capacity());
        prop_assert!(bytes > 0);
        case.inherit(&touched, &mut scratch, &mut changed).unwrap();
        prop_assert_eq!(scratch.memory_bytes(), bytes);
        prop_assert_eq!(changed.capacity(), room);
        // A smaller edit needs no more room either.
        case.inherit(&touched[..1], &mut scratch, &mut changed).unwrap();
        prop_assert_eq!(scratch.memory_bytes(), bytes);
        prop_assert_eq!(changed.capacity(), room);
    }
}

/// The denominator with cut children: all the children's strands, a child without the point
/// adding nothing; a point no child has left becomes 0.
#[test]
fn a_cut_child_adds_nothing_to_its_parents_mean() {
    let (_, h) = small_head(300, 2);
    let p = (0..h.node_count() as u32)
        .find(|&v| h.children(v).len() >= 2 && h.parent(v).is_some())
        .expect("a parent of two children");
    let mut state = LodState::new(&h);
    let kids: Vec<u32> = h.children(p).collect();
    // Every child wet at 1 and stiff at 2; the first child cut to two points.
    let cut_to = 2;
    let mut ranges: Vec<Range<usize>> = (0..h.node_count() as u32)
        .map(|v| h.control_point_range(v))
        .collect();
    ranges[kids[0] as usize].end = ranges[kids[0] as usize].start + cut_to;
    for &c in &kids {
        state.wetness[ranges[c as usize].clone()].fill(1.0);
        state.stiffness[ranges[c as usize].clone()].fill(2.0);
    }
    let (mut scratch, mut changed) = (InheritScratch::default(), Vec::new());
    inherit_edits(
        &h,
        &kids,
        |n| ranges[n as usize].clone(),
        &mut [&mut state.wetness, &mut state.stiffness],
        &mut scratch,
        &mut changed,
    )
    .unwrap();
    let all: f64 = kids.iter().map(|&c| f64::from(h.strand_count(c))).sum();
    let reach = (all - f64::from(h.strand_count(kids[0]))) / all;
    let s = h.control_point_start(p);
    for j in 0..h.control_points(p) {
        let share = if j < cut_to { 1.0 } else { reach };
        assert_eq!(state.wetness[s + j], share as Real, "point {j}");
        assert_eq!(state.stiffness[s + j], (2.0 * share) as Real, "point {j}");
    }
    // Every child cut: past the cut no hair is left under the parent.
    for &c in &kids {
        ranges[c as usize].end = ranges[c as usize].start + cut_to;
    }
    inherit_edits(
        &h,
        &kids,
        |n| ranges[n as usize].clone(),
        &mut [&mut state.wetness],
        &mut scratch,
        &mut changed,
    )
    .unwrap();
    assert_eq!(state.wetness[s + cut_to], 0.0);
    assert_eq!(state.wetness[s + cut_to - 1], 1.0);
    // The parent's own parent changed too, and is listed after its child.
    let grand = h.parent(p).unwrap();
    let at = |v: u32| changed.iter().position(|&x| x == v).unwrap();
    assert!(at(p) < at(grand), "ancestors deepest first");
}

#[test]
fn a_shallower_touched_node_wins_whatever_the_order() {
    let (_, h) = small_head(300, 4);
    let root = h.tree_root(0);
    let kid = h.children(root).start;
    let mut a = LodState::new(&h);
    a.wetness[h.control_point_range(root)].fill(0.25);
    a.wetness[h.control_point_range(kid)].fill(0.75);
    let mut b = a.clone();
    let mut scratch = InheritScratch::default();
    let (mut ca, mut cb) = (Vec::new(), Vec::new());
    let full = |n| h.control_point_range(n);
    inherit_edits(
        &h,
        &[root, kid],
        full,
        &mut [&mut a.wetness],
        &mut scratch,
        &mut ca,
    )
    .unwrap();
    inherit_edits(
        &h,
        &[kid, root, kid],
        full,
        &mut [&mut b.wetness],
        &mut scratch,
        &mut cb,
    )
    .unwrap();
    assert_eq!(a.wetness, b.wetness);
    assert_eq!(ca, cb);
    assert!(
        a.wetness[h.control_point_range(kid)]
            .iter()
            .all(|&w| w == 0.25)
    );
    assert_eq!(ca.len(), h.tree_nodes(0).len(), "the whole tree, once each");
}

#[test]
fn bad_input_is_an_error_and_writes_nothing() {
    let (_, h) = small_head(200, 5);
    let mut state = LodState::new(&h);
    let leaf = (0..h.node_count() as u32)
        .rev()
        .find(|&v| h.is_leaf(v) && h.parent(v).is_some())
        .unwrap();
    state.wetness[h.control_point_range(leaf)].fill(1.0);
    let before = state.wetness.clone();
    let mut scratch = InheritScratch::default();
    let mut changed = vec![7];
    let full = |n| h.control_point_range(n);
    assert!(matches!(
        inherit_edits(
            &h,
            &[leaf, u32::MAX],
            full,
            &mut [&mut state.wetness],
            &mut scratch,
            &mut changed
        ),
        Err(LodError::UnknownNode { node: u32::MAX, .. })
    ));
    assert_eq!(state.wetness, before);
    assert!(changed.is_empty());
    // A field too short for the layout: the parent's points lie past its end.
    let short = h.control_point_start(h.parent(leaf).unwrap()) + 1;
    let err = inherit_edits(
        &h,
        &[leaf],
        full,
        &mut [&mut state.wetness[..short]],
        &mut scratch,
        &mut changed,
    );
    assert!(
        matches!(err, Err(LodError::PointsOutOfRange { .. })),
        "{err:?}"
    );
    assert_eq!(state.wetness, before);
    assert!(changed.is_empty());
    // The scratch is clean after an error: the same edit gives what a fresh one does.
    let mut fresh = state.clone();
    inherit_edits(
        &h,
        &[leaf],
        full,
        &mut [&mut state.wetness],
        &mut scratch,
        &mut changed,
    )
    .unwrap();
    let mut other = Vec::new();
    inherit_edits(
        &h,
        &[leaf],
        full,
        &mut [&mut fresh.wetness],
        &mut InheritScratch::default(),
        &mut other,
    )
    .unwrap();
    assert_eq!(state.wetness, fresh.wetness);
    assert_eq!(changed, other);
    assert!(changed.len() > 1);
}
