//! Distances, closest points and contacts between SSVs and triangles, against parry3d-f64.

mod support;

use hair_ssv::{Lss, Point, Pss, Real, Rss, Ssv, SsvError, Vector};
use parry3d_f64::query::PointQuery;
use proptest::prelude::*;
use support::*;

const TOL: f64 = 1e-5;
/// parry's GJK on rounded shapes (capsule, round cuboid) stops at about 1e-5 of the scale, so the
/// comparison of whole volumes gets a little more room; the cores are compared at `TOL`.
const ROUND_TOL: f64 = 5e-5;

/// Ours on the scene scaled by `k`, parry on the unit scene scaled back (parry's GJK has absolute
/// tolerances that would otherwise dominate at tiny scales).
fn check_pair(ua: &Ssv, ub: &Ssv, k: Real) -> Result<(), TestCaseError> {
    let (a, b) = (scale_ssv(ua, k), scale_ssv(ub, k));
    let kk = k as f64;
    let tol = TOL * kk;
    let c = a.closest_points(&b);
    prop_assert!(
        c.dist_sq.is_finite()
            && c.on_a
                .coords
                .iter()
                .chain(c.on_b.coords.iter())
                .all(|x| x.is_finite())
    );
    let ours_core = c.distance() as f64;
    let oracle_core = oracle_core_distance(ua, ub) * kk;
    prop_assert!(
        (ours_core - oracle_core).abs() <= tol,
        "core: ours {ours_core} parry {oracle_core} for {a:?} {b:?}"
    );
    // the closest points are on the cores and realise the distance
    let (pa, sa) = parry_core(ua);
    let (pb, sb) = parry_core(ub);
    let on_a_dist = sa.distance_to_point(&pa, v64(&c.on_a) / kk, true) * kk;
    let on_b_dist = sb.distance_to_point(&pb, v64(&c.on_b) / kk, true) * kk;
    prop_assert!(
        on_a_dist <= tol && on_b_dist <= tol,
        "closest points off the cores: {on_a_dist} {on_b_dist}"
    );
    let signed = a.distance(&b) as f64;
    let oracle = oracle_distance(ua, ub) * kk;
    let round_tol = ROUND_TOL * kk;
    if signed > round_tol {
        prop_assert!(
            (signed - oracle).abs() <= round_tol,
            "signed: ours {signed} parry {oracle}"
        );
    } else {
        prop_assert!(
            oracle <= round_tol,
            "ours overlaps ({signed}) but parry says {oracle}"
        );
    }
    // symmetry
    let back = b.distance(&a) as f64;
    prop_assert!(
        (back - signed).abs() <= tol,
        "asymmetric: {signed} vs {back}"
    );
    Ok(())
}

/// Ours on the SSV and triangle scaled by `k` against parry on the unit ones scaled back.
fn check_triangle(ua: &Ssv, ut: &[Point; 3], k: Real) -> Result<(), TestCaseError> {
    let a = scale_ssv(ua, k);
    let t = scale_tri(ut, k);
    let kk = k as f64;
    let tol = TOL * kk;
    let c = a.closest_to_triangle(&t);
    prop_assert!(c.dist_sq.is_finite());
    let ours = c.distance() as f64;
    let oracle = oracle_core_triangle_distance(ua, ut) * kk;
    prop_assert!(
        (ours - oracle).abs() <= tol,
        "ours {ours} parry {oracle} for {a:?} {t:?}"
    );
    let tri = parry_triangle(ut);
    let on_b =
        tri.distance_to_point(&parry3d_f64::math::Pose::IDENTITY, v64(&c.on_b) / kk, true) * kk;
    prop_assert!(on_b <= tol, "closest point off the triangle by {on_b}");
    Ok(())
}

/// A sliver 2 km long and about 0.5 m thick (found by `ssv_triangle_matches_parry`): its `f32`
/// normal cancelled to `(0, 0, 0.03)`, and the point 374 m off its edge was found over it, at
/// distance 0. Segments near it exercise the piercing test, which had the same normal.
#[test]
fn slivers_keep_their_distance() {
    let k = 1000.0;
    let t = [
        Point::new(0.2528669, -1.0, 0.0),
        Point::new(0.0, 1.0, 0.3805519),
        Point::new(0.06542134, 0.48256302, 0.2820961),
    ];
    let p = Point::new(0.0, 1.0, 0.0);
    let cases = [
        Ssv::Point(Pss::new(p, 0.0)),
        Ssv::Line(Lss::new(p, Point::new(0.1, -1.0, 0.05), 0.0)),
        Ssv::Line(Lss::new(p, Point::new(0.05, 1.0, 0.4), 0.0)),
        Ssv::Line(Lss::new(
            Point::new(0.0, 0.0, 0.0),
            Point::new(0.3, 0.2, 0.4),
            0.0,
        )),
    ];
    for ua in &cases {
        if let Err(e) = check_triangle(ua, &t, k) {
            panic!("{ua:?}: {e}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(600))]

    #[test]
    fn lss_lss_matches_parry((a, b) in lss_pair(), k in scale()) {
        check_pair(&Ssv::Line(a), &Ssv::Line(b), k)?;
    }

    #[test]
    fn batched_lss_distances_match_the_scalar_kernel(pairs in proptest::collection::vec(lss_pair(), 0..40), k in scale()) {
        let pairs: Vec<(Lss, Lss)> = pairs
            .iter()
            .map(|(a, b)| match (scale_ssv(&Ssv::Line(*a), k), scale_ssv(&Ssv::Line(*b), k)) {
                (Ssv::Line(a), Ssv::Line(b)) => (a, b),
                _ => unreachable!(),
            })
            .collect();
        let mut out = vec![0.0; pairs.len()];
        hair_ssv::distance_lss_lss_batch(&pairs, &mut out);
        for ((a, b), d) in pairs.iter().zip(&out) {
            let scalar = hair_ssv::distance_lss_lss(a, b);
            prop_assert!((scalar - d).abs() <= 1e-6 * k, "{scalar} vs {d}");
        }
    }

    #[test]
    fn rss_rss_matches_parry((a, b) in rss_pair(), k in scale()) {
        check_pair(&Ssv::Rect(a), &Ssv::Rect(b), k)?;
    }

    #[test]
    fn any_pair_matches_parry(a in ssv(), b in ssv(), k in scale()) {
        check_pair(&a, &b, k)?;
    }

    #[test]
    fn lss_on_rss_plane_matches_parry(r in rss(), s in -0.5f32..1.5, t in -0.5f32..1.5, u in -0.5f32..1.5, v in -0.5f32..1.5, h in prop_oneof![Just(0.0f32), -0.2f32..0.2], k in scale()) {
        // segments parallel to (or in) the rectangle's plane
        let p = |s: Real, t: Real| r.origin + r.axes[0] * (s * r.extents[0]) + r.axes[1] * (t * r.extents[1]) + r.normal() * h;
        check_pair(&Ssv::Line(Lss::new(p(s, t), p(u, v), 0.05)), &Ssv::Rect(r), k)?;
    }

    #[test]
    fn ssv_triangle_matches_parry(ua in ssv(), ut in triangle(), k in scale()) {
        check_triangle(&ua, &ut, k)?;
    }

    #[test]
    fn contacts_match_parry(a in prop_oneof![pss().prop_map(Ssv::Point), lss().prop_map(Ssv::Line)],
                            b in prop_oneof![pss().prop_map(Ssv::Point), lss().prop_map(Ssv::Line)],
                            k in scale()) {
        let (ua, ub) = (a, b);
        let (a, b) = (scale_ssv(&a, k), scale_ssv(&b, k));
        let kk = k as f64;
        let tol = TOL * kk;
        let core = a.closest_points(&b).distance() as f64;
        let ours = a.contact(&b);
        let (pa, sa) = parry_shape(&ua);
        let (pb, sb) = parry_shape(&ub);
        let theirs = parry3d_f64::query::contact(&pa, sa.as_ref(), &pb, sb.as_ref(), 0.0).expect("supported");
        let signed = a.distance(&b) as f64;
        if signed < -tol {
            let c = ours.expect("overlap must give a contact");
            prop_assert!((c.depth as f64 + signed).abs() <= tol);
            prop_assert!((c.normal.norm() - 1.0).abs() < 1e-5);
            // moving b by depth * normal must leave the volumes just touching
            let shift = c.normal * (c.depth / k);
            let moved = rigid_ssv(&ub, &nalgebra::UnitQuaternion::identity(), &shift);
            let after = oracle_core_distance(&ua, &moved) * kk - (a.radius() + b.radius()) as f64;
            prop_assert!(after.abs() <= tol * 2.0, "after separating: {after}");
            prop_assert!((v64(&c.point_a) - v64(&c.point_b)).length() <= c.depth as f64 + tol);
            // parry's penetration solver (EPA) drifts for deep overlaps, and by about 2% of the
            // radius when the cores touch (a capsule against a segment through its axis): compare
            // shallow overlaps of separate cores. The exact depth is checked above either way.
            let t = theirs.expect("parry sees the overlap");
            if (c.depth as f64) < 0.02 * kk && core > 1e-3 * kk {
                prop_assert!((c.depth as f64 + t.dist * kk).abs() <= ROUND_TOL * kk, "depth {} vs parry {}", c.depth, -t.dist * kk);
            }
            if core > 1e-2 * kk && (c.depth as f64) < 0.02 * kk {
                prop_assert!((d64(&c.normal) - t.normal1).length() < 1e-2, "{c:?} vs {t:?}");
            }
        } else if signed > tol {
            prop_assert!(ours.is_none());
            prop_assert!(theirs.is_none_or(|t| t.dist * kk > -ROUND_TOL * kk), "parry reports {theirs:?} at signed distance {signed}");
        }
    }

    #[test]
    fn distance_is_invariant_under_rigid_motion(a in ssv(), b in ssv(), rot in rotation(), tr in unit_point()) {
        let tr = tr.coords * 3.0;
        let d0 = a.distance(&b);
        let d1 = rigid_ssv(&a, &rot, &tr).distance(&rigid_ssv(&b, &rot, &tr));
        prop_assert!((d0 - d1).abs() <= 1e-5 * 4.0, "{d0} vs {d1}");
    }

    #[test]
    fn touching_cores_give_a_unit_normal(a in ssv(), s in 0.0f32..1.0) {
        // b's core passes through a point of a's core
        let x = match a {
            Ssv::Point(p) => p.center,
            Ssv::Line(l) => l.a + (l.b - l.a) * s,
            Ssv::Rect(r) => r.origin + r.axes[0] * (s * r.extents[0]) + r.axes[1] * ((1.0 - s) * r.extents[1]),
        };
        for b in [Ssv::Point(Pss::new(x, 0.1)), Ssv::Line(Lss::new(x, x + Vector::new(0.3, 0.2, 0.1), 0.1))] {
            let c = a.contact(&b).expect("touching");
            prop_assert!((c.normal.norm() - 1.0).abs() < 1e-5);
            prop_assert!(c.depth.is_finite() && c.point_a.coords.iter().all(|v| v.is_finite()));
        }
    }
}

#[test]
fn aabb_contains_the_volume() {
    let r = Rss::new(
        Point::new(1.0, 2.0, 3.0),
        [Vector::x(), Vector::z()],
        [2.0, 0.5],
        0.25,
    );
    let (lo, hi) = Ssv::Rect(r).aabb();
    assert_eq!(lo, Point::new(0.75, 1.75, 2.75));
    assert_eq!(hi, Point::new(3.25, 2.25, 3.75));
}

#[test]
fn try_new_rejects_bad_input() {
    let o = Point::origin();
    assert!(matches!(
        Pss::try_new(Point::new(f32::NAN, 0.0, 0.0), 1.0),
        Err(SsvError::NonFinite {
            field: "center",
            ..
        })
    ));
    assert!(matches!(
        Pss::try_new(o, -1.0),
        Err(SsvError::NegativeRadius { .. })
    ));
    assert!(matches!(
        Lss::try_new(o, Point::new(0.0, f32::INFINITY, 0.0), 1.0),
        Err(SsvError::NonFinite { field: "b", .. })
    ));
    assert!(matches!(
        Lss::try_new(o, o, f32::NAN),
        Err(SsvError::NonFinite {
            field: "radius",
            ..
        })
    ));
    assert!(Lss::try_new(o, o, 0.0).is_ok());
    assert!(matches!(
        Rss::try_new(
            o,
            [Vector::x(), Vector::new(0.1, 1.0, 0.0)],
            [1.0, 1.0],
            0.1
        ),
        Err(SsvError::AxesNotOrthonormal { .. })
    ));
    assert!(matches!(
        Rss::try_new(o, [Vector::x() * 2.0, Vector::y()], [1.0, 1.0], 0.1),
        Err(SsvError::AxesNotOrthonormal { .. })
    ));
    assert!(matches!(
        Rss::try_new(o, [Vector::x(), Vector::y()], [1.0, -1.0], 0.1),
        Err(SsvError::NegativeExtent { index: 1, .. })
    ));
    assert!(Rss::try_new(o, [Vector::x(), Vector::y()], [0.0, 0.0], 0.0).is_ok());
    let msg = Rss::try_new(o, [Vector::x(), Vector::y()], [1.0, -1.0], 0.1)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("extents[1]"), "{msg}");
}

#[test]
fn nearly_parallel_segments_stay_accurate() {
    // angle 1e-3 rad, crossing near the middle: the cancellation-prone case
    let a = Lss::new(Point::new(-1.0, 0.0, 0.0), Point::new(1.0, 0.0, 0.0), 0.0);
    let b = Lss::new(
        Point::new(-1.0, -1e-3, 1e-4),
        Point::new(1.0, 1e-3, 1e-4),
        0.0,
    );
    let d = hair_ssv::distance_lss_lss(&a, &b);
    let oracle = oracle_core_distance(&Ssv::Line(a), &Ssv::Line(b));
    assert!((d as f64 - oracle).abs() < 1e-6, "{d} vs {oracle}");
}
