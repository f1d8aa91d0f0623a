//! Body parts that move rigidly with poses the caller gives (a neck, a torso, an arm): each a
//! mesh in its own frame, posed in the world each step, colliding with the hair as the body
//! does while it moves ([`hair_collide::BodyConstraint::apply_moving`]).
//!
//! The hair is simulated in the head's frame, where the body given to the simulation is
//! static. A part's world pose is carried into that frame with the head's pose at the end of
//! the step and the teleport offset, so a part the caller holds still in the world moves in
//! the head's frame as the head turns, and the hair meets it moving.

use crate::{HairError, Simulation, StepStats};
pub use hair_collide::BodyPart;
use hair_collide::BodyReport;
use hair_dynamics::HeadPose;
use hair_ssv::{MeshBody, Point, Real};
use nalgebra::Isometry3;

/// Which body part: its index in [`Simulation::body_parts`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PartId(pub usize);

impl Simulation {
    /// Adds a body part that moves rigidly: a closed triangle mesh (m, the part's own frame) at
    /// `world_from_part` now, held there (in the world) until
    /// [`Simulation::set_body_part_pose`] moves it. Hair collides with it as with the body: no
    /// node is left inside it beyond the scene's tolerance, and a moving part pushes the hair
    /// and carries it by friction. A degenerate mesh (a degenerate triangle, an index out of
    /// range, a non-finite vertex) or a non-finite pose is an error and nothing changes. Hair
    /// the part is placed into is pushed out on the next step at once, not over the
    /// depenetration ramp.
    pub fn add_body_part(
        &mut self,
        name: &str,
        vertices: Vec<[f32; 3]>,
        triangles: Vec<[u32; 3]>,
        world_from_part: Isometry3<Real>,
    ) -> Result<PartId, HairError> {
        check_pose(name, &world_from_part)?;
        let vertices = vertices.into_iter().map(Point::from).collect();
        let body = MeshBody::new(vertices, triangles).map_err(|e| HairError::BodyPart {
            part: name.into(),
            message: e.to_string(),
        })?;
        let track_pose = self.teleport.inverse() * world_from_part;
        Ok(self.push_part(name, body, track_pose))
    }

    /// A part at `track_pose` (the head track's frame).
    pub(crate) fn push_part(&mut self, name: &str, body: MeshBody, track_pose: HeadPose) -> PartId {
        self.parts.push(BodyPart::new(name, body, track_pose));
        PartId(self.parts.len() - 1)
    }

    /// Sets the pose (world from part) part `id` reaches at the end of the next step; a later
    /// call before the step replaces an earlier one. It is carried into the head's frame with
    /// the head's pose at the end of that step, whichever of the two poses is set first. The
    /// part's surface velocity over the step (which the hair's contact with it acts on) is its
    /// move in the head's frame; a move beyond the head's [`TeleportLimits`](hair_dynamics::TeleportLimits) is a teleport: the
    /// part jumps there and pushes the hair out of it with no velocity, nothing whips. An
    /// unknown id or a non-finite pose is an error and nothing changes.
    pub fn set_body_part_pose(
        &mut self,
        id: PartId,
        world_from_part: Isometry3<Real>,
    ) -> Result<(), HairError> {
        let count = self.parts.len();
        let part = self
            .parts
            .get_mut(id.0)
            .ok_or(HairError::UnknownBodyPart { id: id.0, count })?;
        check_pose(part.name(), &world_from_part)?;
        part.set_next(world_from_part);
        Ok(())
    }

    /// The body parts, by [`PartId`].
    pub fn body_parts(&self) -> &[BodyPart] {
        &self.parts
    }

    /// Part `id`'s pose now (world from part), or an error for an unknown id.
    pub fn body_part_pose(&self, id: PartId) -> Result<Isometry3<Real>, HairError> {
        let count = self.parts.len();
        let part = self
            .parts
            .get(id.0)
            .ok_or(HairError::UnknownBodyPart { id: id.0, count })?;
        Ok(self.teleport * part.track_pose())
    }

    /// The hard body constraint against the body and every part. With more than one of them, a
    /// node pushed out of one can be pushed into another where they meet (the nape, between
    /// the neck and the head), so the round over all of them runs twice; with the body alone,
    /// once, as it always has.
    pub(crate) fn collide_bodies(&mut self, stats: &mut StepStats) -> Result<(), HairError> {
        let (head_now, limits) = (*self.head.current(), self.head.limits());
        let head_next = self.head.next().copied().unwrap_or(head_now);
        let track_from_world = self.teleport.inverse();
        for part in &mut self.parts {
            let head = (&head_now, &head_next);
            part.advance(&track_from_world, head, limits, self.settings.dt);
        }
        let rounds = 1 + usize::from(usize::from(self.body.is_some()) + self.parts.len() > 1);
        let (front, step, collision) = (&self.front_nodes, self.steps, &self.scene.collision);
        for round in 0..rounds {
            let mut total = BodyReport::default();
            if let Some(body) = &self.body {
                let constraint = &mut self.body_constraint;
                total.merge(&constraint.apply(&mut self.state, body, front, step, collision)?);
            }
            for part in &mut self.parts {
                if let Some(report) = part.constrain(&mut self.state, front, step, collision)? {
                    total.merge(&report);
                }
            }
            if round == 0 {
                stats.body_contacts = total.contacts;
            }
            stats.max_penetration_m = f64::from(total.max_penetration);
            stats.body_exact_tests += total.exact_tests;
            stats.body_escapes += total.escapes;
        }
        Ok(())
    }
}

/// An error naming the part for a pose with a non-finite number.
fn check_pose(part: &str, pose: &Isometry3<Real>) -> Result<(), HairError> {
    let mut numbers = pose
        .translation
        .vector
        .iter()
        .chain(pose.rotation.coords.iter());
    if numbers.all(|x| x.is_finite()) {
        return Ok(());
    }
    Err(HairError::BodyPart {
        part: part.into(),
        message: format!("the pose must be finite, got {pose:?}"),
    })
}
