//! The facade's error type: every failure names the file, line and field where it can.

use thiserror::Error;

/// Everything that can go wrong loading a scene or running a simulation.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum HairError {
    /// A scene file could not be parsed or has an unknown field.
    #[error("{file}:{line}:{column}: {message}")]
    SceneSyntax {
        /// The scene file (or built-in name).
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// The parser's message.
        message: String,
    },
    /// A scene value is out of range or non-finite.
    #[error("{file}: field `{field}`: {message}")]
    SceneValue {
        /// The scene file (or built-in name).
        file: String,
        /// Dotted path of the field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A groom handed to `Simulation::from_groom` has no strands.
    #[error("the groom has no strands")]
    EmptyGroom,
    /// No built-in scene has this name and no such file exists.
    #[error("no built-in scene or file named `{0}` (built-ins: {1})")]
    UnknownScene(String, String),
    /// Reading a file failed.
    #[error("{file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// The system's message.
        message: String,
    },
    /// A hair or body file was malformed.
    #[error(transparent)]
    Format(#[from] hair_io::IoError),
    /// The dynamics layer rejected a value or a state went non-finite.
    #[error("dynamics: {0}")]
    Dynamics(#[from] hair_dynamics::DynamicsError),
    /// The collision layer rejected a mesh.
    #[error("collision: {0}")]
    Ssv(#[from] hair_ssv::SsvError),
    /// The scene asks for a collision method its body cannot answer with: `Maps` reads
    /// Kurihara's tables, which only the procedural `Head` has (others would silently fall back
    /// to the exact query).
    #[error(
        "{file}: field `{field}`: `{method:?}` needs the cylinder and sphere tables only a `Head` body has, and the body is `{body}` (ask for `Bvh`, the exact query, or `Field`)"
    )]
    MethodUnavailable {
        /// The scene file (or built-in name).
        file: String,
        /// Dotted path of the field: `collision.method`.
        field: &'static str,
        /// The method asked for.
        method: hair_ssv::CollisionMethod,
        /// The body's kind in the scene (`Obj`, `Torus`, `None`).
        body: &'static str,
    },
    /// The scene asks for something the pipeline does not do yet.
    #[error("not supported yet: {0}")]
    Unsupported(String),
    /// The grid rejected its input.
    #[error("grid: {0}")]
    Grid(#[from] hair_grid::GridError),
    /// A collision stage failed (a correction the strand state refused, or the grid's input).
    #[error("collision: {0}")]
    Collide(#[from] hair_collide::CollideError),
    /// A salon tool's change failed.
    #[error("tools: {0}")]
    Tools(#[from] hair_salon::ToolError),
    /// The level-of-detail layer rejected a transition.
    #[error("lod: {0}")]
    Lod(#[from] hair_lod::LodError),
    /// A drawn strand went non-finite, or beyond 1e36 m, although the state is finite: its
    /// skeleton has been thrown so far (by a huge gravity or wind, say) that its curve could
    /// overflow.
    #[error(
        "step {step}: drawn strand {strand} went non-finite or beyond 1e36 m (its skeleton's nodes are finite, but too far out to draw: the hair has left the scene)"
    )]
    NonFiniteRender {
        /// The step counter at which it happened.
        step: u64,
        /// The strand.
        strand: usize,
    },
    /// A strand read from a hair file has a segment of no length (or one too long to measure)
    /// once scaled and resampled for the scene: its points coincide, or the file's units make
    /// it vanish at the scene's `scale`.
    #[error(
        "{file}: strand {strand}, segment {segment}: {length} m long after scaling by {scale} and resampling to {points} points (a segment must have a positive, finite length: do the strand's points coincide, or is `scale` wrong?)"
    )]
    DegenerateStrand {
        /// The hair file.
        file: String,
        /// The strand, counted from 0 in the file.
        strand: usize,
        /// The segment of the resampled strand, counted from 0 at the root.
        segment: usize,
        /// Its length (m).
        length: f32,
        /// The scene's `scale`.
        scale: f32,
        /// The scene's control points per strand.
        points: u32,
    },
    /// A body mesh read from a file cannot be used for collision (a degenerate triangle, say).
    #[error("{file}: {source} (scaled by {scale})")]
    BodyMesh {
        /// The mesh file.
        file: String,
        /// The scene's `scale` for it.
        scale: f32,
        /// What the collision layer found.
        #[source]
        source: hair_ssv::SsvError,
    },
    /// A body part's mesh or pose cannot be used ([`crate::Simulation::add_body_part`],
    /// [`crate::Simulation::set_body_part_pose`]): a degenerate mesh, a non-finite pose.
    #[error("body part `{part}`: {message}")]
    BodyPart {
        /// The part's name.
        part: String,
        /// What is wrong.
        message: String,
    },
    /// No body part has this id.
    #[error("no body part {id} (the simulation has {count})")]
    UnknownBodyPart {
        /// The id asked for.
        id: usize,
        /// How many parts the simulation has.
        count: usize,
    },
}

impl From<hair_salon::SalonError> for HairError {
    fn from(e: hair_salon::SalonError) -> Self {
        HairError::SceneValue {
            file: "tool script".into(),
            field: "tools".into(),
            message: e.to_string(),
        }
    }
}
