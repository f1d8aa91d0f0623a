//! Styling properties through the hierarchy: Ward, Galoppo & Lin, Interactive Virtual Hair
//! Salon, §6.6 (hierarchy inheritance).
//!
//! Down (split): every child takes its parent's wetness, stiffness, thickness and length
//! unchanged, its live control-point count (a cut removes the same trailing points from every
//! child), and every bond of the parent. Up (merge): the parent takes the average over its
//! children, weighted by the strands each stands for (the paper's plain mean conserves water
//! only when children are the same size; the weighted one conserves it always), and every bond
//! of a child. Children with different counts do not merge.

use crate::{BondEnd, Front, Hierarchy, LodBond, LodError, LodState, Real};

/// Copies the parent's properties and count into every child, and passes its bonds to every
/// child. The motion is copied by [`crate::split`].
pub(crate) fn inherit_down(h: &Hierarchy, state: &mut LodState, parent: u32) {
    let ps = h.control_point_start(parent);
    let n = h.control_points(parent);
    for c in h.children(parent) {
        let cs = h.control_point_start(c);
        for field in [
            &mut state.wetness,
            &mut state.stiffness,
            &mut state.thickness,
            &mut state.length,
        ] {
            field.copy_within(ps..ps + n, cs);
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

/// Writes into the parent's slots the strand-weighted mean of its children's (f64 sums, so the
/// mean of identical values is that value exactly).
pub(crate) fn weighted_mean_into(h: &Hierarchy, field: &mut [Real], parent: u32) {
    let ps = h.control_point_start(parent);
    let n = h.control_points(parent);
    let kids = h.children(parent);
    let total: f64 = kids.clone().map(|c| f64::from(h.strand_count(c))).sum();
    for j in 0..n {
        let mut acc = 0.0f64;
        for c in kids.clone() {
            acc += f64::from(h.strand_count(c)) * f64::from(field[h.control_point_start(c) + j]);
        }
        field[ps + j] = (acc / total) as Real;
    }
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
