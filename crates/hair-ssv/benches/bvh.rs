//! Criterion benches of the BVH (build, contacts, closest, batches) and the collision tables on
//! the 53,000-triangle head-and-shoulders mesh.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hair_ssv::head::{head_and_shoulders, head_and_shoulders_body};
use hair_ssv::test_meshes::SplitMix;
use hair_ssv::{Bvh, Lss, Pss, Ssv, SurfaceMap, Vector};

fn bvh(c: &mut Criterion) {
    let (v, t) = head_and_shoulders(96);
    let bvh = Bvh::new(&v, &t).expect("valid mesh");
    let mut rng = SplitMix::new(9);
    let segs: Vec<Ssv> = (0..512)
        .map(|_| {
            let off = rng.range(-0.003, 0.006);
            let (p, _) = rng.surface_point(bvh.triangles(), off);
            let d = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            Ssv::Line(Lss::new(p, p + d.normalize() * 0.015, 0.002))
        })
        .collect();
    let pts: Vec<Ssv> = (0..512)
        .map(|_| {
            let off = rng.range(-0.005, 0.01);
            Ssv::Point(Pss::new(rng.surface_point(bvh.triangles(), off).0, 0.0))
        })
        .collect();
    // The band a body's distance field samples: 0 to 40 mm off the surface.
    let band: Vec<Ssv> = (0..512)
        .map(|_| {
            let off = rng.range(0.0, 0.04);
            Ssv::Point(Pss::new(rng.surface_point(bvh.triangles(), off).0, 0.0))
        })
        .collect();
    let body = head_and_shoulders_body(&bvh, 64).expect("maps");

    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.bench_function("build_50k", |b| {
        b.iter(|| black_box(Bvh::new(&v, &t).expect("valid")))
    });
    g.sample_size(30);
    g.throughput(Throughput::Elements(segs.len() as u64));
    let mut out = Vec::with_capacity(256);
    g.bench_function("lss_contacts", |b| {
        b.iter(|| {
            for s in black_box(&segs) {
                out.clear();
                bvh.contacts(s, 0.0, &mut out);
            }
            black_box(out.len())
        })
    });
    g.bench_function("lss_contacts_batch_parallel", |b| {
        b.iter(|| black_box(bvh.contacts_batch(&segs, 0.0)))
    });
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("point_closest", |b| {
        b.iter(|| {
            for s in black_box(&pts) {
                black_box(bvh.closest(s));
            }
        })
    });
    g.bench_function("point_closest_band", |b| {
        b.iter(|| {
            for s in black_box(&band) {
                black_box(bvh.closest(s));
            }
        })
    });
    let ps: Vec<_> = pts.iter().map(|s| s.center()).collect();
    g.bench_function("body_map_lookup", |b| {
        b.iter(|| {
            for p in black_box(&ps) {
                black_box(body.lookup(p));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bvh);
criterion_main!(benches);
