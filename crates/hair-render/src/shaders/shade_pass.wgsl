// Shading pass (Ward, Galoppo & Lin §5.1): camera-facing hair ribbons with Kajiya-Kay diffuse and
// two shifted highlights, and the body shaded simply; both under the opacity-map shadow.

struct HairVary {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) tangent: vec3<f32>,
    @location(2) color: vec3<f32>,
    // wetness, noise, tex_u, kind
    @location(3) extra: vec4<f32>,
}

@vertex
fn vs_hair(v: RibbonIn) -> HairVary {
    let to_eye = g.cam_eye.xyz - v.position;
    let dist = length(to_eye);
    var view = vec3<f32>(0.0, 0.0, 1.0);
    if dist > 0.0 {
        view = to_eye / dist;
    }
    let along = max(dot(v.position - g.cam_eye.xyz, g.cam_forward.xyz), 0.0);
    let e = expand_ribbon(v, view, along * g.cam_eye.w);
    var out: HairVary;
    out.clip = g.cam_view_proj * vec4<f32>(e.xyz, 1.0);
    out.world = e.xyz;
    out.tangent = v.tangent;
    out.color = v.color;
    out.extra = vec4<f32>(v.wetness, v.extra.x, v.extra.y, v.extra.z);
    return out;
}

@fragment
fn fs_hair(in: HairVary) -> @location(0) vec4<f32> {
    var base = in.color;
    if in.extra.w > 1.5 {
        let tx = hair_texture(in.extra.z);
        if tx < 0.5 {
            discard;
        }
        base = base * (0.55 + 0.45 * tx);
    }
    let wet = in.extra.x;
    let noise = in.extra.y;
    var t = in.tangent;
    let tl = length(t);
    if tl > 1e-6 {
        t = t / tl;
    } else {
        t = vec3<f32>(0.0, -1.0, 0.0);
    }
    let l = g.light_dir.xyz;
    let to_eye = g.cam_eye.xyz - in.world;
    var v = vec3<f32>(0.0, 0.0, 1.0);
    if length(to_eye) > 0.0 {
        v = normalize(to_eye);
    }
    base = base * (1.0 - g.wet.x * wet);
    let lt = dot(l, t);
    let lp0 = l - t * lt;
    let lpn = length(lp0);
    var lp = vec3<f32>(0.0);
    if lpn > 1e-6 {
        lp = lp0 / lpn;
    }
    let t1 = shifted(t, lp, g.spec.x);
    let t2 = shifted(t, lp, g.spec.y + g.spec2.w * noise);
    let m1 = g.spec.z * (1.0 + g.wet.y * wet);
    let k1 = g.spec2.x * (1.0 + wet);
    let diffuse = sqrt(max(1.0 - lt * lt, 0.0));
    let s1 = k1 * pow(highlight(l, v, t1), m1);
    let s2 = g.spec2.y * pow(highlight(l, v, t2), g.spec.w);
    let amb = g.ambient.xyz * base;
    let direct = g.light_color.xyz * (g.spec2.z * base * diffuse + vec3<f32>(s1) + s2 * base);
    return finish(amb, direct, shadow_at(in.world));
}

struct BodyVary {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
}

@vertex
fn vs_body(v: BodyIn) -> BodyVary {
    var out: BodyVary;
    out.clip = g.cam_view_proj * vec4<f32>(v.position, 1.0);
    out.world = v.position;
    out.normal = v.normal;
    return out;
}

@fragment
fn fs_body(in: BodyVary) -> @location(0) vec4<f32> {
    var n = in.normal;
    let nl = length(n);
    if nl > 0.0 {
        n = n / nl;
    }
    let ndl = max(dot(n, g.light_dir.xyz), 0.0);
    let c = g.body_color.xyz;
    let amb = g.ambient.xyz * c;
    let direct = g.light_color.xyz * c * ndl;
    return finish(amb, direct, shadow_at(in.world));
}
