//! Cylinder and sphere maps (Kurihara et al. 1993 §3.1) on shapes with known answers, and their
//! error against the exact BVH distance on the head-and-shoulders mesh.

use hair_ssv::head::{head_and_shoulders, head_and_shoulders_body};
use hair_ssv::test_meshes::SplitMix;
use hair_ssv::{
    Bvh, CylinderMap, CylinderMapConfig, MapFrame, Point, Pss, Real, SphereMap, SphereMapConfig,
    Ssv, SsvError, SurfaceMap, Vector,
};

/// A UV sphere of radius `r` around the origin.
fn sphere(r: Real, n: usize) -> Bvh {
    let mut v = vec![Point::new(0.0, r, 0.0)];
    for k in 1..n {
        let phi = std::f32::consts::PI * k as Real / n as Real;
        for i in 0..2 * n {
            let th = std::f32::consts::TAU * i as Real / (2 * n) as Real;
            v.push(Point::new(
                r * phi.sin() * th.cos(),
                r * phi.cos(),
                r * phi.sin() * th.sin(),
            ));
        }
    }
    v.push(Point::new(0.0, -r, 0.0));
    let m = 2 * n as u32;
    let idx = |k: u32, i: u32| 1 + k * m + i % m;
    let last = v.len() as u32 - 1;
    let mut t = Vec::new();
    for i in 0..m {
        t.push([0, idx(0, i + 1), idx(0, i)]);
        t.push([last, idx(n as u32 - 2, i), idx(n as u32 - 2, i + 1)]);
    }
    for k in 0..n as u32 - 2 {
        for i in 0..m {
            t.push([idx(k, i), idx(k, i + 1), idx(k + 1, i + 1)]);
            t.push([idx(k, i), idx(k + 1, i + 1), idx(k + 1, i)]);
        }
    }
    Bvh::new(&v, &t).unwrap()
}

#[test]
fn cylinder_map_of_a_sphere() {
    let bvh = sphere(0.1, 48);
    let frame = MapFrame::try_new(Point::origin(), Vector::y(), Vector::x()).unwrap();
    let map = CylinderMap::build(
        &bvh,
        frame,
        &CylinderMapConfig {
            heights: (-0.07, 0.07),
            max_radius: 0.3,
            ..Default::default()
        },
    )
    .unwrap();
    let mut rng = SplitMix::new(1);
    for _ in 0..2000 {
        let h = rng.range(-0.06, 0.06);
        let th = rng.range(-4.0, 4.0);
        let exact = (0.01 - h * h).sqrt();
        assert!(
            (map.radius_at(th, h) - exact).abs() < 1e-3,
            "radius at {th} {h}: {} vs {exact}",
            map.radius_at(th, h)
        );
        let p = Point::new(0.0, h, 0.0) + frame.radial(th) * (exact + rng.range(-0.02, 0.02));
        let s = map.lookup(&p).unwrap();
        let dist = p.coords.norm() - 0.1;
        if dist.abs() > 2e-3 {
            assert_eq!(s.inside, dist < 0.0);
        }
        assert!(
            (s.distance - dist).abs() < 2e-3,
            "{} vs {}",
            s.distance,
            dist
        );
        assert!((s.surface.coords.norm() - 0.1).abs() < 3e-3);
        assert!((s.normal.norm() - 1.0).abs() < 1e-5);
    }
    assert!(map.lookup(&Point::new(0.0, 0.09, 0.0)).is_none());
}

#[test]
fn sphere_map_sees_the_top() {
    let bvh = sphere(0.1, 48);
    let frame = MapFrame::try_new(Point::origin(), Vector::y(), Vector::x()).unwrap();
    let map = SphereMap::build(&bvh, frame, &SphereMapConfig::default()).unwrap();
    for p in [
        Point::new(0.0, 0.11, 0.0),
        Point::new(0.0, 0.095, 0.0),
        Point::new(0.01, 0.09, 0.02),
    ] {
        let s = map.lookup(&p).unwrap();
        let dist = p.coords.norm() - 0.1;
        assert_eq!(s.inside, dist < 0.0);
        assert!(
            (s.distance - dist).abs() < 1e-3,
            "{} vs {}",
            s.distance,
            dist
        );
    }
    assert!(map.lookup(&Point::new(0.0, -0.1, 0.0)).is_none());
}

#[test]
fn maps_reject_bad_configs() {
    let bvh = sphere(0.1, 8);
    let frame = MapFrame::try_new(Point::origin(), Vector::y(), Vector::x()).unwrap();
    let bad = CylinderMapConfig {
        azimuth_samples: 2,
        ..Default::default()
    };
    assert!(matches!(
        CylinderMap::build(&bvh, frame, &bad),
        Err(SsvError::InvalidMap { .. })
    ));
    let bad = CylinderMapConfig {
        heights: (0.1, -0.1),
        ..Default::default()
    };
    assert!(matches!(
        CylinderMap::build(&bvh, frame, &bad),
        Err(SsvError::InvalidMap { .. })
    ));
    let bad = SphereMapConfig {
        max_polar: 4.0,
        ..Default::default()
    };
    assert!(matches!(
        SphereMap::build(&bvh, frame, &bad),
        Err(SsvError::InvalidMap { .. })
    ));
    assert!(MapFrame::try_new(Point::origin(), Vector::y(), Vector::y() * 2.0).is_err());
}

#[test]
fn body_map_error_against_the_exact_mesh_distance() {
    let (v, t) = head_and_shoulders(32);
    let bvh = Bvh::new(&v, &t).unwrap();
    let body = head_and_shoulders_body(&bvh, 64).unwrap();
    let mut rng = SplitMix::new(3);
    let mut errs = Vec::new();
    for _ in 0..2000 {
        let off = rng.range(-0.005, 0.01);
        let (p, _) = rng.surface_point(bvh.triangles(), off);
        if hair_ssv::head::inside_neck(&p) {
            continue;
        }
        let Some(s) = body.lookup(&p) else { continue };
        let exact = bvh.closest(&Ssv::Point(Pss::new(p, 0.0))).unwrap();
        let tri = bvh.triangle(exact.triangle as usize).unwrap();
        let n = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
        let sign = if (p - exact.closest.on_b).dot(&n) < 0.0 {
            -1.0
        } else {
            1.0
        };
        errs.push((s.distance - sign * exact.distance).abs());
    }
    errs.sort_by(f32::total_cmp);
    let mean = errs.iter().sum::<Real>() / errs.len() as Real;
    let p95 = errs[errs.len() * 95 / 100];
    assert!(errs.len() > 1500, "coverage {}", errs.len());
    // a coarse mesh (6,700 triangles) and 64 x 64 tables: well under a millimetre on average
    assert!(mean < 1e-3 && p95 < 3e-3, "mean {mean} p95 {p95}");
}
