//! Scenes: serde data in RON files (`scenes/*.ron`), documented in `docs/scene-format.md`.
//!
//! Every struct denies unknown fields and fills missing ones with their defaults, so a scene file
//! names only what differs; [`Scene::validate`] then checks every value's range.

use crate::HairError;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A whole scene: what is simulated, how, and how it is watched.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Scene {
    /// Name, for reports.
    pub name: String,
    /// Seed of every random choice (roots, offsets, turbulence).
    pub seed: u64,
    /// Frames `hair run` simulates when `--frames` is not given.
    pub frames: u32,
    /// Frames per second (s^-1).
    pub frame_rate: f32,
    /// Simulation steps per frame (the fixed step is `1 / (frame_rate * substeps)` s).
    pub substeps: u32,
    /// The body the hair grows on and collides with.
    pub body: BodySpec,
    /// The hair.
    pub hairstyle: HairstyleSpec,
    /// Strand material and integrator.
    pub dynamics: DynamicsSpec,
    /// Collision settings.
    pub collision: CollisionSettings,
    /// Level-of-detail policy.
    pub lod: LodPolicy,
    /// How strands are grouped into the strip / cluster / strand-group hierarchy.
    pub hierarchy: HierarchySpec,
    /// When the `adaptive` policy asks for detail.
    pub adaptive: AdaptiveSettings,
    /// Whether dormant regions stop being integrated (salon paper §4.3).
    pub localization: bool,
    /// Whether the groom is its own rest: rest angles solved so that the groomed shape is the
    /// static equilibrium under gravity and the body's contact; see [`Scene::groom_is_its_rest`].
    pub sag_free: bool,
    /// Camera path.
    pub camera: CameraSpec,
    /// Light.
    pub light: LightSpec,
    /// Wind.
    pub wind: Wind,
    /// The head's motion.
    pub head_motion: HeadMotionSpec,
    /// The salon tool script: a timeline of tool events and the tools' settings
    /// (`docs/salon.md`).
    pub tools: hair_salon::ToolScript,
    /// Rendered strands that follow the groom's strands as guides (three nearest, barycentric);
    /// 0 (the default) draws the groom's strands themselves.
    pub render_strands: u32,
}

impl Default for Scene {
    fn default() -> Self {
        Self {
            name: "untitled".into(),
            seed: 1,
            frames: 120,
            frame_rate: 60.0,
            substeps: 1,
            body: BodySpec::default(),
            hairstyle: HairstyleSpec::default(),
            dynamics: DynamicsSpec::default(),
            collision: CollisionSettings::default(),
            lod: LodPolicy::Fine,
            hierarchy: HierarchySpec::default(),
            adaptive: AdaptiveSettings::default(),
            localization: false,
            sag_free: true,
            camera: CameraSpec::default(),
            light: LightSpec::default(),
            wind: Wind::default(),
            head_motion: HeadMotionSpec::Still,
            tools: hair_salon::ToolScript::default(),
            render_strands: 0,
        }
    }
}

pub use hair_lod::{AdaptiveSettings, HierarchySpec};

/// The body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum BodySpec {
    /// No body.
    None,
    /// The procedural head, neck and shoulders (metres, +y up, face +z, head centre at the origin).
    Head {
        /// Mesh resolution: 96 gives about 53,000 triangles.
        resolution: u32,
    },
    /// An OBJ file, scaled then offset into metres.
    Obj {
        /// Path, relative to the scene file.
        path: String,
        /// Scale from file units to metres.
        scale: f32,
        /// Offset added after scaling (m).
        offset: [f32; 3],
        /// Cap each hole of the mesh (a loop of edges with a triangle on one side only) with a
        /// fan of triangles around the loop's centroid, so that the body is a closed surface with
        /// an inside. Default true. An open mesh has no inside near its holes: the signed
        /// distance changes sign across the hole's opening without a surface there, and hair
        /// pushed out of the body on one side of it reads as deep inside on the other (the
        /// Sintel bust's eye sockets did this). Meshes whose holes are not simple loops stay open.
        #[serde(default = "yes")]
        close_holes: bool,
    },
    /// A torus with wrinkles, lying in the xz plane (Ward & Lin's brushing scene).
    Torus {
        /// Centre (m).
        center: [f32; 3],
        /// Major radius (m).
        major: f32,
        /// Tube radius (m).
        minor: f32,
        /// Wrinkles around the ring.
        wrinkles: u32,
        /// Wrinkle depth as a fraction of the tube radius.
        depth: f32,
    },
}

/// Serde default for flags that are on unless a scene turns them off.
fn yes() -> bool {
    true
}

impl Default for BodySpec {
    fn default() -> Self {
        BodySpec::Head { resolution: 64 }
    }
}

/// The hair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum HairstyleSpec {
    /// Hair grown in code on the procedural head's scalp.
    Procedural(ProceduralHair),
    /// Strands from a `.tfx` or `.hair` file.
    File {
        /// Path, relative to the scene file.
        path: String,
        /// Scale from file units to metres.
        scale: f32,
        /// Offset added after scaling (m).
        offset: [f32; 3],
        /// Control points per skeleton (strands are resampled by arc length).
        points: u32,
    },
}

impl Default for HairstyleSpec {
    fn default() -> Self {
        HairstyleSpec::Procedural(ProceduralHair::default())
    }
}

impl Scene {
    /// Whether `Simulation::new` makes the groom its own rest: `sag_free` and a groom combed as
    /// hair lies (a file, or `combed`); hair grown off the scalp would stand out for good.
    pub fn groom_is_its_rest(&self) -> bool {
        self.sag_free
            && match &self.hairstyle {
                HairstyleSpec::File { .. } => true,
                HairstyleSpec::Procedural(p) => p.combed || p.style == StyleSpec::Draped,
            }
    }
}

/// A procedural hairstyle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ProceduralHair {
    /// Rendered strands.
    pub strands: u32,
    /// Rendered strands per simulated skeleton at the finest level (1 = every strand simulated).
    pub strands_per_skeleton: u32,
    /// Strand length (m).
    pub length: f32,
    /// Control points per skeleton.
    pub points: u32,
    /// Rest shape.
    pub style: StyleSpec,
    /// Laid combed over the head and shoulders as a groom lies (`false`: grown out of the scalp).
    pub combed: bool,
    /// Scalp: roots lie on the head above this height (m, head frame).
    pub scalp_min_height: f32,
    /// Roots lie behind this plane (m along +z, the face direction); keeps the face clear.
    pub scalp_max_forward: f32,
    /// Half-width of the parting along the head's midline (m); 0 for none.
    pub parting_width: f32,
    /// Radius of one rendered strand (m).
    pub strand_radius: f32,
}

impl Default for ProceduralHair {
    fn default() -> Self {
        Self {
            strands: 2000,
            strands_per_skeleton: 1,
            length: 0.3,
            points: 12,
            style: StyleSpec::Straight,
            combed: true,
            scalp_min_height: 0.0,
            scalp_max_forward: 0.06,
            parting_width: 0.0,
            strand_radius: 0.0015,
        }
    }
}

/// Rest shape of every skeleton.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum StyleSpec {
    /// Straight.
    Straight,
    /// Straight and combed, whatever `combed` says (the name older scene files use).
    Draped,
    /// A planar wave.
    Wavy {
        /// Amplitude (m).
        amplitude: f32,
        /// Wavelength (m).
        period: f32,
    },
    /// A helix.
    Curly {
        /// Curl radius (m).
        radius: f32,
        /// Rise per turn (m).
        pitch: f32,
    },
}

/// Strand material and integration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsSpec {
    /// Integrator: `ExplicitEuler`, `SymplecticEuler`, `Rk4`, `ImplicitAngular`, `ImplicitCoupled`, `ImplicitRos2`, `ImplicitRos3`, `ImplicitBdf2` (XPBD is the charts' peer only, not selectable).
    pub integrator: Integrator,
    /// Torque model: `Chain` or `Local`.
    pub torque: TorqueModel,
    /// Mass per unit length of one skeleton (kg/m).
    pub linear_density: f32,
    /// Bending stiffness EI at the root (N m^2).
    pub bending_stiffness: f32,
    /// Tip stiffness as a fraction of the root's.
    pub tip_stiffness_ratio: f32,
    /// Angular damping at the root (N m s / rad).
    pub damping: f32,
    /// Tip damping as a fraction of the root's.
    pub tip_damping_ratio: f32,
    /// Collision radius of a skeleton (m).
    pub radius: f32,
    /// Gravity (m/s^2, world).
    pub gravity: [f32; 3],
}

impl Default for DynamicsSpec {
    fn default() -> Self {
        Self {
            integrator: Integrator::ImplicitCoupled,
            torque: TorqueModel::Chain,
            linear_density: 0.01,
            bending_stiffness: 2e-6,
            tip_stiffness_ratio: 0.3,
            damping: 2e-6,
            tip_damping_ratio: 0.3,
            radius: 0.002,
            gravity: [0.0, -9.81, 0.0],
        }
    }
}

impl DynamicsSpec {
    /// The integration settings of a scene at `frame_rate` frames a second and `substeps`
    /// steps a frame.
    pub fn step_settings(&self, frame_rate: f32, substeps: u32) -> hair_dynamics::StepSettings {
        hair_dynamics::StepSettings {
            dt: 1.0 / (frame_rate * substeps as f32),
            integrator: self.integrator,
            torque: self.torque,
            solver: hair_dynamics::LinearSolver::Structured,
        }
    }
}

pub use hair_collide::{CollisionSettings, PushCombine};
pub use hair_dynamics::{Integrator, TorqueModel, Wind};
pub use hair_ssv::CollisionMethod;

pub use crate::lod_stage::LodPolicy;

pub use crate::drivers::{CameraKey, CameraSpec};

/// A directional light.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LightSpec {
    /// Direction the light travels (world).
    pub direction: [f32; 3],
    /// Colour (linear RGB).
    pub color: [f32; 3],
}

impl Default for LightSpec {
    fn default() -> Self {
        Self {
            direction: [-0.3, -0.8, -0.5],
            color: [1.0, 1.0, 1.0],
        }
    }
}

/// The head's motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum HeadMotionSpec {
    /// The head stays still.
    Still,
    /// The head turns back and forth about an axis through its centre.
    Shake {
        /// Axis (world).
        axis: [f32; 3],
        /// Amplitude (degrees).
        amplitude_degrees: f32,
        /// Frequency (Hz).
        frequency: f32,
    },
}

/// Names and texts of the built-in scenes, embedded so `hair run NAME` works from anywhere.
pub const BUILTIN: [(&str, &str); 8] = [
    ("wind", include_str!("../scenes/wind.ron")),
    ("shake", include_str!("../scenes/shake.ron")),
    ("torus", include_str!("../scenes/torus.ron")),
    ("zoom", include_str!("../scenes/zoom.ron")),
    ("bristles", include_str!("../scenes/bristles.ron")),
    ("wardlin", include_str!("../scenes/wardlin.ron")),
    ("sintel", include_str!("../scenes/sintel.ron")),
    ("salon", include_str!("../scenes/salon.ron")),
];

/// A scene with the directory its relative paths resolve against.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// Where relative paths in it resolve.
    pub base_dir: PathBuf,
    /// The file it came from (or `builtin:NAME`).
    pub source: String,
}

impl Scene {
    /// Parses RON text; `file` names it in errors.
    pub fn from_ron(text: &str, file: &str) -> Result<Scene, HairError> {
        let scene: Scene = ron::from_str(text).map_err(|e| HairError::SceneSyntax {
            file: file.to_string(),
            line: e.span.start.line,
            column: e.span.start.col,
            message: e.code.to_string(),
        })?;
        scene.validate(file)?;
        Ok(scene)
    }

    /// The scene as RON text.
    pub fn to_ron(&self) -> String {
        ron::ser::to_string_pretty(self, ron::ser::PrettyConfig::default()).unwrap_or_default()
    }

    /// Loads a built-in scene by name, or a scene file by path.
    pub fn load(name_or_path: &str) -> Result<LoadedScene, HairError> {
        let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        if let Some((name, text)) = BUILTIN.iter().find(|(n, _)| *n == name_or_path) {
            let source = format!("builtin:{name}");
            return Ok(LoadedScene {
                scene: Scene::from_ron(text, &source)?,
                base_dir: root.join("scenes"),
                source,
            });
        }
        let path = Path::new(name_or_path);
        if !path.exists() {
            let names: Vec<&str> = BUILTIN.iter().map(|(n, _)| *n).collect();
            return Err(HairError::UnknownScene(
                name_or_path.to_string(),
                names.join(", "),
            ));
        }
        let source = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| HairError::Io {
            file: source.clone(),
            message: e.to_string(),
        })?;
        Ok(LoadedScene {
            scene: Scene::from_ron(&text, &source)?,
            base_dir: path.parent().map(Path::to_path_buf).unwrap_or_default(),
            source,
        })
    }

    /// The radius (m) the drawn strands are given: the procedural style's own; for a file
    /// groom 1.5 mm when its guides are drawn alone (each stands for the hair around it), 0.4 mm
    /// when `render_strands` draws many strands around them.
    pub fn drawn_strand_radius(&self) -> f32 {
        match &self.hairstyle {
            HairstyleSpec::Procedural(p) => p.strand_radius,
            HairstyleSpec::File { .. } if self.render_strands > 0 => 0.0004,
            HairstyleSpec::File { .. } => 0.0015,
        }
    }

    /// Checks every value's range; errors name the field.
    pub fn validate(&self, file: &str) -> Result<(), HairError> {
        let bad = |field: &str, message: &str| HairError::SceneValue {
            file: file.to_string(),
            field: field.to_string(),
            message: message.to_string(),
        };
        let finite = |field: &str, v: &[f32]| -> Result<(), HairError> {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(bad(field, "must be finite"))
            }
        };
        let positive = |field: &str, v: f32| -> Result<(), HairError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(bad(field, &format!("must be positive and finite, got {v}")))
            }
        };
        let non_negative = |field: &str, v: f32| -> Result<(), HairError> {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(bad(
                    field,
                    &format!("must be non-negative and finite, got {v}"),
                ))
            }
        };
        positive("frame_rate", self.frame_rate)?;
        if self.substeps == 0 || self.substeps > 1000 {
            return Err(bad("substeps", "must be between 1 and 1000"));
        }
        if self.render_strands > 1_000_000 {
            return Err(bad("render_strands", "must be at most 1,000,000"));
        }
        match &self.body {
            BodySpec::None => {}
            BodySpec::Head { resolution } => {
                if !(8..=512).contains(resolution) {
                    return Err(bad("body.Head.resolution", "must be between 8 and 512"));
                }
            }
            BodySpec::Obj { scale, offset, .. } => {
                positive("body.Obj.scale", *scale)?;
                finite("body.Obj.offset", offset)?;
            }
            BodySpec::Torus {
                center,
                major,
                minor,
                depth,
                ..
            } => {
                finite("body.Torus.center", center)?;
                positive("body.Torus.major", *major)?;
                positive("body.Torus.minor", *minor)?;
                non_negative("body.Torus.depth", *depth)?;
                if minor >= major {
                    return Err(bad(
                        "body.Torus.minor",
                        "must be smaller than the major radius",
                    ));
                }
            }
        }
        match &self.hairstyle {
            HairstyleSpec::Procedural(p) => {
                if p.strands == 0 {
                    return Err(bad("hairstyle.strands", "must be at least 1"));
                }
                if p.strands_per_skeleton == 0 {
                    return Err(bad("hairstyle.strands_per_skeleton", "must be at least 1"));
                }
                positive("hairstyle.length", p.length)?;
                if !(2..=64).contains(&p.points) {
                    return Err(bad("hairstyle.points", "must be between 2 and 64"));
                }
                finite(
                    "hairstyle.scalp_min_height",
                    &[p.scalp_min_height, p.scalp_max_forward],
                )?;
                non_negative("hairstyle.parting_width", p.parting_width)?;
                positive("hairstyle.strand_radius", p.strand_radius)?;
                match p.style {
                    StyleSpec::Straight | StyleSpec::Draped => {}
                    StyleSpec::Wavy { amplitude, period } => {
                        non_negative("hairstyle.style.amplitude", amplitude)?;
                        positive("hairstyle.style.period", period)?;
                    }
                    StyleSpec::Curly { radius, pitch } => {
                        non_negative("hairstyle.style.radius", radius)?;
                        positive("hairstyle.style.pitch", pitch)?;
                    }
                }
            }
            HairstyleSpec::File {
                scale,
                offset,
                points,
                ..
            } => {
                positive("hairstyle.File.scale", *scale)?;
                finite("hairstyle.File.offset", offset)?;
                if !(2..=64).contains(points) {
                    return Err(bad("hairstyle.File.points", "must be between 2 and 64"));
                }
            }
        }
        let body = match self.body {
            BodySpec::Head { .. } => "Head",
            BodySpec::Obj { .. } => "Obj",
            BodySpec::Torus { .. } => "Torus",
            BodySpec::None => "None",
        };
        if self.collision.method == CollisionMethod::Maps && body != "Head" {
            let (file, field, method) = (file.into(), "collision.method", CollisionMethod::Maps);
            return Err(HairError::MethodUnavailable {
                file,
                field,
                method,
                body,
            });
        }
        let d = &self.dynamics;
        positive("dynamics.linear_density", d.linear_density)?;
        non_negative("dynamics.bending_stiffness", d.bending_stiffness)?;
        non_negative("dynamics.tip_stiffness_ratio", d.tip_stiffness_ratio)?;
        non_negative("dynamics.damping", d.damping)?;
        non_negative("dynamics.tip_damping_ratio", d.tip_damping_ratio)?;
        positive("dynamics.radius", d.radius)?;
        finite("dynamics.gravity", &d.gravity)?;
        self.collision
            .validate()
            .map_err(|e| HairError::SceneValue {
                file: file.to_string(),
                field: format!("collision.{}", e.field),
                message: e.message,
            })?;
        for (i, k) in self.camera.keys.iter().enumerate() {
            finite(
                &format!("camera.keys[{i}]"),
                &[
                    k.time,
                    k.eye[0],
                    k.eye[1],
                    k.eye[2],
                    k.target[0],
                    k.target[1],
                    k.target[2],
                ],
            )?;
            if i > 0 && k.time < self.camera.keys[i - 1].time {
                return Err(bad(
                    &format!("camera.keys[{i}].time"),
                    "keyframes must be in time order",
                ));
            }
        }
        if !(self.camera.fov_degrees > 1.0 && self.camera.fov_degrees < 179.0) {
            return Err(bad("camera.fov_degrees", "must be between 1 and 179"));
        }
        finite("light.direction", &self.light.direction)?;
        finite("light.color", &self.light.color)?;
        let w = &self.wind;
        finite("wind.direction", w.direction.as_slice())?;
        for (f, v) in [
            ("wind.speed", w.speed),
            ("wind.gust", w.gust),
            ("wind.gust_frequency", w.gust_frequency),
            ("wind.turbulence", w.turbulence),
            ("wind.turbulence_scale", w.turbulence_scale),
            ("wind.drag", w.drag),
        ] {
            non_negative(f, v)?;
        }
        if let HeadMotionSpec::Shake {
            axis,
            amplitude_degrees,
            frequency,
        } = &self.head_motion
        {
            finite("head_motion.Shake.axis", axis)?;
            if axis.iter().all(|x| *x == 0.0) {
                return Err(bad("head_motion.Shake.axis", "must not be zero"));
            }
            finite("head_motion.Shake.amplitude_degrees", &[*amplitude_degrees])?;
            non_negative("head_motion.Shake.frequency", *frequency)?;
        }
        self.tools
            .validate()
            .map_err(|e| bad("tools", &e.to_string()))?;
        Ok(())
    }
}
