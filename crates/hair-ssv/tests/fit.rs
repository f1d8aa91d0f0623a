//! Fitted volumes contain every input point (checked in f64, independently of the f32 kernels),
//! and are tight on the shapes they should reproduce.

mod support;

use hair_ssv::{Point, Real, SsvError, fit_lss, fit_rss, fit_rss_triangles};
use proptest::prelude::*;
use support::*;

fn points() -> impl Strategy<Value = Vec<Point>> {
    prop_oneof![
        3 => proptest::collection::vec(unit_point(), 1..80),
        1 => (unit_point(), 1usize..20).prop_map(|(p, n)| vec![p; n]),
        1 => (unit_point(), unit_point(), proptest::collection::vec(0.0f32..1.0, 1..40))
            .prop_map(|(a, b, ts)| ts.iter().map(|&t| a + (b - a) * t).collect()),
        1 => (axes(), proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 1..40))
            .prop_map(|(ax, st)| st.iter().map(|&(s, t)| Point::origin() + ax[0] * s + ax[1] * t).collect()),
    ]
    .prop_flat_map(|pts| (Just(pts), scale()))
    .prop_map(|(pts, k)| pts.iter().map(|p| p * k).collect())
}

fn lss_contains(a: &Point, b: &Point, r: Real, p: &Point) -> f64 {
    let (a, b, p) = (v64(a), v64(b), v64(p));
    let d = b - a;
    let t = if d.length_squared() > 0.0 {
        ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + d * t)).length() - r as f64
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]

    #[test]
    fn fitted_lss_contains_every_point(pts in points()) {
        let l = fit_lss(&pts).unwrap();
        let scale = pts.iter().map(|p| p.coords.abs().max()).fold(0.0, Real::max) as f64;
        for p in &pts {
            let d = lss_contains(&l.a, &l.b, l.radius, p);
            prop_assert!(d <= 1e-7 * scale, "point {p:?} outside {l:?} by {d}");
        }
    }

    #[test]
    fn fitted_rss_contains_every_point(pts in points()) {
        let r = fit_rss(&pts).unwrap();
        let scale = pts.iter().map(|p| p.coords.abs().max()).fold(0.0, Real::max) as f64;
        prop_assert!(r.extents[0] >= 0.0 && r.extents[1] >= 0.0 && r.radius >= 0.0);
        prop_assert!((r.axes[0].norm() - 1.0).abs() < 1e-5 && r.axes[0].dot(&r.axes[1]).abs() < 1e-5);
        for p in &pts {
            let d = v64(p) - v64(&r.origin);
            let (u, v) = (d64(&r.axes[0]), d64(&r.axes[1]));
            let s = d.dot(u).clamp(0.0, r.extents[0] as f64);
            let t = d.dot(v).clamp(0.0, r.extents[1] as f64);
            let dist = (d - u * s - v * t).length() - r.radius as f64;
            prop_assert!(dist <= 1e-7 * scale, "point {p:?} outside {r:?} by {dist}");
        }
    }

    #[test]
    fn fitted_rss_contains_every_triangle(tris in proptest::collection::vec(triangle(), 1..30)) {
        let r = fit_rss_triangles(&tris).unwrap();
        let s = hair_ssv::Ssv::Rect(r);
        for t in &tris {
            for p in t {
                prop_assert!(s.distance(&hair_ssv::Ssv::Point(hair_ssv::Pss::new(*p, 0.0))) <= 1e-6);
            }
        }
    }
}

#[test]
fn fits_are_tight_on_their_own_shapes() {
    // points along a segment: radius ~ 0, ends at the extremes
    let pts: Vec<Point> = (0..=10)
        .map(|i| Point::new(i as Real * 0.1, 2.0, -1.0))
        .collect();
    let l = fit_lss(&pts).unwrap();
    assert!(l.radius < 5e-5, "{l:?}");
    assert!(((l.b - l.a).norm() - 1.0).abs() < 1e-4, "{l:?}");
    // a flat rectangle of points: radius ~ 0, area ~ 2 x 1
    let pts: Vec<Point> = (0..=20)
        .flat_map(|i| (0..=10).map(move |j| Point::new(i as Real * 0.1, j as Real * 0.1, 0.5)))
        .collect();
    let r = fit_rss(&pts).unwrap();
    assert!(r.radius < 5e-5, "{r:?}");
    assert!(
        (r.extents[0] - 2.0).abs() < 1e-3 && (r.extents[1] - 1.0).abs() < 1e-3,
        "{r:?}"
    );
}

#[test]
fn fits_reject_bad_input() {
    assert_eq!(
        fit_lss(&[]).unwrap_err(),
        SsvError::EmptyInput { what: "fit_lss" }
    );
    assert_eq!(
        fit_rss(&[]).unwrap_err(),
        SsvError::EmptyInput { what: "fit_rss" }
    );
    assert_eq!(
        fit_rss(&[Point::origin(), Point::new(0.0, f32::NAN, 0.0)]).unwrap_err(),
        SsvError::NonFinitePoint {
            what: "fit_rss",
            index: 1
        }
    );
}
