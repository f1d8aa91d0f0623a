//! The adaptive policy's visibility: drawing the body's depth from the camera (done on every step
//! the view moves) and testing points against it (every control point of the front, every step).

use criterion::{Criterion, criterion_group, criterion_main};

use hair_lod::{BodyDepth, OccluderMesh, View};
use hair_ssv::{Point, Vector};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    // The procedural head at `wardlin`'s resolution (about 53,000 triangles) and its camera.
    let (vertices, triangles) = hair_ssv::head::head_and_shoulders(96);
    let body = OccluderMesh {
        vertices: &vertices,
        triangles: &triangles,
        closed: true,
    };
    let eye = Point::new(0.0, 0.05, 0.6);
    let view = View {
        eye,
        forward: (Point::new(0.0, -0.05, 0.0) - eye).normalize(),
        cos_half_angle: 0.6_f32.cos(),
        occluder: None,
    };
    let mut depth = BodyDepth::new();
    let mut step = 0u32;
    c.bench_function("body_depth_build_head96", |b| {
        b.iter(|| {
            // A new eye each time, a millimetre apart, so that the image is drawn again.
            step = step.wrapping_add(1);
            let moved = View {
                eye: eye + Vector::new(1e-3 * (step % 7) as f32, 0.0, 0.0),
                ..view
            };
            black_box(depth.build(body, &moved))
        })
    });
    depth.build(body, &view);
    let seen = View {
        occluder: Some(&depth),
        ..view
    };
    // A 10 x 10 x 10 block of points around the head, half of them behind it.
    let points: Vec<Point> = (0..1000)
        .map(|i| {
            let (x, y, z) = (i % 10, (i / 10) % 10, i / 100);
            Point::new(
                -0.15 + 0.03 * x as f32,
                -0.25 + 0.04 * y as f32,
                -0.25 + 0.05 * z as f32,
            )
        })
        .collect();
    c.bench_function("view_sees_1000_points", |b| {
        b.iter(|| black_box(points.iter().filter(|p| seen.sees(p)).count()))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
