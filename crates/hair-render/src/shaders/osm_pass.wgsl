// Opacity shadow map pass (Ward, Galoppo & Lin §5.2): hair ribbons seen from the light add their
// opacity to every one of the 16 maps whose plane lies behind them, into four Rgba16Float
// targets with additive blending; the body writes only the depth attachment.

struct OsmVary {
    @builtin(position) clip: vec4<f32>,
    @location(0) depth: f32,
    @location(1) alpha: f32,
    @location(2) tex_u: f32,
    @location(3) kind: f32,
}

struct OsmOut {
    @location(0) m0: vec4<f32>,
    @location(1) m1: vec4<f32>,
    @location(2) m2: vec4<f32>,
    @location(3) m3: vec4<f32>,
}

@vertex
fn vs_hair(v: RibbonIn) -> OsmVary {
    let e = expand_ribbon(v, g.light_dir.xyz, g.light_dir.w);
    var out: OsmVary;
    out.clip = g.light_view_proj * vec4<f32>(e.xyz, 1.0);
    out.depth = dot(e.xyz, -g.light_dir.xyz);
    out.alpha = e.w;
    out.tex_u = v.extra.y;
    out.kind = v.extra.z;
    return out;
}

fn plane_mask(depth: f32, first: f32) -> vec4<f32> {
    var m = vec4<f32>(0.0);
    for (var i = 0; i < 4; i++) {
        if depth < g.osm.x + (first + f32(i) + 1.0) * g.osm.y {
            m[i] = 1.0;
        }
    }
    return m;
}

@fragment
fn fs_hair(in: OsmVary) -> OsmOut {
    var a = in.alpha;
    if in.kind > 1.5 {
        a = a * hair_texture(in.tex_u);
    }
    var out: OsmOut;
    out.m0 = a * plane_mask(in.depth, 0.0);
    out.m1 = a * plane_mask(in.depth, 4.0);
    out.m2 = a * plane_mask(in.depth, 8.0);
    out.m3 = a * plane_mask(in.depth, 12.0);
    return out;
}

@vertex
fn vs_body(v: BodyIn) -> @builtin(position) vec4<f32> {
    return g.light_view_proj * vec4<f32>(v.position, 1.0);
}

@fragment
fn fs_body() -> OsmOut {
    var out: OsmOut;
    out.m0 = vec4<f32>(0.0);
    out.m1 = vec4<f32>(0.0);
    out.m2 = vec4<f32>(0.0);
    out.m3 = vec4<f32>(0.0);
    return out;
}
