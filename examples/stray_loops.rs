//! Finds the drawn strands that stand above the crown (issue 40's stray loops) in a scene's
//! run: every 10 steps, how many drawn strands reach `ABOVE` metres over the top of the
//! procedural head, and for each its front node, the node's kind, level and strand count, and
//! how far each of the node's strands' rest chords runs from the node's (degrees). With a
//! fourth argument, writes the drawn strands' points at the last step there (`f32` x, y, z,
//! little endian) to compare runs.
//!
//! ```sh
//! cargo run --release -p hair --example stray_loops -- salon 120 fine [OUT]
//! ```
use hair::ssv::{Point, Vector};
use hair::{LodPolicy, Scene, Simulation};

/// Height over the head's top (m) above which a drawn vertex counts as standing up.
const ABOVE: f32 = 0.04;
/// The procedural head's top (m, head frame).
const HEAD_TOP: f32 = 0.115;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let scene = args.first().map_or("salon", String::as_str);
    let steps: usize = args.get(1).map_or(Ok(120), |s| s.parse())?;
    let loaded = Scene::load(scene)?;
    let policy = match args.get(2) {
        Some(p) => LodPolicy::from_name(p).ok_or("unknown policy")?,
        None => loaded.scene.lod,
    };
    let mut sim = Simulation::new(&loaded, policy)?;
    let g = sim.frame_geometry();
    let chords: Vec<Vector> = (0..g.strand_count()).map(|s| chord(g.strand(s))).collect();
    for step in 0..=steps {
        if step > 0 {
            sim.step()?;
        }
        if step % 10 == 0 || step == steps {
            report(&sim, step, &chords);
        }
    }
    if let Some(out) = args.get(3) {
        let g = sim.frame_geometry();
        let bytes: Vec<u8> = g
            .positions
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .flat_map(f32::to_le_bytes)
            .collect();
        std::fs::write(out, bytes)?;
    }
    Ok(())
}

/// Unit vector from a polyline's first point to its last.
fn chord(p: &[Point]) -> Vector {
    (p[p.len() - 1] - p[0]).normalize()
}

/// The drawn strands standing up at `step`, with their nodes.
fn report(sim: &Simulation, step: usize, chords: &[Vector]) {
    let h = sim.hierarchy();
    let drawn = sim.frame_geometry();
    let top = |s: usize| drawn.strand(s).iter().map(|q| q.y).fold(f32::MIN, f32::max);
    let standing = (0..drawn.strand_count()).filter(|&s| top(s) > HEAD_TOP + ABOVE);
    println!(
        "step {step}: {} front skeletons, {} drawn strands above {:.3} m, kinetic energy {:.3e} J",
        sim.front_nodes().len(),
        standing.clone().count(),
        HEAD_TOP + ABOVE,
        sim.kinetic_energy()
    );
    for &n in sim.front_nodes() {
        let node = chord(&h.rest_points(n));
        for &s in h.strands(n) {
            if top(s as usize) <= HEAD_TOP + ABOVE {
                continue;
            }
            let spread: Vec<String> = h
                .strands(n)
                .iter()
                .map(|&m| {
                    let c = chords[m as usize].dot(&node).clamp(-1.0, 1.0);
                    format!("{m}:{:.0}", c.acos().to_degrees())
                })
                .collect();
            println!(
                "  strand {s} of node {n} ({:?} level {}, {} strands) top {:.3} m; \
                 members' rest chords from the node's (deg): {}",
                h.kind(n),
                h.level(n),
                h.strand_count(n),
                top(s as usize),
                spread.join(" "),
            );
        }
    }
}
