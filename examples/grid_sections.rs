//! Writes the hair sections a scene's simulation holds in its localization grid after a number
//! of steps, in the format `hair-grid`'s `grid_profile` example reads from `HAIR_GRID_SECTIONS`
//! (per section, little endian: `a`, `b` and the radius as 7 `f32`, then skeleton and segment as
//! 2 `u32`; sections that are not an LSS are left out), so that the pair search can be profiled
//! on a simulation's hair:
//!
//! ```sh
//! cargo run --release -p hair --example grid_sections -- wardlin 41 fine out/wardlin-41.bin
//! HAIR_GRID_SECTIONS=out/wardlin-41.bin \
//!     cargo run --release -p hair-grid --example grid_profile -- pairs 15
//! ```
//!
//! Arguments: a built-in scene or a scene file, the number of steps, the LOD policy (`fine`,
//! `adaptive`, `coarse-strands`, `clusters`, `strips`) and the output file.
use hair::{LodPolicy, Scene, Simulation};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, steps, policy, out] = args.as_slice() else {
        return Err("usage: grid_sections SCENE STEPS POLICY OUT".into());
    };
    let steps: usize = steps.parse()?;
    let policy =
        LodPolicy::from_name(policy).ok_or_else(|| format!("unknown LOD policy {policy:?}"))?;
    let scene = Scene::load(scene)?;
    let mut sim = Simulation::new(&scene, policy)?;
    for _ in 0..steps {
        sim.step()?;
    }
    let grid = sim.grid();
    let mut bytes = Vec::with_capacity(36 * grid.len());
    for i in 0..grid.len() {
        let (Some(hair::ssv::Ssv::Line(l)), Some(skeleton), Some(segment)) =
            (grid.shape(i), grid.skeleton(i), grid.segment(i))
        else {
            continue;
        };
        for v in [l.a.x, l.a.y, l.a.z, l.b.x, l.b.y, l.b.z, l.radius] {
            bytes.extend(v.to_le_bytes());
        }
        bytes.extend(skeleton.to_le_bytes());
        bytes.extend(segment.to_le_bytes());
    }
    std::fs::write(out, &bytes)?;
    println!("{} sections after {steps} steps -> {out}", bytes.len() / 36);
    Ok(())
}
