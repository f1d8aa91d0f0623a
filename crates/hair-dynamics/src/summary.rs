//! What a whole state amounts to: its kinetic energy, and a hash of its floats for
//! determinism tests.

use crate::{SkeletonId, StrandState};

impl StrandState {
    /// Kinetic energy of the listed skeletons' nodes, their water included (J, in the frame
    /// the state is simulated in).
    pub fn kinetic_energy(&self, skeletons: &[u32]) -> f64 {
        let (m, w, v) = (self.mass(), self.wetness(), self.velocities());
        skeletons
            .iter()
            .flat_map(|&n| self.nodes(SkeletonId(n)))
            .map(|i| 0.5 * f64::from(m[i] + w[i]) * f64::from(v[i].norm_squared()))
            .sum()
    }

    /// A hash of the float bits of every angle, angular velocity and position: two chains of
    /// 64-bit words (the angles and rates, two floats a word; the positions), each step an xor,
    /// a multiplication by an odd constant and a rotation, then folded together. Every step is
    /// invertible, so two states that differ in one float always differ in the hash. Word-wise
    /// and in two independent chains it is about nine times cheaper than the byte-wise FNV-1a it
    /// replaced (perf over 60 `wardlin` frames: 1.88% of the samples, then 0.21%).
    pub fn state_hash(&self) -> u64 {
        const K: u64 = 0x9e37_79b9_7f4a_7c15;
        #[inline(always)]
        fn mix(h: u64, w: u64) -> u64 {
            (h ^ w).wrapping_mul(K).rotate_left(29)
        }
        let pair = |a: f32, b: f32| u64::from(a.to_bits()) | u64::from(b.to_bits()) << 32;
        let s = self;
        let (mut angles, mut points) = (0xcbf2_9ce4_8422_2325_u64, 0x8422_2325_cbf2_9ce4_u64);
        let rows = s
            .theta()
            .iter()
            .zip(s.phi())
            .zip(s.omega_theta().iter().zip(s.omega_phi()))
            .zip(s.positions());
        for (((&t, &f), (&wt, &wf)), p) in rows {
            angles = mix(mix(angles, pair(t, f)), pair(wt, wf));
            points = mix(mix(points, pair(p.x, p.y)), u64::from(p.z.to_bits()));
        }
        let h = mix(mix(angles, points), s.node_count() as u64);
        h ^ (h >> 31)
    }
}

#[cfg(test)]
mod tests {
    use crate::*;
    use nalgebra::Rotation3;

    /// One float's lowest bit flipped anywhere in the state (an angle or a rate of the first, a
    /// middle or the last node) changes the hash; flipped back, the hash returns.
    #[test]
    fn the_state_hash_sees_every_float() {
        let mut s = StrandState::new();
        for k in 0..3 {
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
        let base = s.state_hash();
        let n = s.node_count();
        // Flips the lowest bit of one angle or rate of node `i`.
        let flip = |s: &mut StrandState, field: usize, i: usize| {
            let x = match field {
                0 => &mut s.theta_mut()[i],
                1 => &mut s.phi_mut()[i],
                2 => &mut s.omega_theta_mut()[i],
                _ => &mut s.omega_phi_mut()[i],
            };
            *x = f32::from_bits(x.to_bits() ^ 1);
        };
        for i in [0, n / 2, n - 1] {
            for field in 0..4 {
                flip(&mut s, field, i);
                assert_ne!(s.state_hash(), base, "node {i}, field {field}");
                flip(&mut s, field, i);
                assert_eq!(s.state_hash(), base);
            }
        }
    }
}
