//! A groom made its own rest: moved out of the body, its hair-hair radii capped where it packs
//! crossing hair closer than they are, then its rest angles solved so that the settled shape is
//! a static equilibrium under gravity ([`StrandState::make_rest_equilibrium`], Hsu et al. 2023).
//!
//! Both contacts are settled before the solve so that the first steps find nothing to push. A
//! node that starts inside the body goes out by the constraint a step applies, at once, not
//! eased out over the first frames. Crossing hair the groom packs within the sum of its radii
//! cannot be pushed apart (pushes on dense grooms, half the overlap a pass, found more pairs
//! pass after pass on every built-in scene): the groom's clearance is taken as those nodes'
//! hair-hair radius instead ([`Sections::radius_cap`]), so hair is pushed apart only where it
//! comes closer than it was groomed. The springs carry the whole weight, the part the body
//! could hold up included: solved with the body's reaction under the nodes resting on it, the
//! built-in scenes drifted more (`wind` 3.1 mm against 0.17 mm without hair-hair), as the
//! constraint holds a node only after it has sunk in.

use crate::{
    BodyConstraint, BodySupport, CollideError, CollisionSettings, HairHairModel, Sections,
};
use hair_dynamics::{Environment, StrandState, TorqueModel};
use hair_grid::{Grid, GridConfig, PairSet};
use hair_ssv::{Lss, MeshBody, Real, Ssv, Vector};

/// What [`make_groom_rest`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GroomRestReport {
    /// Nodes the body constraint found within their radius of the body and moved out.
    pub body_contacts: usize,
    /// Nodes whose hair-hair radius is capped at the groom's clearance.
    pub capped: usize,
    /// Joints whose rest angles were solved.
    pub joints: usize,
    /// Nodes lying on the body that it pushes at rest ([`BodySupport`]).
    pub carried: usize,
}

/// A capped radius keeps this share of half the groom's clearance, so that a pair at rest is
/// clear of contact by a margin the first steps' small motions do not cross (on `wind`, still:
/// 0.9 drifted 7.1 mm over the first second, 0.5 3.8 mm, 0 (crossing pairs of the groom never
/// pushed) 1.9 mm).
const CAP_SHARE: Real = 0.5;

/// Makes the groom in `state` its own rest under `loads`, gravity (m/s², head frame; a still
/// head, no wind) and the torque model: every skeleton moved out of `body`; with the `Pairs`
/// hair-hair model, the radius cap of the returned sections of `front` set where they cross
/// closer than their radii; then every skeleton's rest angles solved for the settled shape.
/// With no `loads` (the groom not made its rest) it returns plain sections and changes nothing.
///
/// It also returns the body constraint for the steps to come: with the body's pushes on the hair
/// lying on it, and the clearances its own pass found about every node, so that the first step
/// does not ask the body again where the hair has not moved.
pub fn make_groom_rest(
    state: &mut StrandState,
    body: Option<&MeshBody>,
    front: &[u32],
    settings: &CollisionSettings,
    loads: Option<(Vector, TorqueModel)>,
) -> Result<(Sections, GroomRestReport, BodyConstraint), CollideError> {
    let mut report = GroomRestReport::default();
    let mut sections = Sections::default();
    let mut constraint = BodyConstraint::new();
    let Some((gravity, torque)) = loads else {
        return Ok((sections, report, constraint));
    };
    if let Some(body) = body {
        let all = all_skeletons(state);
        // After the depenetration ramp: a node inside goes straight out.
        let step = u64::from(settings.depenetration_steps);
        report.body_contacts = constraint
            .apply(state, body, &all, step, settings)?
            .contacts;
    }
    if settings.hair_hair == HairHairModel::Pairs {
        report.capped = cap_radii(state, front, &mut sections, settings)?;
    }
    let env = Environment {
        gravity,
        ..Environment::default()
    };
    // Hair lying on the body rests on it (`crate::support`): the body's pushes enter the
    // solve, and every step after it applies them.
    let (mut support, lying) = match body {
        Some(body) => BodySupport::lying(state, body, settings),
        None => (BodySupport::default(), Vec::new()),
    };
    let mut pushes = Vec::new();
    report.joints = state.make_rest_equilibrium_on(&env, torque, &lying, &mut pushes)?;
    support.set_pushes(&pushes);
    report.carried = support.len();
    if let Some(body) = body {
        support.apply(state, body, settings)?;
    }
    constraint.set_support(support);
    Ok((sections, report, constraint))
}

fn all_skeletons(state: &StrandState) -> Vec<u32> {
    (0..state.skeleton_count() as u32).collect()
}

/// Sets `sections.radius_cap` so that no two crossing sections of `front` overlap as groomed;
/// returns the nodes capped.
fn cap_radii(
    state: &StrandState,
    front: &[u32],
    sections: &mut Sections,
    settings: &CollisionSettings,
) -> Result<usize, CollideError> {
    sections.radius_cap.clear();
    sections.build(state, front);
    let mut grid = Grid::new(GridConfig::default());
    grid.rebuild(&sections.sections)?;
    let mut pairs = PairSet::default();
    grid.overlapping_pairs_by_rank(&mut pairs);
    let order = grid.search_order();
    let cos_parallel = settings.parallel_angle.cos();
    let mut cap = vec![Real::INFINITY; state.node_count()];
    let line = |rank: u32| match sections.sections[order[rank as usize] as usize].shape {
        Ssv::Line(l) => Some((l, sections.nodes[order[rank as usize] as usize] as usize)),
        _ => None,
    };
    for chunk in 0..pairs.chunk_count() {
        for &[a, b] in pairs.chunk(chunk) {
            let (Some((la, na)), Some((lb, nb))) = (line(a), line(b)) else {
                continue;
            };
            if is_parallel(&la, &lb, cos_parallel) {
                continue;
            }
            let c = hair_ssv::query::segment_segment(&la.a, &la.b, &lb.a, &lb.b);
            let dist = (c.on_b - c.on_a).norm();
            if dist >= la.radius + lb.radius {
                continue;
            }
            let most = 0.5 * CAP_SHARE * dist;
            for node in [na - 1, na, nb - 1, nb] {
                cap[node] = cap[node].min(most);
            }
        }
    }
    let capped = cap.iter().filter(|c| c.is_finite()).count();
    sections.radius_cap = cap;
    Ok(capped)
}

/// Whether two sections are near-parallel as the response decides (their contact shares
/// rates and pushes nothing).
fn is_parallel(a: &Lss, b: &Lss, cos_parallel: Real) -> bool {
    let (u, v) = (a.b - a.a, b.b - b.a);
    match (u.try_normalize(0.0), v.try_normalize(0.0)) {
        (Some(u), Some(v)) => u.dot(&v).abs() >= cos_parallel,
        _ => false,
    }
}
