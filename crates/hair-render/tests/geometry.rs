//! Curve subdivision and strand-group expansion.

use hair_render::geometry::{prepare, subdivide_catmull_rom, tangents};
use hair_render::*;

fn line(n: usize) -> Vec<StrandPoint> {
    (0..n)
        .map(|i| {
            StrandPoint::new(
                Point::new(i as f32 * 0.1, (i as f32 * 0.7).sin() * 0.05, 0.0),
                0.001 * (i + 1) as f32,
                [0.1 * i as f32, 0.2, 0.3],
            )
        })
        .collect()
}

#[test]
fn catmull_rom_passes_through_control_points() {
    let pts = line(6);
    for k in 1..5u32 {
        let sub = subdivide_catmull_rom(&pts, k);
        assert_eq!(sub.len(), (pts.len() - 1) * k as usize + 1);
        for (i, p) in pts.iter().enumerate() {
            let q = sub[i * k as usize];
            assert!((q.position - p.position).norm() < 1e-6);
            assert!((q.radius - p.radius).abs() < 1e-7);
        }
    }
    assert_eq!(subdivide_catmull_rom(&pts[..1], 4).len(), 1);
    assert!(subdivide_catmull_rom(&[], 4).is_empty());
}

#[test]
fn tangents_are_unit_even_with_coincident_points() {
    let mut pts = line(5);
    pts[2].position = pts[1].position;
    for t in tangents(&pts) {
        assert!((t.norm() - 1.0).abs() < 1e-5);
    }
}

#[test]
fn strand_group_strands_stay_in_the_cross_section() {
    let skeleton = line(5);
    let scene = RenderScene {
        groups: vec![StrandGroup {
            skeleton: skeleton.clone(),
            strand_count: 20,
            strand_radius: 0.0001,
            seed: 9,
        }],
        ..RenderScene::default()
    };
    let p = prepare(&scene, 1).unwrap();
    assert_eq!(p.curve_points, 20 * 5);
    assert_eq!(p.segments, 20 * 4);
    // Every drawn point lies within the skeleton radius of its skeleton point.
    for (i, v) in p.hair_vertices.iter().step_by(2).enumerate() {
        let sk = &skeleton[i % 5];
        let d = (Vector::from(v.position) - sk.position.coords).norm();
        assert!(
            d <= sk.radius * 1.0001,
            "strand point {i} is {d} from the skeleton"
        );
    }
    // The offsets are fixed: preparing again gives the same vertices.
    assert_eq!(prepare(&scene, 1).unwrap().hair_vertices, p.hair_vertices);
}
