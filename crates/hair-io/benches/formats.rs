//! Parse and write throughput of the strand formats.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hair_io::{Strands, cyhair, tfx};
use std::hint::black_box;

fn strands(count: usize, per: usize) -> Strands {
    let lines = (0..count)
        .map(|s| {
            (0..per)
                .map(|i| [s as f32 * 1e-3, -(i as f32) * 0.01, (s % 7) as f32 * 1e-3])
                .collect()
        })
        .collect();
    Strands::from_polylines(lines).expect("valid strands")
}

fn formats(c: &mut Criterion) {
    let s = strands(10_000, 32);
    let tfx_bytes = tfx::to_bytes(&s, "bench.tfx").expect("uniform strands");
    let hair_bytes = cyhair::to_bytes(&s);
    let mut g = c.benchmark_group("formats");
    g.throughput(Throughput::Bytes(tfx_bytes.len() as u64));
    g.bench_function("tfx_read_10k_x32", |b| {
        b.iter(|| tfx::from_bytes(black_box(&tfx_bytes), "bench.tfx"))
    });
    g.throughput(Throughput::Bytes(hair_bytes.len() as u64));
    g.bench_function("hair_read_10k_x32", |b| {
        b.iter(|| cyhair::from_bytes(black_box(&hair_bytes), "bench.hair"))
    });
    g.bench_function("hair_write_10k_x32", |b| {
        b.iter(|| cyhair::to_bytes(black_box(&s)))
    });
    g.finish();
}

criterion_group!(benches, formats);
criterion_main!(benches);
