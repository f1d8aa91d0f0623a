//! Rendered strands that follow guides: each follower is a barycentric combination of the three
//! guides nearest its root (as Unreal's groom and Hsu et al. 2024 interpolate), offset so its
//! root sits on its own root, the offset turning with the guides' transport frames.
//!
//! Guides are polylines of `per` control points (point `k` of every guide at the same arc-length
//! fraction, as resampled grooms are). Follower point `k` is
//! `sum_i w_i g_i[k] + (sum_i w_i T_i[k]) d`, where `d` is the follower's rest root minus the
//! weighted rest roots and `T_i[k]` turns guide `i`'s rest frame at `k` into its current frame.
//! A cut guide has fewer live points; a follower keeps `round(sum_i w_i live_i)` of its points.

use crate::follow::{RenderGeometry, catmull_rom_into, transport_frames_into};
use crate::{Point, Real, Vector};
use nalgebra::Matrix3;
use rayon::prelude::*;

/// One follower: its three guides, their weights (non-negative, summing to one) and its root at
/// rest.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Link {
    /// The guides it follows.
    pub guides: [u32; 3],
    /// Their weights.
    pub weights: [Real; 3],
    /// Its root at rest (same frame as the guides' rest points).
    pub root: Point,
}

/// A deterministic 64-bit mix (SplitMix64's finaliser).
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A uniform number in `[0, 1)` from 24 bits of `z`.
fn unit(z: u64) -> Real {
    (z >> 40) as Real / (1u64 << 24) as Real
}

/// The three roots nearest `p` (fewer roots repeat the last), nearest first; ties go to the
/// lower index.
fn nearest3(roots: &[Point], p: &Point, skip: Option<usize>) -> [u32; 3] {
    let mut best = [(Real::INFINITY, u32::MAX); 3];
    for (i, r) in roots.iter().enumerate() {
        if Some(i) == skip {
            continue;
        }
        let d = (r - p).norm_squared();
        let mut slot = (d, i as u32);
        for b in &mut best {
            if slot.0 < b.0 {
                std::mem::swap(b, &mut slot);
            }
        }
    }
    let first = if best[0].1 == u32::MAX { 0 } else { best[0].1 };
    let mut out = [first; 3];
    for k in 1..3 {
        out[k] = if best[k].1 == u32::MAX {
            out[k - 1]
        } else {
            best[k].1
        };
    }
    out
}

/// Barycentric weights of `p` projected onto the triangle `a b c`, negatives clamped to zero and
/// the rest normalised; inverse-distance weights when the triangle is degenerate.
fn weights(p: &Point, a: &Point, b: &Point, c: &Point) -> [Real; 3] {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let (d00, d01, d11) = (v0.dot(&v0), v0.dot(&v1), v1.dot(&v1));
    let (d20, d21) = (v2.dot(&v0), v2.dot(&v1));
    let den = d00 * d11 - d01 * d01;
    let w = if den > 1e-6 * (d00 * d11).max(Real::MIN_POSITIVE) {
        let v = (d11 * d20 - d01 * d21) / den;
        let w = (d00 * d21 - d01 * d20) / den;
        [1.0 - v - w, v, w]
    } else {
        [a, b, c].map(|q| 1.0 / ((q - p).norm() + 1e-6))
    };
    let w = w.map(|x| if x.is_finite() { x.max(0.0) } else { 0.0 });
    let sum: Real = w.iter().sum();
    if sum > 0.0 {
        w.map(|x| x / sum)
    } else {
        [1.0, 0.0, 0.0]
    }
}

/// `count` followers among guides rooted at `roots`, deterministic from `seed`: each root is a
/// uniform point of the triangle between a random guide's root and its two nearest neighbours
/// (on or just under the scalp between guide roots), and it follows the three guides nearest
/// it with their barycentric weights. Brute force: cost grows as `count * roots.len()`.
pub fn sample_links(roots: &[Point], count: usize, seed: u64) -> Vec<Link> {
    if roots.is_empty() {
        return Vec::new();
    }
    let n = roots.len();
    let neighbours: Vec<[u32; 3]> = (0..n)
        .into_par_iter()
        .map(|g| nearest3(roots, &roots[g], Some(g)))
        .collect();
    (0..count)
        .into_par_iter()
        .map(|i| {
            let z = mix(seed ^ mix(i as u64));
            let a = (z % n as u64) as usize;
            let (z1, z2) = (mix(z), mix(z ^ 0x5851_F42D_4C95_7F2D));
            let (mut u, mut v) = (unit(z1), unit(z2));
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let [b, c, _] = neighbours[a].map(|j| if (j as usize) < n { j as usize } else { a });
            let (ra, rb, rc) = (roots[a], roots[b], roots[c]);
            let root = ra + (rb - ra) * u + (rc - ra) * v;
            let guides = nearest3(roots, &root, None);
            let [pa, pb, pc] = guides.map(|j| roots[j as usize]);
            Link {
                guides,
                weights: weights(&root, &pa, &pb, &pc),
                root,
            }
        })
        .collect()
}

/// Followers of guides with their output polylines. Built once; an update allocates nothing.
#[derive(Clone, Debug)]
pub struct Followers {
    /// Control points per guide (and per follower).
    per: usize,
    links: Vec<Link>,
    /// Per follower, its rest root minus the weighted rest roots of its guides.
    offsets: Vec<Vector>,
    /// Per guide and control point, the transpose of its rest transport frame.
    rest_frames_t: Vec<Matrix3<Real>>,
    /// Per guide and control point: its current control point, frame, and the turn from rest.
    control: Vec<Point>,
    frames: Vec<Matrix3<Real>>,
    turn: Vec<Matrix3<Real>>,
    /// Per guide, its live control points; per follower, its own.
    live: Vec<u32>,
    follower_live: Vec<u32>,
    /// The output: follower `f` is strand `f`, then the fallen pieces the guides' output holds.
    pub geometry: RenderGeometry,
}

impl Followers {
    /// Followers `links` of the guides whose rest control points are `guide_rest` (`per` each),
    /// drawn with `subdivisions` points per segment. Links naming a guide that does not exist
    /// follow guide 0.
    pub fn new(guide_rest: &[Point], per: usize, links: Vec<Link>, subdivisions: usize) -> Self {
        let per = per.max(1);
        let n_guides = guide_rest.len() / per;
        let mut rest_frames_t = vec![Matrix3::identity(); n_guides * per];
        for (g, frames) in rest_frames_t.chunks_mut(per).enumerate() {
            transport_frames_into(
                &guide_rest[g * per..(g + 1) * per],
                &Matrix3::identity(),
                frames,
            );
            frames.iter_mut().for_each(|f| *f = f.transpose());
        }
        let links: Vec<Link> = links
            .into_iter()
            .map(|mut l| {
                l.guides = l
                    .guides
                    .map(|g| if (g as usize) < n_guides { g } else { 0 });
                l
            })
            .collect();
        let offsets = links
            .iter()
            .map(|l| {
                let blend = (0..3).fold(Vector::zeros(), |acc, i| {
                    let g = l.guides[i] as usize;
                    acc + guide_rest
                        .get(g * per)
                        .map_or(Vector::zeros(), |p| p.coords)
                        * l.weights[i]
                });
                l.root.coords - blend
            })
            .collect();
        Self {
            per,
            offsets,
            control: vec![Point::origin(); n_guides * per],
            frames: vec![Matrix3::identity(); n_guides * per],
            turn: vec![Matrix3::identity(); n_guides * per],
            live: vec![per as u32; n_guides],
            follower_live: vec![per as u32; links.len()],
            rest_frames_t,
            links,
            geometry: RenderGeometry {
                subdivisions,
                ..RenderGeometry::default()
            },
        }
    }

    /// The followers.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// Rebuilds every follower from the guides as drawn in `guides` (guide `g` is its strand
    /// `g`, its control points every `subdivisions`-th vertex; strands past the guides are
    /// fallen pieces, copied as they are). `rotation` is the guides' frame at their roots
    /// relative to rest: the head's rotation.
    pub fn update(&mut self, guides: &RenderGeometry, rotation: &Matrix3<Real>) {
        let per = self.per;
        let gsub = guides.subdivisions.max(1);
        let n_guides = self.live.len().min(guides.strand_count());
        let rotation = *rotation;
        let rest_t = &self.rest_frames_t;
        self.control
            .par_chunks_mut(per)
            .zip(self.frames.par_chunks_mut(per))
            .zip(self.turn.par_chunks_mut(per))
            .zip(self.live.par_iter_mut())
            .enumerate()
            .take(n_guides)
            .for_each(|(g, (((control, frames), turn), live))| {
                let poly = guides.strand(g);
                let n = if poly.is_empty() {
                    0
                } else {
                    ((poly.len() - 1) / gsub + 1).min(per)
                };
                for k in 0..n {
                    control[k] = poly[k * gsub];
                }
                *live = n as u32;
                transport_frames_into(&control[..n], &rotation, &mut frames[..n]);
                for k in 0..n {
                    turn[k] = frames[k] * rest_t[g * per + k];
                }
            });
        let sub = self.geometry.subdivisions.max(1);
        let verts = sub * (per - 1) + 1;
        let count = self.links.len();
        self.geometry.lay_out(count, verts);
        let (control, turn, live) = (&self.control, &self.turn, &self.live);
        let (links, offsets) = (&self.links, &self.offsets);
        self.geometry
            .positions
            .par_chunks_mut(verts)
            .zip(self.follower_live.par_iter_mut())
            .enumerate()
            .for_each(|(f, (out, own_live))| {
                let (l, d) = (&links[f], offsets[f]);
                let glive = l.guides.map(|g| live[g as usize].max(1) as usize);
                let mut n: Real = 0.0;
                for i in 0..3 {
                    n += l.weights[i] * glive[i] as Real;
                }
                let n = (n.round() as usize).clamp(1, per);
                *own_live = n as u32;
                let mut points = [Point::origin(); 64];
                let n = n.min(64);
                for k in 0..n {
                    let mut p = Vector::zeros();
                    let mut t = Matrix3::zeros();
                    for i in 0..3 {
                        let j = l.guides[i] as usize * per + k.min(glive[i] - 1);
                        p += control[j].coords * l.weights[i];
                        t += turn[j] * l.weights[i];
                    }
                    points[k] = Point::from(p + t * d);
                }
                catmull_rom_into(&points[..n], sub, out);
            });
        // Short followers (cut guides) keep their live vertices, packed.
        if self.follower_live.iter().any(|&n| n as usize != per) {
            let mut write = 0usize;
            for f in 0..count {
                let n = self.follower_live[f] as usize;
                let keep = if sub <= 1 || n < 2 {
                    n
                } else {
                    sub * (n - 1) + 1
                };
                let start = f * verts;
                self.geometry
                    .positions
                    .copy_within(start..start + keep, write);
                self.geometry.offsets[f] = write as u32;
                write += keep;
            }
            self.geometry.offsets[count] = write as u32;
            self.geometry.positions.truncate(write);
        }
        // The fallen pieces, as the guides' output draws them.
        for s in self.live.len()..guides.strand_count() {
            self.geometry.positions.extend_from_slice(guides.strand(s));
            let end = self.geometry.positions.len() as u32;
            self.geometry.offsets.push(end);
        }
    }
}
