//! What a whole state amounts to: its kinetic energy, and a hash of its floats for
//! determinism tests.

use crate::{SkeletonId, StrandState};
use rayon::prelude::*;

/// The summaries split their work into this many fixed parts: a part's bounds depend only on
/// the state's size, and the parts' results are combined in order, so every thread count gives
/// the same bits. The partial results live on the stack, so a summary takes no memory.
const PARTS: usize = 64;

/// The `k`-th of `PARTS` near-equal parts of `0..n`.
fn part(k: usize, n: usize) -> core::ops::Range<usize> {
    k * n / PARTS..(k + 1) * n / PARTS
}

impl StrandState {
    /// Kinetic energy of the listed skeletons' nodes, their water included (J, in the frame
    /// the state is simulated in). Summed in fixed parts of the list, so the result is the same
    /// on any thread count.
    pub fn kinetic_energy(&self, skeletons: &[u32]) -> f64 {
        let (m, w, v) = (self.mass(), self.wetness(), self.velocities());
        let mut parts = [0.0f64; PARTS];
        parts.par_iter_mut().enumerate().for_each(|(k, out)| {
            *out = skeletons[part(k, skeletons.len())]
                .iter()
                .map(|&n| {
                    let r = self.nodes(SkeletonId(n));
                    let rows = m[r.clone()].iter().zip(&w[r.clone()]).zip(&v[r]);
                    rows.map(|((&m, &w), v)| f64::from(m + w) * f64::from(v.norm_squared()))
                        .sum::<f64>()
                })
                .sum();
        });
        0.5 * parts.iter().sum::<f64>()
    }

    /// A hash of the float bits of every angle, angular velocity and position. Each of the
    /// fixed parts of the nodes runs four chains of 64-bit words (angles, rates, `x y`, `z`),
    /// each word an xor, a multiplication by an odd constant and a rotation; the parts' chains
    /// are then folded in order. Every step is invertible, so two states that differ in one
    /// float always differ in the hash. The parts run in parallel and the four chains overlap
    /// in the processor, which took the hash of `strands10k`'s 320,000 nodes from 2.9 ms a step
    /// to a fraction of it (`docs/perf/volume.md`).
    pub fn state_hash(&self) -> u64 {
        const K: u64 = 0x9e37_79b9_7f4a_7c15;
        #[inline(always)]
        fn mix(h: u64, w: u64) -> u64 {
            (h ^ w).wrapping_mul(K).rotate_left(29)
        }
        let pair = |a: f32, b: f32| u64::from(a.to_bits()) | u64::from(b.to_bits()) << 32;
        let s = self;
        let n = s.node_count();
        let mut parts = [[0u64; 4]; PARTS];
        parts.par_iter_mut().enumerate().for_each(|(k, out)| {
            let r = part(k, n);
            let seed = 0xcbf2_9ce4_8422_2325_u64 ^ k as u64;
            let mut h = [
                seed,
                seed.rotate_left(16),
                seed.rotate_left(32),
                seed.rotate_left(48),
            ];
            let rows = s.theta()[r.clone()]
                .iter()
                .zip(&s.phi()[r.clone()])
                .zip(
                    s.omega_theta()[r.clone()]
                        .iter()
                        .zip(&s.omega_phi()[r.clone()]),
                )
                .zip(&s.positions()[r]);
            for (((&t, &f), (&wt, &wf)), p) in rows {
                h[0] = mix(h[0], pair(t, f));
                h[1] = mix(h[1], pair(wt, wf));
                h[2] = mix(h[2], pair(p.x, p.y));
                h[3] = mix(h[3], u64::from(p.z.to_bits()));
            }
            *out = h;
        });
        let h = parts.iter().flatten().fold(n as u64, |h, &w| mix(h, w));
        h ^ (h >> 31)
    }
}

#[cfg(test)]
mod tests {
    use crate::*;
    use nalgebra::Rotation3;

    /// `skeletons` straight strands of 8 points side by side.
    fn strands(skeletons: usize) -> StrandState {
        let mut s = StrandState::new();
        for k in 0..skeletons {
            let root = Point::new(0.01 * k as Real, 0.0, 0.0);
            let frame = Rotation3::identity();
            let points = style_points(root, &frame, &Style::Straight, 8, 0.2).unwrap();
            let root = Root::Attached {
                position: root,
                frame,
            };
            let material = Material::default();
            s.add_skeleton(&SkeletonDesc {
                root,
                points,
                material,
            })
            .unwrap();
        }
        s
    }

    /// One float's lowest bit flipped anywhere in the state (an angle, a rate or a coordinate
    /// of the first, a middle or the last node) changes the hash; flipped back, it returns.
    #[test]
    fn the_state_hash_sees_every_float() {
        let mut s = strands(3);
        let base = s.state_hash();
        let n = s.node_count();
        // Flips the lowest bit of one angle or rate of node `i`.
        let flip = |s: &mut StrandState, field: usize, i: usize| {
            let x = match field {
                0 => &mut s.theta_mut()[i],
                1 => &mut s.phi_mut()[i],
                2 => &mut s.omega_theta_mut()[i],
                3 => &mut s.omega_phi_mut()[i],
                4 => &mut s.positions[i].x,
                5 => &mut s.positions[i].y,
                _ => &mut s.positions[i].z,
            };
            *x = f32::from_bits(x.to_bits() ^ 1);
        };
        for i in [0, n / 2, n - 1] {
            for field in 0..7 {
                flip(&mut s, field, i);
                assert_ne!(s.state_hash(), base, "node {i}, field {field}");
                flip(&mut s, field, i);
                assert_eq!(s.state_hash(), base);
            }
        }
    }

    /// The summaries split their work in parts fixed by the state's size, not by the threads:
    /// the hash and the energy's bits are the same on 1, 2 and 5 threads, with more skeletons
    /// than parts and with fewer nodes than parts.
    #[test]
    fn summaries_do_not_depend_on_the_thread_count() {
        for skeletons in [5, 300] {
            let mut s = strands(skeletons);
            let n = s.node_count();
            for (i, v) in s.velocities.iter_mut().enumerate() {
                *v = Vector::new(
                    1.0 + (i % 7) as Real,
                    0.3 * (i % 3) as Real,
                    -0.01 * i as Real,
                );
            }
            let all: Vec<u32> = (0..skeletons as u32).collect();
            let on = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                pool.install(|| (s.state_hash(), s.kinetic_energy(&all).to_bits()))
            };
            let one = on(1);
            assert_eq!(on(2), one, "{n} nodes");
            assert_eq!(on(5), one, "{n} nodes");
            let serial: f64 = (0..n)
                .map(|i| {
                    0.5 * f64::from(s.mass()[i] + s.wetness()[i])
                        * f64::from(s.velocities()[i].norm_squared())
                })
                .sum();
            let ke = f64::from_bits(one.1);
            assert!(
                (ke - serial).abs() <= 1e-12 * serial,
                "{ke} against {serial}"
            );
        }
    }
}
