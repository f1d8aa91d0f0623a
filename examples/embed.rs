//! Embedding the simulation in an engine: no scene file. A groom from arrays of points on the
//! procedural head, a loop that poses the head each step (a sine: nodding and turning) for three
//! seconds, the torso (a separate rigid part) swaying under it, and per step its time and the
//! tip of one strand, read from the drawn strands without a copy.
//!
//! Run from the workspace root: `cargo run --release --example embed`.

use hair::{Body, HairError, PartId, Scene, Simulation};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::f32::consts::TAU;
use std::time::Instant;

/// `count` strands of `points` points and `length` m, rooted just outside the procedural head's
/// crown (its semi-axes 0.078, 0.115, 0.097 m) and standing out along the ellipsoid's normal.
pub fn groom(count: usize, points: usize, length: f32) -> Vec<Vec<[f32; 3]>> {
    let axes = [0.078f32 * 1.04, 0.115 * 1.04, 0.097 * 1.04];
    (0..count)
        .map(|i| {
            // A golden-angle spiral over the upper back of the head.
            let f = (i as f32 + 0.5) / count as f32;
            let (polar, azimuth) = (1.2 * f.sqrt(), i as f32 * 2.399_963);
            let dir = [
                polar.sin() * azimuth.sin(),
                polar.cos(),
                -polar.sin() * azimuth.cos().abs(),
            ];
            let root: [f32; 3] = std::array::from_fn(|k| axes[k] * dir[k]);
            let normal = Vector3::from(std::array::from_fn(|k| dir[k] / axes[k])).normalize();
            (0..points)
                .map(|k| {
                    let s = length * k as f32 / (points - 1) as f32;
                    std::array::from_fn(|c| root[c] + normal[c] * s)
                })
                .collect()
        })
        .collect()
}

/// The head's pose at time `t` (s): turning about +y by 0.5 rad and bobbing 3 cm.
pub fn head_pose(t: f32) -> Isometry3<f32> {
    let turn = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.5 * (TAU * 0.8 * t).sin());
    Isometry3::from_parts(
        Translation3::new(0.0, 0.03 * (TAU * 0.4 * t).sin(), 0.0),
        turn,
    )
}

/// The torso's pose at time `t` (s): leaning 0.15 rad forward and back about the waist, 0.6 m
/// below the head's centre.
pub fn torso_pose(t: f32) -> Isometry3<f32> {
    let waist = Vector3::new(0.0, -0.6, 0.0);
    let lean = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.15 * (TAU * 0.5 * t).sin());
    Translation3::from(waist) * lean * Translation3::from(-waist)
}

/// Simulates `seconds` of the head driven by [`head_pose`], calling `report` with each step's
/// line; returns the last tip of strand 0 (m, world).
pub fn run(seconds: f32, mut report: impl FnMut(&str)) -> Result<[f32; 3], HairError> {
    let strands = hair::io::Strands::from_polylines(groom(300, 12, 0.25))?;
    // The head is the body; the neck (part 0) and torso (part 1) move as the caller poses them.
    let body = Body::HeadNeckTorso { resolution: 32 };
    let mut sim = Simulation::from_groom(&strands, body, &Scene::default())?;
    let steps = (seconds / sim.dt()).round() as u32;
    let mut tip = [0.0; 3];
    for _ in 0..steps {
        // The pose the head reaches at the end of this step.
        let t = sim.time() + sim.dt();
        sim.set_head_pose(head_pose(t))?;
        sim.set_body_part_pose(PartId(1), torso_pose(t))?;
        let start = Instant::now();
        let stats = sim.step()?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        // Borrowed from the simulation: the drawn strand's points, no copy.
        let drawn = sim.render_geometry().strand(0);
        tip = drawn.last().map_or([0.0; 3], |p| [p.x, p.y, p.z]);
        report(&format!(
            "step {:3}  t = {:.3} s  {ms:6.2} ms  tip of strand 0: ({:+.4}, {:+.4}, {:+.4}) m",
            stats.step, stats.time, tip[0], tip[1], tip[2]
        ));
    }
    Ok(tip)
}

fn main() -> Result<(), HairError> {
    let tip = run(3.0, |line| println!("{line}"))?;
    println!("done: 3 s simulated, tip of strand 0 at {tip:?}");
    Ok(())
}
