//! Drivers: the head's rigid motion and the camera at time `t`.

use crate::scene::{CameraSpec, HeadMotionSpec, Scene};
use hair_dynamics::{Environment, HeadMotion, Wind};
use hair_ssv::{Point, Real, Vector};
use nalgebra::{Rotation3, Unit};

/// The head's pose, velocity and acceleration at time `t` (s).
pub fn head_motion(spec: &HeadMotionSpec, t: Real) -> HeadMotion {
    match spec {
        HeadMotionSpec::Still => HeadMotion::default(),
        HeadMotionSpec::Shake {
            axis,
            amplitude_degrees,
            frequency,
        } => {
            let axis = Unit::new_normalize(Vector::from(*axis));
            let a = amplitude_degrees.to_radians();
            let w = std::f32::consts::TAU * frequency;
            let (s, c) = (w * t).sin_cos();
            HeadMotion {
                rotation: Rotation3::from_axis_angle(&axis, a * s),
                angular_velocity: axis.into_inner() * (a * w * c),
                angular_acceleration: axis.into_inner() * (-a * w * w * s),
                ..HeadMotion::default()
            }
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

/// The environment of the step that starts at time `t`: gravity, the head's motion, the wind.
pub fn environment(scene: &Scene, t: Real) -> Environment {
    Environment {
        gravity: Vector::from(scene.dynamics.gravity),
        head: head_motion(&scene.head_motion, t),
        wind: Wind {
            seed: scene.seed,
            ..scene.wind
        },
        fields: Vec::new(),
        time: t,
    }
}
