//! Test fixtures (feature `test-support`): the procedural head and shoulders of [`crate::head`],
//! re-exported, and a seeded generator with the samplers the tests, benches and reports use.

use rand_xoshiro::SplitMix64;
use rand_xoshiro::rand_core::{Rng, SeedableRng};

use crate::{Point, Real, Vector};

pub use crate::head::{
    HEAD, NECK_RADIUS, SHOULDERS, head_and_shoulders, head_and_shoulders_body, inside_neck,
};

/// A seeded generator for tests, benches and reports: SplitMix64 (`rand_xoshiro`'s), with
/// the samplers the fixtures use. The same seed gives the same values on every platform.
#[derive(Clone, Debug)]
pub struct SplitMix(SplitMix64);

impl SplitMix {
    /// The generator seeded with `seed` (SplitMix64's state).
    pub fn new(seed: u64) -> Self {
        Self(SplitMix64::seed_from_u64(seed))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in `[0, 1)`: the top 24 bits of [`SplitMix::next_u64`].
    pub fn unit(&mut self) -> Real {
        (self.next_u64() >> 40) as Real / (1u64 << 24) as Real
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: Real, hi: Real) -> Real {
        let u = self.unit();
        lo + (hi - lo) * u
    }

    /// Uniform point in the box `[-h, h]^3` around `c`.
    pub fn point_near(&mut self, c: &Point, h: Real) -> Point {
        c + Vector::new(self.range(-h, h), self.range(-h, h), self.range(-h, h))
    }

    /// A point on a random triangle of the mesh moved by `offset` along its face normal, with
    /// the triangle's index.
    pub fn surface_point(&mut self, tris: &[[Point; 3]], offset: Real) -> (Point, usize) {
        let k = (self.next_u64() % tris.len() as u64) as usize;
        let t = &tris[k];
        let (mut u, mut w) = (self.range(0.0, 1.0), self.range(0.0, 1.0));
        if u + w > 1.0 {
            (u, w) = (1.0 - u, 1.0 - w);
        }
        let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * w;
        let n = (t[1] - t[0])
            .cross(&(t[2] - t[0]))
            .try_normalize(0.0)
            .unwrap_or_else(Vector::y);
        (p + n * offset, k)
    }
}
