//! Criterion benches of the closest-point kernels and SSV distances (seeded inputs).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hair_ssv::query::{point_triangle, segment_rectangle, segment_segment, segment_triangle};
use hair_ssv::test_meshes::SplitMix;
use hair_ssv::{Lss, Point, Rss, Vector, distance_lss_lss, distance_rss_rss};

const N: usize = 1024;

fn axes(rng: &mut SplitMix) -> [Vector; 2] {
    loop {
        let u = Vector::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        let w = Vector::new(
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
        );
        if let Some(u) = u.try_normalize(1e-2)
            && let Some(v) = (w - u * u.dot(&w)).try_normalize(1e-2)
        {
            return [u, v];
        }
    }
}

fn lss(rng: &mut SplitMix) -> Lss {
    let a = rng.point_near(&Point::origin(), 0.1);
    Lss::new(a, rng.point_near(&a, 0.02), rng.range(0.0, 0.005))
}

fn rss(rng: &mut SplitMix) -> Rss {
    let o = rng.point_near(&Point::origin(), 0.05);
    Rss::new(
        o,
        axes(rng),
        [rng.range(0.0, 0.04), rng.range(0.0, 0.02)],
        rng.range(0.0, 0.003),
    )
}

fn tri(rng: &mut SplitMix) -> [Point; 3] {
    let a = rng.point_near(&Point::origin(), 0.1);
    [a, rng.point_near(&a, 0.01), rng.point_near(&a, 0.01)]
}

fn kernels(c: &mut Criterion) {
    let mut rng = SplitMix::new(42);
    let lss_pairs: Vec<(Lss, Lss)> = (0..N).map(|_| (lss(&mut rng), lss(&mut rng))).collect();
    let rss_pairs: Vec<(Rss, Rss)> = (0..N).map(|_| (rss(&mut rng), rss(&mut rng))).collect();
    let lss_rss: Vec<(Lss, Rss)> = (0..N).map(|_| (lss(&mut rng), rss(&mut rng))).collect();
    let lss_tri: Vec<(Lss, [Point; 3])> = (0..N).map(|_| (lss(&mut rng), tri(&mut rng))).collect();
    let mut g = c.benchmark_group("kernels");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("segment_segment", |b| {
        b.iter(|| {
            for (x, y) in black_box(&lss_pairs) {
                black_box(segment_segment(&x.a, &x.b, &y.a, &y.b));
            }
        })
    });
    g.bench_function("distance_lss_lss", |b| {
        b.iter(|| {
            for (x, y) in black_box(&lss_pairs) {
                black_box(distance_lss_lss(x, y));
            }
        })
    });
    g.bench_function("segment_rectangle", |b| {
        b.iter(|| {
            for (x, y) in black_box(&lss_rss) {
                black_box(segment_rectangle(&x.a, &x.b, y));
            }
        })
    });
    g.bench_function("distance_rss_rss", |b| {
        b.iter(|| {
            for (x, y) in black_box(&rss_pairs) {
                black_box(distance_rss_rss(x, y));
            }
        })
    });
    g.bench_function("point_triangle", |b| {
        b.iter(|| {
            for (x, t) in black_box(&lss_tri) {
                black_box(point_triangle(&x.a, t));
            }
        })
    });
    g.bench_function("segment_triangle", |b| {
        b.iter(|| {
            for (x, t) in black_box(&lss_tri) {
                black_box(segment_triangle(&x.a, &x.b, t));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, kernels);
criterion_main!(benches);
