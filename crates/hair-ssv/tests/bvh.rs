//! The BVH against brute force over all triangles: contacts, closest triangle, ray casts,
//! batches, rigid motion, and mesh validation errors.

mod support;

use hair_ssv::{Bvh, MeshContact, Point, Real, Ssv, SsvError, Vector};
use proptest::prelude::*;
use support::*;

/// A random mesh: a bumpy height field (connected, many near neighbours) plus a triangle soup.
fn mesh() -> impl Strategy<Value = (Vec<Point>, Vec<[u32; 3]>)> {
    (
        3usize..12,
        0usize..60,
        proptest::collection::vec(-1.0f32..1.0, 600),
        0.0f32..0.5,
    )
        .prop_map(|(n, soup, r, amp)| {
            let mut v = Vec::new();
            let mut t = Vec::new();
            let mut k = 0;
            let mut next = || {
                k = (k + 1) % r.len();
                r[k]
            };
            for j in 0..n {
                for i in 0..n {
                    let (x, z) = (
                        i as Real / (n - 1) as Real * 2.0 - 1.0,
                        j as Real / (n - 1) as Real * 2.0 - 1.0,
                    );
                    v.push(Point::new(x, amp * next(), z));
                }
            }
            for j in 0..n - 1 {
                for i in 0..n - 1 {
                    let a = (j * n + i) as u32;
                    t.push([a, a + 1, a + n as u32 + 1]);
                    t.push([a, a + n as u32 + 1, a + n as u32]);
                }
            }
            for _ in 0..soup {
                let base = v.len() as u32;
                let c = Point::new(next(), next(), next());
                for _ in 0..3 {
                    v.push(c + Vector::new(next(), next(), next()) * 0.3);
                }
                t.push([base, base + 1, base + 2]);
            }
            // drop the (rare) degenerate soup triangles so the mesh validates
            let t = t
                .into_iter()
                .filter(|tri| {
                    let [a, b, c] = tri.map(|i| v[i as usize]);
                    let longest = (b - a)
                        .norm_squared()
                        .max((c - a).norm_squared())
                        .max((c - b).norm_squared());
                    (b - a).cross(&(c - a)).norm() > 1e-4 * longest
                })
                .collect();
            (v, t)
        })
}

fn brute_contacts(tris: &[[Point; 3]], s: &Ssv, margin: Real) -> Vec<MeshContact> {
    tris.iter()
        .enumerate()
        .filter_map(|(i, t)| {
            s.contact_with_triangle(t, margin)
                .map(|contact| MeshContact {
                    triangle: i as u32,
                    contact,
                })
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn contacts_equal_brute_force((v, t) in mesh(), s in ssv(), margin in prop_oneof![Just(0.0f32), 0.0f32..0.2]) {
        let bvh = Bvh::new(&v, &t).expect("valid mesh");
        let mut ours = Vec::new();
        bvh.contacts(&s, margin, &mut ours);
        let brute = brute_contacts(bvh.triangles(), &s, margin);
        prop_assert_eq!(ours, brute);
    }

    #[test]
    fn closest_equals_brute_force((v, t) in mesh(), s in ssv()) {
        let bvh = Bvh::new(&v, &t).expect("valid mesh");
        let ours = bvh.closest(&s).expect("non-empty");
        let brute = bvh.triangles().iter().map(|t| s.closest_to_triangle(t).dist_sq).fold(Real::INFINITY, Real::min);
        prop_assert_eq!(ours.closest.dist_sq, brute);
        prop_assert_eq!(s.closest_to_triangle(bvh.triangle(ours.triangle as usize).unwrap()).dist_sq, brute);
        prop_assert!((ours.distance - (brute.sqrt() - s.radius())).abs() <= 1e-6);
    }

    #[test]
    fn contacts_are_invariant_under_rigid_motion((v, t) in mesh(), s in ssv(), rot in rotation(), tr in unit_point()) {
        let margin = 0.05;
        let bvh = Bvh::new(&v, &t).expect("valid mesh");
        let tr = tr.coords * 2.0;
        let moved: Vec<Point> = v.iter().map(|p| rigid(p, &rot, &tr)).collect();
        let bvh2 = Bvh::new(&moved, &t).expect("valid mesh");
        let s2 = rigid_ssv(&s, &rot, &tr);
        let (mut a, mut b) = (Vec::new(), Vec::new());
        bvh.contacts(&s, margin, &mut a);
        bvh2.contacts(&s2, margin, &mut b);
        // triangles far enough from the margin's boundary must agree; depths agree everywhere
        let near_boundary = |c: &MeshContact| (c.contact.depth + margin).abs() < 1e-4;
        let ida: Vec<u32> = a.iter().filter(|c| !near_boundary(c)).map(|c| c.triangle).collect();
        let idb: Vec<u32> = b.iter().filter(|c| !near_boundary(c)).map(|c| c.triangle).collect();
        prop_assert_eq!(ida, idb);
        let d1 = bvh.closest(&s).unwrap().distance;
        let d2 = bvh2.closest(&s2).unwrap().distance;
        prop_assert!((d1 - d2).abs() <= 2e-5, "{} vs {}", d1, d2);
    }

    #[test]
    fn ray_cast_equals_brute_force((v, t) in mesh(), o in unit_point(), d in unit_vector()) {
        let bvh = Bvh::new(&v, &t).expect("valid mesh");
        // off the lattice, so the ray does not lie in a triangle's plane (such rays do not hit)
        let o = o * 1.5 + Vector::new(0.0123, 0.0071, -0.0093);
        let hit = bvh.cast_ray(&o, &d, 10.0);
        // brute force: parry's f64 ray cast on every triangle
        use parry3d_f64::query::{Ray, RayCast};
        let ray = Ray::new(v64(&o), d64(&d));
        let brute = bvh.triangles().iter().filter_map(|tri| parry_triangle(tri).cast_local_ray(&ray, 10.0, true)).fold(f64::INFINITY, f64::min);
        match hit {
            Some(h) => prop_assert!((h.t as f64 - brute).abs() < 1e-4, "{} vs {}", h.t, brute),
            None => prop_assert!(brute == f64::INFINITY || brute > 10.0 - 1e-4, "missed a hit at {}", brute),
        }
    }

    #[test]
    fn batches_match_single_queries_in_order((v, t) in mesh(), ssvs in proptest::collection::vec(ssv(), 0..200)) {
        let bvh = Bvh::new(&v, &t).expect("valid mesh");
        let batch = bvh.contacts_batch(&ssvs, 0.02);
        prop_assert_eq!(batch.offsets.len(), ssvs.len() + 1);
        for (i, s) in ssvs.iter().enumerate() {
            let mut one = Vec::new();
            bvh.contacts(s, 0.02, &mut one);
            prop_assert_eq!(batch.of(i), &one[..]);
        }
        let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap().install(|| bvh.contacts_batch(&ssvs, 0.02));
        prop_assert_eq!(&single, &batch);
        let closest = bvh.closest_batch(&ssvs);
        for (s, c) in ssvs.iter().zip(&closest) {
            prop_assert_eq!(*c, bvh.closest(s));
        }
    }
}

#[test]
fn head_mesh_contacts_equal_brute_force() {
    let (v, t) = hair_ssv::head::head_and_shoulders(24);
    let bvh = Bvh::new(&v, &t).unwrap();
    let mut rng = hair_ssv::test_meshes::SplitMix::new(7);
    for _ in 0..200 {
        let off = rng.range(-0.01, 0.01);
        let (p, _) = rng.surface_point(bvh.triangles(), off);
        let q = rng.point_near(&p, 0.03);
        let s = Ssv::Line(hair_ssv::Lss::new(p, q, 0.005));
        let mut ours = Vec::new();
        bvh.contacts(&s, 0.0, &mut ours);
        assert_eq!(ours, brute_contacts(bvh.triangles(), &s, 0.0));
    }
}

#[test]
fn bad_meshes_give_typed_errors() {
    let v = vec![
        Point::origin(),
        Point::new(1.0, 0.0, 0.0),
        Point::new(0.0, 1.0, 0.0),
        Point::new(2.0, 0.0, 0.0),
    ];
    assert_eq!(Bvh::new(&v, &[]).unwrap_err(), SsvError::EmptyMesh);
    let err = Bvh::new(&v, &[[0, 1, 2], [0, 1, 9]]).unwrap_err();
    assert_eq!(
        err,
        SsvError::IndexOutOfRange {
            triangle: 1,
            index: 9,
            vertex_count: 4
        }
    );
    assert!(err.to_string().contains("triangle 1"), "{err}");
    assert!(matches!(
        Bvh::new(&v, &[[0, 1, 2], [0, 1, 3]]),
        Err(SsvError::DegenerateTriangle { triangle: 1, .. })
    ));
    assert!(matches!(
        Bvh::new(&v, &[[0, 0, 2]]),
        Err(SsvError::DegenerateTriangle { triangle: 0, .. })
    ));
    let mut bad = v.clone();
    bad[2].y = f32::NAN;
    assert_eq!(
        Bvh::new(&bad, &[[0, 1, 2]]).unwrap_err(),
        SsvError::NonFiniteVertex { vertex: 2 }
    );
}

/// A point with a NaN or infinite coordinate has no closest triangle: the query answers `None`
/// rather than a NaN distance.
#[test]
fn non_finite_points_have_no_closest_triangle() {
    let (v, t) = hair_ssv::head::head_and_shoulders(24);
    let bvh = Bvh::new(&v, &t).expect("valid mesh");
    for bad in [Real::NAN, Real::INFINITY, Real::NEG_INFINITY] {
        for axis in 0..3 {
            let mut p = Point::new(0.01, 0.02, 0.03);
            p[axis] = bad;
            let s = Ssv::Point(hair_ssv::Pss::new(p, 0.0));
            assert_eq!(bvh.closest(&s), None, "point {p:?}");
        }
    }
    // A finite point still has one.
    let s = Ssv::Point(hair_ssv::Pss::new(Point::new(0.01, 0.02, 0.03), 0.0));
    assert!(bvh.closest(&s).is_some_and(|m| m.distance.is_finite()));
}
