//! Runtime selection of the level of detail: Ward & Lin 2003 §6.1, with the user-activity
//! criterion of Ward, Galoppo & Lin §4.4.
//!
//! Selection is a pure function of the hierarchy, the current [`Front`] and per-node inputs; it
//! returns a [`Plan`] that [`crate::apply`] carries out.

use crate::error::{finite_non_negative, ordered};
use crate::{Hierarchy, LodError, Real};

/// What the grid says about a node's hair (Ward, Galoppo & Lin §4.3-4.4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Activity {
    /// In dormant cells: not simulated, so its motion asks for no detail (speed counts as 0).
    Dormant,
    /// Ordinary: distance and speed decide.
    #[default]
    Moving,
    /// Under a tool's influence volume: the finest level.
    Tool,
}

/// Hysteresis of the selection, in levels: a node splits as soon as its inputs ask for a finer
/// level, but votes to merge only when they ask for a level at least this much coarser than its
/// own, so that inputs hovering at a level's threshold do not split a node on one step and merge
/// it on the next.
pub const MERGE_MARGIN: Real = 0.5;

/// Per-level intervals of distance and speed, given at the coarsest and finest levels and
/// interpolated linearly in between (Ward & Lin §6.1). SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectParams {
    /// Hair closer to the viewer than this gets the finest level (m).
    pub distance_finest: Real,
    /// Hair farther than this gets the coarsest level (m); above `distance_finest`.
    pub distance_coarsest: Real,
    /// Hair slower than this asks for the coarsest level (m/s).
    pub speed_coarsest: Real,
    /// Hair faster than this asks for the finest level (m/s); above `speed_coarsest`.
    pub speed_finest: Real,
}

impl Default for SelectParams {
    fn default() -> Self {
        Self {
            distance_finest: 0.5,
            distance_coarsest: 4.0,
            speed_coarsest: 0.05,
            speed_finest: 1.5,
        }
    }
}

impl SelectParams {
    /// Checks that values are finite and non-negative and that each pair is in order.
    pub fn validate(&self) -> Result<(), LodError> {
        finite_non_negative("distance_finest", self.distance_finest)?;
        finite_non_negative("distance_coarsest", self.distance_coarsest)?;
        finite_non_negative("speed_coarsest", self.speed_coarsest)?;
        finite_non_negative("speed_finest", self.speed_finest)?;
        ordered(
            "distance_finest",
            self.distance_finest,
            "distance_coarsest",
            self.distance_coarsest,
        )?;
        ordered(
            "speed_coarsest",
            self.speed_coarsest,
            "speed_finest",
            self.speed_finest,
        )
    }

    /// The level a node asks for, `0 ..= max_level`: the finer of what distance and speed ask
    /// for ("the stricter wins"); a tool asks for the finest. A level `l` accepts distances up
    /// to `d_l = d_coarsest + (d_finest - d_coarsest) l / max_level` and is asked for by speeds
    /// from `v_l = v_coarsest + (v_finest - v_coarsest) l / max_level`.
    pub fn desired_level(
        &self,
        max_level: u8,
        distance: Real,
        speed: Real,
        activity: Activity,
    ) -> u8 {
        self.level_with_margin(max_level, distance, speed, activity, 0.0)
    }

    /// [`SelectParams::desired_level`] with the inputs' level raised by `margin` levels.
    fn level_with_margin(
        &self,
        max_level: u8,
        distance: Real,
        speed: Real,
        activity: Activity,
        margin: Real,
    ) -> u8 {
        if activity == Activity::Tool || max_level == 0 {
            return max_level;
        }
        let m = f32::from(max_level);
        let by_distance = ((self.distance_coarsest - distance)
            / (self.distance_coarsest - self.distance_finest))
            .clamp(0.0, 1.0);
        let speed = if activity == Activity::Dormant {
            0.0
        } else {
            speed
        };
        let by_speed = ((speed - self.speed_coarsest) / (self.speed_finest - self.speed_coarsest))
            .clamp(0.0, 1.0);
        // NaN (never after validation) falls to the coarsest.
        let t = by_distance.max(by_speed);
        let l = (t * m + 1e-4 + margin).floor();
        if l.is_nan() { 0 } else { l.clamp(0.0, m) as u8 }
    }
}

/// Inputs per node of the hierarchy (every slice is indexed by node id). The selection reads
/// them for active nodes, for root strips, and, when a tree becomes visible again, for the
/// nodes on the way down to the level it should return to.
#[derive(Clone, Copy, Debug)]
pub struct NodeInputs<'a> {
    /// Inside the camera frustum and not occluded by the body (a query the facade answers).
    pub visible: &'a [bool],
    /// Distance to the viewer (m).
    pub distance: &'a [Real],
    /// Speed of the node's fastest control point (m/s).
    pub speed: &'a [Real],
    /// Activity from the grid.
    pub activity: &'a [Activity],
}

impl NodeInputs<'_> {
    fn check(&self, h: &Hierarchy) -> Result<(), LodError> {
        let n = h.node_count();
        for (name, got) in [
            ("visible", self.visible.len()),
            ("distance", self.distance.len()),
            ("speed", self.speed.len()),
            ("activity", self.activity.len()),
        ] {
            if got != n {
                return Err(LodError::InputLength {
                    name,
                    got,
                    expected: n,
                });
            }
        }
        Ok(())
    }
}

/// Which nodes are active (simulated), and which trees were sent to their root strip by
/// occlusion. Every strand belongs to exactly one active node.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Front {
    pub(crate) active: Vec<bool>,
    pub(crate) hidden: Vec<bool>,
}

impl Front {
    /// Every tree at its root strip.
    pub fn coarsest(h: &Hierarchy) -> Self {
        let mut active = vec![false; h.node_count()];
        for t in 0..h.tree_count() as u32 {
            active[h.tree_root(t) as usize] = true;
        }
        Self {
            active,
            hidden: vec![false; h.tree_count()],
        }
    }

    /// Every leaf active.
    pub fn finest(h: &Hierarchy) -> Self {
        Self {
            active: (0..h.node_count() as u32).map(|n| h.is_leaf(n)).collect(),
            hidden: vec![false; h.tree_count()],
        }
    }

    /// Whether a node is active.
    pub fn is_active(&self, node: u32) -> bool {
        self.active[node as usize]
    }

    /// Whether a tree sits at its root strip because it was not visible.
    pub fn is_hidden(&self, tree: u32) -> bool {
        self.hidden[tree as usize]
    }

    /// The active nodes, ascending.
    pub fn active_nodes(&self) -> impl Iterator<Item = u32> + '_ {
        self.active
            .iter()
            .enumerate()
            .filter(|(_, a)| **a)
            .map(|(n, _)| n as u32)
    }

    /// How many nodes are active.
    pub fn active_count(&self) -> usize {
        self.active.iter().filter(|a| **a).count()
    }

    /// For every strand, the active node that stands for it; an error if a strand has none or
    /// more than one.
    pub fn active_of_strands(&self, h: &Hierarchy) -> Result<Vec<u32>, LodError> {
        self.check(h)?;
        let mut owner = vec![u32::MAX; h.strand_total()];
        for n in self.active_nodes() {
            for &s in h.strands(n) {
                if owner[s as usize] != u32::MAX {
                    return Err(LodError::NotAllowed {
                        node: n,
                        reason: "a strand belongs to two active nodes",
                    });
                }
                owner[s as usize] = n;
            }
        }
        if let Some(s) = owner.iter().position(|&o| o == u32::MAX) {
            return Err(LodError::NotAllowed {
                node: s as u32,
                reason: "strand with no active node",
            });
        }
        Ok(owner)
    }

    pub(crate) fn check(&self, h: &Hierarchy) -> Result<(), LodError> {
        if self.active.len() != h.node_count() || self.hidden.len() != h.tree_count() {
            return Err(LodError::Mismatch { what: "front" });
        }
        Ok(())
    }
}

/// The changes one step makes, in the order [`crate::apply`] makes them.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    /// Trees whose root strip is not visible: collapse to the root strip (any number of levels).
    pub collapses: Vec<u32>,
    /// Trees visible again after an occlusion: their split chains below go down as far as the
    /// inputs ask, in one step.
    pub restores: Vec<u32>,
    /// Parents whose children all ask to be coarser (the merge may still wait on distance).
    pub merges: Vec<u32>,
    /// Active nodes that ask to be finer, parents before children.
    pub splits: Vec<u32>,
}

impl Plan {
    /// Empties the plan, keeping its memory.
    pub fn clear(&mut self) {
        self.collapses.clear();
        self.restores.clear();
        self.merges.clear();
        self.splits.clear();
    }
}

/// Selects the changes for one step (allocating the plan; see [`select_into`]).
pub fn select(
    h: &Hierarchy,
    front: &Front,
    inputs: &NodeInputs<'_>,
    params: &SelectParams,
) -> Result<Plan, LodError> {
    let mut plan = Plan::default();
    select_into(h, front, inputs, params, &mut plan)?;
    Ok(plan)
}

/// Selects the changes for one step into `plan`. A pure function of its inputs:
///
/// - a tree whose root strip is not visible collapses to it (not rendered);
/// - a tree visible again after that goes straight down to the level its inputs ask for;
/// - otherwise each active node compares the level it asks for
///   ([`SelectParams::desired_level`]; an invisible node asks for level 0) with its own: finer
///   splits it; coarser by at least [`MERGE_MARGIN`] of a level votes to merge, and a parent
///   merges when all its children are active and vote so. Nothing moves more than one level.
pub fn select_into(
    h: &Hierarchy,
    front: &Front,
    inputs: &NodeInputs<'_>,
    params: &SelectParams,
    plan: &mut Plan,
) -> Result<(), LodError> {
    params.validate()?;
    front.check(h)?;
    inputs.check(h)?;
    plan.clear();
    let max = h.max_level();
    // The level a node asks for, with `margin` levels added (an invisible node asks for 0).
    let asks = |n: u32, margin: Real| -> u8 {
        let i = n as usize;
        if !inputs.visible[i] {
            return 0;
        }
        let (d, v, a) = (inputs.distance[i], inputs.speed[i], inputs.activity[i]);
        params.level_with_margin(max, d, v, a, margin)
    };
    let desired = |n: u32| asks(n, 0.0);
    for t in 0..h.tree_count() as u32 {
        let root = h.tree_root(t);
        if !inputs.visible[root as usize] {
            if !front.hidden[t as usize] {
                plan.collapses.push(t);
            }
            continue;
        }
        let nodes = h.tree_nodes(t);
        if front.hidden[t as usize] {
            plan.restores.push(t);
            let first = plan.splits.len();
            for n in nodes {
                let reached = match h.parent(n) {
                    None => true,
                    Some(p) => plan.splits[first..].binary_search(&p).is_ok(),
                };
                if reached && !h.is_leaf(n) && desired(n) > h.level(n) {
                    plan.splits.push(n);
                }
            }
            continue;
        }
        for n in nodes {
            if !front.active[n as usize] {
                continue;
            }
            let want = desired(n);
            let level = h.level(n);
            if want > level && !h.is_leaf(n) {
                plan.splits.push(n);
            }
            if let Some(p) = h.parent(n) {
                let kids = h.children(p);
                if kids.start == n
                    && kids
                        .clone()
                        .all(|c| front.active[c as usize] && asks(c, MERGE_MARGIN) < h.level(c))
                {
                    plan.merges.push(p);
                }
            }
        }
    }
    Ok(())
}

/// Whether an active node is drawn this step: active, in a tree not hidden, and visible.
pub fn rendered(h: &Hierarchy, front: &Front, inputs: &NodeInputs<'_>, node: u32) -> bool {
    front.is_active(node) && !front.is_hidden(h.tree_of(node)) && inputs.visible[node as usize]
}
