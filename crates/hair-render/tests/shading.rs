//! The two-highlight hair model: uncoloured primary, coloured secondary, wet hair darker with a
//! sharper highlight.

use hair_render::shading::{HairFragment, hair_radiance};
use hair_render::{ShadingParams, Vector};

fn frag(view_angle: f32, color: [f32; 3], wetness: f32) -> HairFragment {
    // Tangent along x, light from above at 45 degrees, eye swept in the x-y plane.
    HairFragment {
        tangent: Vector::x(),
        to_light: Vector::new(-1.0, 1.0, 0.0).normalize(),
        to_eye: Vector::new(view_angle.cos(), view_angle.sin(), 0.0),
        color,
        wetness,
        noise: 0.0,
    }
}

fn peak(p: &ShadingParams, color: [f32; 3], wetness: f32, channel: usize) -> (f32, f32) {
    // The angle of the brightest highlight in the channel and its value.
    let mut best = (0.0, f32::MIN);
    for k in 0..=720 {
        let a = k as f32 / 720.0 * std::f32::consts::PI;
        let (_, d) = hair_radiance(p, &frag(a, color, wetness), [1.0; 3], [0.0; 3]);
        if d[channel] > best.1 {
            best = (a, d[channel]);
        }
    }
    best
}

#[test]
fn primary_highlight_is_uncoloured() {
    let p = ShadingParams::default();
    // Pure red hair still reflects green at the primary highlight; none elsewhere.
    let (a, g) = peak(&p, [1.0, 0.0, 0.0], 0.0, 1);
    assert!(g > 0.1, "primary highlight {g} at {a}");
    let (_, d) = hair_radiance(&p, &frag(a + 0.8, [1.0, 0.0, 0.0], 0.0), [1.0; 3], [0.0; 3]);
    assert!(d[1] < 0.05 * g);
}

#[test]
fn secondary_highlight_is_coloured_and_shifted() {
    let p = ShadingParams {
        k1: 0.0,
        kd: 0.0,
        ..ShadingParams::default()
    };
    let (_, g) = peak(&p, [1.0, 0.0, 0.0], 0.0, 1);
    assert!(g < 1e-6, "with k1 = 0 nothing uncoloured remains: {g}");
    let (a2, r) = peak(&p, [1.0, 0.0, 0.0], 0.0, 0);
    assert!(r > 0.1);
    let q = ShadingParams {
        k2: 0.0,
        kd: 0.0,
        ..ShadingParams::default()
    };
    let (a1, _) = peak(&q, [1.0, 1.0, 1.0], 0.0, 0);
    assert!(
        (a1 - a2).abs() > 0.05,
        "the two highlights sit apart: {a1} vs {a2}"
    );
}

#[test]
fn wet_hair_is_darker_with_a_sharper_highlight() {
    let p = ShadingParams::default();
    let c = [0.5, 0.35, 0.2];
    let off = 1.2;
    let (_, dry) = hair_radiance(&p, &frag(off, c, 0.0), [1.0; 3], [0.0; 3]);
    let (_, wet) = hair_radiance(&p, &frag(off, c, 1.0), [1.0; 3], [0.0; 3]);
    assert!(
        wet[0] < dry[0] && wet[2] < dry[2],
        "wet hair darker: {wet:?} vs {dry:?}"
    );
    // Sharper: the primary lobe falls off faster around its peak.
    let only_primary = ShadingParams {
        kd: 0.0,
        k2: 0.0,
        ..ShadingParams::default()
    };
    let width = |wetness: f32| {
        let (a, top) = peak(&only_primary, [1.0; 3], wetness, 1);
        let (_, d) = hair_radiance(
            &only_primary,
            &frag(a + 0.08, [1.0; 3], wetness),
            [1.0; 3],
            [0.0; 3],
        );
        d[1] / top
    };
    assert!(
        width(1.0) < width(0.0),
        "wet {} vs dry {}",
        width(1.0),
        width(0.0)
    );
}
