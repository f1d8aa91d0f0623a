//! The tool script: a timeline of [`ToolEvent`]s (press, move, release) and the tools'
//! settings, validated so that it replays bit for bit.
//!
//! Why a timeline: a styling session is then plain data (a scene's `tools` field), can be
//! edited, and the same event type carries an interactive window's or a 6-DOF device's input.

use hair_dynamics::Vector;
use thiserror::Error;

/// The salon tools.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Tool {
    /// Wets the hair in its cone: heavier nodes, thinner sections, stretching curls.
    Water,
    /// Hairspray: stiffens the springs and bonds sections in contact.
    Spray,
    /// Volume mousse: grows the sections' radius.
    Mousse,
    /// Hair dryer: a strong force along its direction; dries; pulls bonds apart.
    Dryer,
    /// Grab: one control point per skeleton follows the tool.
    Grab,
    /// Scissors: cuts the skeletons crossing the triangle between the blades.
    Scissors,
}

impl Tool {
    /// Every tool, in the order they are applied within a step.
    pub const ALL: [Tool; 6] = [
        Tool::Water,
        Tool::Spray,
        Tool::Mousse,
        Tool::Dryer,
        Tool::Grab,
        Tool::Scissors,
    ];

    /// A short lowercase name.
    pub fn name(self) -> &'static str {
        match self {
            Tool::Water => "water",
            Tool::Spray => "spray",
            Tool::Mousse => "mousse",
            Tool::Dryer => "dryer",
            Tool::Grab => "grab",
            Tool::Scissors => "scissors",
        }
    }

    pub(crate) fn index(self) -> usize {
        self as usize
    }
}

/// What an event does to its tool.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum ToolAction {
    /// Press the button: the tool starts acting at the event's pose (scissors: close the blades
    /// once, a snip; grab: take one control point per skeleton inside the cone).
    Press,
    /// Move a pressed tool to a new pose or path, with the event's strength, reach and angle
    /// (scissors: another snip there).
    Move,
    /// Release the button: the tool stops (grabbed points fall, the dryer's force goes).
    Release,
}

/// A tool's pose (world frame).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct Pose {
    /// Tip of the tool (m).
    pub position: [f32; 3],
    /// Direction the tool points (not zero; normalised on use).
    pub direction: [f32; 3],
    /// Scissors only: the blades open in the plane of `direction` and `up x direction`.
    pub up: [f32; 3],
}

impl Default for Pose {
    fn default() -> Self {
        Self {
            position: [0.0; 3],
            direction: [0.0, 0.0, -1.0],
            up: [0.0, 1.0, 0.0],
        }
    }
}

/// A later pose of a path: the tool moves linearly (position) and by normalised interpolation
/// (direction, up) from the previous key, and stays at the last one.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct PoseKey {
    /// Time (s, absolute; after the event's and the previous key's).
    pub time: f32,
    /// The pose at that time.
    pub pose: Pose,
}

#[cfg(feature = "serde")]
fn one() -> f32 {
    1.0
}
#[cfg(feature = "serde")]
fn default_reach() -> f32 {
    0.15
}
#[cfg(feature = "serde")]
fn default_angle() -> f32 {
    0.35
}

/// One event of a styling session: a tool pressed, moved or released at a time.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct ToolEvent {
    /// When (s); events are in time order.
    pub time: f32,
    /// Which tool.
    pub tool: Tool,
    /// Press, move or release.
    pub action: ToolAction,
    /// Pose at `time` (ignored by `Release`).
    #[cfg_attr(feature = "serde", serde(default))]
    pub pose: Pose,
    /// Later poses the tool follows while held (until the next event of the same tool).
    #[cfg_attr(feature = "serde", serde(default))]
    pub path: Vec<PoseKey>,
    /// Strength, a multiple of the tool's nominal effect ([`SalonSettings`]); >= 0.
    #[cfg_attr(feature = "serde", serde(default = "one"))]
    pub strength: f32,
    /// Reach of the cone along its axis, or blade length of the scissors (m, >= 0).
    #[cfg_attr(feature = "serde", serde(default = "default_reach"))]
    pub reach: f32,
    /// Cut-off (half) angle of the cone, or half the opening of the blades (rad, in [0, pi/2)).
    #[cfg_attr(feature = "serde", serde(default = "default_angle"))]
    pub angle: f32,
}

/// Nominal effects of the tools (SI units) and the limits of the cut.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct SalonSettings {
    /// Water added per control point in the water's cone at strength 1 (kg/s).
    pub water_rate: f32,
    /// Most water a control point holds, as a multiple of its dry mass.
    pub saturation: f32,
    /// Fraction of the radius lost when a control point is saturated (wet hair clumps).
    pub wet_shrink: f32,
    /// Axial stiffness of a wet, fully curled segment (N per unit strain); divided by the wet
    /// fraction and the curl, so wetter and curlier hair stretches more.
    pub wet_stretch_stiffness: f32,
    /// Bend (rad) of a groomed joint counted as fully curled.
    pub curl_angle: f32,
    /// Growth of the spring factor per second under spray at strength 1.
    pub spray_rate: f32,
    /// Largest spring factor spray gives.
    pub max_stiffness: f32,
    /// Stiffness of a spray bond (N/m).
    pub bond_stiffness: f32,
    /// A bond breaks when stretched this far past its rest distance (m).
    pub bond_break_stretch: f32,
    /// Most bonds per control point.
    pub bonds_per_node: u32,
    /// Growth of the radius factor per second under mousse at strength 1.
    pub mousse_rate: f32,
    /// Largest radius factor mousse gives.
    pub max_thickness: f32,
    /// Force of the dryer at its nozzle at strength 1 (N per control point), fading to zero at
    /// its reach.
    pub dryer_force: f32,
    /// Water the dryer removes per control point at strength 1 (kg/s).
    pub dry_rate: f32,
    /// No piece shorter than this is cut off or left on the scalp (m).
    pub min_cut_length: f32,
    /// Fallen pieces entirely below this height (m, head frame) are swept up: no longer
    /// simulated or drawn (their water and length still count).
    pub floor_height: f32,
}

impl Default for SalonSettings {
    fn default() -> Self {
        Self {
            water_rate: 2e-4,
            saturation: 1.0,
            wet_shrink: 0.5,
            wet_stretch_stiffness: 0.5,
            curl_angle: 0.6,
            spray_rate: 3.0,
            max_stiffness: 8.0,
            bond_stiffness: 0.05,
            bond_break_stretch: 0.01,
            bonds_per_node: 2,
            mousse_rate: 1.0,
            max_thickness: 3.0,
            dryer_force: 4e-3,
            dry_rate: 2e-4,
            min_cut_length: 2e-3,
            floor_height: -0.8,
        }
    }
}

/// The scene's tool script: the events of a session and the tools' settings.
#[derive(Clone, Debug, Default, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct ToolScript {
    /// Events, in time order.
    pub events: Vec<ToolEvent>,
    /// Nominal effects and limits.
    pub settings: SalonSettings,
}

/// What the salon stage can fail on: a state, grid or hierarchy operation refusing its input.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum ToolError {
    /// The strand state refused a tool's change (a cut, a bond, a correction).
    #[error("dynamics: {0}")]
    Dynamics(#[from] hair_dynamics::DynamicsError),
    /// The grid refused a tool's volume.
    #[error("grid: {0}")]
    Grid(#[from] hair_grid::GridError),
    /// The hierarchy refused a property's inheritance.
    #[error("lod: {0}")]
    Lod(#[from] hair_lod::LodError),
    /// Fallen hair's body constraint refused a correction.
    #[error("fallen hair: {0}")]
    Collide(#[from] hair_collide::CollideError),
    /// A live event broke the script.
    #[error(transparent)]
    Script(#[from] SalonError),
}

/// A bad tool script; every message names the event (its index and time).
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum SalonError {
    /// An event comes before the one listed ahead of it.
    #[error(
        "tool event {index} ({tool} at t = {time} s) is out of time order: the previous event is at t = {previous} s"
    )]
    OutOfOrder {
        /// Index of the event in the script.
        index: usize,
        /// Its tool.
        tool: &'static str,
        /// Its time.
        time: f32,
        /// The previous event's time.
        previous: f32,
    },
    /// A value of an event is invalid.
    #[error("tool event {index} ({tool} at t = {time} s): `{field}` {message}")]
    Value {
        /// Index of the event in the script.
        index: usize,
        /// Its tool.
        tool: &'static str,
        /// Its time.
        time: f32,
        /// The field.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// A move or release of a tool that is not pressed.
    #[error("tool event {index} ({tool} at t = {time} s): {action} of a tool that is not pressed")]
    NotPressed {
        /// Index of the event in the script.
        index: usize,
        /// Its tool.
        tool: &'static str,
        /// Its time.
        time: f32,
        /// `move` or `release`.
        action: &'static str,
    },
    /// A setting is out of range.
    #[error("tool settings: `{field}` {message}")]
    Setting {
        /// The field.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
}

fn finite3(v: &[f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

pub(crate) fn vec3(v: &[f32; 3]) -> Vector {
    Vector::new(v[0], v[1], v[2])
}

impl ToolScript {
    /// Checks every event and setting: finite poses with non-zero directions (scissors: `up`
    /// not along the direction), non-negative strength and reach, angles in `[0, pi/2)`, path
    /// keys after their event and in order, events in time order, and moves and releases only
    /// of pressed tools.
    pub fn validate(&self) -> Result<(), SalonError> {
        let s = &self.settings;
        for (field, v) in [
            ("water_rate", s.water_rate),
            ("saturation", s.saturation),
            ("wet_shrink", s.wet_shrink),
            ("wet_stretch_stiffness", s.wet_stretch_stiffness),
            ("curl_angle", s.curl_angle),
            ("spray_rate", s.spray_rate),
            ("max_stiffness", s.max_stiffness),
            ("bond_stiffness", s.bond_stiffness),
            ("bond_break_stretch", s.bond_break_stretch),
            ("mousse_rate", s.mousse_rate),
            ("max_thickness", s.max_thickness),
            ("dryer_force", s.dryer_force),
            ("dry_rate", s.dry_rate),
            ("min_cut_length", s.min_cut_length),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SalonError::Setting {
                    field,
                    message: format!("must be non-negative and finite, got {v}"),
                });
            }
        }
        if s.wet_shrink >= 1.0 {
            return Err(SalonError::Setting {
                field: "wet_shrink",
                message: "must be below 1".into(),
            });
        }
        if s.curl_angle <= 0.0 {
            return Err(SalonError::Setting {
                field: "curl_angle",
                message: "must be positive".into(),
            });
        }
        if !(s.max_stiffness >= 1.0 && s.max_thickness >= 1.0) {
            return Err(SalonError::Setting {
                field: "max_stiffness",
                message: "max_stiffness and max_thickness must be at least 1".into(),
            });
        }
        if !s.floor_height.is_finite() {
            return Err(SalonError::Setting {
                field: "floor_height",
                message: "must be finite".into(),
            });
        }
        let mut pressed = [false; 6];
        let mut previous = f32::NEG_INFINITY;
        for (index, e) in self.events.iter().enumerate() {
            let tool = e.tool.name();
            let time = e.time;
            let bad = |field: &'static str, message: String| SalonError::Value {
                index,
                tool,
                time,
                field,
                message,
            };
            if !time.is_finite() {
                return Err(bad("time", "must be finite".into()));
            }
            if time < previous {
                return Err(SalonError::OutOfOrder {
                    index,
                    tool,
                    time,
                    previous,
                });
            }
            previous = time;
            if !(e.strength.is_finite() && e.strength >= 0.0) {
                return Err(bad(
                    "strength",
                    format!("must be non-negative and finite, got {}", e.strength),
                ));
            }
            if !(e.reach.is_finite() && e.reach >= 0.0) {
                return Err(bad(
                    "reach",
                    format!("must be non-negative and finite, got {}", e.reach),
                ));
            }
            if !(e.angle.is_finite() && e.angle >= 0.0 && e.angle < core::f32::consts::FRAC_PI_2) {
                return Err(bad(
                    "angle",
                    format!("must be in [0, pi/2) rad, got {}", e.angle),
                ));
            }
            let check_pose = |p: &Pose, field: &'static str| -> Result<(), SalonError> {
                if !(finite3(&p.position) && finite3(&p.direction) && finite3(&p.up)) {
                    return Err(bad(field, "must be finite".into()));
                }
                let d = vec3(&p.direction);
                if d.norm() == 0.0 {
                    return Err(bad(field, "has a zero direction".into()));
                }
                if e.tool == Tool::Scissors && vec3(&p.up).cross(&d).norm() <= 1e-6 * d.norm() {
                    return Err(bad(field, "has `up` along the direction".into()));
                }
                Ok(())
            };
            if e.action != ToolAction::Release {
                check_pose(&e.pose, "pose")?;
                let mut t = time;
                for k in &e.path {
                    check_pose(&k.pose, "path")?;
                    if !(k.time.is_finite() && k.time >= t) {
                        return Err(bad(
                            "path",
                            format!("key at t = {} s is before the one ahead of it", k.time),
                        ));
                    }
                    t = k.time;
                }
            }
            let i = e.tool.index();
            match e.action {
                ToolAction::Press => pressed[i] = true,
                ToolAction::Move | ToolAction::Release => {
                    if !pressed[i] {
                        return Err(SalonError::NotPressed {
                            index,
                            tool,
                            time,
                            action: if e.action == ToolAction::Move {
                                "move"
                            } else {
                                "release"
                            },
                        });
                    }
                    if e.action == ToolAction::Release {
                        pressed[i] = false;
                    }
                }
            }
        }
        Ok(())
    }
}

impl ToolEvent {
    /// The pose (world) at time `t` along the event's pose and path.
    pub fn pose_at(&self, t: f32) -> Pose {
        let mut a = (self.time, self.pose);
        for k in &self.path {
            if t <= k.time {
                let span = k.time - a.0;
                let f = if span > 0.0 {
                    ((t - a.0) / span).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                return lerp_pose(&a.1, &k.pose, f);
            }
            a = (k.time, k.pose);
        }
        a.1
    }
}

fn lerp_pose(a: &Pose, b: &Pose, f: f32) -> Pose {
    let mix = |x: &[f32; 3], y: &[f32; 3]| -> [f32; 3] {
        [
            x[0] + (y[0] - x[0]) * f,
            x[1] + (y[1] - x[1]) * f,
            x[2] + (y[2] - x[2]) * f,
        ]
    };
    let dir = |x: &[f32; 3], y: &[f32; 3]| -> [f32; 3] {
        let u = vec3(x).normalize();
        let v = vec3(y).normalize();
        let w = (u + (v - u) * f).try_normalize(1e-9).unwrap_or(v);
        [w.x, w.y, w.z]
    };
    Pose {
        position: mix(&a.position, &b.position),
        direction: dir(&a.direction, &b.direction),
        up: dir(&a.up, &b.up),
    }
}
