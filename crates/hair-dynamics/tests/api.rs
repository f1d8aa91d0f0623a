//! Bad input, collision response, bonds, free roots, head motion and thread-count determinism.

mod support;

use hair_dynamics::*;
use nalgebra::Rotation3;
use support::*;

#[test]
fn bad_input_gives_typed_errors() {
    let mut state = StrandState::new();
    let frame = Rotation3::identity();
    let attached = Root::Attached {
        position: Point::origin(),
        frame,
    };
    let err = state
        .add_skeleton(&SkeletonDesc {
            root: attached,
            points: vec![Point::origin()],
            material: Material::default(),
        })
        .unwrap_err();
    assert!(matches!(err, DynamicsError::TooFewPoints { count: 1, .. }));
    let err = state
        .add_skeleton(&SkeletonDesc {
            root: attached,
            points: vec![Point::origin(), Point::origin()],
            material: Material::default(),
        })
        .unwrap_err();
    assert!(
        matches!(err, DynamicsError::DegenerateSegment { segment: 1, .. }),
        "{err}"
    );
    let err = state
        .add_skeleton(&SkeletonDesc {
            root: attached,
            points: vec![Point::origin(), Point::new(0.0, f32::NAN, 0.0)],
            material: Material::default(),
        })
        .unwrap_err();
    assert!(
        matches!(
            err,
            DynamicsError::InvalidNode {
                node: 1,
                field: "point",
                ..
            }
        ),
        "{err}"
    );
    let err = state
        .add_skeleton(&SkeletonDesc {
            root: attached,
            points: vec![Point::origin(), Point::new(0.0, 0.0, 0.1)],
            material: Material {
                damping: -1.0,
                ..Material::default()
            },
        })
        .unwrap_err();
    assert!(err.to_string().contains("material.damping"), "{err}");

    let (mut state, _) = one_strand(Style::Straight, 5, 0.1, frame, Material::default());
    for dt in [0.0, -0.01, f32::NAN, f32::INFINITY] {
        let err = state
            .step(
                &Environment::default(),
                &settings(dt, Integrator::ImplicitCoupled, TorqueModel::Chain),
            )
            .unwrap_err();
        assert!(
            matches!(err, DynamicsError::InvalidTimeStep { .. }),
            "{err}"
        );
    }
    let env = Environment {
        gravity: Vector::new(0.0, f32::NAN, 0.0),
        ..Environment::default()
    };
    let err = state.step(&env, &StepSettings::default()).unwrap_err();
    assert!(err.to_string().contains("gravity"), "{err}");
    assert!(
        style_points(
            Point::origin(),
            &frame,
            &Style::Wavy {
                amplitude: 0.01,
                period: 0.0
            },
            5,
            0.1
        )
        .is_err()
    );
}

#[test]
fn explicit_euler_blow_up_is_reported_and_the_strand_restored() {
    let (mut state, _) = one_strand(
        Style::Straight,
        20,
        0.25,
        frame_along(Vector::x()),
        Material::default(),
    );
    state.k_theta_mut().iter_mut().for_each(|k| *k = 1e6);
    state.k_phi_mut().iter_mut().for_each(|k| *k = 1e6);
    state.theta_mut()[3] = 0.5;
    let s = settings(0.05, Integrator::ExplicitEuler, TorqueModel::Chain);
    let mut failed = None;
    for _ in 0..200 {
        let before = state.theta().to_vec();
        if let Err(e) = state.step(&Environment::default(), &s) {
            assert_eq!(
                state.theta(),
                &before[..],
                "the failing strand must be restored"
            );
            failed = Some(e);
            break;
        }
    }
    let err = failed.expect("explicit Euler with k = 1e6 at 50 ms must blow up");
    assert!(
        matches!(err, DynamicsError::NonFiniteState { skeleton: 0, .. }),
        "{err}"
    );
    assert!(state.theta().iter().all(|x| x.is_finite()));
}

#[test]
fn corrections_move_nodes_and_keep_lengths() {
    let (mut state, id) = one_strand(
        Style::Straight,
        10,
        0.2,
        frame_along(-Vector::y()),
        Material::default(),
    );
    let r = state.nodes(id);
    let tip = r.end - 1;
    let delta = Vector::new(0.03, 0.0, 0.0);
    let target = state.positions()[tip] + delta;
    state
        .apply_corrections(&[NodeCorrection {
            node: tip as u32,
            delta,
        }])
        .unwrap();
    let p = state.positions();
    for i in r.start + 1..r.end {
        assert!(((p[i] - p[i - 1]).norm() - state.length()[i]).abs() < 1e-6);
    }
    // The last segment re-aims at the target: the tip moves toward it.
    assert!((p[tip] - target).norm() < 0.03);
    assert!(p[tip].x > 0.0);
    assert_eq!(
        p[r.start],
        Point::origin(),
        "an attached root does not move"
    );
    assert!(
        state
            .apply_corrections(&[NodeCorrection { node: 999, delta }])
            .is_err()
    );
}

#[test]
fn velocity_constraints_remove_the_approach_and_apply_friction() {
    let (mut state, id) = one_strand(
        Style::Straight,
        6,
        0.1,
        frame_along(Vector::x()),
        Material::default(),
    );
    // Swing it down under gravity for a few steps, then forbid downward motion at the tip.
    for _ in 0..10 {
        state
            .step(
                &Environment::default(),
                &settings(1.0 / 120.0, Integrator::ImplicitCoupled, TorqueModel::Chain),
            )
            .unwrap();
    }
    // A contact is taken by every joint above its node: next to the clamped root and at the
    // tip alike the node's approach is removed, and the strand's kinetic energy never grows.
    let first = state.nodes(id).start + 1;
    let tip = state.nodes(id).end - 1;
    let env = Environment::default();
    for node in [first, tip] {
        let v = state.velocities()[node];
        assert!(v.y < 0.0, "node {node} should approach the surface");
        let before = state.model_energy(&env, TorqueModel::Chain);
        state
            .apply_velocity_constraints(&[VelocityConstraint {
                node: node as u32,
                normal: Vector::y(),
                friction: 0.0,
            }])
            .unwrap();
        let after = state.velocities()[node];
        // The fit is regularised by 1 % of the joints' response: a little approach may stay.
        assert!(
            after.y >= 0.03 * v.y,
            "node {node}: normal velocity {} from {}",
            after.y,
            v.y
        );
        let energy = state.model_energy(&env, TorqueModel::Chain);
        assert!(
            energy <= before + 1e-12,
            "node {node}: energy {energy} from {before}"
        );
    }
}

#[test]
fn surface_constraints_act_on_the_velocity_relative_to_the_moving_surface() {
    let (mut state, id) = one_strand(
        Style::Straight,
        6,
        0.1,
        frame_along(Vector::x()),
        Material::default(),
    );
    for _ in 0..10 {
        state
            .step(
                &Environment::default(),
                &settings(1.0 / 120.0, Integrator::ImplicitCoupled, TorqueModel::Chain),
            )
            .unwrap();
    }
    // Next to the clamped root, along x: its own joint moves the node along y and z freely.
    let node = state.nodes(id).start + 1;
    let falling = state.velocities()[node];
    assert!(falling.y < -0.01, "the node falls at {falling:?}");
    let floor = |friction| VelocityConstraint {
        node: node as u32,
        normal: Vector::y(),
        friction,
    };
    let apply = |surface: Vector, friction: Real| {
        let mut s = state.clone();
        s.apply_velocity_constraints_on_surfaces(&[floor(friction)], &[surface])
            .unwrap();
        s.velocities()[node]
    };
    // A floor dropping away faster than the node falls leaves it alone.
    let after = apply(Vector::new(0.0, 2.0 * falling.y, 0.0), 1.0);
    assert_eq!(after, falling);
    // A floor rising at 0.3 m/s lifts it at the floor's speed (within the fit's 2 %), no more.
    let after = apply(Vector::new(0.0, 0.3, 0.0), 0.0);
    assert!(
        after.y > 0.3 * 0.97 && after.y < 0.3 + 1e-4,
        "lifted at {}",
        after.y
    );
    assert!(
        (after.z - falling.z).abs() < 1e-3,
        "no friction, yet z went {}",
        after.z
    );
    // A floor sliding along z drags it by friction toward its speed, never past it (but for
    // rounding between the normal and friction impulses, 0.1 %); without friction it does not
    // drag it at all. Next to the root the impulse has to turn the whole strand; at the tip it
    // turns the light last joints, so the tip is dragged far more.
    let slide = Vector::new(0.0, 0.0, 0.5);
    let dragged = apply(slide, 1.0);
    assert!(
        dragged.z > falling.z + 1e-4 && dragged.z <= 0.5 * 1.001,
        "dragged to {}",
        dragged.z
    );
    let slipped = apply(slide, 0.0);
    assert!(
        (slipped.z - falling.z).abs() < 1e-3,
        "slipped to {}",
        slipped.z
    );
    let tip = state.nodes(id).end - 1;
    let mut s = state.clone();
    let at_tip = VelocityConstraint {
        node: tip as u32,
        ..floor(1.0)
    };
    s.apply_velocity_constraints_on_surfaces(&[at_tip], &[slide])
        .unwrap();
    let (from, to) = (state.velocities()[tip].z, s.velocities()[tip].z);
    assert!(
        to - from > 4.0 * (dragged.z - falling.z) && to <= 0.5 * 1.001,
        "tip dragged from {from} to {to}; next to the root {} to {}",
        falling.z,
        dragged.z
    );
    // One surface velocity per constraint, finite: otherwise an error and nothing changes.
    let before = state.state_hash();
    assert!(
        state
            .apply_velocity_constraints_on_surfaces(&[floor(0.5)], &[])
            .is_err()
    );
    assert!(
        state
            .apply_velocity_constraints_on_surfaces(
                &[floor(0.5)],
                &[Vector::new(Real::NAN, 0.0, 0.0)]
            )
            .is_err()
    );
    assert_eq!(state.state_hash(), before);
}

#[test]
fn bonds_pull_and_break_at_their_distance() {
    let down = -Vector::y();
    let mut state = strands(
        &[
            (Point::origin(), down, Style::Straight),
            (Point::new(0.01, 0.0, 0.0), down, Style::Straight),
        ],
        6,
        0.1,
    );
    let a = state.nodes(SkeletonId(0)).end - 1;
    let b = state.nodes(SkeletonId(1)).end - 1;
    state
        .add_bond(Bond {
            a: a as u32,
            b: b as u32,
            rest: 0.0,
            stiffness: 1.0,
            break_distance: 0.05,
        })
        .unwrap();
    let s = settings(1.0 / 120.0, Integrator::ImplicitCoupled, TorqueModel::Chain);
    let env = Environment::default();
    for _ in 0..30 {
        state.step(&env, &s).unwrap();
    }
    let gap = (state.positions()[a] - state.positions()[b]).norm();
    assert!(gap < 0.01, "the bond pulls the tips together: {gap}");
    assert_eq!(state.bonds().len(), 1);
    // Push the tips apart hard: the bond must break once they pass 5 cm, not before.
    state.external_force_mut()[a] = Vector::new(-5.0, 0.0, 0.0);
    state.external_force_mut()[b] = Vector::new(5.0, 0.0, 0.0);
    let mut broke = false;
    for _ in 0..200 {
        let report = state.step(&env, &s).unwrap();
        let gap = (state.positions()[a] - state.positions()[b]).norm();
        if report.bonds_broken == 1 {
            assert!(gap > 0.05, "broke early at {gap}");
            broke = true;
            break;
        }
        assert!(gap <= 0.05, "still bonded at {gap}");
    }
    assert!(broke);
    assert!(
        state
            .add_bond(Bond {
                a: 0,
                b: 10_000,
                rest: 0.0,
                stiffness: 1.0,
                break_distance: 1.0
            })
            .is_err()
    );
}

#[test]
fn a_free_piece_falls_without_spinning() {
    let mut state = StrandState::new();
    let frame = frame_along(Vector::x());
    let points = style_points(Point::origin(), &frame, &Style::Straight, 8, 0.1).unwrap();
    let id = state
        .add_skeleton(&SkeletonDesc {
            root: Root::Free {
                position: Point::origin(),
                velocity: Vector::zeros(),
                frame,
            },
            points,
            material: Material::default(),
        })
        .unwrap();
    let s = settings(1.0 / 100.0, Integrator::ImplicitCoupled, TorqueModel::Chain);
    for _ in 0..50 {
        state.step(&Environment::default(), &s).unwrap();
    }
    // Free fall for 0.5 s (symplectic Euler on the root): y = -g t (t + dt) / 2.
    let y = -9.81 * 0.5 * (0.5 + 0.01) / 2.0;
    for i in state.nodes(id) {
        assert!(
            (state.positions()[i].y - y).abs() < 1e-4,
            "node {i}: {}",
            state.positions()[i]
        );
    }
}

#[test]
fn a_shaking_head_swings_the_hair() {
    // A strand hanging from the side of the head, 10 cm off the vertical axis the head turns about.
    let mut still = StrandState::new();
    let frame = frame_along(-Vector::y());
    let root = Point::new(0.1, 0.0, 0.0);
    let points = style_points(root, &frame, &Style::Straight, 12, 0.25).unwrap();
    let id = still
        .add_skeleton(&SkeletonDesc {
            root: Root::Attached {
                position: root,
                frame,
            },
            points,
            material: Material::default(),
        })
        .unwrap();
    let mut shaken = still.clone();
    let s = settings(1.0 / 120.0, Integrator::ImplicitCoupled, TorqueModel::Chain);
    for step in 0..120 {
        let t = step as f32 / 120.0;
        let w = 4.0 * (6.0 * t).sin();
        let head = HeadMotion {
            angular_velocity: Vector::new(0.0, w, 0.0),
            angular_acceleration: Vector::new(0.0, 24.0 * (6.0 * t).cos(), 0.0),
            rotation: Rotation3::from_axis_angle(
                &Vector::y_axis(),
                -4.0 / 6.0 * ((6.0 * t).cos() - 1.0),
            ),
            ..HeadMotion::default()
        };
        still.step(&Environment::default(), &s).unwrap();
        shaken
            .step(
                &Environment {
                    head,
                    ..Environment::default()
                },
                &s,
            )
            .unwrap();
    }
    let tip = still.nodes(id).end - 1;
    let d = (still.positions()[tip] - shaken.positions()[tip]).norm();
    assert!(d > 0.01, "fictitious forces should swing the tip: {d}");
}

#[test]
fn results_are_identical_for_any_thread_count() {
    let roots: Vec<(Point, Vector, Style)> = (0..64)
        .map(|k| {
            let a = k as f32 * 0.1;
            let root = Point::new(0.1 * a.cos(), 0.1, 0.1 * a.sin());
            let style = if k % 2 == 0 {
                Style::Curly {
                    radius: 0.01,
                    pitch: 0.03,
                }
            } else {
                Style::Straight
            };
            (root, Vector::new(a.cos(), 0.3, a.sin()), style)
        })
        .collect();
    let env = Environment {
        wind: Wind {
            speed: 4.0,
            turbulence: 0.5,
            drag: 2e-3,
            ..Wind::default()
        },
        ..Environment::default()
    };
    let run = |threads: usize| {
        on_threads(threads, || {
            let mut state = strands(&roots, 20, 0.25);
            for _ in 0..60 {
                state
                    .step(
                        &env,
                        &settings(1.0 / 60.0, Integrator::ImplicitCoupled, TorqueModel::Chain),
                    )
                    .unwrap();
            }
            state
                .positions()
                .iter()
                .flat_map(|p| p.coords.iter().map(|c| c.to_bits()))
                .collect::<Vec<u32>>()
        })
    };
    assert_eq!(run(1), run(2));
    assert_eq!(run(1), run(3));
}

/// A force for the next step acts exactly as the same external force set for one step and
/// cleared after it, bit for bit; a bad node or a non-finite force is an error that queues
/// nothing.
#[test]
fn forces_for_the_next_step_act_for_one_step_only() {
    let (mut queued, id) = one_strand(
        Style::Wavy {
            amplitude: 0.01,
            period: 0.08,
        },
        12,
        0.25,
        frame_along(Vector::new(1.0, -0.4, 0.2)),
        Material::default(),
    );
    let mut external = queued.clone();
    let mut unpushed = queued.clone();
    let s = settings(1.0 / 60.0, Integrator::ImplicitCoupled, TorqueModel::Chain);
    let env = Environment::default();
    let tip = queued.nodes(id).end - 1;
    let push = Vector::new(0.0, 0.0, 3e-4);
    assert!(queued.add_forces_for_next_step(&[(99, push)]).is_err());
    assert!(
        queued
            .add_forces_for_next_step(&[(tip as u32, Vector::new(f32::NAN, 0.0, 0.0))])
            .is_err()
    );
    queued
        .add_forces_for_next_step(&[(tip as u32, push)])
        .unwrap();
    external.external_force_mut()[tip] = push;
    for k in 0..5 {
        queued.step(&env, &s).unwrap();
        external.step(&env, &s).unwrap();
        external.external_force_mut()[tip] = Vector::zeros();
        assert_eq!(queued.positions(), external.positions(), "step {k}");
        assert_eq!(queued.omega_theta(), external.omega_theta(), "step {k}");
        unpushed.step(&env, &s).unwrap();
    }
    let moved = (queued.positions()[tip] - unpushed.positions()[tip]).norm();
    assert!(moved > 1e-4, "the push moved the tip only {moved} m");
}

/// Per-node forces for the next step act as the same forces queued by list, bit for bit, for
/// one step only (the listed ones are cleared after it, the per-node ones zeroed); a copy of
/// the state carries them.
#[test]
fn node_forces_for_the_next_step_act_as_listed_ones() {
    let (mut dense, id) = one_strand(
        Style::Wavy {
            amplitude: 0.01,
            period: 0.08,
        },
        12,
        0.25,
        frame_along(Vector::new(0.3, -1.0, 0.2)),
        Material::default(),
    );
    let mut listed = dense.clone();
    let s = settings(1.0 / 60.0, Integrator::ImplicitCoupled, TorqueModel::Chain);
    let env = Environment::default();
    let nodes = dense.nodes(id);
    let push = |i: usize| Vector::new(1e-4 * i as f32, -2e-4, 3e-5 * (i % 3) as f32);
    let list: Vec<(u32, Vector)> = nodes.clone().map(|i| (i as u32, push(i))).collect();
    listed.add_forces_for_next_step(&list).unwrap();
    dense.add_node_forces_for_next_step(|state, forces| {
        assert_eq!(forces.len(), state.node_count());
        assert!(forces.iter().all(|f| *f == Vector::zeros()));
        for i in nodes.clone() {
            forces[i] += push(i);
        }
    });
    let carried = dense.clone();
    for k in 0..4 {
        dense.step(&env, &s).unwrap();
        listed.step(&env, &s).unwrap();
        assert_eq!(dense.positions(), listed.positions(), "step {k}");
        assert_eq!(dense.omega_phi(), listed.omega_phi(), "step {k}");
    }
    // The step that used them left none for the next response.
    dense.add_node_forces_for_next_step(|_, forces| {
        assert!(
            forces.iter().all(|f| *f == Vector::zeros()),
            "forces left over"
        );
    });
    let mut unpushed = carried.clone();
    unpushed.add_node_forces_for_next_step(|_, forces| forces.fill(Vector::zeros()));
    let mut pushed = carried;
    unpushed.step(&env, &s).unwrap();
    pushed.step(&env, &s).unwrap();
    assert_ne!(
        unpushed.state_hash(),
        pushed.state_hash(),
        "the copy lost the forces"
    );
}
