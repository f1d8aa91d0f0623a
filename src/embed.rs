//! A simulation driven by its caller: built from data with no scene file, the head posed each
//! step ([`Simulation::set_head_pose`]), teleports beyond [`TeleportLimits`].

use crate::scene::{HairstyleSpec, Scene};
use crate::{HairError, Simulation, hairstyle};
use hair_dynamics::{HeadPose, HeadPoseTrack, PoseJump, TeleportLimits};
use hair_ssv::{MeshBody, Point, Real};
use nalgebra::Isometry3;

/// The body of a simulation built from data ([`Simulation::from_groom`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Body {
    /// No body.
    None,
    /// The procedural head, neck and shoulders (head centre at the origin, +y up, face +z).
    Head {
        /// Mesh resolution (64 is the scenes' default).
        resolution: u32,
    },
    /// The procedural head as the body, and its neck and torso as separate rigid parts
    /// ([`hair_ssv::head::head_neck_torso`]; [`crate::PartId`] 0 the neck, 1 the torso), each
    /// in the head's frame at rest: posed at the head's pose they are where
    /// [`Body::Head`]'s neck and shoulders are. Move them with
    /// [`Simulation::set_body_part_pose`]; until then they hold their place in the world.
    HeadNeckTorso {
        /// Mesh resolution (64 is the scenes' default).
        resolution: u32,
    },
    /// A triangle mesh (m, head frame): an error for a degenerate triangle, an index out of
    /// range or a non-finite vertex.
    Mesh {
        /// Vertex positions.
        vertices: Vec<[f32; 3]>,
        /// Triangles as indices into `vertices`.
        triangles: Vec<[u32; 3]>,
    },
}

impl Simulation {
    /// Builds a simulation with no scene file: the strands of `groom` (from arrays of points by
    /// [`hair_io::Strands::from_polylines`], or read by [`hair_io::read_strands`]; head frame,
    /// m), `body`, and every other setting from `settings` (its `body` and procedural
    /// `hairstyle` unread; [`Scene::default`] for the defaults). Each strand is resampled by
    /// arc length to the hairstyle's control points (12 by default); a `File` hairstyle's
    /// `scale`, `offset` and `points` apply to the groom. The scene's `head_motion` still drives
    /// the head unless [`Simulation::set_head_pose`] does. An empty groom, a non-finite point
    /// or a degenerate mesh is a typed error.
    pub fn from_groom(
        groom: &hair_io::Strands,
        body: Body,
        settings: &Scene,
    ) -> Result<Self, HairError> {
        groom.validate("groom")?;
        if groom.strand_count() == 0 {
            return Err(HairError::EmptyGroom);
        }
        let placed = match &settings.hairstyle {
            HairstyleSpec::Procedural(p) => (1.0, [0.0; 3], p.points),
            HairstyleSpec::File {
                scale,
                offset,
                points,
                ..
            } => (*scale, *offset, *points),
        };
        let style = hairstyle::from_strands(groom, placed, "groom")?;
        let spec = match body {
            Body::None => crate::scene::BodySpec::None,
            Body::Head { resolution } => crate::scene::BodySpec::Head { resolution },
            Body::HeadNeckTorso { resolution } => {
                let [head, neck, torso] = hair_ssv::head::head_neck_torso(resolution as usize);
                let head = MeshBody::new(head.0, head.1)?;
                let mut sim =
                    Self::build(settings.clone(), style, Some(head), "groom", settings.lod)?;
                let rest = *sim.head.current();
                for (name, (v, t)) in [("neck", neck), ("torso", torso)] {
                    sim.push_part(name, MeshBody::new(v, t)?, rest);
                }
                return Ok(sim);
            }
            Body::Mesh {
                vertices,
                triangles,
            } => {
                let vertices = vertices.into_iter().map(Point::from).collect();
                let mesh = MeshBody::new(vertices, triangles);
                let body = Some(mesh.map_err(|source| HairError::BodyMesh {
                    file: "body mesh".into(),
                    scale: 1.0,
                    source,
                })?);
                return Self::build(settings.clone(), style, body, "groom", settings.lod);
            }
        };
        let body = crate::body::from_spec(&spec, std::path::Path::new("."))?;
        Self::build(settings.clone(), style, body, "groom", settings.lod)
    }

    /// Sets the pose (world from head) the head reaches at the end of the next step. The hair
    /// feels the head's velocity and acceleration, estimated from the poses given
    /// ([`HeadPoseTrack`]: central differences over the last, this and the next pose), as
    /// fictitious forces. A step without a pose holds the head still (or follows the scene's
    /// `head_motion`, if it moves). A jump beyond the [`TeleportLimits`] is a teleport: the
    /// head and hair are carried rigidly, nothing whips. A non-finite pose is an error and the
    /// simulation is unchanged.
    pub fn set_head_pose(&mut self, pose: Isometry3<Real>) -> Result<(), HairError> {
        self.drive_head(self.teleport.inverse() * pose)
    }

    /// The scene's head path and the caller's poses alike: `pose` in the head track's frame.
    pub(crate) fn drive_head(&mut self, pose: HeadPose) -> Result<(), HairError> {
        if let PoseJump::Teleport { offset } = self.head.set_next(pose)? {
            self.teleport *= offset;
        }
        Ok(())
    }

    /// Places the head at `current` (world from head) with the pose it had a step before at
    /// `previous`: a head already moving when the caller takes over starts with that velocity
    /// rather than from rest. The hair is carried along; an error, and no change, for a
    /// non-finite pose.
    pub fn start_head(
        &mut self,
        previous: Isometry3<Real>,
        current: Isometry3<Real>,
    ) -> Result<(), HairError> {
        let to_track = self.teleport.inverse();
        let (previous, current) = (to_track * previous, to_track * current);
        let mut track = HeadPoseTrack::with_previous(self.dt(), previous, current)?;
        track.set_limits(self.head.limits())?;
        self.head = track;
        // A pose too far out to draw is reported by the next step.
        let _finite = self.draw();
        Ok(())
    }

    /// Sets how far the head may move in one step before a move is a teleport (finite and
    /// non-negative, else an error and no change).
    pub fn set_teleport_limits(&mut self, limits: TeleportLimits) -> Result<(), HairError> {
        Ok(self.head.set_limits(limits)?)
    }

    /// The head's poses (the track's frame: world is [`Simulation::teleport_offset`] times it)
    /// and the motion estimated from them.
    pub fn head_track(&self) -> &HeadPoseTrack {
        &self.head
    }

    /// The head's pose now (world from head).
    pub fn head_pose(&self) -> Isometry3<Real> {
        self.teleport * self.head.current()
    }

    /// Moves the whole head (and the hair with it) by a rigid offset in one jump, as a game
    /// does when a character respawns: the hair's motion relative to the head is untouched, so
    /// nothing whips. Offsets compose; the drawn geometry follows from the next update.
    pub fn teleport(&mut self, offset: Isometry3<Real>) {
        self.teleport = offset * self.teleport;
        // An offset too large to draw is reported by the next step.
        let _finite = self.draw();
    }

    /// The accumulated teleport offset (world from the head track's frame).
    pub fn teleport_offset(&self) -> Isometry3<Real> {
        self.teleport
    }
}
