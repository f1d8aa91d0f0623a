//! The CPU reference of Ward, Galoppo & Lin's opacity shadow maps and hair shading (§5): the same
//! vertex expansion, opacity accumulation (rounded to 16-bit floats like the GPU's targets),
//! hat-weighted lookup and shading as the WGSL, on a rayon-parallel rasteriser that samples pixel
//! centres with 1/256-pixel snapped vertices and a top-left fill rule, as GPU rasterisers do.

use crate::RenderError;
use crate::frame::{Globals, globals};
use crate::geometry::{BodyVertex, PreparedScene, RibbonVertex, any_perpendicular, prepare};
use crate::osm::{OSM_MAPS, OpacityMaps, round_f16};
use crate::scene::{Point, RenderScene, RenderSettings, Vector};
use crate::shading::{HairFragment, ShadingParams, body_radiance, finish, hair_radiance};
use image::RgbaImage;
use nalgebra::{Matrix4, Vector4};
use rayon::prelude::*;

/// Rows of pixels per parallel band.
const BAND: usize = 8;

/// Renders scenes on the CPU; the reference for the GPU path and the fallback without an adapter.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuRenderer;

/// A vertex after the vertex stage: clip position and `N` varyings.
#[derive(Clone, Copy, Debug)]
struct ClipVert<const N: usize> {
    clip: [f32; 4],
    var: [f32; N],
}

/// A triangle set up for rasterisation.
#[derive(Clone, Copy, Debug)]
struct Setup {
    x: [i64; 3],
    y: [i64; 3],
    area: i64,
    bias: [i64; 3],
    inv_w: [f32; 3],
    z: [f32; 3],
    idx: [u32; 3],
    min_x: usize,
    max_x: usize,
    min_y: usize,
    max_y: usize,
}

fn setup<const N: usize>(
    verts: &[ClipVert<N>],
    tri: [u32; 3],
    width: usize,
    height: usize,
) -> Option<Setup> {
    let mut x = [0i64; 3];
    let mut y = [0i64; 3];
    let mut inv_w = [0f32; 3];
    let mut z = [0f32; 3];
    for k in 0..3 {
        let c = verts.get(tri[k] as usize)?.clip;
        if c[3].is_nan() || c[3] <= 1e-7 {
            return None;
        }
        let iw = 1.0 / c[3];
        let sx = (c[0] * iw * 0.5 + 0.5) * width as f32;
        let sy = (0.5 - c[1] * iw * 0.5) * height as f32;
        if !(sx.abs() < 1.0e6 && sy.abs() < 1.0e6) {
            return None;
        }
        x[k] = (sx * 256.0).round() as i64;
        y[k] = (sy * 256.0).round() as i64;
        inv_w[k] = iw;
        z[k] = c[2] * iw;
    }
    let mut idx = tri;
    let mut area = (x[1] - x[0]) * (y[2] - y[0]) - (x[2] - x[0]) * (y[1] - y[0]);
    if area == 0 {
        return None;
    }
    if area < 0 {
        x.swap(1, 2);
        y.swap(1, 2);
        inv_w.swap(1, 2);
        z.swap(1, 2);
        idx.swap(1, 2);
        area = -area;
    }
    // Edge k is opposite vertex k: from vertex k+1 to vertex k+2.
    let mut bias = [0i64; 3];
    for k in 0..3 {
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let (dx, dy) = (x[b] - x[a], y[b] - y[a]);
        let top_left = dy < 0 || (dy == 0 && dx > 0);
        bias[k] = if top_left { 0 } else { -1 };
    }
    let min_xf = *x.iter().min()?;
    let max_xf = *x.iter().max()?;
    let min_yf = *y.iter().min()?;
    let max_yf = *y.iter().max()?;
    let lo = |v: i64| ((v - 128).div_euclid(256)).max(0);
    let hi = |v: i64, n: usize| ((v - 128).div_euclid(256) + 1).min(n as i64 - 1);
    let (min_x, max_x) = (lo(min_xf), hi(max_xf, width));
    let (min_y, max_y) = (lo(min_yf), hi(max_yf, height));
    if max_x < min_x || max_y < min_y {
        return None;
    }
    Some(Setup {
        x,
        y,
        area,
        bias,
        inv_w,
        z,
        idx,
        min_x: min_x as usize,
        max_x: max_x as usize,
        min_y: min_y as usize,
        max_y: max_y as usize,
    })
}

/// Rasterises a triangle list into `pixels` (row-major, `width` wide), calling `frag` for every
/// covered pixel centre in primitive order with the screen-linear depth and the
/// perspective-correct varyings.
fn rasterize<const N: usize, P: Send>(
    pixels: &mut [P],
    width: usize,
    height: usize,
    verts: &[ClipVert<N>],
    indices: &[u32],
    frag: &(impl Fn(&mut P, f32, &[f32; N]) + Sync),
) {
    let setups: Vec<Setup> = indices
        .par_chunks_exact(3)
        .filter_map(|t| setup(verts, [t[0], t[1], t[2]], width, height))
        .collect();
    pixels
        .par_chunks_mut(BAND * width)
        .enumerate()
        .for_each(|(band, rows)| {
            let y0 = band * BAND;
            let y1 = (y0 + BAND).min(height) - 1;
            for s in &setups {
                if s.max_y < y0 || s.min_y > y1 {
                    continue;
                }
                raster_tri(s, verts, rows, width, y0, y1, frag);
            }
        });
}

fn raster_tri<const N: usize, P>(
    s: &Setup,
    verts: &[ClipVert<N>],
    rows: &mut [P],
    width: usize,
    y0: usize,
    y1: usize,
    frag: &impl Fn(&mut P, f32, &[f32; N]),
) {
    let edge = |k: usize, px: i64, py: i64| -> i64 {
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        (s.x[b] - s.x[a]) * (py - s.y[a]) - (s.y[b] - s.y[a]) * (px - s.x[a])
    };
    let inv_area = 1.0 / s.area as f64;
    let v = [
        &verts[s.idx[0] as usize],
        &verts[s.idx[1] as usize],
        &verts[s.idx[2] as usize],
    ];
    for py in s.min_y.max(y0)..=s.max_y.min(y1) {
        let cy = py as i64 * 256 + 128;
        for px in s.min_x..=s.max_x {
            let cx = px as i64 * 256 + 128;
            let e = [edge(0, cx, cy), edge(1, cx, cy), edge(2, cx, cy)];
            if e[0] + s.bias[0] < 0 || e[1] + s.bias[1] < 0 || e[2] + s.bias[2] < 0 {
                continue;
            }
            // The edge functions here are negated barycentrics under y-down; the orientation was
            // normalised so that all three are non-negative inside.
            let b = [
                (e[0] as f64 * inv_area) as f32,
                (e[1] as f64 * inv_area) as f32,
                (e[2] as f64 * inv_area) as f32,
            ];
            let z = b[0] * s.z[0] + b[1] * s.z[1] + b[2] * s.z[2];
            if !(0.0..=1.0).contains(&z) {
                continue;
            }
            let q = [b[0] * s.inv_w[0], b[1] * s.inv_w[1], b[2] * s.inv_w[2]];
            let qs = q[0] + q[1] + q[2];
            if qs <= 0.0 {
                continue;
            }
            let mut var = [0.0f32; N];
            for (i, out) in var.iter_mut().enumerate() {
                *out = (q[0] * v[0].var[i] + q[1] * v[1].var[i] + q[2] * v[2].var[i]) / qs;
            }
            frag(&mut rows[(py - y0) * width + px], z, &var);
        }
    }
}

/// The body's depth map from the light (1 where there is no body).
pub(crate) fn body_depth_map(g: &Globals, prepared: &PreparedScene) -> Vec<f32> {
    let size = g.osm[3] as usize;
    let m = Matrix4::from_column_slice(&g.light_view_proj);
    let mut depth = vec![1.0f32; size * size];
    let body: Vec<ClipVert<0>> = prepared
        .body_vertices
        .par_iter()
        .map(|v: &BodyVertex| ClipVert {
            clip: transform(&m, &v3(v.position)),
            var: [],
        })
        .collect();
    rasterize(
        &mut depth,
        size,
        size,
        &body,
        &prepared.body_indices,
        &|p: &mut f32, z, _| {
            if z < *p {
                *p = z;
            }
        },
    );
    depth
}

fn v3(a: [f32; 3]) -> Vector {
    Vector::new(a[0], a[1], a[2])
}

fn transform(m: &Matrix4<f32>, p: &Vector) -> [f32; 4] {
    let c = m * Vector4::new(p.x, p.y, p.z, 1.0);
    [c.x, c.y, c.z, c.w]
}

/// `expand_ribbon` of the WGSL: widened world position and opacity.
fn expand_ribbon(
    g: &Globals,
    v: &RibbonVertex,
    to_viewer: &Vector,
    pixel_world: f32,
) -> (Vector, f32) {
    let kind = v.kind;
    let mut half = v.half_width;
    let mut alpha = v.opacity * g.body_color[3];
    if kind > 0.5 {
        alpha = v.opacity * g.misc[0];
    }
    let t = v3(v.tangent);
    let fixed = v3(v.fixed_side);
    let mut dir = fixed;
    if kind < 1.5 || fixed.dot(&fixed) == 0.0 {
        let c = t.cross(to_viewer);
        let l = c.norm();
        dir = if l > 1e-6 {
            c / l
        } else {
            any_perpendicular(&t)
        };
        if kind < 1.5 {
            let drawn = half.max(g.cam_forward[3] * pixel_world);
            if drawn > 0.0 {
                alpha *= half / drawn;
            }
            half = drawn;
        }
    }
    (v3(v.position) + dir * (v.side * half), alpha)
}

fn hair_texture(g: &Globals, u: f32) -> f32 {
    let i = ((u * 64.0).floor() as i32).clamp(0, 63) as usize;
    g.hair_tex[i / 4][i % 4]
}

fn to_unorm(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

#[derive(Clone, Copy)]
struct OsmPixel {
    maps: [f32; OSM_MAPS],
    depth: f32,
}

#[derive(Clone, Copy)]
struct ColorPixel {
    rgba: [u8; 4],
    depth: f32,
}

fn shading_params(g: &Globals) -> ShadingParams {
    ShadingParams {
        kd: g.spec2[2],
        k1: g.spec2[0],
        k2: g.spec2[1],
        m1: g.spec[2],
        m2: g.spec[3],
        primary_shift: g.spec[0],
        secondary_shift: g.spec[1],
        shift_noise: g.spec2[3],
        wet_darkening: g.wet[0],
        wet_sharpening: g.wet[1],
        gamma: g.wet[2],
    }
}

impl CpuRenderer {
    /// Renders a scene to an RGBA image.
    pub fn render_to_image(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
    ) -> Result<RgbaImage, RenderError> {
        settings.validate()?;
        let prepared = prepare(scene, settings.subdivisions)?;
        Ok(self.render_prepared(scene, &prepared, settings))
    }

    /// Computes the opacity maps and body depth map of a scene (the first pass alone).
    pub fn opacity_maps(
        &self,
        scene: &RenderScene,
        settings: &RenderSettings,
    ) -> Result<OpacityMaps, RenderError> {
        settings.validate()?;
        let prepared = prepare(scene, settings.subdivisions)?;
        let (g, lf) = globals(scene, &prepared, settings);
        Ok(Self::osm_pass(&g, lf, &prepared))
    }

    fn osm_pass(
        g: &Globals,
        frame: crate::osm::LightFrame,
        prepared: &PreparedScene,
    ) -> OpacityMaps {
        let size = g.osm[3] as usize;
        let m = Matrix4::from_column_slice(&g.light_view_proj);
        let mut pixels = vec![
            OsmPixel {
                maps: [0.0; OSM_MAPS],
                depth: 1.0,
            };
            size * size
        ];
        for (p, d) in pixels.iter_mut().zip(body_depth_map(g, prepared)) {
            p.depth = d;
        }
        let l = v3([g.light_dir[0], g.light_dir[1], g.light_dir[2]]);
        let hair: Vec<ClipVert<4>> = prepared
            .hair_vertices
            .par_iter()
            .map(|v| {
                let (e, alpha) = expand_ribbon(g, v, &l, g.light_dir[3]);
                ClipVert {
                    clip: transform(&m, &e),
                    var: [e.dot(&-l), alpha, v.tex_u, v.kind],
                }
            })
            .collect();
        let (near, spacing) = (g.osm[0], g.osm[1]);
        rasterize(
            &mut pixels,
            size,
            size,
            &hair,
            &prepared.hair_indices,
            &|p: &mut OsmPixel, _, var| {
                let [depth, mut a, tex_u, kind] = *var;
                if kind > 1.5 {
                    a *= hair_texture(g, tex_u);
                }
                let a16 = round_f16(a);
                for (n, m) in p.maps.iter_mut().enumerate() {
                    if depth < near + (n as f32 + 1.0) * spacing {
                        *m = round_f16(*m + a16);
                    }
                }
            },
        );
        OpacityMaps {
            size,
            opacity: pixels.iter().map(|p| p.maps).collect(),
            body_depth: pixels.iter().map(|p| p.depth).collect(),
            frame,
            globals: *g,
        }
    }

    /// Renders an already prepared scene (validated sizes assumed).
    pub(crate) fn render_prepared(
        &self,
        scene: &RenderScene,
        prepared: &PreparedScene,
        settings: &RenderSettings,
    ) -> RgbaImage {
        let (g, lf) = globals(scene, prepared, settings);
        let maps = if settings.shadows {
            Some(Self::osm_pass(&g, lf, prepared))
        } else {
            None
        };
        let shadow = |p: &Vector| -> f32 {
            match &maps {
                Some(m) => m.shadow_at(&Point::from(*p)),
                None => 0.0,
            }
        };
        let (w, h) = (settings.width as usize, settings.height as usize);
        let bg = [
            to_unorm(scene.background[0]),
            to_unorm(scene.background[1]),
            to_unorm(scene.background[2]),
            255,
        ];
        let mut pixels = vec![
            ColorPixel {
                rgba: bg,
                depth: 1.0,
            };
            w * h
        ];
        let m = Matrix4::from_column_slice(&g.cam_view_proj);
        let sp = shading_params(&g);
        let light = [g.light_color[0], g.light_color[1], g.light_color[2]];
        let ambient = [g.ambient[0], g.ambient[1], g.ambient[2]];
        let l = v3([g.light_dir[0], g.light_dir[1], g.light_dir[2]]);
        let eye = v3([g.cam_eye[0], g.cam_eye[1], g.cam_eye[2]]);
        let fwd = v3([g.cam_forward[0], g.cam_forward[1], g.cam_forward[2]]);
        let write = |p: &mut ColorPixel, z: f32, rgb: [f32; 3]| {
            p.depth = z;
            p.rgba = [to_unorm(rgb[0]), to_unorm(rgb[1]), to_unorm(rgb[2]), 255];
        };
        let body: Vec<ClipVert<6>> = prepared
            .body_vertices
            .par_iter()
            .map(|v| ClipVert {
                clip: transform(&m, &v3(v.position)),
                var: [
                    v.position[0],
                    v.position[1],
                    v.position[2],
                    v.normal[0],
                    v.normal[1],
                    v.normal[2],
                ],
            })
            .collect();
        let body_color = [g.body_color[0], g.body_color[1], g.body_color[2]];
        rasterize(
            &mut pixels,
            w,
            h,
            &body,
            &prepared.body_indices,
            &|p: &mut ColorPixel, z, var| {
                if z >= p.depth {
                    return;
                }
                let world = Vector::new(var[0], var[1], var[2]);
                let mut n = Vector::new(var[3], var[4], var[5]);
                let nl = n.norm();
                if nl > 0.0 {
                    n /= nl;
                }
                let (amb, direct) = body_radiance(&n, &l, body_color, light, ambient);
                write(p, z, finish(&sp, amb, direct, shadow(&world)));
            },
        );
        let hair: Vec<ClipVert<14>> = prepared
            .hair_vertices
            .par_iter()
            .map(|v| {
                let pos = v3(v.position);
                let to_eye = eye - pos;
                let dist = to_eye.norm();
                let view = if dist > 0.0 {
                    to_eye / dist
                } else {
                    Vector::z()
                };
                let along = (pos - eye).dot(&fwd).max(0.0);
                let (e, _) = expand_ribbon(&g, v, &view, along * g.cam_eye[3]);
                ClipVert {
                    clip: transform(&m, &e),
                    var: [
                        e.x,
                        e.y,
                        e.z,
                        v.tangent[0],
                        v.tangent[1],
                        v.tangent[2],
                        v.color[0],
                        v.color[1],
                        v.color[2],
                        v.wetness,
                        v.noise,
                        v.tex_u,
                        v.kind,
                        0.0,
                    ],
                }
            })
            .collect();
        rasterize(
            &mut pixels,
            w,
            h,
            &hair,
            &prepared.hair_indices,
            &|p: &mut ColorPixel, z, var| {
                if z >= p.depth {
                    return;
                }
                let mut color = [var[6], var[7], var[8]];
                if var[12] > 1.5 {
                    let tx = hair_texture(&g, var[11]);
                    if tx < 0.5 {
                        return;
                    }
                    for c in &mut color {
                        *c *= 0.55 + 0.45 * tx;
                    }
                }
                let world = Vector::new(var[0], var[1], var[2]);
                let mut t = Vector::new(var[3], var[4], var[5]);
                let tl = t.norm();
                t = if tl > 1e-6 { t / tl } else { -Vector::y() };
                let to_eye = eye - world;
                let v = if to_eye.norm() > 0.0 {
                    to_eye.normalize()
                } else {
                    Vector::z()
                };
                let frag = HairFragment {
                    tangent: t,
                    to_light: l,
                    to_eye: v,
                    color,
                    wetness: var[9],
                    noise: var[10],
                };
                let (amb, direct) = hair_radiance(&sp, &frag, light, ambient);
                write(p, z, finish(&sp, amb, direct, shadow(&world)));
            },
        );
        let mut img = RgbaImage::new(settings.width, settings.height);
        for (dst, src) in img.pixels_mut().zip(&pixels) {
            dst.0 = src.rgba;
        }
        img
    }
}
