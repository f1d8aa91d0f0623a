//! Seeded hair scenes for tests, benches, profiling and reports (feature `test-support`).
//!
//! [`head_shell`] is the scene of `hair bench grid`, the crate's criterion benches and
//! `examples/grid_profile.rs`, so that their figures describe the same sections.

use crate::{Point, Section, Ssv, Vector};
use hair_ssv::Lss;
use hair_ssv::test_meshes::SplitMix;

/// Head radius (m), segment length (m), segment radius (m).
const HEAD: f32 = 0.1;
const SEG: f32 = 0.01;
const RADIUS: f32 = 0.0005;

/// A head-sized shell of hair: `segments` sections in strands of `per_strand`, rooted on the
/// scalp (the upper part of a 10 cm sphere, off the face), growing out, bending under gravity,
/// lying on the head in layers 1-30 mm thick and hanging down below it, in segments of about
/// 1 cm with a 0.5 mm radius. The same seed gives the same sections.
pub fn head_shell(segments: usize, per_strand: usize, seed: u64) -> Vec<Section> {
    let per_strand = per_strand.max(1);
    let strands = segments.div_ceil(per_strand);
    let mut rng = SplitMix::new(seed);
    let mut out = Vec::with_capacity(strands * per_strand);
    let down = Vector::new(0.0, -1.0, 0.0);
    for s in 0..strands {
        // Root: uniform on the sphere, kept on the scalp (above the ears, not on the face).
        let n = loop {
            let v = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let l = v.norm();
            if l > 1e-3 && l <= 1.0 {
                let v = v / l;
                let face = v.z > 0.3 && v.y < 0.5;
                if v.y > -0.2 && !face {
                    break v;
                }
            }
        };
        let layer = HEAD + rng.range(0.001, 0.03);
        let mut p = Point::from(n * HEAD);
        let mut dir = (n * 0.8 + down * 0.2).normalize();
        let stiff = rng.range(0.1, 0.3);
        for k in 0..per_strand.min(segments - out.len()) {
            let noise = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            dir = (dir * (1.0 - stiff) + down * stiff + noise * 0.08).normalize();
            let mut q = p + dir * SEG * rng.range(0.9, 1.1);
            let r = q.coords.norm();
            if r < layer {
                q = Point::from(q.coords * (layer / r));
                dir = (q - p).normalize();
            }
            out.push(Section {
                skeleton: s as u32,
                segment: k as u32,
                shape: Ssv::Line(Lss::new(p, q, RADIUS)),
            });
            p = q;
        }
    }
    out
}

/// A wisp of `strands` near-parallel strands of six 5 cm sections (radius 1.5-2.5 mm) rooted in
/// a 3 cm square and running down along y: dense hair as a simulation's wisps make it, whose
/// cells hold hundreds of sections (the pair search sweeps them). The same seed gives the same
/// sections.
pub fn wisp(strands: u32, seed: u64) -> Vec<Section> {
    let mut rng = SplitMix::new(seed);
    let mut out = Vec::with_capacity(6 * strands as usize);
    for s in 0..strands {
        let mut p = Point::new(rng.unit(), 0.0, rng.unit()) * 0.03;
        for k in 0..6 {
            let q = p + Vector::new(rng.unit() - 0.5, 2.0, rng.unit() - 0.5) * 0.025;
            out.push(Section {
                skeleton: s,
                segment: k,
                shape: Ssv::Line(Lss::new(p, q, rng.range(0.0015, 0.0025))),
            });
            p = q;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shell_is_seeded_and_sized() {
        let a = head_shell(1000, 30, 1);
        assert_eq!(a.len(), 1000);
        assert_eq!(a, head_shell(1000, 30, 1));
        assert_ne!(a, head_shell(1000, 30, 2));
        // 34 strands: 33 of 30 sections and one of 10.
        assert_eq!(a.last().map(|s| (s.skeleton, s.segment)), Some((33, 9)));
    }
}
