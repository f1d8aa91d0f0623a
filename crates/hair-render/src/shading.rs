//! Hair shading as in Ward, Galoppo & Lin, "Interactive Virtual Hair Salon" (§5.1): Kajiya-Kay
//! diffuse plus two specular lobes (Heidrich-Seidel form) from tangents shifted in the plane of
//! the tangent and the light: a narrow uncoloured one toward the root and a wide coloured one
//! toward the tip whose shift carries noise. Wet hair is darker with a sharper highlight. The
//! WGSL in `shaders/common.wgsl` computes the same expressions.

use crate::scene::{Real, Rgb, Vector};

/// Shading constants.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadingParams {
    /// Diffuse weight.
    pub kd: Real,
    /// Primary (uncoloured) highlight strength.
    pub k1: Real,
    /// Secondary (coloured) highlight strength.
    pub k2: Real,
    /// Primary highlight exponent (narrow).
    pub m1: Real,
    /// Secondary highlight exponent (wide).
    pub m2: Real,
    /// Tangent shift of the primary highlight; negative moves it toward the root.
    pub primary_shift: Real,
    /// Tangent shift of the secondary highlight; positive moves it toward the tip.
    pub secondary_shift: Real,
    /// Amplitude of the noise on the secondary shift.
    pub shift_noise: Real,
    /// How much fully wet hair is darkened (0 none, 1 black).
    pub wet_darkening: Real,
    /// How much the primary exponent grows on fully wet hair (exponent times `1 + gain`).
    pub wet_sharpening: Real,
    /// Output gamma (1 keeps linear values).
    pub gamma: Real,
}

impl Default for ShadingParams {
    fn default() -> Self {
        Self {
            kd: 0.8,
            k1: 0.28,
            k2: 0.35,
            m1: 90.0,
            m2: 18.0,
            primary_shift: -0.12,
            secondary_shift: 0.18,
            shift_noise: 0.15,
            wet_darkening: 0.55,
            wet_sharpening: 2.0,
            gamma: 2.2,
        }
    }
}

fn strength(l: &Vector, v: &Vector, t: &Vector) -> Real {
    let lt = l.dot(t);
    let vt = v.dot(t);
    let c = (1.0 - lt * lt).max(0.0).sqrt() * (1.0 - vt * vt).max(0.0).sqrt() - lt * vt;
    c.max(0.0)
}

fn shift(t: &Vector, lp: &Vector, amount: Real) -> Vector {
    let s = t + lp * amount;
    let n = s.norm();
    if n > 1e-6 { s / n } else { *t }
}

/// The geometry and material of one hair fragment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HairFragment {
    /// Unit tangent toward the tip.
    pub tangent: Vector,
    /// Unit direction to the light.
    pub to_light: Vector,
    /// Unit direction to the eye.
    pub to_eye: Vector,
    /// Hair colour.
    pub color: Rgb,
    /// Wetness in `[0, 1]`.
    pub wetness: Real,
    /// Noise in `[-1, 1]` on the secondary highlight's shift.
    pub noise: Real,
}

/// Lit colour of a hair fragment before the shadow, as `(ambient part, direct part)`.
pub fn hair_radiance(p: &ShadingParams, f: &HairFragment, light: Rgb, ambient: Rgb) -> (Rgb, Rgb) {
    let (t, l, v) = (&f.tangent, &f.to_light, &f.to_eye);
    let (color, wetness, noise) = (f.color, f.wetness, f.noise);
    let base = Vector::from(color) * (1.0 - p.wet_darkening * wetness);
    let lt = l.dot(t);
    let lp0 = l - t * lt;
    let lpn = lp0.norm();
    let lp = if lpn > 1e-6 {
        lp0 / lpn
    } else {
        Vector::zeros()
    };
    let t1 = shift(t, &lp, p.primary_shift);
    let t2 = shift(t, &lp, p.secondary_shift + p.shift_noise * noise);
    let m1 = p.m1 * (1.0 + p.wet_sharpening * wetness);
    let k1 = p.k1 * (1.0 + wetness);
    let diffuse = (1.0 - lt * lt).max(0.0).sqrt();
    let s1 = k1 * strength(l, v, &t1).powf(m1);
    let s2 = p.k2 * strength(l, v, &t2).powf(p.m2);
    let mut amb = [0.0; 3];
    let mut direct = [0.0; 3];
    for c in 0..3 {
        amb[c] = ambient[c] * base[c];
        direct[c] = light[c] * (p.kd * base[c] * diffuse + s1 + s2 * base[c]);
    }
    (amb, direct)
}

/// Combines ambient and direct light under a shadow in `[0, 1]` and applies the gamma.
pub fn finish(p: &ShadingParams, amb: Rgb, direct: Rgb, shadow: Real) -> Rgb {
    let mut out = [0.0; 3];
    for c in 0..3 {
        let lin = (amb[c] + (1.0 - shadow) * direct[c]).clamp(0.0, 1.0);
        out[c] = lin.powf(1.0 / p.gamma);
    }
    out
}

/// Lit colour of a body fragment before the shadow, as `(ambient part, direct part)`.
pub fn body_radiance(n: &Vector, l: &Vector, color: Rgb, light: Rgb, ambient: Rgb) -> (Rgb, Rgb) {
    let ndl = n.dot(l).max(0.0);
    let mut amb = [0.0; 3];
    let mut direct = [0.0; 3];
    for c in 0..3 {
        amb[c] = ambient[c] * color[c];
        direct[c] = light[c] * color[c] * ndl;
    }
    (amb, direct)
}
