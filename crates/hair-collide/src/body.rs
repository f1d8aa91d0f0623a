//! The hard body constraint: Kurihara, Anjyo & Thalmann §4's reaction constraint, made
//! positional. After integration no node is inside the body beyond the stated tolerance.

use crate::{BodySupport, CollisionSettings};
use hair_dynamics::{DynamicsError, NodeCorrection, SkeletonId, StrandState, VelocityConstraint};
use hair_ssv::{
    BodyIdentity, Clearance, CollisionMethod, MeshBody, Point, Real, Vector, any_perpendicular,
};
use nalgebra::Isometry3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};

/// What one application of the body constraint found.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyReport {
    /// Nodes in contact with the body on the first pass.
    pub contacts: usize,
    /// Deepest node centre left inside the body (m), each node counted where it was last
    /// tested.
    pub max_penetration: Real,
    /// Node tests the late passes made by the exact distance where the scene's method is
    /// approximate (few nodes still moving, where the method's answer cannot be trusted).
    pub exact_tests: usize,
    /// Nodes caught inside after the regular passes and sent to the nearest clear place on
    /// their sphere (each by up to a few hundred exact queries).
    pub escapes: usize,
}

impl BodyReport {
    /// Adds `other`'s counts to these and keeps the deeper penetration: the report of
    /// several bodies.
    pub fn merge(&mut self, other: &BodyReport) {
        self.contacts += other.contacts;
        self.max_penetration = self.max_penetration.max(other.max_penetration);
        self.exact_tests += other.exact_tests;
        self.escapes += other.escapes;
    }
}

/// The hard body constraint with its scratch buffers: after the first call, a call allocates
/// nothing once the buffers have grown to the hair.
///
/// It also keeps, per node, the clearance of its last query (how far it may move from where it
/// was asked and stay out of reach: [`Clearance`]), so that a node still within it is not
/// queried again (most nodes, most steps; the results are the same bits). The clearances hold
/// for one body ([`MeshBody::identity`]) by one [`CollisionMethod`] and are dropped when
/// either, or the node count, changes; they are kept in the body's own frame, so a part's pose
/// may change.
#[derive(Clone, Debug, Default)]
pub struct BodyConstraint {
    body_nodes: Vec<BodyNode>,
    /// Per skeleton, the first node a pass moved (`u32::MAX`: none).
    first_moved: Vec<u32>,
    /// Per node of a pass: what its test found, and the clearance its query found (none
    /// where its clearance kept it out of reach without one, or it was not asked by the
    /// clearances' method).
    body_hits: Vec<PassTest>,
    /// The sweeps: the chains of this pass and the next (`[skeleton, first node asked]`, by
    /// skeleton), per skeleton its radius, the first node each chain moved, the chains in
    /// contact on the first pass (`[skeleton, first node in contact]`, global index), and per
    /// node what its last test found and its clearance.
    sweep_chains: Vec<[u32; 2]>,
    sweep_next: Vec<[u32; 2]>,
    sweep_radius: Vec<Real>,
    sweep_moved: Vec<u32>,
    swept: Vec<[u32; 2]>,
    sweep_hits: Vec<SweepHit>,
    /// The body, method and node count the clearances in `sweep_hits` were found for: they
    /// bound that body's distances by that method only.
    clearance_key: Option<(BodyIdentity, CollisionMethod, usize)>,
    /// Tests set it to compare the sweeps without the clearances.
    clearance_off: bool,
    /// Per node, during the depenetration ramp: how far its sphere may still reach into the
    /// body at the end of this step (m).
    allowance: Vec<Real>,
    /// Whether any node is still held by an allowance after the last ramp step: once none
    /// is, the ramp is over.
    ramp_held: bool,
    corrections: Vec<NodeCorrection>,
    constraints: Vec<VelocityConstraint>,
    /// A moving part's surface velocity (head frame) at each constraint's node.
    surface_velocities: Vec<Vector>,
    /// The body's support of hair lying on it, when the groom was made its rest with it, and
    /// the step it was last added to.
    support: Option<BodySupport>,
    supported_step: Option<u64>,
    /// The joint angles before this application's passes, and the skeletons the passes moved
    /// (ascending once sorted).
    recorded_theta: Vec<Real>,
    recorded_phi: Vec<Real>,
    moved_skeletons: Vec<u32>,
    /// Per chain of a sweep, its first node in contact (`u32::MAX`: none).
    chain_contact: ChainContacts,
}

impl BodyConstraint {
    /// A constraint with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// A constraint that also applies the body's pushes on the hair lying on it, when there
    /// are any ([`crate::make_groom_rest`] solves them with the groom's rest).
    pub fn with_support(support: Option<BodySupport>) -> Self {
        Self {
            support: support.filter(|s| !s.is_empty()),
            ..Self::default()
        }
    }

    /// Takes `support` as the body's pushes (none when it is empty), from the next step on.
    pub(crate) fn set_support(&mut self, support: BodySupport) {
        self.support = Some(support).filter(|s| !s.is_empty());
        self.supported_step = None;
    }

    /// The hard constraint (Kurihara et al. §4's reaction constraint, made positional): every
    /// front node closer to the body than its radius is moved out along the body's normal and
    /// loses its velocity into the body, with friction. The node stays on the sphere about the
    /// node before it, so a segment hanging straight into a surface swings out of it instead of
    /// being re-aimed along itself (`body_target`).
    ///
    /// After the ramp (below) the regular passes are sweeps ([`StrandState::sweep_chains`]):
    /// each skeleton root to tip, in parallel over skeletons, every node tested where the
    /// corrections before it on its skeleton put it, so that one sweep resolves a whole chain
    /// where a pass over every node at once found the nodes after each corrected one pushed in
    /// again by its refit. A corrected node's target is tested and moved again while still
    /// inside, up to [`CollisionSettings::sweep_retests`] times; the skeletons with a corrected node left
    /// unconfirmed are swept again from their first such node, up to [`CollisionSettings::body_passes`] sweeps.
    ///
    /// Hair that starts inside the body (at the first step, or the first after a reset) comes
    /// out linearly over the first [`CollisionSettings::depenetration_steps`] steps (the ramp): at the end of ramp
    /// step `k` a node may still reach `(ramp - k - 1) / (ramp - k)` of the way it reached at the
    /// start of that step, and never more than it was allowed the step before, so whatever
    /// pushes it back in, it is held to the ramp; a node next to one still allowed inside is
    /// allowed that, less the segment between them. Every other node, including one that
    /// reaches the body during the ramp, is resolved at once. The ramp ends early, and the
    /// sweeps begin, once no node is allowed inside (at once when none starts inside). On the
    /// ramp the passes test every node where the last pass left it from each skeleton's first
    /// node its clearance does not keep out of reach (the allowances are set on the first), refit the
    /// skeletons they moved, and repeat on them until no node is deeper than the skin
    /// ([`CollisionSettings::contact_skin`] of the tolerance) beyond its allowance, or [`CollisionSettings::body_passes`] have run.
    ///
    /// Late passes, from [`CollisionSettings::body_passes`] on (on the ramp, or for the skeletons the sweeps left
    /// moving), run until no node is deeper than half the tolerance beyond its allowance or
    /// [`CollisionSettings::max_body_passes`] have run. They use the exact distance, whatever the scene's method,
    /// once at most [`CollisionSettings::exact_late_nodes`] nodes are left; after the ramp they send a node whose
    /// centre is still inside by more than half the tolerance to the nearest point of its
    /// sphere about its parent that clears the body (`escape`): lifting along the node's own
    /// normal can land it inside again where the body is thin (an ear) or creased, pass after
    /// pass. The contacts of every pass lose their approach velocity once, after the last pass.
    /// Returns the nodes in contact on the first pass and the deepest node centre left inside
    /// the body (m), each node counted where it was last tested.
    ///
    pub fn apply(
        &mut self,
        state: &mut StrandState,
        body: &MeshBody,
        front: &[u32],
        step: u64,
        settings: &CollisionSettings,
    ) -> Result<BodyReport, DynamicsError> {
        let surface = Surface { body, motion: None };
        let report = self.apply_to(state, &surface, front, step, settings)?;
        // The body's pushes on the hair lying on it: once a step, however many rounds run.
        if let Some(support) = &mut self.support
            && self.supported_step.replace(step) != Some(step)
        {
            support.apply(state, body, settings)?;
        }
        Ok(report)
    }

    /// [`BodyConstraint::apply`] for a body part that moves rigidly: `body` is in the part's
    /// own frame, placed in the hair's frame by `motion.pose` at the end of the step. Each node
    /// is tested in the part's frame and moved out along the part's normal as
    /// [`BodyConstraint::apply`] moves it out of the body. When the part moved over the step
    /// (`motion.previous` differs from `motion.pose`), the velocity constraint acts on the
    /// node's velocity relative to the part's surface at that point (from the two poses): the
    /// approach along the normal is removed, so the node moves out at least as fast as the
    /// surface, and Coulomb friction (the scene's coefficient times the approach removed) slows
    /// its sliding along it, so a moving part carries hair resting on it. A part that did not
    /// move is constrained exactly as the body is (the same result as the same mesh given as
    /// the body, bit for bit, at the identity pose). Use one constraint per part: it keeps the
    /// part's ramp allowances.
    pub fn apply_moving(
        &mut self,
        state: &mut StrandState,
        body: &MeshBody,
        motion: &PartMotion,
        front: &[u32],
        step: u64,
        settings: &CollisionSettings,
    ) -> Result<BodyReport, DynamicsError> {
        let surface = Surface {
            body,
            motion: Some(motion),
        };
        self.apply_to(state, &surface, front, step, settings)
    }

    fn apply_to(
        &mut self,
        state: &mut StrandState,
        body: &Surface<'_>,
        front: &[u32],
        step: u64,
        settings: &CollisionSettings,
    ) -> Result<BodyReport, DynamicsError> {
        let ramp = settings.depenetration_steps as u64;
        // The share of its reach into the body a node that started inside may keep at the end
        // of this ramp step (see above).
        let in_ramp = step < ramp && (step == 0 || self.ramp_held);
        let keep = if in_ramp {
            (ramp - step - 1) as Real / (ramp - step) as Real
        } else {
            0.0
        };
        if step == 0 {
            // The allowances start from the depths read on the first pass below (a root the
            // constraint does not move is allowed nothing).
            self.allowance.clear();
            self.allowance.resize(state.positions().len(), 0.0);
        }
        // The angles before the passes, for the rates they take back (below).
        let still = body.motion.is_none_or(|m| m.pose == m.previous);
        // All of them on the ramp (its passes may move any skeleton) or when the nodes changed;
        // after it, only those of the skeletons the sweeps may move (below).
        let record_all = still
            && (in_ramp || self.clearance_off || self.recorded_theta.len() != state.theta().len());
        if record_all {
            self.recorded_theta.clear();
            self.recorded_theta.extend_from_slice(state.theta());
            self.recorded_phi.clear();
            self.recorded_phi.extend_from_slice(state.phi());
        }
        let method = settings.method;
        let friction = settings.friction;
        let tolerance = 0.5 * settings.tolerance;
        // A node the last pass left within rounding of the surface is in contact but needs no
        // refit: without this skin every pass found a few hundred nodes a few nanometres in and
        // ran all its passes to move them by nothing.
        let skin = settings.contact_skin * settings.tolerance;
        // The passes test positions only, so the velocity constraints of every pass wait for the
        // last one, in pass order: one refresh of each touched skeleton instead of one a pass.
        self.constraints.clear();
        self.body_nodes.clear();
        self.moved_skeletons.clear();
        let mut contacts = 0;
        let key = (body.body.identity(), method, state.node_count());
        if self.clearance_key != Some(key) {
            // Found on another body (or this one changed), by another method, or for other
            // nodes: none holds here.
            for h in &mut self.sweep_hits {
                h.clearance = Clearance::default();
            }
            self.clearance_key = Some(key);
        }
        self.sweep_hits
            .resize(state.node_count(), SweepHit::default());
        // The deepest node centre among the nodes the sweeps left (they no longer move).
        let mut swept_depth: Real = 0.0;
        // The chains of this application (`[skeleton, first node asked]`) and each skeleton's
        // radius: the sweep holds the state, so its callback reads them from here.
        // The radius is read for these chains' skeletons only, so only theirs is written.
        self.sweep_chains.clear();
        self.sweep_radius.resize(state.skeleton_count(), 0.0);
        for &n in front {
            let id = SkeletonId(n);
            // Not one frozen by localization: it has not moved since it was last resolved.
            if state.is_active(id) {
                self.sweep_chains.push([n, u32::from(!state.is_free(id))]);
                let first = state.nodes(id).start;
                self.sweep_radius[n as usize] = state.radius().get(first).copied().unwrap_or(0.0);
            }
        }
        // Each chain's first node that its clearance does not keep out of reach (`u32::MAX`:
        // none), so that neither the sweeps nor the ramp's first pass test the nodes before it
        // one by one: a test would find each out of reach, move none and keep its clearance.
        // (The first pass is the ramp's only one that queries by the scene's method.)
        let clear_first = !self.clearance_off && (!in_ramp || settings.body_passes > 0);
        if clear_first {
            let (hits, positions) = (&self.sweep_hits, state.positions());
            let (radius, shared) = (&self.sweep_radius, &*state);
            self.sweep_chains.par_iter_mut().for_each(|chain| {
                let [n, from] = *chain;
                let r = shared.nodes(SkeletonId(n));
                let reach = radius[n as usize];
                let clear = |i: &usize| {
                    let c = hits[*i].clearance;
                    c.keeps_out(&body.local(&positions[*i]), reach)
                };
                chain[1] = (r.start + from as usize..r.end)
                    .find(|i| !clear(i))
                    .map_or(u32::MAX, |i| (i - r.start) as u32);
            });
        }
        let first_pass = if in_ramp {
            // Room for every node, as on the first step: a ramp starting again (a reset) may
            // find fewer nodes clear than the first did, and must not allocate.
            let nodes = state.node_count();
            self.body_nodes
                .reserve(nodes.saturating_sub(self.body_nodes.len()));
            self.body_hits
                .reserve(nodes.saturating_sub(self.body_hits.len()));
            for &[n, first] in &self.sweep_chains {
                let id = SkeletonId(n);
                let r = state.nodes(id);
                let from = r.start + usize::from(!state.is_free(id));
                // The nodes kept out of reach are allowed nothing, as the pass would allow
                // them (a root is allowed nothing, so neither is a node after it).
                let first = r.start.saturating_add(first as usize).min(r.end);
                let held = self.allowance.len();
                if from < first.min(held) {
                    self.allowance[from..first.min(held)].fill(0.0);
                }
                push_body_nodes(&mut self.body_nodes, &*state, n, (first - r.start) as u32);
            }
            0
        } else {
            // The regular passes as sweeps: each skeleton root to tip, every node tested where
            // the corrections before it put it, in parallel over skeletons. One sweep leaves
            // a skeleton with every node tested where it ends except the corrected ones (the
            // turn onto the sphere about the parent can leave one a little inside), so the next
            // sweep starts at each skeleton's first corrected node. A chain with no node left
            // to ask is not swept: the sweep would record those nodes as out of reach without
            // a query and move none of them (what it records there is read this step only from
            // a chain's first contact on, and their clearances stay as they are).
            self.sweep_chains.retain(|c| c[1] != u32::MAX);
            self.sweep_chains.sort_unstable();
            if still && !record_all {
                for &[n, _] in &self.sweep_chains {
                    let r = state.nodes(SkeletonId(n));
                    self.recorded_theta[r.clone()].copy_from_slice(&state.theta()[r.clone()]);
                    self.recorded_phi[r.clone()].copy_from_slice(&state.phi()[r]);
                }
            }
            self.swept.clear();
            for pass in 0..settings.body_passes {
                if self.sweep_chains.is_empty() {
                    break;
                }
                self.sweep_moved.clear();
                self.sweep_moved.resize(self.sweep_chains.len(), u32::MAX);
                self.chain_contact.reset(self.sweep_chains.len());
                let (chains, skeleton_radius) = (&self.sweep_chains, &self.sweep_radius);
                let use_clearance = !self.clearance_off;
                let chain_contact = &self.chain_contact.0;
                state.sweep_chains(
                    chains,
                    &mut self.sweep_hits,
                    &mut self.sweep_moved,
                    |ask, slot| {
                        // A node a sweep before this one tested where it still is and did not
                        // correct is not tested again.
                        if pass > 0 && !ask.moved && !slot.corrected {
                            slot.tested = false;
                            return None;
                        }
                        let radius = skeleton_radius[chains[ask.chain][0] as usize];
                        let inside = |p: &Point| {
                            body.distance_within(method, p, radius)
                                .filter(|(d, _)| *d < radius)
                        };
                        // A node that its clearance from its last query still keeps out of
                        // reach is recorded as a query out of reach would record it, without
                        // the query: a look-up of the near field's cell (and for some a query
                        // of the distance field) saved for most nodes after the first sweep.
                        let local = body.local(&ask.at);
                        let clear = slot.clearance;
                        if use_clearance && clear.keeps_out(&local, radius) {
                            *slot = SweepHit {
                                normal: None,
                                depth: 0.0,
                                tested: true,
                                corrected: false,
                                clearance: clear,
                            };
                            return None;
                        }
                        let (hit, clearance) =
                            body.distance_within_clearance(method, &local, radius);
                        let hit = hit.filter(|(d, _)| *d < radius);
                        *slot = SweepHit {
                            normal: hit.map(|(_, n)| n),
                            depth: hit.map_or(0.0, |(d, _)| -d),
                            tested: true,
                            corrected: false,
                            clearance,
                        };
                        let (d, n) = hit?;
                        // Only the thread sweeping this chain writes its entry; the atomic
                        // lets the shared callback write at all.
                        chain_contact[ask.chain].fetch_min(ask.node as u32, Ordering::Relaxed);
                        if radius - d <= skin {
                            return None;
                        }
                        // The target is tested here, and moved again while still inside, a few
                        // times: a query costs a small part of refitting the skeleton again on
                        // the next sweep. Where it ends untested, the next sweep tests it.
                        let mut target =
                            body_target(body, method, ask.at, ask.parent, &n, radius - d, radius);
                        slot.corrected = true;
                        for _ in 0..settings.sweep_retests {
                            match inside(&target) {
                                Some((d, n)) if radius - d > skin => {
                                    target = body_target(
                                        body,
                                        method,
                                        target,
                                        ask.parent,
                                        &n,
                                        radius - d,
                                        radius,
                                    );
                                }
                                end => {
                                    slot.depth = end.map_or(0.0, |(d, _)| -d);
                                    slot.corrected = false;
                                    break;
                                }
                            }
                        }
                        Some(target)
                    },
                )?;
                // The contacts in chain order, read from each chain's first (the sweep noted
                // it: reading every node's hit again cost more than the sweep's own tests),
                // then the chains to sweep again.
                self.sweep_next.clear();
                for (k, &[n, _]) in self.sweep_chains.iter().enumerate() {
                    let r = state.nodes(SkeletonId(n));
                    let first = self.chain_contact.0[k].load(Ordering::Relaxed);
                    if first != u32::MAX {
                        if pass == 0 {
                            self.swept.push([n, first]);
                        }
                        for node in first as usize..r.end {
                            let h = &self.sweep_hits[node];
                            if let (true, Some(normal)) = (h.tested, h.normal) {
                                self.constraints.push(VelocityConstraint {
                                    node: node as u32,
                                    normal,
                                    friction,
                                });
                            }
                        }
                    }
                    let moved = self.sweep_moved[k];
                    if moved != u32::MAX {
                        self.sweep_next.push([n, moved - r.start as u32]);
                        self.moved_skeletons.push(n);
                    }
                }
                if pass == 0 {
                    contacts = self.constraints.len();
                }
                std::mem::swap(&mut self.sweep_chains, &mut self.sweep_next);
            }
            // Skeletons still moving after the regular sweeps go on to the late passes below,
            // from their first corrected node.
            for &[n, from] in &self.sweep_chains {
                let r = state.nodes(SkeletonId(n));
                for h in &mut self.sweep_hits[r.start + from as usize..r.end] {
                    h.depth = 0.0;
                }
                push_body_nodes(&mut self.body_nodes, &*state, n, from);
            }
            // A node is left inside only where its chain had a contact on the first sweep (the
            // later sweeps go over the chains it moved): from that contact on.
            for &[n, first] in &self.swept {
                let end = state.nodes(SkeletonId(n)).end;
                for h in &self.sweep_hits[first as usize..end] {
                    swept_depth = swept_depth.max(h.depth);
                }
            }
            settings.body_passes
        };
        let mut deepest: Real = 0.0;
        let (mut exact_tests, mut escaped) = (0, 0);
        // The deepest node centre among the nodes the passes stopped testing (they no longer
        // move).
        let mut settled: Real = 0.0;
        for pass in first_pass..=settings.max_body_passes {
            if pass > 0 && self.body_nodes.is_empty() {
                break;
            }
            let positions = state.positions();
            // The late passes, once few nodes are still moving, query the exact distance: an
            // approximate field or table can be wrong by about its spacing where the body is
            // thinner than that, and there its gradient can send a node back and forth across
            // the surface without ever reaching it. (With many nodes left, as when dense hair
            // starts inside the body, exact queries would cost seconds per step.)
            let method = if pass >= settings.body_passes
                && self.body_nodes.len() <= settings.exact_late_nodes
            {
                CollisionMethod::Bvh
            } else {
                method
            };
            if method != settings.method {
                exact_tests += self.body_nodes.len();
            }
            // As in the sweeps, a node its clearance keeps out of reach is not queried (the
            // ramp's passes test every node, most of them far from the body).
            let clearances = !self.clearance_off && method == settings.method;
            let sweep_hits = &self.sweep_hits;
            self.body_nodes
                .par_iter()
                .map(|bn| {
                    let at = &positions[bn.node as usize];
                    if !clearances {
                        let hit = body.distance_within(method, at, bn.radius);
                        return (hit.filter(|(d, _)| *d < bn.radius), None);
                    }
                    let local = body.local(at);
                    let clear = sweep_hits[bn.node as usize].clearance;
                    if clear.keeps_out(&local, bn.radius) {
                        return (None, None);
                    }
                    let (hit, clearance) =
                        body.distance_within_clearance(method, &local, bn.radius);
                    (hit.filter(|(d, _)| *d < bn.radius), Some(clearance))
                })
                .collect_into_vec(&mut self.body_hits);
            for (bn, (_, clearance)) in self.body_nodes.iter().zip(&self.body_hits) {
                if let Some(clearance) = clearance {
                    self.sweep_hits[bn.node as usize].clearance = *clearance;
                }
            }
            self.corrections.clear();
            deepest = 0.0;
            // The deepest node centre beyond what the ramp allows it: the passes stop when it is
            // out.
            let mut deepest_free: Real = 0.0;
            // Nodes sent to [`escape`] this pass (each costs up to a few hundred exact queries).
            let mut escapes = 0;
            self.first_moved.clear();
            self.first_moved.resize(state.skeleton_count(), u32::MAX);
            for (bn, (hit, _)) in self.body_nodes.iter().zip(&self.body_hits) {
                let node = bn.node as usize;
                if in_ramp && pass == 0 && node < self.allowance.len() {
                    let reach = hit.map_or(0.0, |(d, _)| (bn.radius - d).max(0.0));
                    let before = if step == 0 {
                        reach
                    } else {
                        self.allowance[node].min(reach)
                    };
                    let mut a = before * keep;
                    // A node next to one still allowed inside may be held inside by it, less
                    // the segment between them (its sphere about that node reaches no farther
                    // out). The nodes of a skeleton come root first, so the one before is done.
                    if let Some(&b) = self.allowance.get(bn.prev as usize)
                        && b > 0.0
                    {
                        let len = (positions[node] - positions[bn.prev as usize]).norm();
                        a = a.max(b - len);
                    }
                    self.allowance[node] = a;
                }
                let Some((d, n)) = hit else { continue };
                deepest = deepest.max(-d);
                self.constraints.push(VelocityConstraint {
                    node: bn.node,
                    normal: *n,
                    friction,
                });
                let allowed = if in_ramp {
                    self.allowance.get(node).copied().unwrap_or(0.0)
                } else {
                    0.0
                };
                let ramped = allowed > 0.0;
                let lift = bn.radius - d - allowed;
                if lift <= skin {
                    // In contact but out as far as it needs to be: only its approach is
                    // removed.
                    continue;
                }
                deepest_free = deepest_free.max(-d - allowed);
                let p = positions[bn.node as usize];
                let parent = (bn.prev != u32::MAX).then(|| positions[bn.prev as usize]);
                // After the ramp, a node still inside after the regular passes is caught where
                // lifting along its own normal lands in the body again (a thin part such as an
                // ear, or a crease): it goes to the nearest place on its sphere that clears.
                let stuck = parent.is_some_and(|a| (p - a).norm() > 1e-9)
                    && !ramped
                    && pass >= settings.body_passes
                    && -d > tolerance
                    && escapes < settings.exact_late_nodes;
                escapes += usize::from(stuck);
                let target = match parent {
                    Some(a) if stuck => {
                        let len = (p - a).norm();
                        escape(body, a, (p - a) / len, len, bn.radius, -d).unwrap_or(p + n * lift)
                    }
                    _ => body_target(body, method, p, parent.as_ref(), n, lift, bn.radius),
                };
                self.corrections.push(NodeCorrection {
                    node: bn.node,
                    delta: target - p,
                });
                let first = &mut self.first_moved[bn.skeleton as usize];
                if *first == u32::MAX {
                    self.moved_skeletons.push(bn.skeleton);
                }
                *first = (*first).min(bn.node);
            }
            escaped += escapes;
            if pass == 0 {
                contacts = self.constraints.len();
                if in_ramp {
                    self.ramp_held = self.allowance.iter().any(|&a| a > 0.0);
                }
            }
            let done = self.corrections.is_empty()
                || pass == settings.max_body_passes
                || (pass >= settings.body_passes && deepest_free <= tolerance);
            if done {
                break;
            }
            state.apply_corrections(&self.corrections)?;
            // The refit moves a skeleton's nodes from its first corrected one on; the nodes
            // before it stay where this pass found them: out of the body, or (on the ramp)
            // within their allowance, which the depth reported at the end still counts.
            let (first_moved, mut hits) = (&self.first_moved, self.body_hits.iter());
            self.body_nodes.retain(|bn| {
                let moved = bn.node >= first_moved[bn.skeleton as usize];
                if let (false, Some((Some((d, _)), _))) = (moved, hits.next()) {
                    settled = settled.max(-d);
                }
                moved
            });
        }
        // Where the passes turned a joint back against its rate (the dynamics drove a node in
        // and the push-out undid it), the rate shrinks by that turn over the step: the hair
        // did not move that way, and a rate left in place drove it in again every step. (Not
        // against a moving part: its push-out is motion the hair keeps.)
        // A skeleton no pass moved has no turn to take back.
        if still {
            self.moved_skeletons.sort_unstable();
            self.moved_skeletons.dedup();
            state.absorb_turns(
                &self.recorded_theta,
                &self.recorded_phi,
                &self.moved_skeletons,
            )?;
        }
        if !self.constraints.is_empty() {
            match body.motion.filter(|m| m.pose != m.previous) {
                None => state.apply_velocity_constraints(&self.constraints)?,
                Some(motion) => {
                    let positions = state.positions();
                    self.surface_velocities.clear();
                    self.surface_velocities.extend(
                        self.constraints
                            .iter()
                            .map(|c| motion.velocity_at(&positions[c.node as usize])),
                    );
                    state.apply_velocity_constraints_on_surfaces(
                        &self.constraints,
                        &self.surface_velocities,
                    )?;
                }
            }
        }
        Ok(BodyReport {
            contacts,
            max_penetration: deepest.max(settled).max(swept_depth).max(0.0),
            exact_tests,
            escapes: escaped,
        })
    }
}

/// Per chain of a sweep, the first node the sweep found in contact (`u32::MAX`: none): the
/// sweep's threads each write their own chains' entries.
#[derive(Debug, Default)]
struct ChainContacts(Vec<AtomicU32>);

impl ChainContacts {
    /// `chains` entries, each none.
    fn reset(&mut self, chains: usize) {
        self.0.truncate(chains);
        for c in &mut self.0 {
            *c.get_mut() = u32::MAX;
        }
        self.0.resize_with(chains, || AtomicU32::new(u32::MAX));
    }
}

impl Clone for ChainContacts {
    fn clone(&self) -> Self {
        Self(
            self.0
                .iter()
                .map(|c| AtomicU32::new(c.load(Ordering::Relaxed)))
                .collect(),
        )
    }
}

/// The nodes of skeleton `n` from its node `from` on, for the hard constraint's passes, each with
/// the node before it and the skeleton's radius.
fn push_body_nodes(out: &mut Vec<BodyNode>, state: &StrandState, n: u32, from: u32) {
    let r = state.nodes(SkeletonId(n));
    let radius = state.radius()[r.start];
    out.extend((r.start + from as usize..r.end).map(|i| BodyNode {
        node: i as u32,
        prev: if i > r.start { i as u32 - 1 } else { u32::MAX },
        skeleton: n,
        radius,
    }));
}

/// Where the hard constraint sends a node at `p` whose sphere reaches `lift` into the body
/// (`n` the body's normal there): lifted along `n`, then, if it has a parent node, back onto
/// its sphere about the parent at the height the lift asked for, so that a segment hanging
/// straight into a surface swings out of it instead of being re-aimed along itself; where no
/// place on that sphere is high enough, turned out ([`turn_out`]) by `method`.
fn body_target(
    body: &Surface<'_>,
    method: CollisionMethod,
    p: Point,
    parent: Option<&Point>,
    n: &Vector,
    lift: Real,
    radius: Real,
) -> Point {
    let lifted = p + n * lift;
    let Some(&a) = parent else {
        return lifted;
    };
    let len = (p - a).norm();
    if len <= 1e-9 {
        return lifted;
    }
    let u0 = (p - a) / len;
    let c = (n.dot(&u0) * len + lift) / len;
    if c > 1.0
        && let Some(t) = turn_out(body, method, a, u0, len, radius)
    {
        return t;
    }
    let c = c.clamp(-1.0, 1.0);
    let side = (u0 - n * n.dot(&u0))
        .try_normalize(1e-6)
        .unwrap_or_else(|| any_perpendicular(n));
    a + (side * (1.0 - c * c).max(0.0).sqrt() + n * c) * len
}

/// Where a node at `len` from its parent node `a` (its segment along `u0`) can go outside the
/// body when lifting it along its own surface normal cannot reach the surface: the first of a
/// few directions turned from `u0` toward the body's normal at `a` (back along the segment when
/// `a` is far from the body) that leaves the node's centre `radius` outside, by `method`.
/// A node that swung up into the underside of a part finds its nearest surface on the top, out
/// of reach of its segment; this sends it back out the side it came in by.
fn turn_out(
    body: &Surface<'_>,
    method: CollisionMethod,
    a: Point,
    u0: Vector,
    len: Real,
    radius: Real,
) -> Option<Point> {
    let away = body.distance(method, &a).map_or(-u0, |(_, n)| n);
    (1..=TURN_OUT_STEPS).find_map(|k| {
        let t = k as Real / TURN_OUT_STEPS as Real;
        let dir = (u0 * (1.0 - t) + away * t).try_normalize(1e-6)?;
        let q = a + dir * len;
        body.distance(method, &q)
            .is_none_or(|(d, _)| d >= radius)
            .then_some(q)
    })
}

/// Where a node caught inside the body can go on its sphere about its parent node `a` (radius
/// `len`, the segment's direction now `u0`): of [`ESCAPE_DIRECTIONS`] directions spread evenly
/// over the sphere, the one nearest `u0` whose point leaves the node's centre `radius` outside by
/// the exact distance; failing that, the one whose point is least deep, if it is less deep than
/// the node (`depth`) now. `None` when no direction improves on where the node is.
fn escape(
    body: &Surface<'_>,
    a: Point,
    u0: Vector,
    len: Real,
    radius: Real,
    depth: Real,
) -> Option<Point> {
    let mut order: [(Real, u16); ESCAPE_DIRECTIONS] = [(0.0, 0); ESCAPE_DIRECTIONS];
    for (k, slot) in order.iter_mut().enumerate() {
        *slot = (-sphere_direction(k).dot(&u0), k as u16);
    }
    order.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
    let mut best: Option<(Real, Point)> = None;
    for &(_, k) in &order {
        let q = a + sphere_direction(k as usize) * len;
        let d = body
            .distance(CollisionMethod::Bvh, &q)
            .map_or(Real::INFINITY, |(d, _)| d);
        if d >= radius {
            return Some(q);
        }
        if best.is_none_or(|(b, _)| d > b) {
            best = Some((d, q));
        }
    }
    best.filter(|&(d, _)| -d < depth).map(|(_, q)| q)
}

/// Directions [`escape`] tries: enough that neighbours are about 15 degrees apart.
const ESCAPE_DIRECTIONS: usize = 192;

/// The `k`-th of [`ESCAPE_DIRECTIONS`] unit vectors on a Fibonacci sphere (evenly spread).
fn sphere_direction(k: usize) -> Vector {
    let golden = std::f32::consts::PI * (3.0 - 5.0f32.sqrt());
    let y = 1.0 - 2.0 * (k as Real + 0.5) / ESCAPE_DIRECTIONS as Real;
    let r = (1.0 - y * y).max(0.0).sqrt();
    let phi = golden * k as Real;
    Vector::new(r * phi.cos(), y, r * phi.sin())
}

/// Directions [`turn_out`] tries between a segment and the body's normal at its parent node.
const TURN_OUT_STEPS: usize = 8;

/// What a pass's test of a node found: the body within its reach (depth and normal), and the
/// clearance its query found.
type PassTest = (Option<(Real, Vector)>, Option<Clearance>);

/// What the hard constraint's sweeps last found at a node.
#[derive(Clone, Copy, Debug, Default)]
struct SweepHit {
    /// The body's normal where the node's sphere reached the body when last tested (its
    /// velocity constraint).
    normal: Option<Vector>,
    /// How deep its centre is inside the body where it ends, as far as tested (m; negative
    /// outside).
    depth: Real,
    /// Whether the present sweep tested it.
    tested: bool,
    /// Whether the sweep that last tested it moved it to a place it could not confirm clear.
    corrected: bool,
    /// The clearance a sweep's last query of it found (for the body and method of
    /// `BodyConstraint::clearance_key`).
    clearance: Clearance,
}

/// A node the hard body constraint tests, with the node before it on its skeleton.
#[derive(Clone, Copy, Debug)]
struct BodyNode {
    node: u32,
    /// The previous node of the skeleton, `u32::MAX` for a free root.
    prev: u32,
    skeleton: u32,
    radius: Real,
}

/// Where a rigid body part is over one step, in the hair's (head) frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PartMotion {
    /// Head from part at the end of the step: where the part is when the hair is tested.
    pub pose: Isometry3<Real>,
    /// Head from part at the start of the step (the surface's velocity is the change).
    pub previous: Isometry3<Real>,
    /// The step (s).
    pub dt: Real,
}

impl PartMotion {
    /// The velocity (head frame) of the part's material point that is at `p` at the end of the
    /// step: where it is less where it was, over the step.
    pub fn velocity_at(&self, p: &Point) -> Vector {
        let local = self.pose.inverse_transform_point(p);
        (p - self.previous * local) / self.dt
    }
}

/// A body as the constraint queries it: a mesh in the hair's frame, or a part's mesh in its own
/// frame posed in the hair's (positions in, normals out transformed).
struct Surface<'a> {
    body: &'a MeshBody,
    motion: Option<&'a PartMotion>,
}

impl Surface<'_> {
    /// Where `p` (hair frame) is in the body's own frame, where its distances are queried.
    #[inline]
    fn local(&self, p: &Point) -> Point {
        match self.motion {
            None => *p,
            Some(m) => m.pose.inverse_transform_point(p),
        }
    }

    /// [`MeshBody::distance_within_clearance`] at `local` (the body's frame), the normal in the
    /// hair frame.
    #[inline]
    fn distance_within_clearance(
        &self,
        method: CollisionMethod,
        local: &Point,
        reach: Real,
    ) -> (Option<(Real, Vector)>, Clearance) {
        let (hit, clearance) = self.body.distance_within_clearance(method, local, reach);
        match self.motion {
            None => (hit, clearance),
            Some(m) => (hit.map(|(d, n)| (d, m.pose.rotation * n)), clearance),
        }
    }

    /// [`MeshBody::distance_within`] at `p` (hair frame), the normal in the hair frame.
    #[inline]
    fn distance_within(
        &self,
        method: CollisionMethod,
        p: &Point,
        reach: Real,
    ) -> Option<(Real, Vector)> {
        match self.motion {
            None => self.body.distance_within(method, p, reach),
            Some(m) => {
                let local = m.pose.inverse_transform_point(p);
                let hit = self.body.distance_within(method, &local, reach);
                hit.map(|(d, n)| (d, m.pose.rotation * n))
            }
        }
    }

    /// [`MeshBody::distance`] at `p` (hair frame), the normal in the hair frame.
    #[inline]
    fn distance(&self, method: CollisionMethod, p: &Point) -> Option<(Real, Vector)> {
        match self.motion {
            None => self.body.distance(method, p),
            Some(m) => {
                let local = m.pose.inverse_transform_point(p);
                let hit = self.body.distance(method, &local);
                hit.map(|(d, n)| (d, m.pose.rotation * n))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hair_dynamics::{
        Environment, Material, Root, SkeletonDesc, StepSettings, Style, style_points,
    };
    use hair_ssv::wrinkled_torus;
    use nalgebra::{Rotation3, Translation3, UnitQuaternion};
    use proptest::prelude::*;

    /// A ring-shaped body at `centre`.
    fn torus(centre: Point) -> MeshBody {
        let (v, t) = wrinkled_torus(centre, 0.1, 0.03, 5, 0.15, 48, 16);
        MeshBody::new(v, t).expect("a valid torus")
    }

    /// Strands of 12 nodes, 0.2 m long, from `roots` (position, tilt about x and z from
    /// hanging straight down), through and around the torus's tube.
    fn strands(roots: &[(Point, Real, Real)]) -> StrandState {
        let mut state = StrandState::new();
        for &(root, tx, tz) in roots {
            let frame = Rotation3::from_euler_angles(std::f32::consts::FRAC_PI_2 + tx, 0.0, tz);
            state
                .add_skeleton(&SkeletonDesc {
                    root: Root::Attached {
                        position: root,
                        frame,
                    },
                    points: style_points(root, &frame, &Style::Straight, 12, 0.2).unwrap(),
                    material: Material::default(),
                })
                .unwrap();
        }
        state
    }

    /// Every node's place, velocity and angles, as bits.
    fn bits(state: &StrandState) -> Vec<u32> {
        let p = state
            .positions()
            .iter()
            .flat_map(|p| p.coords.iter().copied());
        let v = state.velocities().iter().flat_map(|v| v.iter().copied());
        let a = state.theta().iter().chain(state.phi()).copied();
        p.chain(v).chain(a).map(Real::to_bits).collect()
    }

    /// The same small moves of every third node of both states.
    fn nudge(states: [&mut StrandState; 2], seed: u64) {
        let mut corrections = Vec::new();
        let mut x = seed;
        let mut next = || {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((x >> 40) as Real / (1u64 << 24) as Real - 0.5) * 0.01
        };
        for node in (1..states[0].node_count() as u32).step_by(3) {
            corrections.push(NodeCorrection {
                node,
                delta: Vector::new(next(), next(), next()),
            });
        }
        for s in states {
            s.apply_corrections(&corrections).unwrap();
        }
    }

    /// Roots on five rings about the vertical through `centre`, 0.1 m above it, each strand
    /// tilted a little: the rings span the torus's tube and a little more each side.
    fn roots_around(centre: Point) -> Vec<(Point, Real, Real)> {
        let mut roots = Vec::new();
        for i in 0..24 {
            let a = std::f32::consts::TAU * i as Real / 24.0;
            for r in [0.07, 0.085, 0.1, 0.115, 0.13] {
                let p = centre + Vector::new(r * a.cos(), 0.1, r * a.sin());
                roots.push((p, 0.1 * (i % 3) as Real - 0.1, 0.05 * (i % 5) as Real - 0.1));
            }
        }
        roots
    }

    /// The ramp lasts only while a node is allowed inside: after a first step with the hair
    /// clear of the body, the next step through the body's tube moves the hair exactly as a
    /// step after the ramp does; after a first step with the hair through the tube, it does not
    /// (the nodes are held to the ramp).
    #[test]
    fn the_ramp_ends_once_no_node_is_held() {
        let centre = Point::new(0.0, -0.1, 0.0);
        let body = torus(centre);
        let settings = CollisionSettings::default();
        let after = u64::from(settings.depenetration_steps);
        let through = roots_around(centre);
        let clear = roots_around(centre + Vector::new(0.0, 1.0, 0.0));
        let front: Vec<u32> = (0..through.len() as u32).collect();
        let step_after_ramp = || {
            let mut state = strands(&through);
            let mut constraint = BodyConstraint::new();
            let report = constraint
                .apply(&mut state, &body, &front, after, &settings)
                .unwrap();
            assert!(report.contacts > 100, "{report:?}");
            bits(&state)
        };
        let second_step = |first: &[(Point, Real, Real)]| {
            let mut constraint = BodyConstraint::new();
            let mut state = strands(first);
            constraint
                .apply(&mut state, &body, &front, 0, &settings)
                .unwrap();
            let mut state = strands(&through);
            constraint
                .apply(&mut state, &body, &front, 1, &settings)
                .unwrap();
            bits(&state)
        };
        let expected = step_after_ramp();
        assert!(second_step(&clear) == expected, "the ramp went on");
        assert!(second_step(&through) != expected, "the ramp ended");
    }

    /// The late passes' exact tests are counted where the scene's method is approximate and
    /// the late passes switch to the exact distance, and only there: strands through the
    /// torus's tube, one sweep, then late passes over the 755 nodes still moving.
    #[test]
    fn exact_late_tests_are_counted() {
        let centre = Point::new(0.0, -0.1, 0.0);
        let body = torus(centre);
        let through = roots_around(centre);
        let front: Vec<u32> = (0..through.len() as u32).collect();
        let report = |method, exact_late_nodes| {
            let settings = CollisionSettings {
                depenetration_steps: 0,
                method,
                exact_late_nodes,
                body_passes: 1,
                sweep_retests: 0,
                ..CollisionSettings::default()
            };
            let mut state = strands(&through);
            let mut constraint = BodyConstraint::new();
            constraint
                .apply(&mut state, &body, &front, 0, &settings)
                .unwrap()
        };
        let switched = report(CollisionMethod::Field, 10_000);
        assert!(switched.exact_tests >= 755, "{switched:?}");
        // Too many nodes still moving for the switch, and a method that is exact already.
        assert_eq!(report(CollisionMethod::Field, 100).exact_tests, 0);
        assert_eq!(report(CollisionMethod::Bvh, 10_000).exact_tests, 0);
    }

    /// One constraint applied in turn to two bodies a little apart, to a clone of one whose
    /// structures were replaced by the other's, and by both methods, moves the hair exactly as
    /// a new constraint for each call does: no clearance found on one surface or by one method
    /// is used on another.
    #[test]
    fn clearances_are_not_used_across_surfaces_or_methods() {
        let a = torus(Point::new(0.0, -0.1, 0.0));
        let b = torus(Point::new(0.012, -0.1, 0.004));
        let mut replaced = a.clone();
        replaced.vertices = b.vertices.clone();
        replaced.triangles = b.triangles.clone();
        replaced.bvh = b.bvh.clone();
        replaced.near = b.near.clone();
        replaced.field = b.field.clone();
        replaced.pseudo_normals = b.pseudo_normals.clone();
        assert_ne!(replaced.identity(), a.identity());
        let roots = roots_around(Point::new(0.0, -0.1, 0.0));
        let (mut shared, mut fresh) = (strands(&roots), strands(&roots));
        let front: Vec<u32> = (0..roots.len() as u32).collect();
        let mut constraint = BodyConstraint::new();
        let (field, bvh) = (CollisionMethod::Field, CollisionMethod::Bvh);
        let calls = [
            (&a, field),
            (&b, field),
            (&a, field),
            (&replaced, field),
            (&a, field),
            (&a, bvh),
            (&a, field),
            (&b, bvh),
            (&b, field),
            (&a, field),
        ];
        let mut contacts = 0;
        for (k, &(body, method)) in calls.iter().cycle().take(30).enumerate() {
            let settings = CollisionSettings {
                depenetration_steps: 0,
                method,
                ..CollisionSettings::default()
            };
            let step = k as u64;
            let report = constraint
                .apply(&mut shared, body, &front, step, &settings)
                .unwrap();
            let expected = BodyConstraint::new()
                .apply(&mut fresh, body, &front, step, &settings)
                .unwrap();
            assert_eq!(report, expected, "call {k}");
            assert_eq!(bits(&shared), bits(&fresh), "call {k}");
            contacts += report.contacts;
            nudge([&mut shared, &mut fresh], k as u64);
        }
        assert!(contacts > 100, "{contacts} contacts");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Over random strands near a body, moved between calls, and the body still or posed
        /// as a moving part, the sweeps give the same bits with the clearances as without.
        #[test]
        fn clearances_change_no_result(
            roots in prop::collection::vec(
                ((-0.15f32..0.15, -0.02f32..0.12, -0.15f32..0.15), -0.4f32..0.4, -0.4f32..0.4),
                4..40,
            ),
            poses in prop::collection::vec(
                (any::<bool>(), -0.01f32..0.01, -0.2f32..0.2),
                6..12,
            ),
            seed in any::<u64>(),
            field in any::<bool>(),
            ramp in 0u32..4,
        ) {
            static BODY: std::sync::OnceLock<MeshBody> = std::sync::OnceLock::new();
            let body = BODY.get_or_init(|| torus(Point::new(0.0, -0.1, 0.0)));
            let roots: Vec<_> =
                roots.iter().map(|&((x, y, z), tx, tz)| (Point::new(x, y, z), tx, tz)).collect();
            let (mut with, mut without) = (strands(&roots), strands(&roots));
            let front: Vec<u32> = (0..roots.len() as u32).collect();
            let mut cached = BodyConstraint::new();
            let mut plain = BodyConstraint { clearance_off: true, ..BodyConstraint::new() };
            // With a ramp, its first steps test every node in passes, not in sweeps.
            let settings = CollisionSettings {
                depenetration_steps: ramp,
                method: if field { CollisionMethod::Field } else { CollisionMethod::Bvh },
                ..CollisionSettings::default()
            };
            let mut previous = Isometry3::identity();
            for (k, &(moving, shift, turn)) in poses.iter().enumerate() {
                let step = k as u64;
                let (x, y) = if moving {
                    let pose = Isometry3::from_parts(
                        Translation3::new(shift, 0.5 * shift, 0.0),
                        UnitQuaternion::from_euler_angles(0.0, turn, 0.0),
                    );
                    let motion = PartMotion { pose, previous, dt: 1.0 / 60.0 };
                    previous = pose;
                    (
                        cached.apply_moving(&mut with, body, &motion, &front, step, &settings),
                        plain.apply_moving(&mut without, body, &motion, &front, step, &settings),
                    )
                } else {
                    (
                        cached.apply(&mut with, body, &front, step, &settings),
                        plain.apply(&mut without, body, &front, step, &settings),
                    )
                };
                prop_assert_eq!(x.unwrap(), y.unwrap(), "call {}", k);
                prop_assert_eq!(bits(&with), bits(&without), "call {}", k);
                // A step between calls, so that the turns the passes take back act on rates.
                for s in [&mut with, &mut without] {
                    s.step(&Environment::default(), &StepSettings::default()).unwrap();
                }
                nudge([&mut with, &mut without], seed.wrapping_add(k as u64));
            }
        }
    }
}
