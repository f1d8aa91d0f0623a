//! Styling properties through the hierarchy: Ward, Galoppo & Lin, Interactive Virtual Hair
//! Salon, §6.6 (hierarchy inheritance).
//!
//! Down (split): every child takes its parent's wetness, stiffness, thickness and length
//! unchanged, its live control-point count (a cut removes the same trailing points from every
//! child), and every bond of the parent. Up (merge): the parent takes the average over its
//! children, weighted by the strands each stands for (the paper's plain mean conserves water
//! only when children are the same size; the weighted one conserves it always), and every bond
//! of a child. Children with different counts do not merge.
//!
//! The one implementation of that rule is [`copy_points`] (down) and [`children_mean`] (up):
//! split and merge use them on [`LodState`]'s layout, and [`inherit_edits`] uses them on any
//! layout, for tools that edit the active nodes and keep every level up to date.

use crate::{BondEnd, Front, Hierarchy, LodBond, LodError, LodState, Real};
use core::ops::Range;

/// Copies a node's values to another over the points both have (the first `min` of the two
/// counts): the downward half of the rule.
pub(crate) fn copy_points(field: &mut [Real], from: Range<usize>, to: Range<usize>) {
    let n = from.len().min(to.len());
    field.copy_within(from.start..from.start + n, to.start);
}

/// The strand-weighted mean of the children's values at point `j` of `parent`: the upward half
/// of the rule. The denominator is all the children's strands, and a child without point `j`
/// (cut shorter) adds nothing to the sum: see [`inherit_edits`] for why. f64 sums in child
/// order, so the mean of identical values is that value exactly. 0 for a node without children.
pub(crate) fn children_mean(
    h: &Hierarchy,
    field: &[Real],
    parent: u32,
    j: usize,
    points: &impl Fn(u32) -> Range<usize>,
) -> Real {
    let (mut sum, mut strands) = (0.0f64, 0.0f64);
    for c in h.children(parent) {
        let m = f64::from(h.strand_count(c));
        strands += m;
        let r = points(c);
        if j < r.len() {
            sum += m * f64::from(field[r.start + j]);
        }
    }
    if strands > 0.0 {
        (sum / strands) as Real
    } else {
        0.0
    }
}

/// Writes into each of the parent's points the strand-weighted mean of its children's.
fn mean_into(
    h: &Hierarchy,
    field: &mut [Real],
    parent: u32,
    points: &impl Fn(u32) -> Range<usize>,
) {
    let r = points(parent);
    for j in 0..r.len() {
        field[r.start + j] = children_mean(h, field, parent, j, points);
    }
}

/// Where [`LodState`]'s fields keep a node's values: all its control points, live or not.
fn state_points(h: &Hierarchy) -> impl Fn(u32) -> Range<usize> + '_ {
    |n| h.control_point_range(n)
}

/// Copies the parent's properties and count into every child, and passes its bonds to every
/// child. The motion is copied by [`crate::split`].
pub(crate) fn inherit_down(h: &Hierarchy, state: &mut LodState, parent: u32) {
    let points = state_points(h);
    for c in h.children(parent) {
        for field in [
            &mut state.wetness,
            &mut state.stiffness,
            &mut state.thickness,
            &mut state.length,
        ] {
            copy_points(field, points(parent), points(c));
        }
        state.count[c as usize] = state.count[parent as usize];
    }
    // Bonds: one copy per child for each end on the parent.
    if state.bonds.is_empty() {
        return;
    }
    let kids = h.children(parent);
    let mut moved = Vec::new();
    state.bonds.retain(|b| {
        if b.a.node == parent || b.b.node == parent {
            moved.push(*b);
            false
        } else {
            true
        }
    });
    for b in moved {
        for c in kids.clone() {
            let mut nb = b;
            if nb.a.node == parent {
                nb.a.node = c;
            }
            if nb.b.node == parent {
                nb.b.node = c;
            }
            state.bonds.push(nb);
        }
    }
    normalise_bonds(&mut state.bonds);
}

/// Strand-weighted averages of the children's properties into the parent, the common count,
/// and the children's bonds moved to the parent (a bond between two points that become one is
/// dropped). The caller has checked that the counts agree.
pub(crate) fn average_up(h: &Hierarchy, state: &mut LodState, parent: u32) {
    let kids = h.children(parent);
    for field in [
        &mut state.wetness,
        &mut state.stiffness,
        &mut state.thickness,
        &mut state.length,
    ] {
        weighted_mean_into(h, field, parent);
    }
    state.count[parent as usize] = state.count[kids.start as usize];
    for b in state.bonds.iter_mut() {
        if kids.contains(&b.a.node) {
            b.a.node = parent;
        }
        if kids.contains(&b.b.node) {
            b.b.node = parent;
        }
    }
    state.bonds.retain(|b| b.a != b.b);
    normalise_bonds(&mut state.bonds);
}

/// Writes into the parent's slots of a [`LodState`] field the strand-weighted mean of its
/// children's. Every node of a tree has the same slots, so every child holds every point.
pub(crate) fn weighted_mean_into(h: &Hierarchy, field: &mut [Real], parent: u32) {
    mean_into(h, field, parent, &state_points(h));
}

/// The strand-weighted mean of a [`LodState`] field's children at point `j` of `parent`.
pub(crate) fn weighted_mean(h: &Hierarchy, field: &[Real], parent: u32, j: usize) -> Real {
    children_mean(h, field, parent, j, &state_points(h))
}

/// What [`inherit_edits`] has made of a node during one call.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Role {
    /// Not reached (every node between calls).
    #[default]
    Untouched,
    /// Touched, not yet known to be under another touched node.
    Touched,
    /// Touched with no touched ancestor: its values are copied down.
    Source,
    /// Under a source: takes its values.
    Below,
    /// Above a source: takes its children's mean.
    Ancestor,
}

/// Working lists of [`inherit_edits`], kept by the caller between calls so that a call
/// allocates nothing once they have grown to the largest edit.
#[derive(Clone, Debug, Default)]
pub struct InheritScratch {
    /// Per node; every entry is `Untouched` between calls.
    role: Vec<Role>,
    /// Sources, ascending.
    sources: Vec<u32>,
    /// `(source, descendant)` pairs to copy.
    copies: Vec<(u32, u32)>,
    /// Ancestors of the sources, deepest first.
    ancestors: Vec<u32>,
    /// Depth-first walk below a source.
    stack: Vec<u32>,
}

impl InheritScratch {
    /// Bytes held (every list, by capacity): unchanged by a call that needs no more room.
    pub fn memory_bytes(&self) -> usize {
        self.role.capacity() * core::mem::size_of::<Role>()
            + self.sources.capacity() * 4
            + self.copies.capacity() * 8
            + self.ancestors.capacity() * 4
            + self.stack.capacity() * 4
    }
}

/// Carries edits of the `touched` nodes' per-control-point values to every other level of the
/// hierarchy, in any layout: `points(n)` is where node `n`'s control points live in each of
/// `fields` (so a node cut shorter has a shorter range).
///
/// The rule (Ward, Galoppo & Lin §6.6), the same one [`crate::split`] and [`crate::merge`]
/// apply:
/// - **Down.** Every descendant of a touched node takes the touched node's values over the
///   points both have (the first `min` of the two counts); its points past that keep theirs. A
///   touched node under another touched node is a descendant like any other: the shallower edit
///   wins, so the result does not depend on the order of `touched`.
/// - **Up.** Every other ancestor of a touched node, deepest first, takes at each of its points
///   `j` the strand-weighted mean of its children's: `sum strands * value / sum strands`, where
///   the denominator is *all* the children's strands and a child cut shorter than `j` adds
///   nothing to the sum. Why all children: a node stands for all its strands, and at `j` only
///   those that reach it carry water, stiffness or thickness, so the parent's `strands * value`
///   at each point is its children's sum (water, as [`LodState::total_water`] counts it, is
///   conserved up the levels even when children were cut); a mean over only the children
///   holding `j` would credit the cut-off strands with the others' water. The price: past a
///   cut a parent's stiffness and thickness factors fall below its children's, as they describe
///   the bundle, not one strand; a point no child reaches becomes 0, no hair being left there
///   (a merge cuts the parent to its children's count anyway).
///
/// Sums are f64 in child order, so identical children give their value exactly. `changed`
/// receives every node whose values the edit can have changed, each once: the touched nodes
/// with no touched ancestor (ascending), each followed by its descendants, then the ancestors,
/// deepest first. Nothing else is written; only the nodes in those trees are visited.
///
/// # Errors
/// [`LodError::UnknownNode`] for a touched node not in `h`, and [`LodError::PointsOutOfRange`]
/// for a visited node whose `points` are not within every field. On error nothing is written
/// and `changed` is empty.
///
/// ```
/// use hair_lod::*;
///
/// let h = Hierarchy::build(&test_heads::ward_lin_head(200, 3), &HierarchyParams::default())?;
/// let mut state = LodState::new(&h);
/// // Wet one root strip; its whole tree follows.
/// let root = h.tree_root(0);
/// state.wetness[h.control_point_range(root)].fill(0.5);
/// let (mut scratch, mut changed) = (InheritScratch::default(), Vec::new());
/// inherit_edits(
///     &h,
///     &[root],
///     |n| h.control_point_range(n),
///     &mut [&mut state.wetness],
///     &mut scratch,
///     &mut changed,
/// )?;
/// assert_eq!(changed.len(), h.tree_nodes(0).len());
/// let leaf = h.tree_nodes(0).last().unwrap();
/// assert!(state.wetness[h.control_point_range(leaf)].iter().all(|&w| w == 0.5));
/// # Ok::<(), LodError>(())
/// ```
pub fn inherit_edits(
    h: &Hierarchy,
    touched: &[u32],
    points: impl Fn(u32) -> Range<usize>,
    fields: &mut [&mut [Real]],
    scratch: &mut InheritScratch,
    changed: &mut Vec<u32>,
) -> Result<(), LodError> {
    changed.clear();
    for &t in touched {
        h.check(t)?;
    }
    if scratch.role.len() != h.node_count() {
        scratch.role.clear();
        scratch.role.resize(h.node_count(), Role::Untouched);
    }
    plan_edits(h, touched, scratch, changed);
    let len = fields.iter().map(|f| f.len()).min().unwrap_or(usize::MAX);
    let result = check_points(h, &points, len, scratch, changed);
    if result.is_ok() {
        for &(s, d) in &scratch.copies {
            for field in fields.iter_mut() {
                copy_points(field, points(s), points(d));
            }
        }
        for &a in &scratch.ancestors {
            for field in fields.iter_mut() {
                mean_into(h, field, a, &points);
            }
        }
    }
    // Every node given a role is in `changed` (touched ones as sources or below one).
    for &n in changed.iter() {
        scratch.role[n as usize] = Role::Untouched;
    }
    if result.is_err() {
        changed.clear();
    }
    result
}

/// Finds the sources, the copies below them and their ancestors, deepest first, and lists
/// them in `changed`.
fn plan_edits(
    h: &Hierarchy,
    touched: &[u32],
    scratch: &mut InheritScratch,
    changed: &mut Vec<u32>,
) {
    let InheritScratch {
        role,
        sources,
        copies,
        ancestors,
        stack,
    } = scratch;
    sources.clear();
    copies.clear();
    ancestors.clear();
    for &t in touched {
        role[t as usize] = Role::Touched;
    }
    for &t in touched {
        if role[t as usize] == Role::Source {
            continue; // listed twice
        }
        let mut up = h.parent(t);
        let mut covered = false;
        while let Some(p) = up {
            if matches!(role[p as usize], Role::Touched | Role::Source) {
                covered = true;
                break;
            }
            up = h.parent(p);
        }
        if !covered {
            role[t as usize] = Role::Source;
            sources.push(t);
        }
    }
    sources.sort_unstable();
    for &s in sources.iter() {
        changed.push(s);
        stack.clear();
        stack.extend(h.children(s));
        while let Some(d) = stack.pop() {
            role[d as usize] = Role::Below;
            copies.push((s, d));
            changed.push(d);
            stack.extend(h.children(d));
        }
    }
    // No ancestor of a source is touched (it would be covered) or below another source (that
    // source would be above it too), so the walk stops only at ancestors already listed.
    for &s in sources.iter() {
        let mut up = h.parent(s);
        while let Some(p) = up {
            if role[p as usize] == Role::Ancestor {
                break;
            }
            role[p as usize] = Role::Ancestor;
            ancestors.push(p);
            up = h.parent(p);
        }
    }
    ancestors.sort_unstable_by_key(|&a| (core::cmp::Reverse(h.level(a)), a));
    changed.extend_from_slice(ancestors);
}

/// Checks that every node read or written has its points within fields of `len` values.
fn check_points(
    h: &Hierarchy,
    points: &impl Fn(u32) -> Range<usize>,
    len: usize,
    scratch: &InheritScratch,
    changed: &[u32],
) -> Result<(), LodError> {
    let check = |node: u32| {
        let r = points(node);
        if r.start <= r.end && r.end <= len {
            Ok(())
        } else {
            Err(LodError::PointsOutOfRange {
                node,
                start: r.start,
                end: r.end,
                len,
            })
        }
    };
    for &n in changed {
        check(n)?;
    }
    for &a in &scratch.ancestors {
        for c in h.children(a) {
            check(c)?;
        }
    }
    Ok(())
}

/// Orders each bond's ends, sorts, and folds duplicates (same two ends) into one with averaged
/// parameters.
pub(crate) fn normalise_bonds(bonds: &mut Vec<LodBond>) {
    if bonds.is_empty() {
        return;
    }
    for b in bonds.iter_mut() {
        if b.b < b.a {
            core::mem::swap(&mut b.a, &mut b.b);
        }
    }
    bonds.sort_by_key(|b| (b.a, b.b));
    let mut out: Vec<LodBond> = Vec::with_capacity(bonds.len());
    let mut i = 0;
    while i < bonds.len() {
        let mut j = i + 1;
        while j < bonds.len() && bonds[j].a == bonds[i].a && bonds[j].b == bonds[i].b {
            j += 1;
        }
        let k = (j - i) as f64;
        let mean = |f: fn(&LodBond) -> Real| {
            (bonds[i..j].iter().map(|b| f64::from(f(b))).sum::<f64>() / k) as Real
        };
        out.push(LodBond {
            a: bonds[i].a,
            b: bonds[i].b,
            rest: mean(|b| b.rest),
            stiffness: mean(|b| b.stiffness),
            break_distance: mean(|b| b.break_distance),
        });
        i = j;
    }
    *bonds = out;
}

/// Adds a hairspray bond between control points of two active nodes.
pub fn add_bond(
    h: &Hierarchy,
    front: &Front,
    state: &mut LodState,
    bond: LodBond,
) -> Result<(), LodError> {
    state.check(h)?;
    front.check(h)?;
    for end in [bond.a, bond.b] {
        h.check(end.node)?;
        if !front.is_active(end.node) {
            return Err(LodError::NotAllowed {
                node: end.node,
                reason: "bonds join active nodes",
            });
        }
        if end.point >= state.count[end.node as usize] {
            return Err(LodError::NotAllowed {
                node: end.node,
                reason: "bond point past the node's live control points",
            });
        }
    }
    if bond.a == bond.b {
        return Err(LodError::NotAllowed {
            node: bond.a.node,
            reason: "a bond joins two different points",
        });
    }
    for (name, v) in [
        ("bond.rest", bond.rest),
        ("bond.stiffness", bond.stiffness),
        ("bond.break_distance", bond.break_distance),
    ] {
        crate::error::finite_non_negative(name, v)?;
    }
    state.bonds.push(bond);
    normalise_bonds(&mut state.bonds);
    Ok(())
}

/// Cuts an active node (Ward, Galoppo & Lin §6.1): it keeps its first `keep` control points,
/// the last kept segment shortened to `last_fraction` of its length, and loses its bonds past
/// them. Its children inherit the cut when it splits.
pub fn cut(
    h: &Hierarchy,
    front: &Front,
    state: &mut LodState,
    node: u32,
    keep: usize,
    last_fraction: Real,
) -> Result<(), LodError> {
    h.check(node)?;
    state.check(h)?;
    front.check(h)?;
    if !front.is_active(node) {
        return Err(LodError::NotAllowed {
            node,
            reason: "only an active node can be cut",
        });
    }
    let count = state.count[node as usize] as usize;
    if keep < 2 || keep > count {
        return Err(LodError::InvalidParameter {
            name: "cut.keep",
            value: keep as f64,
            expected: "between 2 and the node's live control points",
        });
    }
    if !(last_fraction.is_finite() && last_fraction > 0.0 && last_fraction <= 1.0) {
        return Err(LodError::InvalidParameter {
            name: "cut.last_fraction",
            value: f64::from(last_fraction),
            expected: "in (0, 1]",
        });
    }
    state.count[node as usize] = keep as u16;
    state.length[h.control_point_start(node) + keep - 1] *= last_fraction;
    let gone = |e: &BondEnd| e.node == node && usize::from(e.point) >= keep;
    state.bonds.retain(|b| !gone(&b.a) && !gone(&b.b));
    Ok(())
}
