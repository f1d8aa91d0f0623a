// Shared declarations of both passes: the uniform block, ribbon expansion, the opacity-map
// lookup with hat weights (Ward, Galoppo & Lin §5.2-5.3) and the two-highlight hair shading
// (§5.1). `src/cpu.rs`, `src/osm.rs` and `src/shading.rs` compute the same expressions.

struct Globals {
    cam_view_proj: mat4x4<f32>,
    light_view_proj: mat4x4<f32>,
    cam_eye: vec4<f32>,
    cam_forward: vec4<f32>,
    light_dir: vec4<f32>,
    light_color: vec4<f32>,
    ambient: vec4<f32>,
    osm: vec4<f32>,
    spec: vec4<f32>,
    spec2: vec4<f32>,
    wet: vec4<f32>,
    body_color: vec4<f32>,
    misc: vec4<f32>,
    hair_tex: array<vec4<f32>, 16>,
}

@group(0) @binding(0) var<uniform> g: Globals;

struct RibbonIn {
    @location(0) position: vec3<f32>,
    @location(1) side: f32,
    @location(2) tangent: vec3<f32>,
    @location(3) half_width: f32,
    @location(4) fixed_side: vec3<f32>,
    @location(5) opacity: f32,
    @location(6) color: vec3<f32>,
    @location(7) wetness: f32,
    // noise, tex_u, kind, unused
    @location(8) extra: vec4<f32>,
}

struct BodyIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

fn any_perpendicular(t: vec3<f32>) -> vec3<f32> {
    var axis = vec3<f32>(1.0, 0.0, 0.0);
    if abs(t.x) >= 0.9 {
        axis = vec3<f32>(0.0, 1.0, 0.0);
    }
    return normalize(cross(t, axis));
}

// World position of a ribbon vertex widened across `to_viewer` (xyz) and its opacity (w).
fn expand_ribbon(v: RibbonIn, to_viewer: vec3<f32>, pixel_world: f32) -> vec4<f32> {
    let kind = v.extra.z;
    var half = v.half_width;
    var alpha = v.opacity * g.body_color.w;
    if kind > 0.5 {
        alpha = v.opacity * g.misc.x;
    }
    var dir = v.fixed_side;
    if kind < 1.5 || dot(v.fixed_side, v.fixed_side) == 0.0 {
        let c = cross(v.tangent, to_viewer);
        let l = length(c);
        if l > 1e-6 {
            dir = c / l;
        } else {
            dir = any_perpendicular(v.tangent);
        }
        if kind < 1.5 {
            let drawn = max(half, g.cam_forward.w * pixel_world);
            if drawn > 0.0 {
                alpha = alpha * (half / drawn);
            }
            half = drawn;
        }
    }
    return vec4<f32>(v.position + (v.side * half) * dir, alpha);
}

fn hair_texture(u: f32) -> f32 {
    let i = clamp(i32(floor(u * 64.0)), 0, 63);
    return g.hair_tex[i / 4][i % 4];
}

@group(1) @binding(1) var osm0: texture_2d<f32>;
@group(1) @binding(2) var osm1: texture_2d<f32>;
@group(1) @binding(3) var osm2: texture_2d<f32>;
@group(1) @binding(4) var osm3: texture_2d<f32>;
@group(1) @binding(5) var body_depth: texture_depth_2d;
// Nearest, `LessEqual` comparison at texel centres (GLSL cannot `textureLoad` a depth texture):
// 1 where the fragment is at or in front of the body's depth, that is, lit.
@group(1) @binding(6) var depth_sampler: sampler_comparison;

fn hat4(t: f32, first: f32) -> vec4<f32> {
    let n = vec4<f32>(first, first + 1.0, first + 2.0, first + 3.0);
    return max(vec4<f32>(0.0), vec4<f32>(1.0) - abs(n - vec4<f32>(t)));
}

// Shadow in [0, 1] at a world point: the larger of the hair's opacity shadow and the body's
// depth shadow, both filtered bilinearly over four texels.
fn shadow_at(p: vec3<f32>) -> f32 {
    if g.light_color.w < 0.5 {
        return 0.0;
    }
    let lc = g.light_view_proj * vec4<f32>(p, 1.0);
    let size = g.osm.w;
    let uv = vec2<f32>(lc.x * 0.5 + 0.5, 0.5 - lc.y * 0.5) * size - vec2<f32>(0.5);
    let base = floor(uv);
    let f = uv - base;
    let depth = dot(p, -g.light_dir.xyz) - g.osm.z;
    let t = min((depth - g.osm.x) / g.osm.y - 1.0, 15.0);
    let w0 = hat4(t, 0.0);
    let w1 = hat4(t, 4.0);
    let w2 = hat4(t, 8.0);
    let w3 = hat4(t, 12.0);
    let hi = i32(size) - 1;
    var opacity = 0.0;
    var body = 0.0;
    for (var k = 0; k < 4; k++) {
        let ox = k & 1;
        let oy = k >> 1u;
        var wx = 1.0 - f.x;
        if ox == 1 {
            wx = f.x;
        }
        var wy = 1.0 - f.y;
        if oy == 1 {
            wy = f.y;
        }
        let w = wx * wy;
        let c = clamp(vec2<i32>(base) + vec2<i32>(ox, oy), vec2<i32>(0), vec2<i32>(hi));
        let o = dot(textureLoad(osm0, c, 0), w0) + dot(textureLoad(osm1, c, 0), w1)
            + dot(textureLoad(osm2, c, 0), w2) + dot(textureLoad(osm3, c, 0), w3);
        opacity += w * o;
        let uv_c = (vec2<f32>(c) + vec2<f32>(0.5)) / size;
        let lit = textureSampleCompareLevel(body_depth, depth_sampler, uv_c, lc.z - g.ambient.w);
        body += w * (1.0 - lit);
    }
    return max(1.0 - exp(-opacity), body);
}

fn highlight(l: vec3<f32>, v: vec3<f32>, t: vec3<f32>) -> f32 {
    let lt = dot(l, t);
    let vt = dot(v, t);
    let c = sqrt(max(1.0 - lt * lt, 0.0)) * sqrt(max(1.0 - vt * vt, 0.0)) - lt * vt;
    return max(c, 0.0);
}

fn shifted(t: vec3<f32>, lp: vec3<f32>, amount: f32) -> vec3<f32> {
    let s = t + lp * amount;
    let n = length(s);
    if n > 1e-6 {
        return s / n;
    }
    return t;
}

fn finish(amb: vec3<f32>, direct: vec3<f32>, shadow: f32) -> vec4<f32> {
    let lin = clamp(amb + (1.0 - shadow) * direct, vec3<f32>(0.0), vec3<f32>(1.0));
    return vec4<f32>(pow(lin, vec3<f32>(1.0 / g.wet.z)), 1.0);
}
