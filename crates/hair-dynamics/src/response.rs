//! Collision response on the angular model: position corrections and velocity constraints on
//! nodes, mapped back to angles from root to tip with segment lengths kept.
//!
//! Ward & Lin §5.4 move a penetrating section out along the normal and remove its normal
//! velocity; Kurihara et al. §3.2 constrain the velocity with friction. In angle coordinates a
//! node cannot move alone: each segment is re-aimed at its corrected target in turn.

use crate::bend::{Bend, bend_between};
use crate::run::{GRAIN_SKELETONS, Run, for_each_skeleton};
use crate::{DynamicsError, Point, Real, StrandState, Vector};
use nalgebra::Matrix3;
use std::ops::Range;

/// Move a node by `delta` (m, head frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeCorrection {
    /// Global node index.
    pub node: u32,
    /// Displacement wanted.
    pub delta: Vector,
}

/// Remove the velocity of a node into a surface and apply friction along it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityConstraint {
    /// Global node index.
    pub node: u32,
    /// Unit surface normal, pointing away from the obstacle.
    pub normal: Vector,
    /// Coulomb friction coefficient in [0, 1].
    pub friction: Real,
}

/// Re-aims every segment of a strand at `targets` in turn, keeping `length`, and writes the angles.
pub(crate) fn fit_angles(
    frame: &Matrix3<Real>,
    root: Point,
    targets: &[Point],
    length: &[Real],
    theta: &mut [Real],
    phi: &mut [Real],
) {
    let mut rot = *frame;
    let mut prev = root;
    for i in 1..targets.len() {
        let (x, y) = aim(&rot, &prev, &targets[i], (theta[i], phi[i]));
        theta[i] = x;
        phi[i] = y;
        rot *= Bend::new(x, y).rotation;
        prev += rot.column(2) * length[i];
    }
}

/// The bend that aims a segment starting at `from`, in the parent frame `rot`, at `target`;
/// `keep` where the two points coincide.
#[inline]
fn aim(rot: &Matrix3<Real>, from: &Point, target: &Point, keep: (Real, Real)) -> (Real, Real) {
    let d = target - from;
    let norm = d.norm();
    if norm > 0.0 && norm.is_finite() {
        bend_between(&(rot.transpose() * (d / norm)))
    } else {
        keep
    }
}

/// [`fit_angles`] on skeleton `s` (nodes `r` of `run`), then its node positions and velocities
/// from the new angles, in one pass: the same arithmetic as `fit_angles` followed by
/// `Run::refresh`, with each bend evaluated once instead of twice. Node `k` of the skeleton aims
/// at `targets[k]` where `moved[k]`, else at where it is.
///
/// Measured and dropped: two skeletons refitted side by side, node by node, so that one chain
/// of arctangent, sine and cosine could run while the other waits (bit-identical). The first
/// body pass's refit on `wardlin` (about 6,800 corrections) took 0.87-0.90 ms against
/// 0.91-0.96 ms (fastest of 50 steps, three alternated rounds; medians equal): the chains were
/// not what it waits on.
fn refit_skeleton(run: &mut Run<'_>, s: usize, r: Range<usize>, targets: &[Point], moved: &[bool]) {
    let mut chain = Refit::from_root(run, s, r.start);
    for (k, i) in r.clone().enumerate().skip(1) {
        // Node `i` is read before it is written below, and later nodes are not yet written.
        let target = if moved[k] {
            targets[k]
        } else {
            run.positions[i]
        };
        let (x, y) = aim(
            &chain.rot,
            &chain.position,
            &target,
            (run.theta[i], run.phi[i]),
        );
        chain.joint(run, i, (x, y), &Bend::new(x, y));
    }
}

/// A refit in progress, root to tip: the frame, place and velocity of the last node written,
/// and the angular velocity summed to it.
struct Refit {
    rot: Matrix3<Real>,
    position: Point,
    velocity: Vector,
    omega: Vector,
}

impl Refit {
    /// From skeleton `s`'s root (its node `root` in `run`), which it writes.
    #[inline(always)]
    fn from_root(run: &mut Run<'_>, s: usize, root: usize) -> Self {
        let rs = &run.roots[s - run.first];
        let velocity = if rs.free {
            rs.velocity
        } else {
            Vector::zeros()
        };
        let chain = Self {
            rot: rs.rotation,
            position: rs.position,
            velocity,
            omega: Vector::zeros(),
        };
        run.positions[root] = chain.position;
        run.velocities[root] = velocity;
        chain
    }

    /// Node `i` with the angles `(x, y)` and their `bend`: its angles, place and velocity
    /// written, the chain advanced past it.
    #[inline(always)]
    fn joint(&mut self, run: &mut Run<'_>, i: usize, (x, y): (Real, Real), bend: &Bend<Real>) {
        run.theta[i] = x;
        run.phi[i] = y;
        let ax = self.rot * bend.axis_x;
        let ay = self.rot * bend.axis_y;
        self.rot *= bend.rotation;
        let segment = self.rot.column(2).into_owned() * run.length[i];
        self.omega += ax * run.omega_theta[i] + ay * run.omega_phi[i];
        self.position += segment;
        self.velocity += self.omega.cross(&segment);
        run.positions[i] = self.position;
        run.velocities[i] = self.velocity;
    }
}

/// The velocity constraints on skeleton `s` (nodes `r` of `run`), `group` their indices into
/// `constraints` sorted by node (stably: a node's constraints in their order), then its node
/// positions and velocities from its angles and rates. Up to [`MAX_CHAIN`] nodes the contacts
/// are impulses through the whole chain ([`constrain_chain`]); a longer skeleton has each taken
/// by its own joint, in one pass root to tip as follows. Each joint's
/// bend is evaluated once, for the constraints on its node and for the refresh: the same
/// arithmetic as the joint axes, the constraints and `Run::refresh` one after the other (a
/// constraint changes only its own joint's rates, which the refresh reads after it, and reads
/// the positions from before the refresh).
fn constrain_and_refresh(
    run: &mut Run<'_>,
    s: usize,
    r: Range<usize>,
    group: &[u32],
    constraints: &[VelocityConstraint],
    surface: Option<&[Vector]>,
    inverse_inertia: &[Real],
) {
    if r.len() <= MAX_CHAIN {
        let contacts = Contacts {
            group,
            constraints,
            surface,
        };
        constrain_chain(run, s, r.clone(), &contacts, inverse_inertia);
        refresh_skeleton(run, s, r);
        return;
    }
    let lo = r.start;
    let base = run.node_base;
    let node_of = |ci: u32| constraints[ci as usize].node as usize - base;
    let mut next = 0;
    // A root: only a free root moves, and it moves with its velocity.
    while next < group.len() && node_of(group[next]) == lo {
        let c = &constraints[group[next] as usize];
        let root = &mut run.roots[s - run.first];
        if root.free {
            let n = c.normal.try_normalize(1e-12).unwrap_or_else(Vector::zeros);
            match surface {
                None => {
                    let v = root.velocity;
                    let vn = v.dot(&n);
                    if vn < 0.0 {
                        root.velocity = (v - n * vn) * (1.0 - c.friction.min(1.0));
                    }
                }
                Some(surface) => {
                    let at = surface[group[next] as usize];
                    if let Some((normal, friction)) =
                        surface_change(&(root.velocity - at), &n, c.friction)
                    {
                        root.velocity += normal + friction;
                    }
                }
            }
        }
        next += 1;
    }
    let root = &run.roots[s - run.first];
    let mut rot = root.rotation;
    let mut position = root.position.coords;
    let mut velocity = if root.free {
        root.velocity
    } else {
        Vector::zeros()
    };
    let mut omega = Vector::zeros();
    let mut before = run.positions[lo];
    run.positions[lo] = Point::from(position);
    run.velocities[lo] = velocity;
    for i in lo + 1..r.end {
        let bend = Bend::new(run.theta[i], run.phi[i]);
        let ax = rot * bend.axis_x;
        let ay = rot * bend.axis_y;
        let here = run.positions[i];
        let segment = here - before;
        let joint = JointAxes {
            x: &ax,
            y: &ay,
            segment: &segment,
        };
        while next < group.len() && node_of(group[next]) == i {
            let k = group[next] as usize;
            match surface {
                None => constrain_joint(run, i, &segment, &ax, &ay, &constraints[k]),
                Some(surface) => {
                    // The node's velocity from its parent's motion, its own joint aside.
                    let carried = velocity + omega.cross(&segment);
                    let contact = SurfaceContact {
                        constraint: &constraints[k],
                        surface: &surface[k],
                        carried: &carried,
                        end: r.end,
                    };
                    constrain_joint_on_surface(run, i, &joint, &contact);
                }
            }
            next += 1;
        }
        rot *= bend.rotation;
        let segment = rot.column(2).into_owned() * run.length[i];
        omega += ax * run.omega_theta[i] + ay * run.omega_phi[i];
        position += segment;
        velocity += omega.cross(&segment);
        run.positions[i] = Point::from(position);
        run.velocities[i] = velocity;
        before = here;
    }
}

/// Longest skeleton (nodes) whose contacts [`constrain_chain`] takes through its whole chain;
/// a longer one has each contact taken by its own joint ([`constrain_joint`]).
const MAX_CHAIN: usize = 64;

/// Rounds of [`constrain_chain`] over a skeleton's contacts: an impulse turns the joints above
/// its node, and so moves the contacts nearer the root, which the next round sees again.
const CONTACT_ROUNDS: usize = 3;

/// The velocity constraints on skeleton `s` (nodes `r` of `run`, at most [`MAX_CHAIN`]), as
/// impulses on the constrained nodes taken by every joint between the root and the node, on
/// the velocity relative to each contact's surface (still, or moving at `contacts.surface`),
/// in the model's own inertia (`inverse_inertia`, per node slot: the inverse of
/// the joint's diagonal inertia, as the step uses it).
///
/// An impulse `p` at a node turns joint `j` by `I_j^-1 J_j^T p` (`J_j`: how the joint's two
/// rates move the node), so the node's velocity changes by `A p`, `A = sum_j J_j I_j^-1 J_j^T`.
/// The normal impulse `p = n lambda` with `lambda = -(v . n) / (n . A n)` removes the approach;
/// the friction impulse along the remaining slide `t`, at most the coefficient times `lambda`
/// and at most what stops the slide (`|v_t| / (t . A t)`), slows it. Each lowers the kinetic
/// energy `sum_j I_j |w_j|^2 / 2` by `(v . n)^2 / (2 n . A n)` and at least nothing. Taken by
/// its own joint alone, as until 2026-12, a contact left the joints above it driving the node
/// into the body and sliding it along: hair lying on the head crept and swung for seconds.
fn constrain_chain(
    run: &mut Run<'_>,
    s: usize,
    r: Range<usize>,
    contacts: &Contacts<'_>,
    inverse_inertia: &[Real],
) {
    let Contacts {
        group,
        constraints,
        surface,
    } = *contacts;
    let (lo, n) = (r.start, r.len());
    let base = run.node_base;
    // World axes of each joint (index within the skeleton; the root's unused).
    let mut axis_x = [Vector::zeros(); MAX_CHAIN];
    let mut axis_y = [Vector::zeros(); MAX_CHAIN];
    let root = &run.roots[s - run.first];
    let free = root.free;
    let mut rot = root.rotation;
    for k in 1..n {
        let bend = Bend::new(run.theta[lo + k], run.phi[lo + k]);
        axis_x[k] = rot * bend.axis_x;
        axis_y[k] = rot * bend.axis_y;
        rot *= bend.rotation;
    }
    for _ in 0..CONTACT_ROUNDS {
        for &ci in group {
            let c = &constraints[ci as usize];
            let normal = c.normal.try_normalize(1e-12).unwrap_or_else(Vector::zeros);
            let k = c.node as usize - base - lo;
            let moving = surface.map_or_else(Vector::zeros, |v| v[ci as usize]);
            if k == 0 {
                // A free root moves with its own velocity; an attached one does not move.
                let root = &mut run.roots[s - run.first];
                if free
                    && let Some((n, f)) =
                        surface_change(&(root.velocity - moving), &normal, c.friction)
                {
                    root.velocity += n + f;
                }
                continue;
            }
            let at = run.positions[lo + k];
            let lever = |j: usize| at - run.positions[lo + j - 1];
            let weight = |j: usize| inverse_inertia[base + lo + j];
            let mut velocity = if free {
                run.roots[s - run.first].velocity
            } else {
                Vector::zeros()
            };
            let mut response = Matrix3::zeros();
            for j in 1..=k {
                let arm = lever(j);
                let (cx, cy) = (axis_x[j].cross(&arm), axis_y[j].cross(&arm));
                velocity += cx * run.omega_theta[lo + j] + cy * run.omega_phi[lo + j];
                response += (cx * cx.transpose() + cy * cy.transpose()) * weight(j);
            }
            // Relative to the surface from here on.
            velocity -= moving;
            let approach = velocity.dot(&normal);
            let stiffness = normal.dot(&(response * normal));
            if approach >= 0.0 || stiffness <= 0.0 {
                continue;
            }
            let lambda = -approach / stiffness;
            let mut impulse = normal * lambda;
            let slide = {
                let v = velocity + response * impulse;
                v - normal * v.dot(&normal)
            };
            let speed = slide.norm();
            if speed > 0.0 {
                let t = slide / speed;
                let t_stiffness = t.dot(&(response * t));
                if t_stiffness > 0.0 {
                    let stop = speed / t_stiffness;
                    impulse -= t * stop.min(c.friction * lambda);
                }
            }
            if !impulse.iter().all(|x| x.is_finite()) {
                continue;
            }
            for j in 1..=k {
                let arm = lever(j);
                let w = weight(j);
                run.omega_theta[lo + j] += axis_x[j].cross(&arm).dot(&impulse) * w;
                run.omega_phi[lo + j] += axis_y[j].cross(&arm).dot(&impulse) * w;
            }
        }
    }
}

/// A skeleton's contacts as [`constrain_chain`] takes them: indices into `constraints`
/// (ascending by node) and, against moving surfaces, each constraint's surface velocity.
#[derive(Clone, Copy)]
struct Contacts<'a> {
    group: &'a [u32],
    constraints: &'a [VelocityConstraint],
    surface: Option<&'a [Vector]>,
}

/// Skeleton `s`'s node positions and velocities from its angles and rates (nodes `r` of `run`).
fn refresh_skeleton(run: &mut Run<'_>, s: usize, r: Range<usize>) {
    let mut chain = Refit::from_root(run, s, r.start);
    for i in r.start + 1..r.end {
        let (x, y) = (run.theta[i], run.phi[i]);
        chain.joint(run, i, (x, y), &Bend::new(x, y));
    }
}

/// `rate` moved by `change` where that brings it toward zero, never past it.
#[inline]
fn toward_zero(rate: Real, change: Real) -> Real {
    if rate * change >= 0.0 {
        rate
    } else if change.abs() >= rate.abs() {
        0.0
    } else {
        rate + change
    }
}

/// Removes the approach of node `i` (its segment `r` from the node before it) along the
/// constraint's normal that its own joint (world axes `ax`, `ay`) causes, and applies friction.
fn constrain_joint(
    run: &mut Run<'_>,
    i: usize,
    r: &Vector,
    ax: &Vector,
    ay: &Vector,
    c: &VelocityConstraint,
) {
    let n = c.normal.try_normalize(1e-12).unwrap_or_else(Vector::zeros);
    // Normal velocity of the node due to its own joint: g . w, g = (n . (ax x r), n . (ay x r)).
    let (gx, gy) = (n.dot(&ax.cross(r)), n.dot(&ay.cross(r)));
    let (wx, wy) = (run.omega_theta[i], run.omega_phi[i]);
    let into = gx * wx + gy * wy;
    let g2 = gx * gx + gy * gy;
    if into < 0.0 && g2 > 0.0 {
        let (px, py) = (wx - gx * into / g2, wy - gy * into / g2);
        let removed = ((wx - px).powi(2) + (wy - py).powi(2)).sqrt();
        let left = (px * px + py * py).sqrt();
        let keep = if left > 0.0 {
            (1.0 - c.friction.min(1.0) * removed / left).max(0.0)
        } else {
            0.0
        };
        run.omega_theta[i] = px * keep;
        run.omega_phi[i] = py * keep;
    }
}

/// A joint's two axes (world) and the segment it turns (from its parent node to its node).
struct JointAxes<'a> {
    x: &'a Vector,
    y: &'a Vector,
    segment: &'a Vector,
}

/// Tikhonov weight of the rate change [`JointAxes::fit_rates`] fits, as a share of the trace
/// of the joint's normal matrix. It bounds the change of the joint's rates to about
/// 3.5 |change| / |segment| where the joint can hardly move its node the way asked (an axis
/// along the segment), and costs about 2 % of the change where it moves it freely.
const SURFACE_FIT_WEIGHT: Real = 0.01;

/// The change of a node's velocity that a contact with a surface moving at the velocity that
/// leaves `relative` (the node's velocity less the surface's) asks for, as its part along the
/// unit normal `n` (the approach removed) and its part along the surface (the sliding slowed by
/// Coulomb friction: the coefficient times the approach removed, at most to rest on the
/// surface). `None` when the node is not approaching.
#[inline]
fn surface_change(relative: &Vector, n: &Vector, friction: Real) -> Option<(Vector, Vector)> {
    let approach = relative.dot(n);
    if approach >= 0.0 || n.norm_squared() == 0.0 {
        return None;
    }
    let slide = relative - n * approach;
    let speed = slide.norm();
    let stop = if speed > 0.0 {
        (friction.min(1.0) * -approach / speed).min(1.0)
    } else {
        0.0
    };
    Some((-(n * approach), -(slide * stop)))
}

/// A contact of a node with a moving surface, as [`constrain_joint_on_surface`] takes it.
struct SurfaceContact<'a> {
    constraint: &'a VelocityConstraint,
    /// The surface's velocity where the node is.
    surface: &'a Vector,
    /// The node's velocity from its parent's motion, its own joint aside.
    carried: &'a Vector,
    /// One past the skeleton's last node (run-local).
    end: usize,
}

/// [`constrain_joint`] against a moving surface: node `i` loses its approach to the surface and
/// friction slows its sliding relative to the surface ([`surface_change`]), through its own
/// joint's rates (the friction by [`JointAxes::fit_rates`]); the nodes beyond follow rigidly,
/// as they do from `constrain_joint`.
///
/// The friction's change is scaled by the node's share of the joint's moment of inertia about
/// its parent (nodes weighted by their segments' lengths): friction is an impulse on the node,
/// and turning the joint turns everything beyond it. Given in full, a node near the root
/// dragged by a sliding part swung the whole strand with it, its tip ten segments out ten times
/// as fast as the surface, and friction at the nodes beyond, slowing only what slides, could
/// not stop it (measured: tips carried 11.5 cm by a box that moved 10 cm). So scaled, no node
/// beyond gets a larger change than the node itself. The approach is removed in full, as
/// `constrain_joint` removes it.
fn constrain_joint_on_surface(
    run: &mut Run<'_>,
    i: usize,
    joint: &JointAxes<'_>,
    contact: &SurfaceContact<'_>,
) {
    let c = contact.constraint;
    let n = c.normal.try_normalize(1e-12).unwrap_or_else(Vector::zeros);
    let (wx, wy) = (run.omega_theta[i], run.omega_phi[i]);
    let (c1, c2) = (joint.x.cross(joint.segment), joint.y.cross(joint.segment));
    let relative = contact.carried + c1 * wx + c2 * wy - contact.surface;
    let Some((normal, friction)) = surface_change(&relative, &n, c.friction) else {
        return;
    };
    // The approach: the smallest rate change that moves the node along the normal by it, as
    // `constrain_joint` removes it (regularised like the fit).
    let (gx, gy) = (n.dot(&c1), n.dot(&c2));
    let lambda = SURFACE_FIT_WEIGHT * (c1.norm_squared() + c2.norm_squared());
    let lift = normal.norm() / (gx * gx + gy * gy + lambda);
    let (nx, ny) = if lift.is_finite() {
        (gx * lift, gy * lift)
    } else {
        (0.0, 0.0)
    };
    let pivot = run.positions[i - 1];
    let reach = |j: usize| run.length[j] * (run.positions[j] - pivot).norm_squared();
    let inertia: Real = (i..contact.end).map(reach).sum();
    let share = if inertia > 0.0 {
        reach(i) / inertia
    } else {
        0.0
    };
    let (fx, fy) = joint.fit_rates(&(friction * share));
    run.omega_theta[i] = wx + nx + fx;
    run.omega_phi[i] = wy + ny + fy;
}

impl JointAxes<'_> {
    /// The change of the joint's two rates that best changes its node's velocity by `change`:
    /// least squares regularised by [`SURFACE_FIT_WEIGHT`]; none for a segment of no length.
    #[inline]
    fn fit_rates(&self, change: &Vector) -> (Real, Real) {
        let (c1, c2) = (self.x.cross(self.segment), self.y.cross(self.segment));
        let (a11, a12, a22) = (c1.dot(&c1), c1.dot(&c2), c2.dot(&c2));
        let lambda = SURFACE_FIT_WEIGHT * (a11 + a22);
        if lambda <= 0.0 {
            return (0.0, 0.0);
        }
        let (a11, a22) = (a11 + lambda, a22 + lambda);
        let (b1, b2) = (c1.dot(change), c2.dot(change));
        let det = a11 * a22 - a12 * a12;
        ((a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det)
    }
}

impl StrandState {
    /// Moves nodes by the given displacements and refits the angles of every skeleton touched,
    /// root to tip, keeping segment lengths. Roots of attached skeletons do not move.
    pub fn apply_corrections(
        &mut self,
        corrections: &[NodeCorrection],
    ) -> Result<(), DynamicsError> {
        let count = self.theta.len();
        for c in corrections {
            if c.node as usize >= count {
                return Err(DynamicsError::UnknownNode {
                    node: c.node as usize,
                    count,
                });
            }
            crate::error::finite_vec("correction.delta", &c.delta)?;
        }
        // Only the corrected nodes get a target; the others aim where they are. (Copying every
        // position into the targets cost as much as a small refit, pass after pass.)
        let mut targets = std::mem::take(&mut self.target_scratch);
        let mut moved = std::mem::take(&mut self.moved_scratch);
        if moved.len() < count {
            moved.resize(count, false);
            targets.resize(count, Point::origin());
        }
        for c in corrections {
            let i = c.node as usize;
            if !moved[i] {
                moved[i] = true;
                targets[i] = self.positions[i];
            }
            targets[i] += c.delta;
        }
        let mut touched = std::mem::take(&mut self.touched_scratch);
        self.touched_skeletons(corrections.iter().map(|c| c.node), &mut touched);
        // Skeletons are independent: refit them in parallel.
        let (run, offsets, counts) = self.run_with_layout();
        let (targets_ref, moved_ref, touched_ref) = (&targets, &moved, &touched);
        for_each_skeleton(run, &touched, offsets, &|run, k| {
            let s = touched_ref[k] as usize;
            let r = run.local_nodes(s, offsets, counts);
            let g = offsets[s] as usize..offsets[s] as usize + r.len();
            let here = run.positions[r.start];
            let root = &mut run.roots[s - run.first];
            if root.free {
                // A free root follows its correction like any node.
                root.position = if moved_ref[g.start] {
                    targets_ref[g.start]
                } else {
                    here
                };
            }
            refit_skeleton(run, s, r, &targets_ref[g.clone()], &moved_ref[g]);
        });
        for c in corrections {
            moved[c.node as usize] = false;
        }
        self.moved_scratch = moved;
        self.target_scratch = targets;
        self.touched_scratch = touched;
        Ok(())
    }

    /// Projects nodes onto a position constraint root to tip, skeleton by skeleton, in one pass:
    /// the hard body constraint's sweep. Each chain `[skeleton, from]` (sorted by skeleton, one
    /// per skeleton) asks `project(&ask, &mut out[node])` about nodes `from..` of its skeleton
    /// (`from` counted within the skeleton) in order, with [`SweepAsk`] telling which node and
    /// where it is given every correction made before it. `Some(target)` re-aims the node's
    /// joint at `target` (its segment keeps its length, so the node reaches the target's
    /// direction from its parent; a free root moves to it, a fixed one stays). From
    /// the first corrected node on, the skeleton is refitted as
    /// [`StrandState::apply_corrections`] would (each later node aims at where it was, from its
    /// parent's new place) and every later node is asked at its new place, so a chain leaves the
    /// sweep with every node tested where it ends. `first_moved[k]` gets the first node chain `k`
    /// moved, or `u32::MAX`.
    ///
    /// Chains run in parallel over disjoint skeletons and each depends on its own skeleton alone,
    /// so the result does not depend on the thread count. A non-finite target is not applied; the
    /// sweep finishes and returns [`DynamicsError::InvalidNode`] for the first chain that gave
    /// one.
    pub fn sweep_chains<E, F>(
        &mut self,
        chains: &[[u32; 2]],
        out: &mut [E],
        first_moved: &mut [u32],
        project: F,
    ) -> Result<(), DynamicsError>
    where
        E: Send,
        F: Fn(&SweepAsk<'_>, &mut E) -> Option<Point> + Sync,
    {
        let count = self.theta.len();
        if out.len() != count || first_moved.len() != chains.len() {
            return Err(DynamicsError::UnknownNode {
                node: out.len().max(first_moved.len()),
                count,
            });
        }
        let mut last = None;
        for &[s, from] in chains {
            let (s, from) = (s as usize, from as usize);
            if s >= self.offsets.len() || last.is_some_and(|l| l >= s) {
                return Err(DynamicsError::UnknownSkeleton { skeleton: s });
            }
            last = Some(s);
            if from >= self.counts[s] as usize {
                return Err(DynamicsError::UnknownNode {
                    node: self.offsets[s] as usize + from,
                    count,
                });
            }
        }
        let bad = std::sync::Mutex::new(None::<(usize, usize, Real)>);
        let (run, offsets, counts) = self.run_with_layout();
        let job = SweepJob {
            offsets,
            counts,
            project: &project,
            bad: &bad,
        };
        job.split(run, out, chains, first_moved, 0);
        match bad.into_inner().unwrap_or_else(|e| e.into_inner()) {
            Some((skeleton, node, value)) => Err(DynamicsError::InvalidNode {
                skeleton,
                node,
                field: "sweep target",
                value: f64::from(value),
                expected: "finite",
            }),
            None => Ok(()),
        }
    }

    /// Applies velocity constraints as impulses on the constrained nodes, taken by every joint
    /// between the root and the node in the model's inertia: the node loses its approach to
    /// the surface and friction slows its sliding (Coulomb on the impulses), and neither raises
    /// the kinetic energy (`constrain_chain`). A skeleton's contacts are taken root to tip,
    /// three rounds. Node velocities are then recomputed from the rates. (A skeleton of more
    /// than 64 nodes has each contact taken by its own joint alone.)
    pub fn apply_velocity_constraints(
        &mut self,
        constraints: &[VelocityConstraint],
    ) -> Result<(), DynamicsError> {
        self.constrain_velocities(constraints, None)
    }

    /// [`StrandState::apply_velocity_constraints`] against moving surfaces: `surface[k]` is the
    /// velocity (head frame) of the surface of `constraints[k]` where its node is. A node
    /// approaching its surface loses the approach relative to it, and friction slows its
    /// sliding relative to it, so a surface moving along itself drags the nodes resting on it
    /// and one moving out pushes them, by the same impulses as
    /// [`StrandState::apply_velocity_constraints`]. A `surface` of another length than
    /// `constraints` is an error, as is a non-finite velocity; either way nothing changes.
    pub fn apply_velocity_constraints_on_surfaces(
        &mut self,
        constraints: &[VelocityConstraint],
        surface: &[Vector],
    ) -> Result<(), DynamicsError> {
        if surface.len() != constraints.len() {
            return Err(DynamicsError::OutOfRange {
                name: "surface velocities (count)",
                value: surface.len() as f64,
                expected: "one per velocity constraint",
            });
        }
        for v in surface {
            crate::error::finite_vec("surface velocity", v)?;
        }
        self.constrain_velocities(constraints, Some(surface))
    }

    fn constrain_velocities(
        &mut self,
        constraints: &[VelocityConstraint],
        surface: Option<&[Vector]>,
    ) -> Result<(), DynamicsError> {
        let count = self.theta.len();
        for c in constraints {
            if c.node as usize >= count {
                return Err(DynamicsError::UnknownNode {
                    node: c.node as usize,
                    count,
                });
            }
            crate::error::finite_vec("constraint.normal", &c.normal)?;
            crate::error::non_negative("constraint.friction", c.friction)?;
        }
        // Group the constraints by skeleton, keeping their order within each: a skeleton's
        // constraints are taken in turn, and skeletons in parallel.
        let mut order = std::mem::take(&mut self.order_scratch);
        let mut groups = std::mem::take(&mut self.group_scratch);
        let mut touched = std::mem::take(&mut self.touched_scratch);
        // A counting sort by skeleton: the touched skeletons ascending, then each constraint
        // placed in its skeleton's group in its original order.
        self.touched_skeletons(constraints.iter().map(|c| c.node), &mut touched);
        groups.clear();
        groups.resize(touched.len() + 1, 0);
        for (g, &s) in touched.iter().enumerate() {
            self.slot_scratch[s as usize] = g as u32;
        }
        for c in constraints {
            let s = self.node_skeleton[c.node as usize];
            groups[self.slot_scratch[s as usize] as usize + 1] += 1;
        }
        for g in 1..groups.len() {
            groups[g] += groups[g - 1];
        }
        order.clear();
        order.resize(constraints.len(), 0);
        // Each group's start serves as its cursor.
        for (k, c) in constraints.iter().enumerate() {
            let g = self.slot_scratch[self.node_skeleton[c.node as usize] as usize] as usize;
            order[groups[g] as usize] = k as u32;
            groups[g] += 1;
        }
        // The cursors ran to the ends of their groups: shift back to the starts.
        for g in (1..groups.len()).rev() {
            groups[g] = groups[g - 1];
        }
        groups[0] = 0;
        for &s in &touched {
            self.slot_scratch[s as usize] = u32::MAX;
        }
        // Within each group, by node; a node's constraints keep their order (a group lists
        // them ascending, so the index breaks ties as a stable sort would).
        sort_groups_by_node(&mut order, &groups, constraints);
        let mut inverse_inertia = std::mem::take(&mut self.inertia_scratch);
        self.inverse_joint_inertia(&touched, &mut inverse_inertia);
        let (run, offsets, counts) = self.run_with_layout();
        let (order_ref, groups_ref, touched_ref) = (&order, &groups, &touched);
        let inertia_ref = &inverse_inertia;
        for_each_skeleton(run, &touched, offsets, &|run, k| {
            let s = touched_ref[k] as usize;
            let r = run.local_nodes(s, offsets, counts);
            let group = &order_ref[groups_ref[k] as usize..groups_ref[k + 1] as usize];
            constrain_and_refresh(run, s, r, group, constraints, surface, inertia_ref);
        });
        self.order_scratch = order;
        self.group_scratch = groups;
        self.touched_scratch = touched;
        self.inertia_scratch = inverse_inertia;
        Ok(())
    }

    /// Per node slot of the skeletons listed, the inverse of its joint's inertia as the step
    /// uses it with the chain torque (the dry and wet mass beyond the joint about its pivot, in
    /// the rest shape, floored at `1e-2 m l^2`), into `out`, grown to the node count.
    fn inverse_joint_inertia(&self, skeletons: &[u32], out: &mut Vec<Real>) {
        if out.len() < self.theta.len() {
            out.resize(self.theta.len(), 0.0);
        }
        self.fill_inverse_joint_inertia(skeletons, out, 0);
    }

    /// [`StrandState::inverse_joint_inertia`] of `skeletons` (ascending) into `out`, whose first
    /// slot is node `base`: in parallel over halves of the list, each writing its own nodes.
    fn fill_inverse_joint_inertia(&self, skeletons: &[u32], out: &mut [Real], base: usize) {
        if skeletons.len() > crate::run::GRAIN_SKELETONS {
            let half = skeletons.len() / 2;
            let mid = self.offsets[skeletons[half] as usize] as usize;
            let (left, right) = out.split_at_mut(mid - base);
            rayon::join(
                || self.fill_inverse_joint_inertia(&skeletons[..half], left, base),
                || self.fill_inverse_joint_inertia(&skeletons[half..], right, mid),
            );
            return;
        }
        for &s in skeletons {
            let r = self.nodes(crate::SkeletonId(s));
            // Suffix sums from the tip, in f64: sum m, sum m p, sum m |p|^2.
            let (mut m0, mut m1, mut m2) = (0.0f64, nalgebra::Vector3::<f64>::zeros(), 0.0f64);
            for i in (r.start + 1..r.end).rev() {
                let m = f64::from(self.mass[i] + self.wetness[i]);
                let p = self.rest_points[i].cast::<f64>();
                m0 += m;
                m1 += p * m;
                m2 += m * p.norm_squared();
                let c = self.rest_points[i - 1].cast::<f64>();
                let chain = m2 - 2.0 * c.dot(&m1) + m0 * c.norm_squared();
                let floor = 1e-2 * m * f64::from(self.length[i]).powi(2);
                let inertia = chain.max(floor);
                out[i - base] = if inertia > 0.0 {
                    (1.0 / inertia) as Real
                } else {
                    0.0
                };
            }
        }
    }

    /// Takes back from the joint rates the turns made since `theta` and `phi` were recorded
    /// (per node, as [`StrandState::theta`] and [`StrandState::phi`] were), on the skeletons
    /// listed (ascending): where a joint was turned against its rate, as when a push-out undoes
    /// the last step's motion into a surface, its rate shrinks by that turn over the last step's
    /// length, never past zero. A turn along the rate changes nothing, so nothing speeds up.
    /// The nodes' velocities are then recomputed from the rates. Without it, a rate that drove a
    /// node into the body survived the push-out unchanged, drove it in again the next step, and
    /// hair lying on the body never came to rest. Before the first step it changes nothing.
    pub fn absorb_turns(
        &mut self,
        theta: &[Real],
        phi: &[Real],
        skeletons: &[u32],
    ) -> Result<(), DynamicsError> {
        let count = self.theta.len();
        if theta.len() != count || phi.len() != count {
            return Err(DynamicsError::OutOfRange {
                name: "recorded angles (count)",
                value: theta.len().min(phi.len()) as f64,
                expected: "one per node slot",
            });
        }
        if let Some(&s) = skeletons
            .iter()
            .find(|&&s| s as usize >= self.offsets.len())
        {
            return Err(DynamicsError::UnknownSkeleton {
                skeleton: s as usize,
            });
        }
        if skeletons.windows(2).any(|w| w[0] >= w[1]) {
            return Err(DynamicsError::OutOfRange {
                name: "skeletons (order)",
                value: skeletons.len() as f64,
                expected: "ascending, each once",
            });
        }
        let dt = self.last_dt;
        if dt <= 0.0 {
            return Ok(());
        }
        let inv_dt = 1.0 / dt;
        let (run, offsets, counts) = self.run_with_layout();
        for_each_skeleton(run, skeletons, offsets, &|run, k| {
            let s = skeletons[k] as usize;
            let r = run.local_nodes(s, offsets, counts);
            let g = offsets[s] as usize;
            let mut turned = false;
            for (j, i) in r.clone().enumerate().skip(1) {
                let (dx, dy) = (
                    (run.theta[i] - theta[g + j]) * inv_dt,
                    (run.phi[i] - phi[g + j]) * inv_dt,
                );
                if dx != 0.0 || dy != 0.0 {
                    run.omega_theta[i] = toward_zero(run.omega_theta[i], dx);
                    run.omega_phi[i] = toward_zero(run.omega_phi[i], dy);
                    turned = true;
                }
            }
            if turned {
                refresh_skeleton(run, s, r);
            }
        });
        Ok(())
    }

    /// Checks that every `(node, vector)` names a node slot and is finite, before any is used.
    fn check_node_vectors(
        &self,
        what: &'static str,
        items: &[(u32, Vector)],
    ) -> Result<(), DynamicsError> {
        let count = self.theta.len();
        for (node, v) in items {
            if *node as usize >= count {
                return Err(DynamicsError::UnknownNode {
                    node: *node as usize,
                    count,
                });
            }
            crate::error::finite_vec(what, v)?;
        }
        Ok(())
    }

    /// Adds forces (node, N in the head frame) that act during the next [`StrandState::step`]
    /// only, on top of [`StrandState::external_force_mut`]'s. A response that asks for a velocity
    /// change `dv` over a step of `dt` applies `m dv / dt` here, so the step distributes it to the
    /// joints through the model's own inertia, and its power on the model's energy is exactly its
    /// power on the nodes' velocities; a velocity set directly has no such bound.
    pub fn add_forces_for_next_step(
        &mut self,
        forces: &[(u32, Vector)],
    ) -> Result<(), DynamicsError> {
        self.check_node_vectors("force for the next step", forces)?;
        self.next_step_forces.extend_from_slice(forces);
        Ok(())
    }

    /// Adds a force (N, head frame) to any node for the next [`StrandState::step`] only, as
    /// [`StrandState::add_forces_for_next_step`] does for a list of nodes: `fill` reads the
    /// state and adds to the per-node forces it is given (one per node, zero where nothing was
    /// added). For a response with a force on most nodes, such as the hair-hair volume's
    /// friction: no list to build, check and scatter. The step checks the forces as it uses them
    /// (a non-finite one makes its skeleton's step fail, reported).
    pub fn add_node_forces_for_next_step<R>(
        &mut self,
        fill: impl FnOnce(&StrandState, &mut [Vector]) -> R,
    ) -> R {
        let mut forces = std::mem::take(&mut self.next_step_node_forces);
        let result = fill(self, &mut forces);
        self.next_step_node_forces = forces;
        self.node_forces_pending = true;
        result
    }

    /// Sets node velocities (head frame) and maps them back to angular velocities, root to tip,
    /// as [`StrandState::apply_velocity_constraints`] does.
    pub fn apply_velocity_targets(
        &mut self,
        targets: &[(u32, Vector)],
    ) -> Result<(), DynamicsError> {
        self.check_node_vectors("velocity target", targets)?;
        for (node, v) in targets {
            self.velocities[*node as usize] = *v;
        }
        let mut touched = std::mem::take(&mut self.touched_scratch);
        self.touched_skeletons(targets.iter().map(|t| t.0), &mut touched);
        let mut sweep = std::mem::take(&mut self.force_scratch);
        for &s in &touched {
            self.project_to_inextensible(s as usize, &mut sweep);
            self.velocities_to_angles(s as usize);
        }
        self.force_scratch = sweep;
        self.touched_scratch = touched;
        Ok(())
    }

    /// Replaces skeleton `s`'s stored node velocities by the nearest (in kinetic energy, mass
    /// weighted) velocities that keep every segment's length, with the root's velocity held:
    /// `min sum m_i |v_i - v*_i|^2` subject to `r_i . (v_i - v_{i-1}) = 0`. Targets a segment
    /// cannot follow (a stretch along it) are dropped here, once, instead of being carried
    /// from joint to joint by the root-to-tip fit, which turned them into bending on bent
    /// strands and raised their energy. A projection onto a subspace through the held root
    /// velocity never raises the energy of the velocities relative to the root.
    ///
    /// The multipliers solve the tridiagonal `J M^-1 J^T lambda = -J v*` (Thomas algorithm,
    /// `O(n)`), with `sweep` as scratch: per segment the eliminated upper coefficient, the
    /// eliminated right-hand side and the multiplier.
    fn project_to_inextensible(&mut self, s: usize, sweep: &mut Vec<Vector>) {
        let range = self.nodes(crate::SkeletonId(s as u32));
        let (o, n) = (range.start, range.len());
        if n < 2 {
            return;
        }
        if sweep.len() < n {
            sweep.resize(n, Vector::zeros());
        }
        let inv_mass = |st: &Self, i: usize| {
            if i == o {
                0.0
            } else {
                let m = st.mass[i] + st.wetness[i];
                if m > 0.0 { 1.0 / m } else { 0.0 }
            }
        };
        let axis = |st: &Self, i: usize| {
            let r = st.positions[i] - st.positions[i - 1];
            let l = r.norm();
            if l > 0.0 { r / l } else { Vector::zeros() }
        };
        // The root's velocity as the fit reads it (an attached root is still in the head frame).
        let root_velocity = if self.roots[s].free {
            self.velocities[o]
        } else {
            Vector::zeros()
        };
        // Forward elimination: row k (segment k, nodes k-1 and k) reads
        // (1/m_k + 1/m_{k-1}) l_k - c_{k-1} l_{k-1} / m_{k-1} - c_k l_{k+1} / m_k = -r_k . (v*_k - v*_{k-1}).
        let mut upper_prev = 0.0;
        let mut rhs_prev = 0.0;
        let mut coupling_prev = 0.0;
        for k in 1..n {
            let i = o + k;
            let r = axis(self, i);
            let (inv, inv_before) = (inv_mass(self, i), inv_mass(self, i - 1));
            let diag = inv + inv_before;
            let lower = -coupling_prev;
            let upper = if k + 1 < n {
                -r.dot(&axis(self, i + 1)) * inv
            } else {
                0.0
            };
            let before = if k > 1 {
                self.velocities[i - 1]
            } else {
                root_velocity
            };
            let rhs = -r.dot(&(self.velocities[i] - before));
            let pivot = diag - lower * upper_prev;
            let (u, d) = if pivot > 0.0 && pivot.is_finite() {
                (upper / pivot, (rhs - lower * rhs_prev) / pivot)
            } else {
                (0.0, 0.0)
            };
            sweep[k] = Vector::new(u, d, 0.0);
            (upper_prev, rhs_prev) = (u, d);
            coupling_prev = -upper;
        }
        // Back substitution, then the velocities from the multipliers.
        let mut next = 0.0;
        for k in (1..n).rev() {
            let lambda = sweep[k].y - sweep[k].x * next;
            sweep[k].z = lambda;
            next = lambda;
        }
        for k in 1..n {
            let i = o + k;
            let after = if k + 1 < n {
                axis(self, i + 1) * sweep[k + 1].z
            } else {
                Vector::zeros()
            };
            let change = (axis(self, i) * sweep[k].z - after) * inv_mass(self, i);
            self.velocities[i] += change;
        }
    }

    /// Sets angular velocities from the stored node velocities, root to tip (least squares per
    /// segment), then recomputes node velocities so they agree exactly with the angles.
    fn velocities_to_angles(&mut self, s: usize) {
        let range = self.nodes(crate::SkeletonId(s as u32));
        let root = self.roots[s];
        let mut rot = root.rotation;
        let mut omega = Vector::zeros();
        let o = range.start;
        let mut v_prev = if root.free {
            self.velocities[o]
        } else {
            Vector::zeros()
        };
        for i in o + 1..range.end {
            let bend = Bend::new(self.theta[i], self.phi[i]);
            let ax = rot * bend.axis_x;
            let ay = rot * bend.axis_y;
            rot *= bend.rotation;
            let r = self.positions[i] - self.positions[i - 1];
            // (Omega_prev + ax wx + ay wy) x r = v_i - v_prev, least squares in (wx, wy).
            let b = self.velocities[i] - v_prev - omega.cross(&r);
            let c1 = ax.cross(&r);
            let c2 = ay.cross(&r);
            // Least squares for the change from the current rates, regularised so a joint whose
            // axis lines up with its segment (a 90 degree bend) is not asked for infinite rates.
            let (w0x, w0y) = (self.omega_theta[i], self.omega_phi[i]);
            let b = b - c1 * w0x - c2 * w0y;
            let (a11, a12, a22) = (c1.dot(&c1), c1.dot(&c2), c2.dot(&c2));
            let lambda = 1e-3 * (a11 + a22) + 1e-30;
            let (a11, a22) = (a11 + lambda, a22 + lambda);
            let (b1, b2) = (c1.dot(&b), c2.dot(&b));
            let det = a11 * a22 - a12 * a12;
            let (wx, wy) = (
                w0x + (a22 * b1 - a12 * b2) / det,
                w0y + (a11 * b2 - a12 * b1) / det,
            );
            self.omega_theta[i] = wx;
            self.omega_phi[i] = wy;
            omega += ax * wx + ay * wy;
            v_prev += omega.cross(&r);
            self.velocities[i] = v_prev;
        }
    }

    /// The skeletons owning `nodes` (valid node slots), each once and ascending, into `touched`:
    /// marked in `slot_scratch` as they come (responses touch a few thousand skeletons through
    /// hundreds of thousands of nodes), which is left all `u32::MAX` again.
    fn touched_skeletons(&mut self, nodes: impl Iterator<Item = u32>, touched: &mut Vec<u32>) {
        touched.clear();
        for node in nodes {
            let s = self.node_skeleton[node as usize];
            let mark = &mut self.slot_scratch[s as usize];
            if *mark == u32::MAX {
                *mark = 0;
                touched.push(s);
            }
        }
        touched.sort_unstable();
        for &s in touched.iter() {
            self.slot_scratch[s as usize] = u32::MAX;
        }
    }

    /// The skeleton that owns a node slot.
    ///
    /// # Panics
    /// If `node` is not a node slot (`node >= node_count()`).
    pub fn skeleton_of(&self, node: usize) -> u32 {
        self.node_skeleton[node]
    }
}

/// Sorts each group of constraint indices (`order[groups[g]..groups[g + 1]]`, each ascending)
/// by node, in place and in parallel halves of the groups. The sort is unstable on (node,
/// index), which orders as a stable sort by node would, and takes no memory.
fn sort_groups_by_node(order: &mut [u32], groups: &[u32], constraints: &[VelocityConstraint]) {
    // Fewer constraints than this are sorted on the calling thread.
    const SERIAL: usize = 4096;
    let base = groups[0] as usize;
    if groups.len() <= 2 || order.len() <= SERIAL {
        for w in groups.windows(2) {
            order[w[0] as usize - base..w[1] as usize - base]
                .sort_unstable_by_key(|&ci| (constraints[ci as usize].node, ci));
        }
        return;
    }
    let mid = groups.len() / 2;
    let (left, right) = order.split_at_mut(groups[mid] as usize - base);
    rayon::join(
        || sort_groups_by_node(left, &groups[..=mid], constraints),
        || sort_groups_by_node(right, &groups[mid..], constraints),
    );
}

/// One node [`StrandState::sweep_chains`] asks about.
#[derive(Clone, Copy, Debug)]
pub struct SweepAsk<'a> {
    /// Index of the node's chain in the list given.
    pub chain: usize,
    /// Global node index.
    pub node: usize,
    /// Where its parent node is now (`None` for a root).
    pub parent: Option<&'a Point>,
    /// Where the node is now, every correction before it on its skeleton made.
    pub at: Point,
    /// Whether this sweep has moved it (a correction before it on its skeleton): `false` means
    /// it is where the sweep found it.
    pub moved: bool,
}

/// The shared part of one [`StrandState::sweep_chains`] call.
struct SweepJob<'a, F> {
    offsets: &'a [u32],
    counts: &'a [u32],
    project: &'a F,
    /// The first chain (by index) that gave a non-finite target: its skeleton, node within the
    /// skeleton and a coordinate.
    bad: &'a std::sync::Mutex<Option<(usize, usize, Real)>>,
}

impl<F> SweepJob<'_, F> {
    /// Splits the chains (and the run and outputs with them) in halves down to the grain of
    /// `for_each_skeleton`, then
    /// sweeps each chain; `base` is the index of `chains[0]` in the whole list.
    fn split<E: Send>(
        &self,
        mut run: Run<'_>,
        out: &mut [E],
        chains: &[[u32; 2]],
        first_moved: &mut [u32],
        base: usize,
    ) where
        F: Fn(&SweepAsk<'_>, &mut E) -> Option<Point> + Sync,
    {
        if chains.len() > GRAIN_SKELETONS {
            let half = chains.len() / 2;
            let mid = chains[half][0] as usize;
            let at = self.offsets[mid] as usize;
            let (a, b) = run.split(mid, at);
            let (out_a, out_b) = out.split_at_mut(at - a.node_base);
            let (ca, cb) = chains.split_at(half);
            let (fa, fb) = first_moved.split_at_mut(half);
            rayon::join(
                || self.split(a, out_a, ca, fa, base),
                || self.split(b, out_b, cb, fb, base + half),
            );
            return;
        }
        for (k, (&[s, from], moved)) in chains.iter().zip(first_moved).enumerate() {
            *moved = self.sweep(&mut run, out, base + k, s as usize, from as usize);
        }
    }

    /// One chain: asks about its nodes at their stored places until one is corrected, then
    /// refits the skeleton from its root, asking about every later node at its new place.
    /// Returns the first node moved (global index) or `u32::MAX`.
    fn sweep<E>(&self, run: &mut Run<'_>, out: &mut [E], k: usize, s: usize, from: usize) -> u32
    where
        F: Fn(&SweepAsk<'_>, &mut E) -> Option<Point> + Sync,
    {
        let r = run.local_nodes(s, self.offsets, self.counts);
        let base = run.node_base;
        let finite = |t: &Point| t.coords.iter().all(|c| c.is_finite());
        let report = |i: usize, t: &Point| {
            let c = t
                .coords
                .iter()
                .copied()
                .find(|c| !c.is_finite())
                .unwrap_or(0.0);
            let mut bad = self.bad.lock().unwrap_or_else(|e| e.into_inner());
            if bad.is_none() {
                *bad = Some((s, i - r.start, c));
            }
        };
        // At the stored places, until the first correction.
        let mut first = None;
        for i in r.start + from..r.end {
            let parent = (i > r.start).then(|| run.positions[i - 1]);
            let ask = SweepAsk {
                chain: k,
                node: base + i,
                parent: parent.as_ref(),
                at: run.positions[i],
                moved: false,
            };
            if let Some(t) = (self.project)(&ask, &mut out[i]) {
                if finite(&t) {
                    first = Some((i, t));
                    break;
                }
                report(i, &t);
            }
        }
        let Some((moved, target)) = first else {
            return u32::MAX;
        };
        // The refit, as `refit_skeleton` with the one target, then the later nodes asked.
        let root = &mut run.roots[s - run.first];
        if root.free {
            root.position = if moved == r.start {
                target
            } else {
                run.positions[r.start]
            };
        }
        let mut chain = Refit::from_root(run, s, r.start);
        for i in r.start + 1..r.end {
            let keep = (run.theta[i], run.phi[i]);
            let (rot, position) = (chain.rot, chain.position);
            let (mut x, mut y) = if i == moved {
                aim(&rot, &position, &target, keep)
            } else {
                aim(&rot, &position, &run.positions[i], keep)
            };
            let mut bend = Bend::new(x, y);
            if i > moved {
                let ask = SweepAsk {
                    chain: k,
                    node: base + i,
                    parent: Some(&position),
                    at: position + rot * bend.rotation.column(2) * run.length[i],
                    moved: true,
                };
                let asked = (self.project)(&ask, &mut out[i]);
                if let Some(t) = asked {
                    if finite(&t) {
                        (x, y) = aim(&rot, &position, &t, keep);
                        bend = Bend::new(x, y);
                    } else {
                        report(i, &t);
                    }
                }
            }
            chain.joint(run, i, (x, y), &bend);
        }
        (base + moved) as u32
    }
}
