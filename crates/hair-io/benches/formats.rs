//! Parse and write throughput of the strand formats, and of the streaming frame writers.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hair_io::npy::NpyPointsWriter;
use hair_io::usda::{UsdStage, UsdaWriter};
use hair_io::{Existing, Strands, cyhair, tfx};
use std::hint::black_box;
use std::time::Instant;

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

/// One frame of 1,000 strands of 30 points (30,000 points, a run's typical frame) per
/// iteration, written to a file in the temporary directory. Each sample writes into a writer of
/// its own, dropped unfinished (its file removed), so the file does not grow over the run.
fn frame_writers(c: &mut Criterion) {
    let s = strands(1_000, 30);
    let counts: Vec<u32> = s.iter().map(|p| p.len() as u32).collect();
    let dir = std::env::temp_dir().join(format!("hair-io-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    // Points that move each frame, with digits to print (not the short values of the rest pose).
    let frame = |f: u64| {
        let sway = 1.0 + f as f32 * 1e-3;
        s.points
            .iter()
            .map(move |p| [p[0] * sway + 0.123_456_7, p[1] * sway, p[2] + 0.987_654_3])
    };
    let mut g = c.benchmark_group("frame_writers");
    g.sample_size(20);
    g.throughput(Throughput::Elements(s.points.len() as u64));
    g.bench_function("usda_frame_30k_points", |b| {
        b.iter_custom(|iters| {
            let path = dir.join("bench.usda");
            let mut w = UsdaWriter::create(
                &path,
                &UsdStage::default(),
                None,
                &counts,
                &[1e-3],
                Existing::Replace,
            )
            .expect("writer");
            let start = Instant::now();
            for f in 0..iters {
                w.write_frame(f as f64, black_box(frame(f))).expect("frame");
            }
            start.elapsed()
        })
    });
    g.bench_function("npy_frame_30k_points", |b| {
        b.iter_custom(|iters| {
            let path = dir.join("bench.npy");
            let mut w = NpyPointsWriter::create(&path, &counts, Existing::Replace).expect("writer");
            let start = Instant::now();
            for f in 0..iters {
                w.write_frame(black_box(frame(f))).expect("frame");
            }
            start.elapsed()
        })
    });
    g.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, formats, frame_writers);
criterion_main!(benches);
