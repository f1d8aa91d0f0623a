//! A rigid body part the caller poses: its mesh, its pose in the head track's frame, and the
//! motion over each step its constraint acts on.

use crate::{BodyConstraint, BodyReport, CollisionSettings, PartMotion};
use hair_dynamics::{DynamicsError, HeadPose, StrandState, TeleportLimits};
use hair_ssv::{MeshBody, Real};

/// A rigid body part: its mesh in its own frame and where it is.
#[derive(Clone, Debug)]
pub struct BodyPart {
    name: String,
    body: MeshBody,
    /// Track frame (world less the teleport offset) from part, as of the end of the last step.
    track_pose: HeadPose,
    /// The world pose the caller set for the end of the next step.
    pending: Option<HeadPose>,
    /// This step's motion in the head frame, once the step reached the collision stage.
    motion: Option<PartMotion>,
    constraint: BodyConstraint,
}

impl BodyPart {
    /// A part named `name` at `track_pose` (track frame from part).
    pub fn new(name: &str, body: MeshBody, track_pose: HeadPose) -> Self {
        Self {
            name: name.into(),
            body,
            track_pose,
            pending: None,
            motion: None,
            constraint: BodyConstraint::new(),
        }
    }

    /// The name the part was added with.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The part's mesh (m, its own frame).
    pub fn body(&self) -> &MeshBody {
        &self.body
    }

    /// The part's poses in the head's frame (the hair's) at the start and end of the last
    /// step; `None` before the first step.
    pub fn motion(&self) -> Option<&PartMotion> {
        self.motion.as_ref()
    }

    /// Track frame from part now.
    pub fn track_pose(&self) -> &HeadPose {
        &self.track_pose
    }

    /// Sets the pose (world from part) the part reaches at the end of the next step.
    pub fn set_next(&mut self, world_from_part: HeadPose) {
        self.pending = Some(world_from_part);
    }

    /// Moves the part to its pose for the end of this step, given the track frame from the
    /// world (`track_from_world`, the inverse of the teleport offset) and the head's poses
    /// (track frame) at the start and end of the step: its motion in the head's frame over
    /// `dt`. A move beyond `limits` is a teleport: the part jumps there with no surface velocity.
    pub fn advance(
        &mut self,
        track_from_world: &HeadPose,
        (head_now, head_next): (&HeadPose, &HeadPose),
        limits: TeleportLimits,
        dt: Real,
    ) {
        let next = self
            .pending
            .take()
            .map_or(self.track_pose, |w| track_from_world * w);
        let previous = head_now.inverse() * self.track_pose;
        let pose = head_next.inverse() * next;
        let jump = limits.exceeded_by(&previous, &pose);
        self.motion = Some(PartMotion {
            pose,
            previous: if jump { pose } else { previous },
            dt,
        });
        self.track_pose = next;
    }

    /// The body constraint against the part where [`BodyPart::advance`] put it; `None` before
    /// the first advance.
    pub fn constrain(
        &mut self,
        state: &mut StrandState,
        front: &[u32],
        step: u64,
        settings: &CollisionSettings,
    ) -> Result<Option<BodyReport>, DynamicsError> {
        let Some(motion) = self.motion else {
            return Ok(None);
        };
        let report = self
            .constraint
            .apply_moving(state, &self.body, &motion, front, step, settings)?;
        Ok(Some(report))
    }
}
