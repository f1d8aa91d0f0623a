//! Opacity shadow maps as in Ward, Galoppo & Lin, "Interactive Virtual Hair Salon" (§5.2-5.3),
//! after Kim & Neumann: 16 maps at uniform depths across the hair seen from the light, written in
//! one pass into four four-channel targets with additive blending; shading reads the two maps
//! bracketing a fragment with hat weights, the planes pushed back so lit fragments stay lit, and
//! takes the larger of the hair shadow and the body's depth shadow.

use crate::geometry::PreparedScene;
use crate::scene::{Real, Vector};

/// Number of opacity maps (four render targets of four channels).
pub const OSM_MAPS: usize = 16;

/// Opacity shadow map settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ShadowSettings {
    /// Side of the square shadow maps in texels.
    pub map_size: u32,
    /// Opacity a fibre one texel wide adds where it crosses a texel (narrower fibres add less,
    /// in proportion to their width). Light transmitted is `exp(-opacity)`.
    pub strand_opacity: Real,
    /// Opacity a cluster tube adds per texel.
    pub cluster_opacity: Real,
    /// How far the planes are pushed back, in map spacings (§5.3), so a lit fragment does not
    /// sample its own opacity.
    pub push_back: Real,
    /// Depth bias of the body's shadow map, metres.
    pub body_bias: Real,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        Self {
            map_size: 512,
            strand_opacity: 1.0,
            cluster_opacity: 1.5,
            push_back: 1.0,
            body_bias: 0.004,
        }
    }
}

/// Depths of the 16 planes: plane `n` lies at `near + (n + 1) * spacing` along the light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OsmPlanes {
    /// Depth of the hair nearest the light.
    pub near: Real,
    /// Distance between planes: the hair's depth extent over 16.
    pub spacing: Real,
}

impl OsmPlanes {
    /// Planes spread uniformly over the depth range `[near, far]`.
    pub fn new(near: Real, far: Real) -> Self {
        let extent = (far - near).max(0.0);
        let spacing = (extent / OSM_MAPS as Real).max(1e-6 * (1.0 + near.abs()));
        Self { near, spacing }
    }

    /// Depth of plane `n`.
    pub fn depth(&self, n: usize) -> Real {
        self.near + (n as Real + 1.0) * self.spacing
    }

    /// Plane coordinate of a depth: plane `n` sits at `n`, the front of the hair at `-1`.
    pub fn coordinate(&self, depth: Real) -> Real {
        (depth - self.near) / self.spacing - 1.0
    }
}

/// Hat weights of the 16 maps for a fragment at `depth` (the paper's
/// `w = max(0, 1 - |z_n - z_p| / Δ)`). Between the first and the last plane they sum to 1;
/// in front of the first they fade to 0 (the front of the hair has no opacity); behind the last
/// the last map has weight 1.
pub fn hat_weights(planes: &OsmPlanes, depth: Real) -> [Real; OSM_MAPS] {
    let t = planes.coordinate(depth).min((OSM_MAPS - 1) as Real);
    let mut w = [0.0; OSM_MAPS];
    for (n, wn) in w.iter_mut().enumerate() {
        *wn = (1.0 - (n as Real - t).abs()).max(0.0);
    }
    w
}

/// Accumulated opacity in front of `depth`, given one texel's 16 map values.
pub fn opacity_at(planes: &OsmPlanes, maps: &[Real; OSM_MAPS], depth: Real) -> Real {
    let w = hat_weights(planes, depth);
    w.iter().zip(maps).map(|(a, b)| a * b).sum()
}

/// Whether a fragment at `depth` adds to map `n` (it lies in front of the plane).
pub fn contributes(planes: &OsmPlanes, depth: Real, n: usize) -> bool {
    depth < planes.depth(n)
}

/// Rounds to the nearest 16-bit float (what an `Rgba16Float` target stores).
pub fn round_f16(x: f32) -> f32 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    if x.abs() >= 65520.0 {
        return 65504.0f32.copysign(x);
    }
    if x.abs() < 6.103_515_6e-5 {
        let q = 5.960_464_5e-8; // 2^-24, the subnormal step
        return (x / q).round_ties_even() * q;
    }
    let bits = x.to_bits();
    let lsb = 1u32 << 13;
    let rem = bits & (lsb - 1);
    let mut b = bits & !(lsb - 1);
    if rem > lsb / 2 || (rem == lsb / 2 && b & lsb != 0) {
        b += lsb;
    }
    f32::from_bits(b)
}

/// The light's orthographic frame fitted around the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightFrame {
    /// Direction the light travels (from the light into the scene), unit.
    pub forward: Vector,
    /// Map x axis, unit.
    pub right: Vector,
    /// Map y axis, unit.
    pub up: Vector,
    /// Map centre along `right` and `up`.
    pub centre: [Real; 2],
    /// Half the side of the square covered by the maps, metres.
    pub half_extent: Real,
    /// Depth range of everything (hair and body) along `forward`.
    pub depth_range: [Real; 2],
    /// The opacity map planes over the hair's depth range.
    pub planes: OsmPlanes,
}

impl LightFrame {
    /// Fits the frame around the prepared scene for a light shining from `toward_light`.
    pub fn fit(prepared: &PreparedScene, toward_light: &Vector) -> Self {
        let forward = -toward_light.normalize();
        let right = crate::geometry::any_perpendicular(&forward);
        let up = right.cross(&forward);
        let mut lo = [Real::INFINITY; 3];
        let mut hi = [Real::NEG_INFINITY; 3];
        let mut hair = [Real::INFINITY, Real::NEG_INFINITY];
        let mut max_w: Real = 0.0;
        let add = |p: Vector, lo: &mut [Real; 3], hi: &mut [Real; 3]| {
            let c = [p.dot(&right), p.dot(&up), p.dot(&forward)];
            for k in 0..3 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
            c[2]
        };
        for v in prepared.hair_vertices.iter().step_by(2) {
            let d = add(Vector::from(v.position), &mut lo, &mut hi);
            hair[0] = hair[0].min(d);
            hair[1] = hair[1].max(d);
            max_w = max_w.max(v.half_width);
        }
        for v in &prepared.body_vertices {
            add(Vector::from(v.position), &mut lo, &mut hi);
        }
        if !lo[0].is_finite() {
            lo = [-1.0; 3];
            hi = [1.0; 3];
        }
        if !hair[0].is_finite() {
            hair = [lo[2], hi[2]];
        }
        let half = 0.5 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let half_extent = (half * 1.04 + 2.0 * max_w).max(1e-4);
        let pad = 0.01 * (hi[2] - lo[2]) + 2.0 * max_w + 1e-4;
        Self {
            forward,
            right,
            up,
            centre: [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])],
            half_extent,
            depth_range: [lo[2] - pad, hi[2] + pad],
            planes: OsmPlanes::new(hair[0] - max_w, hair[1] + max_w),
        }
    }
}

/// The 16 opacity maps and the body's depth map of one frame, read back or computed on the CPU.
#[derive(Clone, Debug)]
pub struct OpacityMaps {
    /// Side of the maps in texels.
    pub size: usize,
    /// Accumulated opacity of the 16 maps at each texel, row-major from the top-left.
    pub opacity: Vec<[f32; OSM_MAPS]>,
    /// The body's depth from the light at each texel, in `[0, 1]` (1 where there is no body).
    pub body_depth: Vec<f32>,
    /// The light frame the maps were drawn in.
    pub frame: LightFrame,
    /// The frame constants the maps were drawn with.
    pub(crate) globals: crate::frame::Globals,
}

impl OpacityMaps {
    /// Map value of texel `(x, y)`.
    pub fn texel(&self, x: usize, y: usize) -> &[f32; OSM_MAPS] {
        &self.opacity[y * self.size + x]
    }

    /// Shadow in `[0, 1]` at a world point: the larger of the hair's opacity shadow
    /// `1 - exp(-opacity)` (bracketing maps read with hat weights, planes pushed back) and the
    /// body's depth shadow, both filtered bilinearly. Matches `shadow_at` in the WGSL.
    pub fn shadow_at(&self, p: &crate::scene::Point) -> Real {
        let g = &self.globals;
        if g.light_color[3] < 0.5 {
            return 0.0;
        }
        let m = nalgebra::Matrix4::from_column_slice(&g.light_view_proj);
        let lc = m * nalgebra::Vector4::new(p.x, p.y, p.z, 1.0);
        let size = g.osm[3];
        let u = (lc.x * 0.5 + 0.5) * size - 0.5;
        let v = (0.5 - lc.y * 0.5) * size - 0.5;
        let (bu, bv) = (u.floor(), v.floor());
        let (fu, fv) = (u - bu, v - bv);
        let l = Vector::new(g.light_dir[0], g.light_dir[1], g.light_dir[2]);
        let depth = p.coords.dot(&-l) - g.osm[2];
        let t = ((depth - g.osm[0]) / g.osm[1] - 1.0).min(15.0);
        let mut w = [0.0f32; OSM_MAPS];
        for (n, wn) in w.iter_mut().enumerate() {
            *wn = (1.0 - (n as f32 - t).abs()).max(0.0);
        }
        let hi = size as i32 - 1;
        let mut opacity = 0.0f32;
        let mut body = 0.0f32;
        for k in 0..4 {
            let (ox, oy) = (k & 1, k >> 1);
            let wx = if ox == 1 { fu } else { 1.0 - fu };
            let wy = if oy == 1 { fv } else { 1.0 - fv };
            let x = (bu as i32 + ox).clamp(0, hi) as usize;
            let y = (bv as i32 + oy).clamp(0, hi) as usize;
            let texel = self.texel(x, y);
            let mut o = 0.0f32;
            for q in 0..4 {
                let mut d = 0.0f32;
                for c in 0..4 {
                    d += texel[4 * q + c] * w[4 * q + c];
                }
                o += d;
            }
            opacity += wx * wy * o;
            let lit = lc.z - g.ambient[3] <= self.body_depth[y * self.size + x];
            if !lit {
                body += wx * wy;
            }
        }
        (1.0 - (-opacity).exp()).max(body)
    }
}

/// Converts IEEE half-precision bits to `f32`.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let mant = f32::from(h & 0x3ff);
    match exp {
        0 => sign * mant * 5.960_464_5e-8,
        31 => {
            if mant == 0.0 {
                sign * f32::INFINITY
            } else {
                f32::NAN
            }
        }
        e => sign * (1.0 + mant / 1024.0) * 2f32.powi(e - 15),
    }
}
