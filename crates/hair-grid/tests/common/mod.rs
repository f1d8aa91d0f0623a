//! Shared proptest strategies and brute-force oracles.

#![allow(dead_code)]

use hair_grid::{Grid, Section};
use hair_ssv::{Lss, Point, Pss, Rss, Ssv, Vector};
use proptest::prelude::*;

/// A coordinate in `[-0.2, 0.2]`, often snapped to a multiple of 0.05 (a cell boundary for the
/// cell sizes the tests use) or to 0.
pub fn coord() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => -0.2f32..0.2,
        2 => (-4i32..=4).prop_map(|k| k as f32 * 0.05),
        1 => Just(0.0f32),
    ]
}

pub fn point() -> impl Strategy<Value = Point> {
    (coord(), coord(), coord()).prop_map(|(x, y, z)| Point::new(x, y, z))
}

/// A radius: usually hair-like, sometimes zero, sometimes huge (several cells).
pub fn radius() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => 0.0f32..0.02,
        1 => Just(0.0f32),
        1 => 0.05f32..0.15,
    ]
}

/// A segment: general, zero-length, axis-aligned, or lying on cell boundaries.
pub fn lss() -> impl Strategy<Value = Lss> {
    prop_oneof![
        5 => (point(), point(), radius()).prop_map(|(a, b, r)| Lss::new(a, b, r)),
        1 => (point(), radius()).prop_map(|(a, r)| Lss::new(a, a, r)),
        2 => (point(), 0usize..3, -0.2f32..0.2, radius()).prop_map(|(a, axis, d, r)| {
            let mut b = a;
            b[axis] += d;
            Lss::new(a, b, r)
        }),
        1 => ((-4i32..=4), (-4i32..=4), -0.2f32..0.2, -0.2f32..0.2, radius()).prop_map(
            |(j, k, x0, x1, r)| {
                let (y, z) = (j as f32 * 0.05, k as f32 * 0.05);
                Lss::new(Point::new(x0, y, z), Point::new(x1, y, z), r)
            }
        ),
    ]
}

pub fn rss() -> impl Strategy<Value = Rss> {
    (
        point(),
        -3.1f32..3.1,
        -1.5f32..1.5,
        0.0f32..0.1,
        0.0f32..0.1,
        radius(),
    )
        .prop_map(|(o, yaw, pitch, e0, e1, r)| {
            let a0 = Vector::new(
                yaw.cos() * pitch.cos(),
                pitch.sin(),
                yaw.sin() * pitch.cos(),
            );
            let helper = if a0.x.abs() < 0.9 {
                Vector::x()
            } else {
                Vector::y()
            };
            let a1 = a0.cross(&helper).normalize();
            Rss::new(o, [a0, a1], [e0, e1], r)
        })
}

pub fn ssv() -> impl Strategy<Value = Ssv> {
    prop_oneof![
        8 => lss().prop_map(Ssv::Line),
        1 => (point(), radius()).prop_map(|(c, r)| Ssv::Point(Pss::new(c, r))),
        1 => rss().prop_map(Ssv::Rect),
    ]
}

/// Sections on a few skeletons (consecutive segment ids), so the neighbour rule is exercised.
pub fn sections(max: usize) -> impl Strategy<Value = Vec<Section>> {
    prop::collection::vec(ssv(), 0..max).prop_map(|shapes| {
        shapes
            .into_iter()
            .enumerate()
            .map(|(i, shape)| Section {
                skeleton: (i / 4) as u32,
                segment: (i % 4) as u32,
                shape,
            })
            .collect()
    })
}

/// Brute force: every pair within the margin, skipping neighbours as the grid does.
pub fn brute_pairs(sections: &[Section], margin: f32, skip: u32) -> Vec<[u32; 2]> {
    let mut out = Vec::new();
    for i in 0..sections.len() {
        for j in i + 1..sections.len() {
            let (a, b) = (&sections[i], &sections[j]);
            if a.skeleton == b.skeleton && a.segment.abs_diff(b.segment) <= skip {
                continue;
            }
            if a.shape.distance(&b.shape) <= margin {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

/// Everything observable about a grid, for determinism checks.
pub fn fingerprint(grid: &Grid) -> Vec<u64> {
    let mut v = vec![grid.cell_count() as u64, grid.entry_count() as u64];
    for (k, s) in grid.cells() {
        v.push(k.pack().unwrap_or(0));
        v.extend(s.iter().map(|&i| u64::from(i)));
    }
    v
}
