//! The WGSL validates with naga, with no GPU needed.

#![cfg(feature = "gpu")]

use hair_render::wgpu::naga;

fn validate(name: &str, src: &str) {
    let module = match naga::front::wgsl::parse_str(src) {
        Ok(m) => m,
        Err(e) => panic!("{name}: {}", e.emit_to_string(src)),
    };
    let mut v = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    );
    if let Err(e) = v.validate(&module) {
        panic!("{name}: {}", e.emit_to_string(src));
    }
    for entry in ["vs_hair", "fs_hair", "vs_body", "fs_body"] {
        assert!(
            module.entry_points.iter().any(|e| e.name == entry),
            "{name} lacks {entry}"
        );
    }
}

#[test]
fn osm_pass_wgsl_validates() {
    validate("osm pass", &hair_render::osm_shader_source());
}

#[test]
fn shade_pass_wgsl_validates() {
    validate("shade pass", &hair_render::shade_shader_source());
}

#[test]
fn globals_layout_matches_wgsl_size() {
    // 2 mat4 (128 bytes) + 11 vec4 (176) + 16 vec4 texture (256).
    assert_eq!(std::mem::size_of::<hair_render::Globals>(), 128 + 176 + 256);
}
