//! Procedural hairstyles for tests, benchmarks and the `hair hierarchy` command.
//!
//! [`ward_lin_head`] stands in for the benchmark of Ward & Lin 2003 §7.2: 9,350 strands of six
//! control points on a head-sized scalp, hanging down.

use crate::{Hairstyle, Point, Real, Strand, Vector};
use nalgebra::{Matrix3, Rotation3};

/// SplitMix64: a small seeded generator, so hairstyles are reproducible without a dependency.
#[derive(Clone, Debug)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Radius of the test head's scalp (m).
pub const HEAD_RADIUS: Real = 0.1;

/// Control points per strand of the test head.
pub const CONTROL_POINTS: usize = 6;

/// A head of `strands` strands, deterministic in `seed`: roots uniform over the upper half of
/// a sphere of radius [`HEAD_RADIUS`] centred at the origin (y up, the face toward +z), six
/// control points per strand, 0.2 to 0.3 m long, leaving the scalp along its normal and falling
/// down and outward, with a little waviness.
pub fn ward_lin_head(strands: usize, seed: u64) -> Hairstyle {
    let mut rng = SplitMix64::new(seed);
    let up = Vector::y();
    let mut out = Vec::with_capacity(strands);
    for _ in 0..strands {
        let y = rng.unit();
        let alpha = rng.unit() * core::f64::consts::TAU;
        let ring = (1.0 - y * y).max(0.0).sqrt();
        let normal = Vector::new(
            (ring * alpha.cos()) as Real,
            y as Real,
            (ring * alpha.sin()) as Real,
        );
        let normal = normal.try_normalize(1e-12).unwrap_or(up);
        let root = Point::from(normal * HEAD_RADIUS);
        // Frame: z along the normal, x along the azimuth.
        let around = Vector::new(-(alpha.sin() as Real), 0.0, alpha.cos() as Real);
        let x = (around - normal * normal.dot(&around))
            .try_normalize(1e-9)
            .unwrap_or_else(Vector::x);
        let yv = normal.cross(&x);
        let frame = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, yv, normal]));
        let outward = Vector::new((alpha.cos()) as Real, 0.0, (alpha.sin()) as Real);
        let length = (0.2 + 0.1 * rng.unit()) as Real;
        let seg = length / (CONTROL_POINTS - 1) as Real;
        let wave = (0.1 * (rng.unit() - 0.5)) as Real;
        let mut points = Vec::with_capacity(CONTROL_POINTS);
        points.push(root);
        let mut p = root;
        for k in 1..CONTROL_POINTS {
            let a = 1.0 - (k - 1) as Real / (CONTROL_POINTS - 2) as Real;
            let side = wave * if k % 2 == 0 { 1.0 } else { -1.0 };
            let dir = normal * a + (-up) * (1.0 - a) + outward * (0.4 * (1.0 - a)) + x * side;
            let dir = dir.try_normalize(1e-9).unwrap_or(-up);
            p += dir * seg;
            points.push(p);
        }
        out.push(Strand {
            root,
            frame,
            points,
        });
    }
    Hairstyle { strands: out }
}
