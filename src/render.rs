//! `hair::render`: the renderer ([`hair_render`], re-exported whole) and the simulation's view
//! for it: camera, light, the body in world space and every drawn strand, as plain data.

pub use hair_render::*;

use crate::Simulation;

/// The renderer's plain-data view of a simulation: camera, light, the body in world space and
/// every rendered strand.
pub fn scene_of(sim: &Simulation) -> RenderScene {
    let scene = sim.scene();
    let (eye, target) = crate::drivers::camera(&scene.camera, sim.time());
    let head = sim.head_track().motion();
    let to_world = |p: &hair_ssv::Point| head.position + head.rotation * p.coords;
    let body = sim.body().map(|b| {
        let positions: Vec<_> = b.vertices.iter().map(to_world).collect();
        let mut normals = vec![hair_ssv::Vector::zeros(); positions.len()];
        for t in &b.triangles {
            let [a, bb, c] = t.map(|i| positions[i as usize]);
            let n = (bb - a).cross(&(c - a));
            for &i in t {
                normals[i as usize] += n;
            }
        }
        for n in &mut normals {
            *n = n.try_normalize(1e-20).unwrap_or_else(hair_ssv::Vector::y);
        }
        BodyMesh {
            positions,
            normals,
            triangles: b.triangles.clone(),
            color: [0.78, 0.6, 0.5],
        }
    });
    let radius = scene.drawn_strand_radius();
    let geometry = sim.render_geometry();
    let strands = (0..geometry.strand_count())
        .map(|s| Strand {
            points: geometry
                .strand(s)
                .iter()
                .map(|p| StrandPoint::new(*p, radius, [0.35, 0.22, 0.12]))
                .collect(),
        })
        .collect();
    let d = hair_ssv::Vector::from(scene.light.direction);
    RenderScene {
        camera: Camera {
            eye,
            target,
            fov_y: scene.camera.fov_degrees.to_radians(),
            ..Camera::default()
        },
        light: Light {
            direction: -d,
            color: scene.light.color,
            ..Light::default()
        },
        body,
        strands,
        ..RenderScene::default()
    }
}
