//! `hair bench ssv`: the swept-sphere-volume kernels, LSS-mesh contacts, point-mesh distances
//! and the collision tables of `hair-ssv`, each measured beside parry3d in the same run,
//! single-threaded.
//!
//! Errors are measured against f64 references (parry3d-f64 on the cores, whose distances are
//! exact projections or converge far below the f32 answers), so `max_abs_err` is the error of
//! our f32 answer in metres.

use std::hint::black_box;
use std::time::Instant;

use hair::ssv::head::{head_and_shoulders, head_and_shoulders_body, inside_neck};
use hair::ssv::{
    Bvh, Lss, MeshContact, Point, Pss, Real, Rss, Ssv, SurfaceMap, Vector, distance_lss_lss,
    distance_lss_lss_batch, distance_rss_rss,
};
use hair_ssv::test_meshes::SplitMix;

/// Arguments of `hair bench ssv`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Seconds spent on each side of each measurement (split over alternating rounds).
    #[arg(long, default_value_t = 0.6)]
    pub seconds: f64,
    /// Mesh resolution: 94 gives about 51,000 triangles.
    #[arg(long, default_value_t = 94)]
    pub resolution: usize,
    /// Samples per axis of each collision table.
    #[arg(long, default_value_t = 64)]
    pub map_samples: usize,
}

/// One measurement beside its peer.
#[derive(Debug, Clone, serde::Serialize)]
struct Entry {
    ours_per_s: f64,
    peer_per_s: f64,
    ratio: f64,
    max_abs_err: f64,
    peer_max_abs_err: f64,
    #[serde(flatten)]
    extra: serde_json::Map<String, serde_json::Value>,
}

impl Entry {
    /// Our rate beside the peer's, their ratio, both errors and the row's own fields.
    fn new(
        ours: f64,
        peer: f64,
        err: f64,
        peer_err: f64,
        extra: serde_json::Map<String, serde_json::Value>,
    ) -> Self {
        Self {
            ours_per_s: ours,
            peer_per_s: peer,
            ratio: ours / peer,
            max_abs_err: err,
            peer_max_abs_err: peer_err,
            extra,
        }
    }
}

/// Queries per second of `f` (which runs `n` queries per call), best of alternating rounds.
fn rate(n: usize, seconds: f64, mut f: impl FnMut()) -> f64 {
    let start = Instant::now();
    let mut calls = 0u64;
    while calls == 0 || start.elapsed().as_secs_f64() < seconds {
        f();
        calls += 1;
    }
    (calls as f64 * n as f64) / start.elapsed().as_secs_f64()
}

/// Runs `ours` and `peer` in alternating rounds and keeps each one's best rate.
fn measure(
    n_ours: usize,
    n_peer: usize,
    seconds: f64,
    mut ours: impl FnMut(),
    mut peer: impl FnMut(),
) -> (f64, f64) {
    let rounds = 4;
    let (mut best_ours, mut best_peer) = (0.0f64, 0.0f64);
    for _ in 0..rounds {
        best_ours = best_ours.max(rate(n_ours, seconds / rounds as f64, &mut ours));
        best_peer = best_peer.max(rate(n_peer, seconds / rounds as f64, &mut peer));
    }
    (best_ours, best_peer)
}

fn v32(p: &Point) -> parry3d::math::Vec3 {
    parry3d::math::Vec3::new(p.x, p.y, p.z)
}

fn v64(p: &Point) -> parry3d_f64::math::Vec3 {
    parry3d_f64::math::Vec3::new(p.x as f64, p.y as f64, p.z as f64)
}

fn d64(v: &Vector) -> parry3d_f64::math::Vec3 {
    parry3d_f64::math::Vec3::new(v.x as f64, v.y as f64, v.z as f64)
}

/// Random LSS pairs of hair scale: 0.3 m box, lengths up to 5 cm, radii up to 5 mm, the second
/// near the first. One in eight pairs is parallel, one in sixteen has a zero-length segment.
fn lss_pairs(rng: &mut SplitMix, n: usize) -> Vec<(Lss, Lss)> {
    (0..n)
        .map(|i| {
            let a0 = rng.point_near(&Point::origin(), 0.15);
            let a1 = rng.point_near(&a0, 0.025);
            let b0 = rng.point_near(&a0, 0.03);
            let b1 = match i % 16 {
                0 => b0,
                1 | 9 => b0 + (a1 - a0) * rng.range(-1.5, 1.5),
                _ => rng.point_near(&b0, 0.025),
            };
            (
                Lss::new(a0, a1, rng.range(0.0, 0.005)),
                Lss::new(b0, b1, rng.range(0.0, 0.005)),
            )
        })
        .collect()
}

fn random_axes(rng: &mut SplitMix) -> [Vector; 2] {
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

/// Random RSS pairs (hair strips: up to 4 x 2 cm, radius up to 3 mm) near each other.
fn rss_pairs(rng: &mut SplitMix, n: usize) -> Vec<(Rss, Rss)> {
    (0..n)
        .map(|_| {
            let o = rng.point_near(&Point::origin(), 0.15);
            let a = Rss::new(
                o,
                random_axes(rng),
                [rng.range(0.005, 0.04), rng.range(0.002, 0.02)],
                rng.range(0.0, 0.003),
            );
            let o2 = rng.point_near(&a.center(), 0.04);
            let b = Rss::new(
                o2,
                random_axes(rng),
                [rng.range(0.005, 0.04), rng.range(0.002, 0.02)],
                rng.range(0.0, 0.003),
            );
            (a, b)
        })
        .collect()
}

fn rss_pose32(r: &Rss) -> (parry3d::math::Pose, parry3d::shape::Cuboid) {
    use parry3d::math::{Mat3, Pose, Rot3, Vec3};
    let u = Vec3::new(r.axes[0].x, r.axes[0].y, r.axes[0].z).normalize();
    let v = Vec3::new(r.axes[1].x, r.axes[1].y, r.axes[1].z);
    let v = (v - u * u.dot(v)).normalize();
    let rot = Rot3::from_mat3(&Mat3::from_cols(u, v, u.cross(v)));
    let half = Vec3::new(r.extents[0] * 0.5, r.extents[1] * 0.5, 0.0);
    let c = v32(&r.center());
    (Pose::from_parts(c, rot), parry3d::shape::Cuboid::new(half))
}

fn rss_pose64(r: &Rss) -> (parry3d_f64::math::Pose, parry3d_f64::shape::Cuboid) {
    use parry3d_f64::math::{Mat3, Pose, Rot3, Vec3};
    let u = d64(&r.axes[0]).normalize();
    let v = (d64(&r.axes[1]) - u * u.dot(d64(&r.axes[1]))).normalize();
    let rot = Rot3::from_mat3(&Mat3::from_cols(u, v, u.cross(v)));
    let half = Vec3::new(r.extents[0] as f64 * 0.5, r.extents[1] as f64 * 0.5, 0.0);
    (
        Pose::from_parts(v64(&r.center()), rot),
        parry3d_f64::shape::Cuboid::new(half),
    )
}

fn bench_lss_lss(args: &Args, rng: &mut SplitMix) -> anyhow::Result<Entry> {
    use parry3d::shape::Capsule;
    let pairs = lss_pairs(rng, 4096);
    let caps: Vec<(Capsule, Capsule)> = pairs
        .iter()
        .map(|(a, b)| {
            (
                Capsule::new(v32(&a.a), v32(&a.b), a.radius),
                Capsule::new(v32(&b.a), v32(&b.b), b.radius),
            )
        })
        .collect();
    let id = parry3d::math::Pose::IDENTITY;
    let mut out = vec![0.0; pairs.len()];
    // ours: the batched kernel (eight pairs per SIMD-friendly block); the scalar per-pair call
    // is measured too and reported as `ours_scalar_per_s`
    let (ours, peer) = measure(
        pairs.len(),
        caps.len(),
        args.seconds,
        || {
            distance_lss_lss_batch(black_box(&pairs), &mut out);
            black_box(&out);
        },
        || {
            let mut s = 0.0;
            for (a, b) in black_box(&caps) {
                s += parry3d::query::distance(&id, a, &id, b)
                    .map(|d| d.distance)
                    .unwrap_or(0.0);
            }
            black_box(s);
        },
    );
    let scalar = rate(pairs.len(), args.seconds / 2.0, || {
        let mut s = 0.0;
        for (a, b) in black_box(&pairs) {
            s += distance_lss_lss(a, b);
        }
        black_box(s);
    });
    distance_lss_lss_batch(&pairs, &mut out);
    // errors against the f64 core distance minus the radii (clamped at zero like parry's)
    let (mut err, mut peer_err) = (0.0f64, 0.0f64);
    let id64 = parry3d_f64::math::Pose::IDENTITY;
    for ((a, b), (ca, cb)) in pairs.iter().zip(&caps) {
        let sa = parry3d_f64::shape::Segment::new(v64(&a.a), v64(&a.b));
        let sb = parry3d_f64::shape::Segment::new(v64(&b.a), v64(&b.b));
        let core = parry3d_f64::query::distance(&id64, &sa, &id64, &sb)?.distance;
        let exact = core - a.radius as f64 - b.radius as f64;
        err = err.max((distance_lss_lss(a, b) as f64 - exact).abs());
        let theirs = parry3d::query::distance(&id, ca, &id, cb)?.distance as f64;
        peer_err = peer_err.max((theirs - exact.max(0.0)).abs());
    }
    // the batched answers, against the same reference
    for ((a, b), d) in pairs.iter().zip(&out) {
        let sa = parry3d_f64::shape::Segment::new(v64(&a.a), v64(&a.b));
        let sb = parry3d_f64::shape::Segment::new(v64(&b.a), v64(&b.b));
        let core = parry3d_f64::query::distance(&id64, &sa, &id64, &sb)?.distance;
        err = err.max((*d as f64 - (core - a.radius as f64 - b.radius as f64)).abs());
    }
    let mut extra = serde_json::Map::new();
    extra.insert("ours_scalar_per_s".into(), scalar.into());
    extra.insert("scalar_ratio".into(), (scalar / peer).into());
    Ok(Entry::new(ours, peer, err, peer_err, extra))
}

fn bench_rss_rss(args: &Args, rng: &mut SplitMix) -> anyhow::Result<Entry> {
    use parry3d::shape::{RoundCuboid, RoundShape};
    let pairs = rss_pairs(rng, 4096);
    let shapes: Vec<_> = pairs
        .iter()
        .map(|(a, b)| {
            let (pa, ca) = rss_pose32(a);
            let (pb, cb) = rss_pose32(b);
            let ra: RoundCuboid = RoundShape {
                inner_shape: ca,
                border_radius: a.radius,
            };
            let rb: RoundCuboid = RoundShape {
                inner_shape: cb,
                border_radius: b.radius,
            };
            (pa, ra, pb, rb)
        })
        .collect();
    let (ours, peer) = measure(
        pairs.len(),
        shapes.len(),
        args.seconds,
        || {
            let mut s = 0.0;
            for (a, b) in black_box(&pairs) {
                s += distance_rss_rss(a, b);
            }
            black_box(s);
        },
        || {
            let mut s = 0.0;
            for (pa, a, pb, b) in black_box(&shapes) {
                s += parry3d::query::distance(pa, a, pb, b)
                    .map(|d| d.distance)
                    .unwrap_or(0.0);
            }
            black_box(s);
        },
    );
    let (mut err, mut peer_err) = (0.0f64, 0.0f64);
    for ((a, b), (pa, sa, pb, sb)) in pairs.iter().zip(&shapes) {
        let (qa, ca) = rss_pose64(a);
        let (qb, cb) = rss_pose64(b);
        let core = parry3d_f64::query::distance(&qa, &ca, &qb, &cb)?.distance;
        let exact = core - a.radius as f64 - b.radius as f64;
        err = err.max((distance_rss_rss(a, b) as f64 - exact).abs());
        let theirs = parry3d::query::distance(pa, sa, pb, sb)?.distance as f64;
        peer_err = peer_err.max((theirs - exact.max(0.0)).abs());
    }
    Ok(Entry::new(ours, peer, err, peer_err, Default::default()))
}

/// Hair segments near the scalp: a surface point moved by -3..+6 mm along the normal, 1-2 cm
/// long, radius 2 mm.
fn scalp_segments(rng: &mut SplitMix, bvh: &Bvh, n: usize) -> Vec<Lss> {
    (0..n)
        .map(|_| {
            let off = rng.range(-0.003, 0.006);
            let (p, _) = rng.surface_point(bvh.triangles(), off);
            let dir = Vector::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
            .try_normalize(1e-3)
            .unwrap_or_else(Vector::y);
            Lss::new(p, p + dir * rng.range(0.01, 0.02), 0.002)
        })
        .collect()
}

/// parry's side: the TriMesh BVH's AABB query, then for each candidate triangle the capsule's
/// distance (GJK) and, when it is not positive, the contact (depth, normal, points) as ours
/// reports. (parry's `contact` alone was seen to report contacts up to 1 cm away here.)
fn peer_contacts(mesh: &parry3d::shape::TriMesh, c: &parry3d::shape::Capsule, out: &mut Vec<u32>) {
    let id = parry3d::math::Pose::IDENTITY;
    let aabb = c.aabb(&id);
    for t in mesh.bvh().intersect_aabb(&aabb) {
        let tri = mesh.triangle(t);
        if let Ok(d) = parry3d::query::distance(&id, c, &id, &tri)
            && d.distance <= 0.0
            && let Ok(Some(_)) = parry3d::query::contact(&id, c, &id, &tri, 0.0)
        {
            out.push(t);
        }
    }
}

fn bench_lss_mesh(
    args: &Args,
    rng: &mut SplitMix,
    bvh: &Bvh,
    mesh: &parry3d::shape::TriMesh,
) -> anyhow::Result<Entry> {
    use parry3d::shape::Capsule;
    let lss = scalp_segments(rng, bvh, 2048);
    let ssvs: Vec<Ssv> = lss.iter().map(|l| Ssv::Line(*l)).collect();
    let caps: Vec<Capsule> = lss
        .iter()
        .map(|l| Capsule::new(v32(&l.a), v32(&l.b), l.radius))
        .collect();
    let mut out: Vec<MeshContact> = Vec::with_capacity(1024);
    let mut peer_out: Vec<u32> = Vec::with_capacity(1024);
    let (ours, peer) = measure(
        ssvs.len(),
        caps.len(),
        args.seconds,
        || {
            let mut total = 0;
            for s in black_box(&ssvs) {
                out.clear();
                bvh.contacts(s, 0.0, &mut out);
                total += out.len();
            }
            black_box(total);
        },
        || {
            let mut total = 0;
            for c in black_box(&caps) {
                peer_out.clear();
                peer_contacts(mesh, c, &mut peer_out);
                total += peer_out.len();
            }
            black_box(total);
        },
    );
    // same contacts? differences only count when the f64 distance is not on the boundary
    let (mut contacts, mut peer_contacts_n, mut mismatched, mut boundary) =
        (0usize, 0usize, 0usize, 0usize);
    let (mut err, mut peer_err) = (0.0f64, 0.0f64);
    let id64 = parry3d_f64::math::Pose::IDENTITY;
    let exact_depth = |l: &Lss, t: u32| -> anyhow::Result<f64> {
        let tri = bvh
            .triangle(t as usize)
            .ok_or_else(|| anyhow::anyhow!("triangle {t}"))?;
        let seg = parry3d_f64::shape::Segment::new(v64(&l.a), v64(&l.b));
        let tri = parry3d_f64::shape::Triangle::new(v64(&tri[0]), v64(&tri[1]), v64(&tri[2]));
        Ok(l.radius as f64 - parry3d_f64::query::distance(&id64, &seg, &id64, &tri)?.distance)
    };
    for (l, c) in lss.iter().zip(&caps) {
        out.clear();
        bvh.contacts(&Ssv::Line(*l), 0.0, &mut out);
        peer_out.clear();
        peer_contacts(mesh, c, &mut peer_out);
        peer_out.sort_unstable();
        contacts += out.len();
        peer_contacts_n += peer_out.len();
        let ours_ids: Vec<u32> = out.iter().map(|m| m.triangle).collect();
        for &t in ours_ids
            .iter()
            .filter(|t| peer_out.binary_search(t).is_err())
            .chain(
                peer_out
                    .iter()
                    .filter(|t| ours_ids.binary_search(t).is_err()),
            )
        {
            if exact_depth(l, t)?.abs() <= 1e-5 {
                boundary += 1
            } else {
                mismatched += 1
            }
        }
        for m in &out {
            err = err.max((m.contact.depth as f64 - exact_depth(l, m.triangle)?).abs());
        }
        let id = parry3d::math::Pose::IDENTITY;
        for &t in &peer_out {
            if let Ok(Some(pc)) = parry3d::query::contact(&id, c, &id, &mesh.triangle(t), 0.0) {
                peer_err = peer_err.max((-pc.dist as f64 - exact_depth(l, t)?).abs());
            }
        }
    }
    let mut extra = serde_json::Map::new();
    extra.insert("triangles".into(), bvh.triangle_count().into());
    extra.insert("queries".into(), lss.len().into());
    extra.insert("contacts".into(), contacts.into());
    extra.insert("peer_contacts".into(), peer_contacts_n.into());
    extra.insert("mismatched".into(), mismatched.into());
    extra.insert("boundary_differences".into(), boundary.into());
    Ok(Entry::new(ours, peer, err, peer_err, extra))
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// The sum of the exact distances from `pss` to the mesh: one pass of our point query.
fn exact_distance_sum(bvh: &Bvh, pss: &[Ssv]) -> Real {
    pss.iter()
        .map(|q| bvh.closest(q).map_or(0.0, |m| m.distance))
        .sum()
}

/// Points 0 to 40 mm off the surface (the band a body's distance field samples): our point
/// query ([`Bvh::closest`] with a PSS) against parry3d's `TriMesh` point projection, both in f32;
/// errors against parry3d-f64's projection onto the same mesh.
fn bench_pss_mesh(
    args: &Args,
    rng: &mut SplitMix,
    bvh: &Bvh,
    mesh: &parry3d::shape::TriMesh,
    vertices: &[Point],
    triangles: &[[u32; 3]],
) -> anyhow::Result<Entry> {
    use parry3d::query::PointQuery;
    let pts: Vec<Point> = (0..4096)
        .map(|_| {
            let off = rng.range(0.0, 0.04);
            rng.surface_point(bvh.triangles(), off).0
        })
        .collect();
    let pss: Vec<Ssv> = pts.iter().map(|p| Ssv::Point(Pss::new(*p, 0.0))).collect();
    let peer_pts: Vec<parry3d::math::Vec3> = pts.iter().map(v32).collect();
    let (ours, peer) = measure(
        pss.len(),
        peer_pts.len(),
        args.seconds,
        || {
            black_box(exact_distance_sum(bvh, black_box(&pss)));
        },
        || {
            let mut s = 0.0;
            for p in black_box(&peer_pts) {
                s += mesh.distance_to_local_point(*p, false);
            }
            black_box(s);
        },
    );
    let mesh64 =
        parry3d_f64::shape::TriMesh::new(vertices.iter().map(v64).collect(), triangles.to_vec())
            .map_err(|e| anyhow::anyhow!("parry TriMesh (f64): {e:?}"))?;
    let (mut err, mut peer_err) = (0.0f64, 0.0f64);
    for ((p, q), pp) in pts.iter().zip(&pss).zip(&peer_pts) {
        let exact = parry3d_f64::query::PointQuery::distance_to_local_point(&mesh64, v64(p), false);
        let m = bvh
            .closest(q)
            .ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
        err = err.max((f64::from(m.distance) - exact).abs());
        peer_err =
            peer_err.max((f64::from(mesh.distance_to_local_point(*pp, false)) - exact).abs());
    }
    let mut extra = serde_json::Map::new();
    extra.insert("triangles".into(), bvh.triangle_count().into());
    extra.insert("queries".into(), pts.len().into());
    extra.insert("offset_mm".into(), serde_json::json!([0.0, 40.0]));
    Ok(Entry::new(ours, peer, err, peer_err, extra))
}

fn bench_cylinder_map(args: &Args, rng: &mut SplitMix, bvh: &Bvh) -> anyhow::Result<Entry> {
    let t0 = Instant::now();
    let body = head_and_shoulders_body(bvh, args.map_samples)?;
    let map_build_ms = t0.elapsed().as_secs_f64() * 1e3;
    // points from 5 mm inside to 1 cm outside the surface that some part covers (not in the
    // neck tube, where the merged mesh keeps interior fragments)
    let mut pts = Vec::with_capacity(4096);
    while pts.len() < 4096 {
        let off = rng.range(-0.005, 0.01);
        let (p, _) = rng.surface_point(bvh.triangles(), off);
        if !inside_neck(&p) && body.lookup(&p).is_some() {
            pts.push(p);
        }
    }
    let pss: Vec<Ssv> = pts.iter().map(|p| Ssv::Point(Pss::new(*p, 0.0))).collect();
    let (ours, peer) = measure(
        pts.len(),
        pss.len(),
        args.seconds,
        || {
            let mut s = 0.0;
            for p in black_box(&pts) {
                s += body.lookup(p).map_or(0.0, |m| m.distance);
            }
            black_box(s);
        },
        || {
            black_box(exact_distance_sum(bvh, black_box(&pss)));
        },
    );
    // the map's signed distance against the exact one (sign from the closest face's normal)
    let mut errs = Vec::with_capacity(pts.len());
    let mut per_part = vec![Vec::new(); body.parts.len()];
    let mut inside_disagree = 0usize;
    for (p, q) in pts.iter().zip(&pss) {
        let (part, m) = body
            .lookup_part(p)
            .ok_or_else(|| anyhow::anyhow!("uncovered point"))?;
        let exact = bvh
            .closest(q)
            .ok_or_else(|| anyhow::anyhow!("empty mesh"))?;
        let tri = bvh
            .triangle(exact.triangle as usize)
            .ok_or_else(|| anyhow::anyhow!("triangle"))?;
        let n = (tri[1] - tri[0]).cross(&(tri[2] - tri[0]));
        let sign: Real = if (p - exact.closest.on_b).dot(&n) < 0.0 {
            -1.0
        } else {
            1.0
        };
        let signed = sign * exact.distance;
        let e = (m.distance - signed).abs() as f64;
        errs.push(e);
        per_part[part].push(e);
        if (m.inside != (signed < 0.0)) && signed.abs() > 1e-3 {
            inside_disagree += 1;
        }
    }
    errs.sort_by(f64::total_cmp);
    let mean = errs.iter().sum::<f64>() / errs.len() as f64;
    let mut extra = serde_json::Map::new();
    extra.insert("points".into(), pts.len().into());
    extra.insert("err_mean_mm".into(), (mean * 1e3).into());
    extra.insert("err_p95_mm".into(), (percentile(&errs, 0.95) * 1e3).into());
    extra.insert("err_max_mm".into(), (percentile(&errs, 1.0) * 1e3).into());
    extra.insert(
        "inside_disagreements_beyond_1mm".into(),
        inside_disagree.into(),
    );
    extra.insert("map_build_ms".into(), map_build_ms.into());
    extra.insert("samples_per_axis".into(), args.map_samples.into());
    let mut parts = serde_json::Map::new();
    for (part, mut e) in body.parts.iter().zip(per_part) {
        e.sort_by(f64::total_cmp);
        let m = if e.is_empty() {
            0.0
        } else {
            e.iter().sum::<f64>() / e.len() as f64
        };
        parts.insert(
            part.name.clone(),
            serde_json::json!({ "points": e.len(), "mean_mm": m * 1e3, "p95_mm": percentile(&e, 0.95) * 1e3, "max_mm": percentile(&e, 1.0) * 1e3 }),
        );
    }
    extra.insert("parts".into(), parts.into());
    let max = percentile(&errs, 1.0);
    Ok(Entry::new(ours, peer, max, 0.0, extra))
}

/// Runs the suite.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut rng = SplitMix::new(0x05ee_d55f);
    let (vertices, triangles) = head_and_shoulders(args.resolution);
    let t0 = Instant::now();
    let bvh = Bvh::new(&vertices, &triangles)?;
    let bvh_build_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t0 = Instant::now();
    let mesh = parry3d::shape::TriMesh::new(vertices.iter().map(v32).collect(), triangles.clone())
        .map_err(|e| anyhow::anyhow!("parry TriMesh: {e:?}"))?;
    let peer_build_ms = t0.elapsed().as_secs_f64() * 1e3;

    let lss_lss = bench_lss_lss(&args, &mut rng)?;
    let rss_rss = bench_rss_rss(&args, &mut rng)?;
    let lss_mesh = bench_lss_mesh(&args, &mut rng, &bvh, &mesh)?;
    let pss_mesh = bench_pss_mesh(&args, &mut rng, &bvh, &mesh, &vertices, &triangles)?;
    let cylinder_map = bench_cylinder_map(&args, &mut rng, &bvh)?;

    let report = serde_json::json!({
        "lss_lss": lss_lss,
        "rss_rss": rss_rss,
        "lss_mesh": lss_mesh,
        "pss_mesh": pss_mesh,
        "cylinder_map": cylinder_map,
        "bvh_build_ms": bvh_build_ms,
        "peer_trimesh_build_ms": peer_build_ms,
        "triangles": bvh.triangle_count(),
        "threads": 1,
    });
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!("{}", serde_json::to_string_pretty(&report)?);
    }
    Ok(())
}
