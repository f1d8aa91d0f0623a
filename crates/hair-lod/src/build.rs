//! Building the hierarchy from a hairstyle: Ward & Lin 2003 §4.1 (strip and cluster
//! subdivision) and §4.2 (strand-group subdivision), with the per-region minimum group size of
//! §7.2.
//!
//! The scalp is parameterised by spherical angles about a sphere fitted to the roots, with the
//! pole along the mean direction hair leaves the scalp. Root strips tile it in rows (of
//! `root_strip_depth` arc length from the pole) and, within a row, in sectors about
//! `root_strip_width` wide. Each root strip's roots are then projected on the scalp's tangent
//! plane at the strip's centre: `u` across the strip, `v` down it. Every cross-section below
//! (strip widths, cluster and strand-group circles) lives in that plane.
//!
//! A root strip whose strands run apart (a crown whorl, a parting: neighbouring roots combed
//! opposite ways) is split into trees by the strands' directions first, until every tree's
//! strands run within [`MAX_STRAND_SPREAD_DEGREES`] of their mean (`split_divergent`). A
//! skeleton is the mean of its strands and each strand is drawn at its offset in the skeleton's
//! frames: strands that run apart average to a skeleton standing off the scalp that stands for
//! none of them, and when it turns under gravity their offsets, as long as the strands, swing
//! with it over the crown (issue 40's stray loops).

use crate::error::{finite_positive, ordered};
use crate::hierarchy::{Hierarchy, NO_PARENT, NodeKind};
use crate::{Hairstyle, LodError, Point, Real, Vector};
use nalgebra::{Matrix3, Matrix4, Rotation3, Vector3, Vector4};
use std::collections::BTreeMap;
use std::collections::VecDeque;

/// The minimum number of strands in a finest strand group.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MinGroup {
    /// The same everywhere (1: down to single strands).
    Uniform(u32),
    /// Per region, as Ward & Lin §7.2 do: `fine` for strands whose root direction points along
    /// `toward` (the parting and the face), `coarse` for those pointing away (the nape), linear in
    /// between in `(1 + cos angle) / 2`. A group splits only when every non-empty quadrant would
    /// hold at least its region's minimum (the mean of its strands' minima, rounded), so finest
    /// groups hold at least that many strands (or are root groups already smaller).
    Regional {
        /// Minimum where hair is most viewable (>= 1).
        fine: u32,
        /// Minimum where it is least viewable (>= `fine`).
        coarse: u32,
        /// Direction (head frame) of the most viewable hair, e.g. up and forward.
        toward: Vector,
    },
}

/// Thresholds of the hierarchy (SI units: metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HierarchyParams {
    /// Width across the scalp of a root strip (m).
    pub root_strip_width: Real,
    /// Extent of a row of root strips along the scalp, from the crown down (m).
    pub root_strip_depth: Real,
    /// Strips split in two until narrower than this (m); below `root_strip_width`.
    pub strip_width_min: Real,
    /// Clusters split into quadrants until their radius is under this (m); below
    /// `strip_width_min`.
    pub cluster_radius_min: Real,
    /// Where strand groups stop splitting.
    pub min_group: MinGroup,
}

impl Default for HierarchyParams {
    /// The thresholds tuned for [`crate::test_heads::ward_lin_head`] (9,350 strands on a 0.1 m
    /// head: about 110 root strips, 330 root clusters and 3,570 finest skeletons).
    fn default() -> Self {
        Self {
            root_strip_width: 0.0265,
            root_strip_depth: 0.026,
            strip_width_min: 0.013,
            cluster_radius_min: 0.010,
            min_group: MinGroup::Regional {
                fine: 1,
                coarse: 5,
                toward: Vector::new(0.0, 1.0, 1.0).normalize(),
            },
        }
    }
}

/// Thresholds of the hierarchy as a scene file gives them (Ward & Lin §4-5; SI units), for
/// [`HierarchyParams`]. The defaults suit a human head of about 0.1 m radius.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct HierarchySpec {
    /// Width across the scalp of a root strip (m).
    pub root_strip_width: f32,
    /// Extent of a row of root strips down the scalp (m).
    pub root_strip_depth: f32,
    /// Strips split in two until narrower than this (m).
    pub strip_width_min: f32,
    /// Clusters split into quadrants until their radius is under this (m).
    pub cluster_radius_min: f32,
    /// Fewest strands in a finest strand group where hair is most viewable (up and forward).
    pub min_group_fine: u32,
    /// Fewest strands in a finest strand group where hair is least viewable (the nape).
    pub min_group_coarse: u32,
}

impl Default for HierarchySpec {
    fn default() -> Self {
        let d = HierarchyParams::default();
        let (fine, coarse) = match d.min_group {
            MinGroup::Regional { fine, coarse, .. } => (fine, coarse),
            MinGroup::Uniform(n) => (n, n),
        };
        Self {
            root_strip_width: d.root_strip_width,
            root_strip_depth: d.root_strip_depth,
            strip_width_min: d.strip_width_min,
            cluster_radius_min: d.cluster_radius_min,
            min_group_fine: fine,
            min_group_coarse: coarse,
        }
    }
}

impl HierarchySpec {
    /// The hair-lod parameters; `toward` is up and forward in the head frame (+y up, face +z).
    pub fn params(&self) -> HierarchyParams {
        HierarchyParams {
            root_strip_width: self.root_strip_width,
            root_strip_depth: self.root_strip_depth,
            strip_width_min: self.strip_width_min,
            cluster_radius_min: self.cluster_radius_min,
            min_group: MinGroup::Regional {
                fine: self.min_group_fine,
                coarse: self.min_group_coarse,
                toward: Vector::new(0.0, 1.0, 1.0).normalize(),
            },
        }
    }
}

impl HierarchyParams {
    /// Checks every threshold and their order.
    pub fn validate(&self) -> Result<(), LodError> {
        finite_positive("root_strip_width", self.root_strip_width)?;
        finite_positive("root_strip_depth", self.root_strip_depth)?;
        finite_positive("strip_width_min", self.strip_width_min)?;
        finite_positive("cluster_radius_min", self.cluster_radius_min)?;
        ordered(
            "strip_width_min",
            self.strip_width_min,
            "root_strip_width",
            self.root_strip_width,
        )?;
        ordered(
            "cluster_radius_min",
            self.cluster_radius_min,
            "strip_width_min",
            self.strip_width_min,
        )?;
        match self.min_group {
            MinGroup::Uniform(m) => {
                if m == 0 {
                    return Err(LodError::InvalidParameter {
                        name: "min_group",
                        value: 0.0,
                        expected: ">= 1",
                    });
                }
            }
            MinGroup::Regional {
                fine,
                coarse,
                toward,
            } => {
                if fine == 0 {
                    return Err(LodError::InvalidParameter {
                        name: "min_group.fine",
                        value: 0.0,
                        expected: ">= 1",
                    });
                }
                if coarse < fine {
                    return Err(LodError::ThresholdOrder {
                        lower: "min_group.fine",
                        lower_value: f64::from(fine),
                        upper: "min_group.coarse",
                        upper_value: f64::from(coarse),
                    });
                }
                let n = toward.norm();
                if !(n.is_finite() && n > 0.0) {
                    return Err(LodError::InvalidParameter {
                        name: "min_group.toward",
                        value: f64::from(n),
                        expected: "a finite non-zero direction",
                    });
                }
            }
        }
        Ok(())
    }
}

/// Deepest level a tree may reach (a guard against degenerate input; never reached by sane
/// thresholds).
const MAX_LEVEL: u8 = 60;

struct Pending {
    lo: usize,
    hi: usize,
    kind: NodeKind,
    level: u8,
    parent: u32,
    /// Cross-section circle (clusters, strand groups) or unused (strips).
    cx: f64,
    cy: f64,
    r: f64,
}

impl Hierarchy {
    /// Builds the hierarchy of a hairstyle (Ward & Lin §4). Deterministic: the same input gives
    /// the same hierarchy, node for node.
    pub fn build(style: &Hairstyle, params: &HierarchyParams) -> Result<Self, LodError> {
        style.validate()?;
        params.validate()?;
        let n_strands = style.strands.len();
        if n_strands >= u32::MAX as usize {
            return Err(LodError::InvalidParameter {
                name: "strands",
                value: n_strands as f64,
                expected: "fewer than 2^32 - 1",
            });
        }
        let scalp = Scalp::fit(style);
        // Root strips: rows of polar angle, sectors of azimuth.
        let depth = f64::from(params.root_strip_depth);
        let width = f64::from(params.root_strip_width);
        let mut strips: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
        for (s, strand) in style.strands.iter().enumerate() {
            let (beta, alpha) = scalp.angles(&strand.root);
            let row = ((beta * scalp.radius / depth).floor().max(0.0)) as u32;
            let sectors = scalp.sectors(row, depth, width);
            let sector = (((alpha + core::f64::consts::PI) / core::f64::consts::TAU
                * f64::from(sectors))
            .floor() as i64)
                .clamp(0, i64::from(sectors) - 1) as u32;
            strips.entry((row, sector)).or_default().push(s as u32);
        }
        let min_group: Vec<u32> = style
            .strands
            .iter()
            .map(|st| match params.min_group {
                MinGroup::Uniform(m) => m,
                MinGroup::Regional {
                    fine,
                    coarse,
                    toward,
                } => {
                    let z = st.frame * Vector::z();
                    let t = f64::from((1.0 + z.dot(&toward.normalize())) * 0.5).clamp(0.0, 1.0);
                    (f64::from(coarse) + (f64::from(fine) - f64::from(coarse)) * t).round() as u32
                }
            })
            .collect();

        let mut h = Hierarchy {
            kind: Vec::new(),
            level: Vec::new(),
            parent: Vec::new(),
            first_child: Vec::new(),
            child_count: Vec::new(),
            strand_start: Vec::new(),
            strand_count: Vec::new(),
            size: Vec::new(),
            cp_start: vec![0],
            offsets: Vec::new(),
            tree: Vec::new(),
            tree_start: vec![0],
            frames: Vec::with_capacity(strips.len()),
            strand_order: Vec::with_capacity(n_strands),
            max_level: 0,
        };
        // Per-strand cross-section coordinates (set per tree).
        let mut uv = vec![(0.0f64, 0.0f64); n_strands];
        let mut rest_scratch: Vec<Vector3<f64>> = Vec::new();
        let mut parent_rest: Vec<Vec<Vector3<f64>>> = Vec::new();
        let mut resampled: Vec<Vector3<f64>> = Vec::new();
        let mut mec_scratch: Vec<(f64, f64)> = Vec::new();
        let mut slot_of = vec![0usize; n_strands];
        let chords: Vec<Vector3<f64>> = style.strands.iter().map(chord).collect();
        let mut trees: Vec<((u32, u32), Vec<u32>)> = Vec::with_capacity(strips.len());
        let mut parts = Vec::new();
        for (key, members) in strips {
            split_divergent(members, &chords, &mut parts);
            trees.extend(parts.drain(..).map(|m| (key, m)));
        }
        for ((row, sector), members) in trees {
            let tree = h.frames.len() as u32;
            let tree_first = h.kind.len() as u32;
            // Tangent plane at the strip's centre.
            let sectors = scalp.sectors(row, depth, width);
            let beta_c = ((f64::from(row) + 0.5) * depth / scalp.radius).min(core::f64::consts::PI);
            let alpha_c = -core::f64::consts::PI
                + (f64::from(sector) + 0.5) * core::f64::consts::TAU / f64::from(sectors);
            let (centre, across, down) = scalp.tangent(beta_c, alpha_c);
            for &s in &members {
                let d = to64(&style.strands[s as usize].root.coords) - centre;
                uv[s as usize] = (d.dot(&across), d.dot(&down));
            }
            // Tree frame: the mean of the strands' root frames.
            let mut z = Vector3::<f64>::zeros();
            let mut x = Vector3::<f64>::zeros();
            let mut cp_sum = 0usize;
            for &s in &members {
                let st = &style.strands[s as usize];
                z += to64(&(st.frame * Vector::z()));
                x += to64(&(st.frame * Vector::x()));
                cp_sum += st.points.len();
            }
            h.frames.push(mean_frame(z, x));
            let ncp = ((cp_sum as f64 / members.len() as f64).round() as usize).max(2);
            // Resampled strand points of this tree, strand-major in `members` order.
            let base = h.strand_order.len();
            resampled.clear();
            for &s in &members {
                slot_of[s as usize] = resampled.len();
                resample(&style.strands[s as usize].points, ncp, &mut resampled);
                h.strand_order.push(s);
            }
            let mut queue = VecDeque::new();
            queue.push_back(Pending {
                lo: base,
                hi: base + members.len(),
                kind: NodeKind::Strip,
                level: 0,
                parent: NO_PARENT,
                cx: 0.0,
                cy: 0.0,
                r: 0.0,
            });
            parent_rest.clear();
            while let Some(p) = queue.pop_front() {
                let id = h.kind.len() as u32;
                let count = p.hi - p.lo;
                // Rest skeleton: mean of the resampled strands.
                rest_scratch.clear();
                rest_scratch.resize(ncp, Vector3::zeros());
                for &s in &h.strand_order[p.lo..p.hi] {
                    let o = slot_of[s as usize];
                    for (r, q) in rest_scratch.iter_mut().zip(&resampled[o..o + ncp]) {
                        *r += q;
                    }
                }
                for r in rest_scratch.iter_mut() {
                    *r /= count as f64;
                }
                let local_id = (id - tree_first) as usize;
                if p.parent == NO_PARENT {
                    for r in &rest_scratch {
                        h.offsets
                            .push(Vector::new(r.x as Real, r.y as Real, r.z as Real));
                    }
                } else {
                    let pr = &parent_rest[(p.parent - tree_first) as usize];
                    for (r, q) in rest_scratch.iter().zip(pr) {
                        let d = r - q;
                        h.offsets
                            .push(Vector::new(d.x as Real, d.y as Real, d.z as Real));
                    }
                }
                debug_assert_eq!(parent_rest.len(), local_id);
                parent_rest.push(rest_scratch.clone());
                h.cp_start.push(h.offsets.len() as u32);
                h.kind.push(p.kind);
                h.level.push(p.level);
                h.parent.push(p.parent);
                h.strand_start.push(p.lo as u32);
                h.strand_count.push(count as u32);
                h.tree.push(tree);
                h.max_level = h.max_level.max(p.level);
                let next_level = p.level.saturating_add(1);
                let may_split = p.level < MAX_LEVEL;
                // Children, in order; each is (lo, hi, kind, circle).
                let mut kids: Vec<(usize, usize, NodeKind, f64, f64, f64)> = Vec::new();
                let size;
                match p.kind {
                    NodeKind::Strip => {
                        let (mut lo_u, mut hi_u) = (f64::INFINITY, f64::NEG_INFINITY);
                        for &s in &h.strand_order[p.lo..p.hi] {
                            lo_u = lo_u.min(uv[s as usize].0);
                            hi_u = hi_u.max(uv[s as usize].0);
                        }
                        let w = hi_u - lo_u;
                        size = w;
                        if may_split && count >= 2 && w >= f64::from(params.strip_width_min) {
                            let mid = 0.5 * (lo_u + hi_u);
                            h.strand_order[p.lo..p.hi].sort_by_key(|&s| uv[s as usize].0 >= mid);
                            let split = p.lo
                                + h.strand_order[p.lo..p.hi]
                                    .iter()
                                    .take_while(|&&s| uv[s as usize].0 < mid)
                                    .count();
                            kids.push((p.lo, split, NodeKind::Strip, 0.0, 0.0, 0.0));
                            kids.push((split, p.hi, NodeKind::Strip, 0.0, 0.0, 0.0));
                        } else {
                            let (cx, cy, r) =
                                min_circle(&h.strand_order[p.lo..p.hi], &uv, &mut mec_scratch);
                            kids.push((p.lo, p.hi, NodeKind::Cluster, cx, cy, r));
                        }
                    }
                    NodeKind::Cluster => {
                        size = p.r;
                        if may_split && count >= 2 && p.r >= f64::from(params.cluster_radius_min) {
                            let runs = quadrants(&mut h.strand_order[p.lo..p.hi], &uv, p.cx, p.cy);
                            let half = 0.5 * p.r;
                            for (q, a, b) in runs {
                                let sx = if q & 1 == 1 { half } else { -half };
                                let sy = if q & 2 == 2 { half } else { -half };
                                kids.push((
                                    p.lo + a,
                                    p.lo + b,
                                    NodeKind::Cluster,
                                    p.cx + sx,
                                    p.cy + sy,
                                    p.r * core::f64::consts::FRAC_1_SQRT_2,
                                ));
                            }
                        } else {
                            let (cx, cy, r) =
                                min_circle(&h.strand_order[p.lo..p.hi], &uv, &mut mec_scratch);
                            kids.push((p.lo, p.hi, NodeKind::StrandGroup, cx, cy, r));
                        }
                    }
                    NodeKind::StrandGroup => {
                        size = p.r;
                        let sum: u64 = h.strand_order[p.lo..p.hi]
                            .iter()
                            .map(|&s| u64::from(min_group[s as usize]))
                            .sum();
                        let min = ((sum as f64 / count as f64).round() as usize).max(1);
                        if may_split && count >= 2 * min {
                            let mut runs =
                                quadrants(&mut h.strand_order[p.lo..p.hi], &uv, p.cx, p.cy);
                            if runs.len() == 1 {
                                // Coincident roots: no quadrant separates them; halve the list.
                                runs = vec![(0, 0, count / 2), (1, count / 2, count)];
                            }
                            if runs.iter().any(|&(_, a, b)| b - a < min) {
                                // A child would fall under the region's minimum: stay a leaf.
                                runs.clear();
                            }
                            for (_, a, b) in runs {
                                let (cx, cy, r) = min_circle(
                                    &h.strand_order[p.lo + a..p.lo + b],
                                    &uv,
                                    &mut mec_scratch,
                                );
                                kids.push((p.lo + a, p.lo + b, NodeKind::StrandGroup, cx, cy, r));
                            }
                        }
                    }
                }
                h.size.push(size as Real);
                let first = h.kind.len() as u32 + queue.len() as u32;
                h.first_child.push(if kids.is_empty() { 0 } else { first });
                h.child_count.push(kids.len() as u8);
                for (lo, hi, kind, cx, cy, r) in kids {
                    queue.push_back(Pending {
                        lo,
                        hi,
                        kind,
                        level: next_level,
                        parent: id,
                        cx,
                        cy,
                        r,
                    });
                }
            }
            h.tree_start.push(h.kind.len() as u32);
        }
        h.shrink();
        Ok(h)
    }

    fn shrink(&mut self) {
        self.kind.shrink_to_fit();
        self.level.shrink_to_fit();
        self.parent.shrink_to_fit();
        self.first_child.shrink_to_fit();
        self.child_count.shrink_to_fit();
        self.strand_start.shrink_to_fit();
        self.strand_count.shrink_to_fit();
        self.size.shrink_to_fit();
        self.cp_start.shrink_to_fit();
        self.offsets.shrink_to_fit();
        self.tree.shrink_to_fit();
        self.tree_start.shrink_to_fit();
        self.frames.shrink_to_fit();
        self.strand_order.shrink_to_fit();
    }
}

fn to64(v: &Vector) -> Vector3<f64> {
    Vector3::new(f64::from(v.x), f64::from(v.y), f64::from(v.z))
}

/// Largest angle between a strand's chord (root to tip) and the mean chord of the strands of
/// its tree (degrees): a root strip spreading wider is split by `split_divergent`.
pub const MAX_STRAND_SPREAD_DEGREES: f64 = 30.0;

/// A strand's unit chord, root to tip; its root direction when it closes on itself.
fn chord(strand: &crate::Strand) -> Vector3<f64> {
    let (first, last) = (strand.points[0], strand.points[strand.points.len() - 1]);
    to64(&(last - first))
        .try_normalize(1e-12)
        .unwrap_or_else(|| to64(&(strand.frame * Vector::z())))
}

/// Splits `members` (strand indices, unit `chords`) into parts whose chords all lie within
/// [`MAX_STRAND_SPREAD_DEGREES`] of their part's mean, appended to `out`, each in `members`'
/// order. A part too wide is cut in two about its two most different chords (the one farthest
/// from the mean and the one farthest from that), each strand going with the nearer of them.
fn split_divergent(members: Vec<u32>, chords: &[Vector3<f64>], out: &mut Vec<Vec<u32>>) {
    let cos_max = MAX_STRAND_SPREAD_DEGREES.to_radians().cos();
    let mut stack = vec![members];
    while let Some(set) = stack.pop() {
        let sum: Vector3<f64> = set.iter().map(|&s| chords[s as usize]).sum();
        let Some(&first) = set.first() else {
            continue;
        };
        let mean = sum.try_normalize(1e-9).unwrap_or(chords[first as usize]);
        let farthest_from = |d: &Vector3<f64>| {
            set.iter()
                .copied()
                .min_by(|&a, &b| {
                    let (ca, cb) = (chords[a as usize].dot(d), chords[b as usize].dot(d));
                    ca.total_cmp(&cb)
                })
                .unwrap_or(first)
        };
        let far = farthest_from(&mean);
        if chords[far as usize].dot(&mean) >= cos_max {
            out.push(set);
            continue;
        }
        let a = chords[far as usize];
        let b = chords[farthest_from(&a) as usize];
        let (near_a, near_b): (Vec<u32>, Vec<u32>) = set
            .iter()
            .partition(|&&s| chords[s as usize].dot(&a) >= chords[s as usize].dot(&b));
        if near_a.is_empty() || near_b.is_empty() {
            out.push(set);
            continue;
        }
        // Popped last-in first: `near_a` is split (or kept) before `near_b`.
        stack.push(near_b);
        stack.push(near_a);
    }
}

/// A right-handed frame with z along `z` and x as close to `x` as possible.
fn mean_frame(z: Vector3<f64>, x: Vector3<f64>) -> Rotation3<Real> {
    let z = z.try_normalize(1e-12).unwrap_or_else(Vector3::z);
    let mut x = x - z * z.dot(&x);
    if x.norm() < 1e-9 {
        x = if z.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        x -= z * z.dot(&x);
    }
    let x = x.normalize();
    let y = z.cross(&x);
    let m = Matrix3::from_columns(&[x, y, z]).map(|c| c as Real);
    Rotation3::from_matrix_unchecked(m)
}

/// Appends `n` points at equal arc-length fractions along `points` (the points themselves when
/// the count already matches).
fn resample(points: &[Point], n: usize, out: &mut Vec<Vector3<f64>>) {
    if points.len() == n {
        out.extend(points.iter().map(|p| to64(&p.coords)));
    } else {
        let even = hair_dynamics::resample_polyline(points, n);
        out.extend(even.iter().map(|p| to64(&p.coords)));
    }
}

/// Sorts `ids` by quadrant about `(cx, cy)` (bit 0: `u >= cx`, bit 1: `v >= cy`) and returns the
/// non-empty runs as `(quadrant, start, end)`; empty quadrants are dropped (Fig. 5e).
fn quadrants(ids: &mut [u32], uv: &[(f64, f64)], cx: f64, cy: f64) -> Vec<(u8, usize, usize)> {
    let key = |s: u32| {
        let (u, v) = uv[s as usize];
        u8::from(u >= cx) | (u8::from(v >= cy) << 1)
    };
    ids.sort_by_key(|&s| key(s));
    let mut runs = Vec::with_capacity(4);
    let mut start = 0;
    while start < ids.len() {
        let q = key(ids[start]);
        let mut end = start + 1;
        while end < ids.len() && key(ids[end]) == q {
            end += 1;
        }
        runs.push((q, start, end));
        start = end;
    }
    runs
}

/// The smallest circle around the strands' cross-section points (Welzl's incremental algorithm
/// over a fixed pseudo-random order, so the result is deterministic).
fn min_circle(ids: &[u32], uv: &[(f64, f64)], pts: &mut Vec<(f64, f64)>) -> (f64, f64, f64) {
    pts.clear();
    pts.extend(ids.iter().map(|&s| uv[s as usize]));
    // Deterministic shuffle (xorshift), for expected linear time.
    let mut state = 0x9E37_79B9_7F4A_7C15u64 ^ pts.len() as u64;
    for i in (1..pts.len()).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let j = (state % (i as u64 + 1)) as usize;
        pts.swap(i, j);
    }
    let Some(&first) = pts.first() else {
        return (0.0, 0.0, 0.0);
    };
    let inside = |c: (f64, f64, f64), p: (f64, f64)| {
        let d = (p.0 - c.0).hypot(p.1 - c.1);
        d <= c.2 * (1.0 + 1e-12) + 1e-15
    };
    let mut c = (first.0, first.1, 0.0);
    for i in 1..pts.len() {
        if inside(c, pts[i]) {
            continue;
        }
        c = (pts[i].0, pts[i].1, 0.0);
        for j in 0..i {
            if inside(c, pts[j]) {
                continue;
            }
            c = diameter(pts[i], pts[j]);
            for k in 0..j {
                if !inside(c, pts[k]) {
                    c = circumcircle(pts[i], pts[j], pts[k]);
                }
            }
        }
    }
    c
}

fn diameter(a: (f64, f64), b: (f64, f64)) -> (f64, f64, f64) {
    let c = (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1));
    (c.0, c.1, 0.5 * (a.0 - b.0).hypot(a.1 - b.1))
}

fn circumcircle(a: (f64, f64), b: (f64, f64), c: (f64, f64)) -> (f64, f64, f64) {
    let (bx, by) = (b.0 - a.0, b.1 - a.1);
    let (cx, cy) = (c.0 - a.0, c.1 - a.1);
    let d = 2.0 * (bx * cy - by * cx);
    if d.abs() < 1e-300 {
        // Collinear: the circle on the farthest pair.
        let cands = [diameter(a, b), diameter(a, c), diameter(b, c)];
        return cands
            .into_iter()
            .fold((0.0, 0.0, -1.0), |m, x| if x.2 > m.2 { x } else { m });
    }
    let b2 = bx * bx + by * by;
    let c2 = cx * cx + cy * cy;
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    (a.0 + ux, a.1 + uy, ux.hypot(uy))
}

/// A sphere fitted to the roots, with a pole along the mean root direction.
struct Scalp {
    centre: Vector3<f64>,
    radius: f64,
    pole: Vector3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
}

impl Scalp {
    fn fit(style: &Hairstyle) -> Self {
        let n = style.strands.len() as f64;
        let mut mean = Vector3::<f64>::zeros();
        let mut dir = Vector3::<f64>::zeros();
        for s in &style.strands {
            mean += to64(&s.root.coords);
            dir += to64(&(s.frame * Vector::z()));
        }
        mean /= n;
        let pole = dir.try_normalize(1e-12).unwrap_or_else(Vector3::z);
        let mut extent: f64 = 0.0;
        for s in &style.strands {
            extent = extent.max((to64(&s.root.coords) - mean).norm());
        }
        // Algebraic sphere fit |p|^2 = 2 c.p + k, relative to the mean for conditioning.
        let mut a = Matrix4::<f64>::zeros();
        let mut b = Vector4::<f64>::zeros();
        for s in &style.strands {
            let p = to64(&s.root.coords) - mean;
            let row = Vector4::new(2.0 * p.x, 2.0 * p.y, 2.0 * p.z, 1.0);
            a += row * row.transpose();
            b += row * p.norm_squared();
        }
        let fitted = a.lu().solve(&b).and_then(|x| {
            let c = Vector3::new(x[0], x[1], x[2]);
            let r2 = x[3] + c.norm_squared();
            let r = r2.sqrt();
            (r.is_finite() && r > 0.0 && r < 20.0 * extent.max(1e-6)).then_some((c + mean, r))
        });
        // Fallback (flat or degenerate patches): a sphere below the roots, large against them.
        let fallback_r = 4.0 * extent.max(1e-3);
        let (centre, radius) = fitted.unwrap_or((mean - pole * fallback_r, fallback_r));
        let helper = if pole.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e1 = (helper - pole * pole.dot(&helper)).normalize();
        let e2 = pole.cross(&e1);
        Self {
            centre,
            radius,
            pole,
            e1,
            e2,
        }
    }

    /// Polar angle from the pole and azimuth of a point about the centre.
    fn angles(&self, p: &Point) -> (f64, f64) {
        let d = to64(&p.coords) - self.centre;
        let d = d.try_normalize(1e-300).unwrap_or(self.pole);
        let beta = d.dot(&self.pole).clamp(-1.0, 1.0).acos();
        let alpha = d.dot(&self.e2).atan2(d.dot(&self.e1));
        (beta, alpha)
    }

    /// Number of sectors in a row of root strips.
    fn sectors(&self, row: u32, depth: f64, width: f64) -> u32 {
        let beta = ((f64::from(row) + 0.5) * depth / self.radius).min(core::f64::consts::PI);
        let around = core::f64::consts::TAU * self.radius * beta.sin();
        ((around / width).round() as u32).clamp(1, 1 << 16)
    }

    /// Scalp point, across (azimuth) and down (polar) unit tangents at `(beta, alpha)`.
    fn tangent(&self, beta: f64, alpha: f64) -> (Vector3<f64>, Vector3<f64>, Vector3<f64>) {
        let (sb, cb) = beta.sin_cos();
        let (sa, ca) = alpha.sin_cos();
        let radial = self.pole * cb + (self.e1 * ca + self.e2 * sa) * sb;
        let across = self.e2 * ca - self.e1 * sa;
        let down = (self.e1 * ca + self.e2 * sa) * cb - self.pole * sb;
        (self.centre + radial * self.radius, across, down)
    }
}
