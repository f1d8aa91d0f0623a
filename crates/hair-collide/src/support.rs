//! The body's support of hair lying on it, for a groom made its own rest.
//!
//! Held up by its springs alone, a groom combed over the scalp and the shoulders needs rest
//! angles bent by up to tens of radians at the roots (the scenes' hair is heavy for its
//! stiffness): a rest shape coiled like a spring, which shows as loops over the crown as soon
//! as a cut takes weight away or a shake lifts the hair off the head. Hair lying on a body
//! rests on it: the body's normal force balances both the weight pressing into it and the
//! pull of the strand's tension around the curved surface. So the rest is solved with the body
//! free to push every node lying on it ([`StrandState::make_rest_equilibrium_on`], the pushes
//! that leave the least to the springs), and every step applies the same pushes.
//!
//! A push acts while its node stays where it was groomed or closer to the body, along the
//! body's normal where the node is now, and fades out over [`SUPPORT_LIFT`] as the node lifts
//! off: a node lifted away falls back under its whole weight, a node pressed in is held by the
//! velocity constraint as before. A cut or a shake that takes tension away lifts the hair a few
//! millimetres instead of springing it into coils.

use crate::CollisionSettings;
use hair_dynamics::{DynamicsError, SkeletonId, StrandState};
use hair_ssv::{MeshBody, Real, Vector};
use rayon::prelude::*;

/// Distance beyond a node's radius within which groomed hair counts as lying on the body (m):
/// the clearance a groom is laid at and the hair layer under the outer strands.
pub const SUPPORT_REACH: Real = 0.015;

/// Distance a node lifts off past where it was groomed over which its push fades out (m).
pub const SUPPORT_LIFT: Real = 0.005;

/// Pushes below this (N) are dropped.
const LEAST_PUSH: Real = 1e-9;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Push {
    node: u32,
    skeleton: u32,
    /// Newtons, at the groomed distance or closer.
    force: Real,
    /// Distance from the body where the node was groomed (m).
    groomed_at: Real,
}

/// The body's pushes on the hair lying on it, solved with the groom's rest.
#[derive(Clone, Debug, Default)]
pub struct BodySupport {
    pushes: Vec<Push>,
    /// Per push, its force this step if it acts.
    acting: Vec<Option<(u32, Vector)>>,
    forces: Vec<(u32, Vector)>,
}

impl BodySupport {
    /// The nodes of `state` lying on `body` (not roots; within their radius plus
    /// [`SUPPORT_REACH`]) with the body's normal at each, in node order, and the support
    /// holding their distances, waiting for [`BodySupport::set_pushes`].
    pub(crate) fn lying(
        state: &StrandState,
        body: &MeshBody,
        settings: &CollisionSettings,
    ) -> (Self, Vec<(u32, Vector)>) {
        let mut support = Self::default();
        let mut lying = Vec::new();
        let (p, radius) = (state.positions(), state.radius());
        for s in 0..state.skeleton_count() as u32 {
            let nodes = state.nodes(SkeletonId(s));
            for i in nodes.start + 1..nodes.end {
                let reach = radius[i] + SUPPORT_REACH;
                if let Some((d, n)) = body.distance_within(settings.method, &p[i], reach)
                    && d < reach
                {
                    lying.push((i as u32, n));
                    support.pushes.push(Push {
                        node: i as u32,
                        skeleton: s,
                        force: 0.0,
                        groomed_at: d,
                    });
                }
            }
        }
        (support, lying)
    }

    /// Takes the solved pushes (N, one per node [`BodySupport::lying`] returned, in order).
    pub(crate) fn set_pushes(&mut self, forces: &[Real]) {
        for (push, f) in self.pushes.iter_mut().zip(forces) {
            push.force = *f;
        }
        self.pushes.retain(|p| p.force > LEAST_PUSH);
    }

    /// Nodes the body pushes at rest.
    pub fn len(&self) -> usize {
        self.pushes.len()
    }

    /// Whether the body pushes no node.
    pub fn is_empty(&self) -> bool {
        self.pushes.is_empty()
    }

    /// Adds the pushes on the active skeletons' nodes to the forces of the state's next step;
    /// returns the nodes pushed.
    pub fn apply(
        &mut self,
        state: &mut StrandState,
        body: &MeshBody,
        settings: &CollisionSettings,
    ) -> Result<usize, DynamicsError> {
        let p = state.positions();
        let shared = &*state;
        self.pushes
            .par_iter()
            .map(|push| {
                if !shared.is_active(SkeletonId(push.skeleton)) {
                    return None;
                }
                let gone = push.groomed_at + SUPPORT_LIFT;
                let (d, n) = body.distance_within(settings.method, &p[push.node as usize], gone)?;
                let share = ((gone - d) / SUPPORT_LIFT).clamp(0.0, 1.0);
                (share > 0.0).then(|| (push.node, n * (push.force * share)))
            })
            .collect_into_vec(&mut self.acting);
        self.forces.clear();
        self.forces.extend(self.acting.iter().flatten());
        state.add_forces_for_next_step(&self.forces)?;
        Ok(self.forces.len())
    }
}
