//! Drivers: the head's rigid motion and the camera at time `t`.

use crate::scene::{HeadMotionSpec, Scene};
use hair_dynamics::{Environment, HeadMotion, HeadPose, Wind};
use hair_ssv::{Point, Real, Vector};
use nalgebra::{Unit, UnitQuaternion};
use serde::{Deserialize, Serialize};

/// The head's pose at time `t` (s) on the scene's path: what the simulation hands its head
/// track ([`hair_dynamics::HeadPoseTrack`]) each step, as a caller's `set_head_pose` would.
pub fn head_pose(spec: &HeadMotionSpec, t: Real) -> HeadPose {
    match spec {
        HeadMotionSpec::Still => HeadPose::identity(),
        HeadMotionSpec::Shake {
            axis,
            amplitude_degrees,
            frequency,
        } => {
            let axis = Unit::new_normalize(Vector::from(*axis));
            let w = std::f32::consts::TAU * frequency;
            let angle = amplitude_degrees.to_radians() * (w * t).sin();
            HeadPose::from_parts(
                nalgebra::Translation3::identity(),
                UnitQuaternion::from_axis_angle(&axis, angle),
            )
        }
    }
}

/// Camera eye and target at time `t`, linear between keyframes, held outside them.
pub fn camera(spec: &CameraSpec, t: Real) -> (Point, Point) {
    let keys = &spec.keys;
    let at = |i: usize| (Point::from(keys[i].eye), Point::from(keys[i].target));
    if keys.is_empty() {
        return (Point::new(0.0, 0.0, 1.0), Point::origin());
    }
    if t <= keys[0].time {
        return at(0);
    }
    for i in 1..keys.len() {
        if t <= keys[i].time {
            let span = keys[i].time - keys[i - 1].time;
            let f = if span > 0.0 {
                (t - keys[i - 1].time) / span
            } else {
                1.0
            };
            let (e0, t0) = at(i - 1);
            let (e1, t1) = at(i);
            return (e0 + (e1 - e0) * f, t0 + (t1 - t0) * f);
        }
    }
    at(keys.len() - 1)
}

/// The environment of the step that starts at time `t`: gravity, the head's motion (as the
/// simulation's head track estimates it), the wind.
pub fn environment(scene: &Scene, head: HeadMotion, t: Real) -> Environment {
    Environment {
        gravity: Vector::from(scene.dynamics.gravity),
        head,
        wind: Wind {
            seed: scene.seed,
            ..scene.wind
        },
        fields: Vec::new(),
        time: t,
    }
}

/// A camera path: keyframes interpolated linearly in time. No keys (a scene without a
/// camera, or `camera: Fit`): the simulation frames the body and the hair from a three-quarter
/// front view when it is built ([`CameraSpec::fit`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default, from = "CameraFile")]
pub struct CameraSpec {
    /// Keyframes, in time order (none: fitted to the scene).
    pub keys: Vec<CameraKey>,
    /// Vertical field of view (degrees).
    pub fov_degrees: f32,
}

impl Default for CameraSpec {
    fn default() -> Self {
        Self {
            keys: Vec::new(),
            fov_degrees: 40.0,
        }
    }
}

/// A camera as a scene file writes it: `Fit`, or a path.
#[derive(Deserialize)]
#[serde(untagged)]
enum CameraFile {
    Fit(FitCamera),
    Path(#[serde(with = "CameraPathFile")] CameraSpec),
}

/// The identifier `Fit`.
#[derive(Deserialize)]
enum FitCamera {
    Fit,
}

/// [`CameraSpec`]'s fields, read as a struct.
#[derive(Deserialize)]
#[serde(
    remote = "CameraSpec",
    deny_unknown_fields,
    default = "CameraSpec::default"
)]
struct CameraPathFile {
    keys: Vec<CameraKey>,
    fov_degrees: f32,
}

impl From<CameraFile> for CameraSpec {
    fn from(file: CameraFile) -> Self {
        match file {
            CameraFile::Fit(FitCamera::Fit) => CameraSpec::default(),
            CameraFile::Path(path) => path,
        }
    }
}

impl CameraSpec {
    /// A camera that frames `points` (the hair and the body near it, head frame at rest) from a
    /// three-quarter front view, a little above, with a margin: the eye looks at the centre of
    /// their bounding box from far enough that the sphere around the box fits the view.
    pub fn fit(points: impl IntoIterator<Item = [f32; 3]>, fov_degrees: f32) -> CameraKey {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in points {
            for k in 0..3 {
                if p[k].is_finite() {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        if lo[0] > hi[0] {
            (lo, hi) = ([-0.1; 3], [0.1; 3]);
        }
        let centre: [f32; 3] = std::array::from_fn(|k| 0.5 * (lo[k] + hi[k]));
        let radius = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f32>().sqrt() * 0.5;
        let half = (0.5 * fov_degrees.to_radians()).clamp(0.05, 1.5);
        let distance = 1.1 * radius.max(0.05) / half.sin();
        // Three-quarter front: between the face (+z) and the side (+x), a little above.
        let dir = Vector::new(0.62, 0.3, 0.72).normalize();
        CameraKey {
            time: 0.0,
            eye: std::array::from_fn(|k| centre[k] + dir[k] * distance),
            target: centre,
        }
    }
}

/// One camera keyframe.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraKey {
    /// Time (s).
    pub time: f32,
    /// Eye position (m, world).
    pub eye: [f32; 3],
    /// Point looked at (m, world).
    pub target: [f32; 3],
}
