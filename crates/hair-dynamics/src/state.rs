//! Strand state: structure of arrays over every control point of every skeleton.

use crate::bend::bend_between;
use crate::error::{finite, non_negative};
use crate::{DynamicsError, Point, Real, Vector};
use nalgebra::{Matrix3, Rotation3};

/// Stable handle of a skeleton in a [`StrandState`]. Handles are never reused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SkeletonId(pub u32);

/// How a skeleton's first node is held.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Root {
    /// Attached to the scalp: the root node and the root frame move rigidly with the head (the
    /// simulation runs in the head's frame, so they are fixed in it).
    Attached {
        /// Root position (m, head frame).
        position: Point,
        /// Root frame: its z axis is the direction the hair leaves the scalp.
        frame: Rotation3<Real>,
    },
    /// Free: a cut piece with both ends loose. The root translates with the strand's total force;
    /// the first joint has no spring.
    Free {
        /// Root position (m, head frame).
        position: Point,
        /// Root velocity (m/s, head frame).
        velocity: Vector,
        /// Reference frame of the first joint (fixed in the head frame).
        frame: Rotation3<Real>,
    },
}

/// Material of one skeleton, from root to tip. Per-node values are derived from it and can be
/// edited afterwards through [`StrandState`]'s `*_mut` accessors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Material {
    /// Mass per unit length (kg/m).
    pub linear_density: Real,
    /// Bending stiffness EI at the root (N m^2). Joint springs are `k = EI / d`, with the root
    /// joint at `2 EI / d` so the discrete chain converges to the elastica at second order.
    pub bending_stiffness: Real,
    /// Stiffness at the tip as a fraction of the root's (linear profile; 1 = uniform).
    pub tip_stiffness_ratio: Real,
    /// Angular damping at the root (N m s / rad).
    pub damping: Real,
    /// Damping at the tip as a fraction of the root's (linear profile; 1 = uniform).
    pub tip_damping_ratio: Real,
    /// Radius of the skeleton's swept volume (m).
    pub radius: Real,
    /// Axial stretch stiffness (N per unit strain); 0 keeps segments rigid.
    pub stretch_stiffness: Real,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            linear_density: 0.02,
            bending_stiffness: 2e-5,
            tip_stiffness_ratio: 1.0,
            damping: 2e-5,
            tip_damping_ratio: 1.0,
            radius: 0.002,
            stretch_stiffness: 0.0,
        }
    }
}

impl Material {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), DynamicsError> {
        non_negative("material.linear_density", self.linear_density)?;
        if self.linear_density == 0.0 {
            return Err(DynamicsError::OutOfRange {
                name: "material.linear_density",
                value: 0.0,
                expected: "> 0",
            });
        }
        non_negative("material.bending_stiffness", self.bending_stiffness)?;
        non_negative("material.tip_stiffness_ratio", self.tip_stiffness_ratio)?;
        non_negative("material.damping", self.damping)?;
        non_negative("material.tip_damping_ratio", self.tip_damping_ratio)?;
        non_negative("material.radius", self.radius)?;
        non_negative("material.stretch_stiffness", self.stretch_stiffness)
    }
}

/// A skeleton to add: its root, its rest shape as a polyline (root first, head frame) and its
/// material. The rest angles are read off the polyline, and the skeleton starts at rest.
#[derive(Clone, Debug, PartialEq)]
pub struct SkeletonDesc {
    /// How the root is held.
    pub root: Root,
    /// Rest shape, root first; the first point must be the root position.
    pub points: Vec<Point>,
    /// Material.
    pub material: Material,
}

/// Root data of one skeleton during simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RootState {
    pub position: Point,
    pub rotation: Matrix3<Real>,
    pub velocity: Vector,
    pub free: bool,
    /// BDF2's history: 0, or the tag (`integrate::history_tag`) of the coordinates the last
    /// [`crate::Integrator::ImplicitBdf2`] step left; the step uses the `prev_*` fields only if
    /// the strand still has those coordinates (nothing rewrote them since) and the same time step.
    pub history: u64,
    /// A free root's position and velocity one step back (BDF2).
    pub prev_position: Point,
    pub prev_velocity: Vector,
}

/// Every control point of every skeleton, one `Vec` per field.
///
/// Node `i` of a skeleton carries the two bend angles of the segment that ends at it (node 0,
/// the root, has none). Skeleton `s` owns nodes `offset(s) .. offset(s) + count(s)`; cutting
/// shrinks `count` in place, adding appends.
#[derive(Debug, Default)]
pub struct StrandState {
    pub(crate) offsets: Vec<u32>,
    pub(crate) counts: Vec<u32>,
    pub(crate) capacities: Vec<u32>,
    pub(crate) roots: Vec<RootState>,
    pub(crate) active: Vec<bool>,
    /// Bend about the parent frame's x axis (rad).
    pub(crate) theta: Vec<Real>,
    /// Bend about the parent frame's y axis (rad).
    pub(crate) phi: Vec<Real>,
    pub(crate) omega_theta: Vec<Real>,
    pub(crate) omega_phi: Vec<Real>,
    /// The angles and rates one step back, kept by [`crate::Integrator::ImplicitBdf2`] (valid
    /// where the skeleton's root carries a history tag).
    pub(crate) prev_theta: Vec<Real>,
    pub(crate) prev_phi: Vec<Real>,
    pub(crate) prev_omega_theta: Vec<Real>,
    pub(crate) prev_omega_phi: Vec<Real>,
    pub(crate) rest_theta: Vec<Real>,
    pub(crate) rest_phi: Vec<Real>,
    pub(crate) rest_length: Vec<Real>,
    pub(crate) length: Vec<Real>,
    pub(crate) mass: Vec<Real>,
    pub(crate) wetness: Vec<Real>,
    pub(crate) k_theta: Vec<Real>,
    pub(crate) k_phi: Vec<Real>,
    pub(crate) k_stretch: Vec<Real>,
    pub(crate) damping: Vec<Real>,
    pub(crate) radius: Vec<Real>,
    pub(crate) rest_points: Vec<Vector>,
    pub(crate) external_force: Vec<Vector>,
    /// Forces for the next step only (node, force), added by `add_forces_for_next_step`.
    pub(crate) next_step_forces: Vec<(u32, Vector)>,
    /// Forces for the next step only, one per node, added by `add_node_forces_for_next_step`;
    /// all zero unless `node_forces_pending` (the step zeroes them as it reads them, in its
    /// parallel pass, so a response need not clear them first).
    pub(crate) next_step_node_forces: Vec<Vector>,
    pub(crate) node_forces_pending: bool,
    pub(crate) positions: Vec<Point>,
    pub(crate) velocities: Vec<Vector>,
    pub(crate) steps: u64,
    /// The step length of the last [`StrandState::step`] (s; 0 before the first).
    pub(crate) last_dt: Real,
    pub(crate) bonds: Vec<crate::Bond>,
    pub(crate) force_scratch: Vec<Vector>,
    /// Per node, a response's target; read only where `moved_scratch` is set (which is all
    /// false between responses).
    pub(crate) target_scratch: Vec<Point>,
    pub(crate) moved_scratch: Vec<bool>,
    pub(crate) touched_scratch: Vec<u32>,
    /// The skeleton owning each node slot (nodes are only ever appended, a skeleton at a time).
    pub(crate) node_skeleton: Vec<u32>,
    /// Per skeleton, `u32::MAX`, or while a response runs, its group among the touched ones.
    pub(crate) slot_scratch: Vec<u32>,
    /// Constraint indices grouped by skeleton, and where each skeleton's group starts.
    pub(crate) order_scratch: Vec<u32>,
    pub(crate) group_scratch: Vec<u32>,
    /// Per node slot, the inverse of its joint's inertia, while velocity constraints run.
    pub(crate) inertia_scratch: Vec<Real>,
    /// The pool size and skeleton length the workers' lane buffers were last grown for.
    pub(crate) lanes_grown: Option<(usize, usize)>,
}

/// `clone_from` copies into the buffers already held (a reset or a rollback takes no new
/// memory for them, and the working buffers keep the room they grew to).
impl Clone for StrandState {
    fn clone(&self) -> Self {
        let mut copy = Self::default();
        copy.clone_from(self);
        copy
    }

    fn clone_from(&mut self, from: &Self) {
        // Every field named: a new one is a compile error here until it is copied too.
        let Self {
            offsets,
            counts,
            capacities,
            roots,
            active,
            theta,
            phi,
            omega_theta,
            omega_phi,
            prev_theta,
            prev_phi,
            prev_omega_theta,
            prev_omega_phi,
            rest_theta,
            rest_phi,
            rest_length,
            length,
            mass,
            wetness,
            k_theta,
            k_phi,
            k_stretch,
            damping,
            radius,
            rest_points,
            external_force,
            next_step_forces,
            next_step_node_forces,
            node_forces_pending,
            positions,
            velocities,
            steps,
            last_dt,
            bonds,
            force_scratch,
            target_scratch,
            moved_scratch,
            touched_scratch,
            node_skeleton,
            slot_scratch,
            order_scratch,
            group_scratch,
            inertia_scratch,
            lanes_grown: _,
        } = self;
        offsets.clone_from(&from.offsets);
        counts.clone_from(&from.counts);
        capacities.clone_from(&from.capacities);
        roots.clone_from(&from.roots);
        active.clone_from(&from.active);
        theta.clone_from(&from.theta);
        phi.clone_from(&from.phi);
        omega_theta.clone_from(&from.omega_theta);
        omega_phi.clone_from(&from.omega_phi);
        prev_theta.clone_from(&from.prev_theta);
        prev_phi.clone_from(&from.prev_phi);
        prev_omega_theta.clone_from(&from.prev_omega_theta);
        prev_omega_phi.clone_from(&from.prev_omega_phi);
        rest_theta.clone_from(&from.rest_theta);
        rest_phi.clone_from(&from.rest_phi);
        rest_length.clone_from(&from.rest_length);
        length.clone_from(&from.length);
        mass.clone_from(&from.mass);
        wetness.clone_from(&from.wetness);
        k_theta.clone_from(&from.k_theta);
        k_phi.clone_from(&from.k_phi);
        k_stretch.clone_from(&from.k_stretch);
        damping.clone_from(&from.damping);
        radius.clone_from(&from.radius);
        rest_points.clone_from(&from.rest_points);
        external_force.clone_from(&from.external_force);
        next_step_forces.clone_from(&from.next_step_forces);
        next_step_node_forces.clone_from(&from.next_step_node_forces);
        *node_forces_pending = from.node_forces_pending;
        positions.clone_from(&from.positions);
        velocities.clone_from(&from.velocities);
        *steps = from.steps;
        *last_dt = from.last_dt;
        bonds.clone_from(&from.bonds);
        force_scratch.clone_from(&from.force_scratch);
        target_scratch.clone_from(&from.target_scratch);
        moved_scratch.clone_from(&from.moved_scratch);
        touched_scratch.clone_from(&from.touched_scratch);
        node_skeleton.clone_from(&from.node_skeleton);
        slot_scratch.clone_from(&from.slot_scratch);
        order_scratch.clone_from(&from.order_scratch);
        group_scratch.clone_from(&from.group_scratch);
        inertia_scratch.clone_from(&from.inertia_scratch);
        // `lanes_grown` is not copied: it describes the pool's buffers, which stay grown.
    }
}

macro_rules! node_field {
    ($(#[$doc:meta])* $name:ident, $name_mut:ident, $ty:ty) => {
        $(#[$doc])*
        pub fn $name(&self) -> &[$ty] {
            &self.$name
        }
        $(#[$doc])*
        ///
        /// Mutable: values are read at the next step; keep them finite.
        pub fn $name_mut(&mut self) -> &mut [$ty] {
            &mut self.$name
        }
    };
}

impl StrandState {
    /// An empty state.
    pub fn new() -> Self {
        Self::default()
    }

    /// The joints' angular rates about both axes at once (`omega_theta`, `omega_phi`), for a
    /// caller that updates them together.
    ///
    /// Mutable: values are read at the next step; keep them finite.
    pub fn rates_mut(&mut self) -> (&mut [Real], &mut [Real]) {
        (&mut self.omega_theta, &mut self.omega_phi)
    }

    /// Adds a skeleton at rest and returns its handle.
    pub fn add_skeleton(&mut self, desc: &SkeletonDesc) -> Result<SkeletonId, DynamicsError> {
        let skeleton = self.offsets.len();
        let n = desc.points.len();
        if n < 2 {
            return Err(DynamicsError::TooFewPoints { skeleton, count: n });
        }
        desc.material.validate()?;
        for (i, p) in desc.points.iter().enumerate() {
            for c in p.coords.iter() {
                if !c.is_finite() {
                    return Err(DynamicsError::InvalidNode {
                        skeleton,
                        node: i,
                        field: "point",
                        value: f64::from(*c),
                        expected: "finite",
                    });
                }
            }
        }
        let (root_pos, frame, velocity, free) = match desc.root {
            Root::Attached { position, frame } => (position, frame, Vector::zeros(), false),
            Root::Free {
                position,
                velocity,
                frame,
            } => (position, frame, velocity, true),
        };
        for c in root_pos
            .coords
            .iter()
            .chain(velocity.iter())
            .chain(frame.matrix().iter())
        {
            finite("root", *c)?;
        }
        let mut lengths = Vec::with_capacity(n);
        lengths.push(0.0);
        for i in 1..n {
            let d = (desc.points[i] - desc.points[i - 1]).norm();
            if !(d.is_finite() && d > 0.0) {
                return Err(DynamicsError::DegenerateSegment {
                    skeleton,
                    segment: i,
                    length: f64::from(d),
                });
            }
            lengths.push(d);
        }
        let (theta, phi) = angles_of_polyline(frame.matrix(), &desc.points);
        let offset = self.theta.len();
        let total: Real = lengths.iter().sum();
        let mat = &desc.material;
        let mut arc = 0.0;
        for i in 0..n {
            // Trapezoid lumping: each node carries half of each adjacent segment.
            let left = lengths[i];
            let right = if i + 1 < n { lengths[i + 1] } else { 0.0 };
            let mass = mat.linear_density * 0.5 * (left + right);
            let s = if total > 0.0 { arc / total } else { 0.0 };
            let stiff = mat.bending_stiffness * (1.0 + (mat.tip_stiffness_ratio - 1.0) * s);
            let damp = mat.damping * (1.0 + (mat.tip_damping_ratio - 1.0) * s);
            let k = if i == 0 {
                0.0
            } else {
                let root_factor = if i == 1 { 2.0 } else { 1.0 };
                root_factor * stiff / lengths[i]
            };
            self.theta.push(theta[i]);
            self.phi.push(phi[i]);
            self.omega_theta.push(0.0);
            self.omega_phi.push(0.0);
            self.prev_theta.push(theta[i]);
            self.prev_phi.push(phi[i]);
            self.prev_omega_theta.push(0.0);
            self.prev_omega_phi.push(0.0);
            self.rest_theta.push(theta[i]);
            self.rest_phi.push(phi[i]);
            self.rest_length.push(lengths[i]);
            self.length.push(lengths[i]);
            self.mass.push(mass);
            self.wetness.push(0.0);
            self.k_theta.push(k);
            self.k_phi.push(k);
            self.k_stretch.push(mat.stretch_stiffness);
            self.damping.push(if i == 0 { 0.0 } else { damp });
            self.radius.push(mat.radius);
            self.rest_points.push(desc.points[i].coords);
            self.external_force.push(Vector::zeros());
            self.next_step_node_forces.push(Vector::zeros());
            self.positions.push(desc.points[i]);
            self.velocities
                .push(if free { velocity } else { Vector::zeros() });
            if i + 1 < n {
                arc += lengths[i + 1];
            }
        }
        self.offsets.push(offset as u32);
        self.node_skeleton
            .extend(std::iter::repeat_n(skeleton as u32, n));
        self.slot_scratch.push(u32::MAX);
        self.counts.push(n as u32);
        self.capacities.push(n as u32);
        self.roots.push(RootState {
            position: root_pos,
            rotation: *frame.matrix(),
            velocity,
            free,
            history: 0,
            prev_position: root_pos,
            prev_velocity: velocity,
        });
        self.active.push(true);
        self.refresh_positions(SkeletonId(skeleton as u32));
        Ok(SkeletonId(skeleton as u32))
    }

    /// Number of skeletons (including cut-down ones).
    pub fn skeleton_count(&self) -> usize {
        self.offsets.len()
    }

    /// Total number of node slots.
    pub fn node_count(&self) -> usize {
        self.theta.len()
    }

    /// Handles of every skeleton.
    pub fn skeletons(&self) -> impl Iterator<Item = SkeletonId> + '_ {
        (0..self.offsets.len() as u32).map(SkeletonId)
    }

    /// The node range of a skeleton in the per-node arrays.
    pub fn nodes(&self, id: SkeletonId) -> core::ops::Range<usize> {
        let s = id.0 as usize;
        let o = self.offsets[s] as usize;
        o..o + self.counts[s] as usize
    }

    /// Checks a handle.
    pub fn check(&self, id: SkeletonId) -> Result<(), DynamicsError> {
        if (id.0 as usize) < self.offsets.len() {
            Ok(())
        } else {
            Err(DynamicsError::UnknownSkeleton {
                skeleton: id.0 as usize,
            })
        }
    }

    /// Whether the skeleton's root is free.
    pub fn is_free(&self, id: SkeletonId) -> bool {
        self.roots[id.0 as usize].free
    }

    /// Whether the skeleton is integrated by the next step (localization: dormant skeletons are
    /// frozen).
    pub fn is_active(&self, id: SkeletonId) -> bool {
        self.active[id.0 as usize]
    }

    /// Marks a skeleton active or dormant.
    pub fn set_active(&mut self, id: SkeletonId, active: bool) {
        self.active[id.0 as usize] = active;
    }

    /// Root position of a skeleton (head frame).
    pub fn root_position(&self, id: SkeletonId) -> Point {
        self.roots[id.0 as usize].position
    }

    /// Root frame of a skeleton (head frame).
    pub fn root_frame(&self, id: SkeletonId) -> Rotation3<Real> {
        Rotation3::from_matrix_unchecked(self.roots[id.0 as usize].rotation)
    }

    /// Moves an attached root (e.g. a scalp that deforms) or a free one.
    pub fn set_root(
        &mut self,
        id: SkeletonId,
        position: Point,
        frame: Rotation3<Real>,
    ) -> Result<(), DynamicsError> {
        self.check(id)?;
        for c in position.coords.iter().chain(frame.matrix().iter()) {
            finite("root", *c)?;
        }
        let r = &mut self.roots[id.0 as usize];
        r.position = position;
        r.rotation = *frame.matrix();
        self.refresh_positions(id);
        Ok(())
    }

    /// Node positions (head frame), as of the last step.
    pub fn positions(&self) -> &[Point] {
        &self.positions
    }

    /// Node velocities (head frame), as of the last step.
    pub fn velocities(&self) -> &[Vector] {
        &self.velocities
    }

    /// How many steps have been taken.
    pub fn step_count(&self) -> u64 {
        self.steps
    }

    node_field!(
        /// Bend angle about the parent frame's x axis (rad), per node.
        theta, theta_mut, Real);
    node_field!(
        /// Bend angle about the parent frame's y axis (rad), per node.
        phi, phi_mut, Real);
    node_field!(
        /// Angular velocity of `theta` (rad/s), per node.
        omega_theta, omega_theta_mut, Real);
    node_field!(
        /// Angular velocity of `phi` (rad/s), per node.
        omega_phi, omega_phi_mut, Real);
    node_field!(
        /// Rest value of `theta` (the style), per node.
        rest_theta, rest_theta_mut, Real);
    node_field!(
        /// Rest value of `phi` (the style), per node.
        rest_phi, rest_phi_mut, Real);
    node_field!(
        /// Rest length of the segment ending at the node (m).
        rest_length, rest_length_mut, Real);
    node_field!(
        /// Current length of the segment ending at the node (m): the rest length, stretched by
        /// the stretch spring.
        length, length_mut, Real);
    node_field!(
        /// Dry mass of the node (kg).
        mass, mass_mut, Real);
    node_field!(
        /// Water held by the node (kg): it adds to the node's mass.
        wetness, wetness_mut, Real);
    node_field!(
        /// Spring constant of `theta` (N m / rad).
        k_theta, k_theta_mut, Real);
    node_field!(
        /// Spring constant of `phi` (N m / rad).
        k_phi, k_phi_mut, Real);
    node_field!(
        /// Axial stretch stiffness of the segment ending at the node (N per unit strain, 0 = rigid).
        k_stretch, k_stretch_mut, Real);
    node_field!(
        /// Angular damping of the joint at the node's parent (N m s / rad).
        damping, damping_mut, Real);
    node_field!(
        /// Radius of the swept volume at the node (m).
        radius, radius_mut, Real);
    node_field!(
        /// Rest shape of the skeleton (m): fixes the inertia of each joint.
        rest_points, rest_points_mut, Vector);
    node_field!(
        /// Extra force on the node (N, head frame), added at every step until changed.
        external_force, external_force_mut, Vector);

    /// Recomputes positions (and velocities) of one skeleton from its angles.
    pub fn refresh_positions(&mut self, id: SkeletonId) {
        let range = self.nodes(id);
        self.run_all().refresh(id.0 as usize, range);
    }

    pub(crate) fn root_dyn(&self, s: usize) -> crate::strand::RootDyn<Real> {
        let r = &self.roots[s];
        crate::strand::RootDyn {
            position: r.position.coords,
            rotation: r.rotation,
            velocity: r.velocity,
            free: r.free,
        }
    }

    /// Energy of the model (J): kinetic energy with the model's inertia, spring energy, and the
    /// potential of gravity in the head frame. Constant under exact, undamped, unforced motion of
    /// a head at rest; the implicit integrators never increase it when damped.
    pub fn model_energy(&self, env: &crate::Environment, torque: crate::TorqueModel) -> f64 {
        let g = env.head.rotation.inverse() * (env.gravity - env.head.linear_acceleration);
        let mut e = 0.0f64;
        for s in 0..self.offsets.len() {
            let r = self.nodes(SkeletonId(s as u32));
            for i in r.clone() {
                let m = f64::from(self.mass[i] + self.wetness[i]);
                e -= m * f64::from(g.dot(&self.positions[i].coords));
                if i == r.start {
                    continue;
                }
                let dt = f64::from(self.theta[i] - self.rest_theta[i]);
                let dp = f64::from(self.phi[i] - self.rest_phi[i]);
                let spring = if self.roots[s].free && i == r.start + 1 {
                    0.0
                } else {
                    1.0
                };
                e += 0.5
                    * spring
                    * (f64::from(self.k_theta[i]) * dt * dt + f64::from(self.k_phi[i]) * dp * dp);
                let c = self.rest_points[i - 1];
                let inertia: f64 = match torque {
                    crate::TorqueModel::Chain => (i..r.end)
                        .map(|j| {
                            f64::from(self.mass[j] + self.wetness[j])
                                * f64::from((self.rest_points[j] - c).norm_squared())
                        })
                        .sum(),
                    crate::TorqueModel::Local => {
                        m * f64::from((self.rest_points[i] - c).norm_squared())
                    }
                };
                let floor = 1e-2 * m * f64::from(self.length[i]).powi(2);
                let w2 =
                    f64::from(self.omega_theta[i]).powi(2) + f64::from(self.omega_phi[i]).powi(2);
                e += 0.5 * inertia.max(floor) * w2;
            }
            if self.roots[s].free {
                let mtot: f64 = r
                    .clone()
                    .map(|j| f64::from(self.mass[j] + self.wetness[j]))
                    .sum();
                e += 0.5 * mtot * f64::from(self.roots[s].velocity.norm_squared());
            }
        }
        e
    }

    /// Shortens a skeleton to its first `count` nodes (a cut). The tail's slots stay reserved.
    pub fn truncate(&mut self, id: SkeletonId, count: usize) -> Result<(), DynamicsError> {
        self.check(id)?;
        let s = id.0 as usize;
        if count < 2 || count > self.counts[s] as usize {
            return Err(DynamicsError::OutOfRange {
                name: "truncate.count",
                value: count as f64,
                expected: "between 2 and the skeleton's current count",
            });
        }
        self.counts[s] = count as u32;
        Ok(())
    }

    /// Sets the angles of a skeleton so that its nodes follow `points` (root first) as closely as
    /// rigid segments allow: each segment points at its target, keeping its length. Angular
    /// velocities are left alone.
    pub fn set_shape(&mut self, id: SkeletonId, points: &[Point]) -> Result<(), DynamicsError> {
        self.check(id)?;
        let range = self.nodes(id);
        if points.len() != range.len() {
            return Err(DynamicsError::OutOfRange {
                name: "set_shape.points",
                value: points.len() as f64,
                expected: "one point per node of the skeleton",
            });
        }
        for (i, p) in points.iter().enumerate() {
            for c in p.coords.iter() {
                if !c.is_finite() {
                    return Err(DynamicsError::InvalidNode {
                        skeleton: id.0 as usize,
                        node: i,
                        field: "point",
                        value: f64::from(*c),
                        expected: "finite",
                    });
                }
            }
        }
        let root = self.roots[id.0 as usize];
        crate::response::fit_angles(
            &root.rotation,
            root.position,
            points,
            &self.length[range.clone()],
            &mut self.theta[range.clone()],
            &mut self.phi[range.clone()],
        );
        self.refresh_positions(id);
        Ok(())
    }
}

/// Bend angles of a polyline relative to a root frame, by parallel transport of the frame.
pub(crate) fn angles_of_polyline(
    frame: &Matrix3<Real>,
    points: &[Point],
) -> (Vec<Real>, Vec<Real>) {
    let n = points.len();
    let mut theta = vec![0.0; n];
    let mut phi = vec![0.0; n];
    let mut rot = *frame;
    for i in 1..n {
        let d = points[i] - points[i - 1];
        let len = d.norm();
        if len <= 0.0 {
            continue;
        }
        let local = rot.transpose() * (d / len);
        let (x, y) = bend_between(&local);
        theta[i] = x;
        phi[i] = y;
        rot *= crate::bend::Bend::new(x, y).rotation;
    }
    (theta, phi)
}
