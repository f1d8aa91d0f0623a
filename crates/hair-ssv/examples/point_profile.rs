//! Profiling driver for the point query ([`Bvh::closest`] with a [`Pss`]) on the 53,000-triangle
//! head-and-shoulders mesh: the same 20,000 seeded points, 0 to 40 mm off the surface (the band
//! a body's distance field samples), queried a given number of times after one warm-up.
//!
//! `cargo run --release -p hair-ssv --example point_profile -- [repeat]` prints the fastest time
//! per query and a hash of every answer (triangle, distance bits), so that a change can be
//! checked to give the same answers. Instruction counts: run it under `valgrind
//! --tool=callgrind` with repeat 1 and 3; half the difference of the totals is one pass.
use std::time::Instant;

use hair_ssv::head::head_and_shoulders;
use hair_ssv::test_meshes::SplitMix;
use hair_ssv::{Bvh, Pss, Ssv};

fn main() {
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let (v, t) = head_and_shoulders(96);
    let bvh = Bvh::new(&v, &t).expect("valid mesh");
    let mut rng = SplitMix::new(17);
    let pts: Vec<Ssv> = (0..20_000)
        .map(|_| {
            let off = rng.range(0.0, 0.04);
            Ssv::Point(Pss::new(rng.surface_point(bvh.triangles(), off).0, 0.0))
        })
        .collect();
    let run = || {
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for p in &pts {
            let c = bvh.closest(p);
            let (tri, d) = c.map_or((u32::MAX, 0), |c| (c.triangle, c.distance.to_bits()));
            for w in [u64::from(tri), u64::from(d)] {
                h = (h ^ w).wrapping_mul(0x100_0000_01b3);
            }
        }
        h
    };
    let hash = run();
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        assert_eq!(run(), hash);
        best = best.min(t.elapsed().as_secs_f64());
    }
    println!(
        "{:.0} ns per query (fastest of {reps}), hash {hash:016x}",
        best / pts.len() as f64 * 1e9
    );
}
