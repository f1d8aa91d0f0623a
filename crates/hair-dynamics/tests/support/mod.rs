//! Shared builders for the dynamics tests.

#![allow(dead_code)]

use hair_dynamics::*;
use nalgebra::{Rotation3, Vector3};

/// A root frame whose z axis (the hair direction) points along `dir`.
pub fn frame_along(dir: Vector) -> Rotation3<Real> {
    Rotation3::rotation_between(&Vector::z(), &dir.normalize())
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector::x_axis(), core::f32::consts::PI))
}

/// One attached strand with a style, returning the state and its id.
pub fn one_strand(
    style: Style,
    n: usize,
    length: Real,
    frame: Rotation3<Real>,
    material: Material,
) -> (StrandState, SkeletonId) {
    let mut state = StrandState::new();
    let points = style_points(Point::origin(), &frame, &style, n, length).expect("valid style");
    let id = state
        .add_skeleton(&SkeletonDesc {
            root: Root::Attached {
                position: Point::origin(),
                frame,
            },
            points,
            material,
        })
        .expect("valid skeleton");
    (state, id)
}

/// Attached strands, one per `(root, direction, style)`, each with `n` points and `length`.
pub fn strands(roots: &[(Point, Vector, Style)], n: usize, length: Real) -> StrandState {
    let mut state = StrandState::new();
    for &(root, dir, style) in roots {
        let frame = frame_along(dir);
        let points = style_points(root, &frame, &style, n, length).expect("valid style");
        state
            .add_skeleton(&SkeletonDesc {
                root: Root::Attached {
                    position: root,
                    frame,
                },
                points,
                material: Material::default(),
            })
            .expect("valid skeleton");
    }
    state
}

/// `f` on a pool of `threads` worker threads.
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
        .install(f)
}

pub fn settings(dt: Real, integrator: Integrator, torque: TorqueModel) -> StepSettings {
    StepSettings {
        dt,
        integrator,
        torque,
        solver: LinearSolver::Structured,
    }
}

pub fn no_gravity() -> Environment {
    Environment {
        gravity: Vector::zeros(),
        ..Environment::default()
    }
}

pub fn cast(v: &Vector3<f64>) -> Vector {
    Vector::new(v.x as f32, v.y as f32, v.z as f32)
}
