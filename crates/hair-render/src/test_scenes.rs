//! Procedural scenes shared by the tests, benches, examples and the CLI: an ellipsoid head on a
//! neck and shoulders, with hair hanging from the scalp around it.

use crate::geometry::hash01;
use crate::scene::{BodyMesh, Camera, Light, Point, RenderScene, Strand, StrandPoint, Vector};

/// Centre and radii of the head ellipsoid.
pub const HEAD: ([f32; 3], [f32; 3]) = ([0.0, 0.0, 0.0], [0.078, 0.102, 0.092]);

fn ellipsoid(mesh: &mut BodyMesh, centre: [f32; 3], radii: [f32; 3], rings: u32, sectors: u32) {
    let base = mesh.positions.len() as u32;
    for i in 0..=rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=sectors {
            let ph = std::f32::consts::TAU * j as f32 / sectors as f32;
            let u = Vector::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            mesh.positions.push(Point::new(
                centre[0] + radii[0] * u.x,
                centre[1] + radii[1] * u.y,
                centre[2] + radii[2] * u.z,
            ));
            let n = Vector::new(u.x / radii[0], u.y / radii[1], u.z / radii[2]);
            mesh.normals.push(n.normalize());
        }
    }
    let row = sectors + 1;
    for i in 0..rings {
        for j in 0..sectors {
            let a = base + i * row + j;
            let b = a + row;
            mesh.triangles.push([a, b, a + 1]);
            mesh.triangles.push([a + 1, b, b + 1]);
        }
    }
}

/// A head, neck and shoulders made of three ellipsoids.
pub fn head_body() -> BodyMesh {
    let mut mesh = BodyMesh {
        color: [0.86, 0.66, 0.55],
        ..BodyMesh::default()
    };
    ellipsoid(&mut mesh, HEAD.0, HEAD.1, 32, 48);
    ellipsoid(&mut mesh, [0.0, -0.13, -0.01], [0.045, 0.08, 0.045], 12, 24);
    ellipsoid(&mut mesh, [0.0, -0.23, -0.01], [0.21, 0.065, 0.11], 20, 48);
    mesh
}

/// Pushes `p` out of the head ellipsoid inflated by `margin`.
fn push_out(p: Point, margin: f32) -> Point {
    let (c, r) = HEAD;
    let q = Vector::new(
        (p.x - c[0]) / (r[0] * margin),
        (p.y - c[1]) / (r[1] * margin),
        (p.z - c[2]) / (r[2] * margin),
    );
    let n = q.norm();
    if n >= 1.0 || n == 0.0 {
        return p;
    }
    let s = q / n;
    Point::new(
        c[0] + s.x * r[0] * margin,
        c[1] + s.y * r[1] * margin,
        c[2] + s.z * r[2] * margin,
    )
}

/// `count` strands of `points` control points hanging from the scalp under gravity, roughly
/// `length` metres long, with a fibre radius of `radius`.
pub fn hanging_hair(
    count: usize,
    points: usize,
    length: f32,
    radius: f32,
    seed: u64,
) -> Vec<Strand> {
    let (c, r) = HEAD;
    let points = points.max(2);
    let mut out = Vec::with_capacity(count);
    let mut k = 0u64;
    while out.len() < count {
        k += 1;
        // A direction on the upper head, away from the face.
        let y = hash01(seed, 4 * k) * 1.25 - 0.25;
        let ph = std::f32::consts::TAU * hash01(seed, 4 * k + 1);
        let s = (1.0 - y * y).max(0.0).sqrt();
        let u = Vector::new(s * ph.cos(), y, s * ph.sin());
        if u.z > -0.05 && u.y < 0.5 && u.x.abs() < 0.8 {
            continue; // the face
        }
        let root = Point::new(c[0] + r[0] * u.x, c[1] + r[1] * u.y, c[2] + r[2] * u.z);
        let normal = Vector::new(u.x / r[0], u.y / r[1], u.z / r[2]).normalize();
        let len = length * (0.85 + 0.3 * hash01(seed, 4 * k + 2));
        let step = len / (points - 1) as f32;
        let tint = 0.8 + 0.4 * hash01(seed, 4 * k + 3);
        let color = [0.30 * tint, 0.17 * tint, 0.08 * tint];
        let mut p = root;
        let mut d = normal;
        let mut pts = Vec::with_capacity(points);
        pts.push(StrandPoint::new(p, radius, color));
        for _ in 1..points {
            // Gravity, and roots above the face combed back and to the side.
            let comb = Vector::new(0.6 * u.x.signum() * u.z.max(0.0), 0.0, -0.8 * u.z.max(0.0));
            d = (d + Vector::new(0.0, -0.9, 0.0) + comb).normalize();
            p = push_out(p + d * step, 1.06);
            pts.push(StrandPoint::new(p, radius, color));
        }
        out.push(Strand { points: pts });
    }
    out
}

/// The demo scene: head and shoulders with `strands` hanging strands of 10 control points,
/// lit from above and to the side.
pub fn head_scene(strands: usize, seed: u64) -> RenderScene {
    RenderScene {
        camera: Camera {
            eye: Point::new(0.2, 0.04, 0.55),
            target: Point::new(0.0, -0.06, 0.0),
            up: Vector::y(),
            fov_y: 0.7,
            near: 0.05,
            far: 5.0,
        },
        light: Light {
            direction: Vector::new(-0.55, 0.9, 0.45),
            color: [1.0, 0.97, 0.92],
            ambient: [0.1, 0.1, 0.12],
        },
        body: Some(head_body()),
        strands: hanging_hair(strands, 10, 0.27, 0.00012, seed),
        ..RenderScene::default()
    }
}

/// The benchmark scene: 8,216 strands of 10 control points, which with 4 subdivisions per
/// segment are 37 rendered points each: 303,992 vertices, the salon paper's 304 K.
pub fn bench_scene() -> RenderScene {
    head_scene(8216, 7)
}

/// Rendered vertices per strand of [`bench_scene`] at 4 subdivisions.
pub const BENCH_SUBDIVISIONS: u32 = 4;
