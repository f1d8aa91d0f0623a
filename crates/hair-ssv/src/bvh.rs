//! A bounding volume hierarchy of RSS over a triangle mesh, built top-down, for the hair-object
//! queries of Ward & Lin 2003 §5.4: the closest triangle to an SSV and every triangle in contact.
//!
//! Points (a body's signed distance, its distance field's samples) search a second tree made
//! from the same one: its levels collapsed so that each node holds four children's boxes side by
//! side and each leaf four triangles' vertices, measured four at a time, which takes fewer
//! instructions per query than the binary tree of boxes, with the same answers. On a processor
//! with AVX the point search runs compiled for it, so that the exact test's `f64` plane tests
//! fill AVX registers: the `wide` crate picks its instructions when it is compiled, for the
//! baseline target, and its four `f64` lanes would otherwise take two SSE2 instructions each.
//! What these cost and what was tried instead: `docs/perf/ssv.md`.

use rayon::prelude::*;

use crate::fit::fit_rss_iter;
use crate::query::rectangle_rectangle::rectangle_rectangle_lower_bound;
use crate::query::segment_rectangle::segment_rectangle_lower_bound;
use crate::query::separation::{rect_support, rect_support_min};
use crate::query::{Closest, TriLanes, point_rectangle, point_triangle_lanes_in};
use crate::{Contact, Point, Real, Rss, Ssv, SsvError, Vector};

/// Triangles per leaf.
const LEAF_SIZE: usize = 4;

/// A triangle that the mesh validation calls degenerate: `|ab x ac| <= DEGENERATE * max_edge^2`.
pub const DEGENERATE: Real = 1e-7;

#[derive(Clone, Debug)]
pub(crate) struct Node {
    /// Axis-aligned bounds, a cheap first rejection.
    pub(crate) lo: Point,
    pub(crate) hi: Point,
    /// The node's bounding RSS.
    rss: Rss,
    /// Leaf: first triangle (in the BVH's order) and count (> 0). Inner: `count == 0`, the left
    /// child is the next node and `first` is the right child.
    pub(crate) first: u32,
    pub(crate) count: u32,
}

/// Children per node of the point-query tree.
const WIDE: usize = 4;

/// A node of the point-query tree: the boxes of up to four children side by side (lane `k` of
/// each array is child `k`), so that one pass of four-lane arithmetic measures how far the point
/// is from all of them. Unused lanes hold an empty box (`lo = +inf`, `hi = -inf`), which is
/// infinitely far. The tree is the RSS hierarchy with levels collapsed: each inner node takes the
/// largest of its descendants until it has four children, and a leaf's children are its
/// triangles, with their own boxes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct WideNode {
    lo: [[Real; WIDE]; 3],
    hi: [[Real; WIDE]; 3],
    /// Inner node: the children's node indices. Leaf: the triangles' indices in leaf order.
    child: [u32; WIDE],
    /// Leaf: its triangles' vertices, lane by lane, in `Bvh::leaf_tris`.
    lanes: u32,
    leaf: bool,
}

impl WideNode {
    const EMPTY: Self = Self {
        lo: [[Real::INFINITY; WIDE]; 3],
        hi: [[Real::NEG_INFINITY; WIDE]; 3],
        child: [0; WIDE],
        lanes: 0,
        leaf: false,
    };

    fn set_lane(&mut self, k: usize, lo: &Point, hi: &Point, child: u32) {
        for a in 0..3 {
            self.lo[a][k] = lo[a];
            self.hi[a][k] = hi[a];
        }
        self.child[k] = child;
    }
}

/// Appends the point-query node for the RSS node `n` (and, first, its subtree's) to `out` and
/// returns its index.
fn collapse(
    nodes: &[Node],
    tris: &[[Point; 3]],
    tri_bounds: &[(Point, Point)],
    n: usize,
    out: &mut Vec<WideNode>,
    leaf_tris: &mut Vec<TriLanes>,
) -> u32 {
    let me = out.len();
    out.push(WideNode::EMPTY);
    let node = &nodes[n];
    if node.count > 0 {
        // LEAF_SIZE <= WIDE: a leaf's triangles fit its lanes.
        let range = node.first as usize..(node.first + node.count) as usize;
        let mut wide = WideNode {
            leaf: true,
            lanes: leaf_tris.len() as u32,
            ..WideNode::EMPTY
        };
        leaf_tris.push(TriLanes::new(&tris[range]));
        for (k, t) in (node.first..node.first + node.count).enumerate() {
            let (lo, hi) = &tri_bounds[t as usize];
            wide.set_lane(k, lo, hi, t);
        }
        out[me] = wide;
        return me as u32;
    }
    // Open the largest inner member (by box half-area) until there are four.
    let half_area = |i: usize| {
        let e = nodes[i].hi - nodes[i].lo;
        e.x * e.y + e.y * e.z + e.z * e.x
    };
    let mut members = vec![n + 1, node.first as usize];
    while members.len() < WIDE {
        let open = (0..members.len())
            .filter(|&k| nodes[members[k]].count == 0)
            .max_by(|&a, &b| half_area(members[a]).total_cmp(&half_area(members[b])));
        let Some(k) = open else { break };
        let m = members[k];
        members[k] = m + 1;
        members.push(nodes[m].first as usize);
    }
    let mut wide = WideNode::EMPTY;
    for (k, &m) in members.iter().enumerate() {
        let child = collapse(nodes, tris, tri_bounds, m, out, leaf_tris);
        wide.set_lane(k, &nodes[m].lo, &nodes[m].hi, child);
    }
    out[me] = wide;
    me as u32
}

const _: () = assert!(LEAF_SIZE <= WIDE);

/// The triangle of a mesh closest to a volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshClosest {
    /// Index of the triangle in the input mesh.
    pub triangle: u32,
    /// Closest points: `on_a` on the volume's core, `on_b` on the triangle.
    pub closest: Closest,
    /// Signed distance: core distance minus the volume's radius.
    pub distance: Real,
}

/// A contact between a volume (`a`) and a mesh triangle (`b`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshContact {
    /// Index of the triangle in the input mesh.
    pub triangle: u32,
    /// The contact; see [`Ssv::contact_with_triangle`] for the normal's convention.
    pub contact: Contact,
}

/// Contacts of many volumes, flattened: the contacts of volume `i` are
/// `contacts[offsets[i]..offsets[i + 1]]`, each sorted by triangle index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ContactBatch {
    /// `volumes + 1` offsets into `contacts`.
    pub offsets: Vec<usize>,
    /// All contacts, grouped by volume in input order.
    pub contacts: Vec<MeshContact>,
}

impl ContactBatch {
    /// The contacts of volume `i` (empty when out of range).
    pub fn of(&self, i: usize) -> &[MeshContact] {
        match (self.offsets.get(i), self.offsets.get(i + 1)) {
            (Some(&a), Some(&b)) => &self.contacts[a..b],
            _ => &[],
        }
    }
}

/// A BVH of RSS over an indexed triangle mesh.
#[derive(Clone, Debug)]
pub struct Bvh {
    pub(crate) nodes: Vec<Node>,
    /// The point-query tree ([`WideNode`]); the root is node 0.
    wide: Vec<WideNode>,
    /// The point-query tree's leaf triangles, four side by side.
    leaf_tris: Vec<TriLanes>,
    /// Triangles in leaf order.
    pub(crate) tris: Vec<[Point; 3]>,
    /// Per triangle in leaf order: axis-aligned bounds.
    tri_bounds: Vec<(Point, Point)>,
    /// Per triangle in leaf order: unit face normal.
    tri_normals: Vec<Vector>,
    /// Per triangle in leaf order: index in the input mesh.
    pub(crate) tri_ids: Vec<u32>,
    /// Triangles in input order.
    input: Vec<[Point; 3]>,
}

fn tri_bounds(t: &[Point; 3]) -> (Point, Point) {
    (t[0].inf(&t[1]).inf(&t[2]), t[0].sup(&t[1]).sup(&t[2]))
}

/// Checks an indexed mesh and returns its triangles as vertex triples.
pub fn validate_mesh(
    vertices: &[Point],
    triangles: &[[u32; 3]],
) -> Result<Vec<[Point; 3]>, SsvError> {
    if triangles.is_empty() {
        return Err(SsvError::EmptyMesh);
    }
    if let Some(vertex) = vertices
        .iter()
        .position(|p| !p.coords.iter().all(|x| x.is_finite()))
    {
        return Err(SsvError::NonFiniteVertex { vertex });
    }
    let mut out = Vec::with_capacity(triangles.len());
    for (triangle, idx) in triangles.iter().enumerate() {
        let mut t = [Point::origin(); 3];
        for (k, &index) in idx.iter().enumerate() {
            t[k] = *vertices
                .get(index as usize)
                .ok_or(SsvError::IndexOutOfRange {
                    triangle,
                    index,
                    vertex_count: vertices.len(),
                })?;
        }
        let (ab, ac, bc) = (t[1] - t[0], t[2] - t[0], t[2] - t[1]);
        let longest = ab
            .norm_squared()
            .max(ac.norm_squared())
            .max(bc.norm_squared());
        let twice_area = ab.cross(&ac).norm();
        if longest <= 0.0 || twice_area <= DEGENERATE * longest {
            return Err(SsvError::DegenerateTriangle {
                triangle,
                area: 0.5 * twice_area,
            });
        }
        out.push(t);
    }
    Ok(out)
}

impl Bvh {
    /// Builds the hierarchy over `triangles` (indices into `vertices`). Empty meshes, non-finite
    /// vertices, out-of-range indices and degenerate triangles are errors.
    pub fn new(vertices: &[Point], triangles: &[[u32; 3]]) -> Result<Self, SsvError> {
        let input = validate_mesh(vertices, triangles)?;
        let mut order: Vec<u32> = (0..input.len() as u32).collect();
        let centroids: Vec<Point> = input
            .iter()
            .map(|t| Point::from((t[0].coords + t[1].coords + t[2].coords) / 3.0))
            .collect();
        let mut nodes = Vec::with_capacity(2 * input.len() / LEAF_SIZE + 1);
        build(&input, &centroids, &mut order, 0, &mut nodes);
        let tris: Vec<[Point; 3]> = order.iter().map(|&i| input[i as usize]).collect();
        let tri_bounds: Vec<(Point, Point)> = tris.iter().map(tri_bounds).collect();
        let tri_normals = tris
            .iter()
            .map(|t| {
                (t[1] - t[0])
                    .cross(&(t[2] - t[0]))
                    .try_normalize(0.0)
                    .unwrap_or_else(Vector::z)
            })
            .collect();
        let mut wide = Vec::with_capacity(nodes.len() / 2 + 1);
        let mut leaf_tris = Vec::with_capacity(nodes.len() / 2 + 1);
        collapse(&nodes, &tris, &tri_bounds, 0, &mut wide, &mut leaf_tris);
        Ok(Self {
            nodes,
            wide,
            leaf_tris,
            tris,
            tri_bounds,
            tri_normals,
            tri_ids: order,
            input,
        })
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.input.len()
    }

    /// Triangle `i` of the input mesh.
    pub fn triangle(&self, i: usize) -> Option<&[Point; 3]> {
        self.input.get(i)
    }

    /// All triangles in input order.
    pub fn triangles(&self) -> &[[Point; 3]] {
        &self.input
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The root's bounding RSS.
    pub fn root_volume(&self) -> Rss {
        self.nodes[0].rss
    }

    /// The triangle closest to `ssv`'s core, with its signed distance; `None` only for an
    /// empty hierarchy (which [`Bvh::new`] never builds).
    pub fn closest(&self, ssv: &Ssv) -> Option<MeshClosest> {
        if let Ssv::Point(p) = ssv {
            return self.closest_to_point(&p.center, p.radius);
        }
        let mut best: Option<(u32, Closest)> = None;
        let mut best_d2 = Real::INFINITY;
        let mut stack = [0u32; 128];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let node = &self.nodes[stack[sp] as usize];
            if node_lower_bound_sq(ssv, &node.rss) >= best_d2 {
                continue;
            }
            if node.count > 0 {
                let leaf = node.first as usize..(node.first + node.count) as usize;
                self.scan_leaf(
                    leaf,
                    |t| ssv.closest_to_triangle(t),
                    &mut best,
                    &mut best_d2,
                );
            } else {
                let left = stack[sp] + 1;
                let right = node.first;
                let dl = node_lower_bound_sq(ssv, &self.nodes[left as usize].rss);
                let dr = node_lower_bound_sq(ssv, &self.nodes[right as usize].rss);
                // push the farther first so the nearer is visited first
                let (far, near) = if dl <= dr {
                    (right, left)
                } else {
                    (left, right)
                };
                if sp + 2 <= stack.len() {
                    stack[sp] = far;
                    stack[sp + 1] = near;
                    sp += 2;
                } else {
                    // deeper than the fixed stack (pathological meshes): fall back to brute force
                    return self.closest_brute(ssv);
                }
            }
        }
        best.map(|(triangle, closest)| MeshClosest {
            triangle,
            closest,
            distance: closest.distance() - ssv.radius(),
        })
    }

    /// [`Bvh::closest`] for a point (core `p`, radius `radius`): the same search over boxes
    /// alone, four children at a time ([`WideNode`]), nearer children first, and in a leaf each
    /// triangle's own box before the exact test. Boxes are looser than the nodes' RSS for curved
    /// patches but cost six comparisons. The answer does not depend on the order of the search:
    /// it is the least squared distance, the lowest input index among equals, and no triangle
    /// that could be either is pruned (see [`BOX_ROUNDING`]).
    ///
    /// On a processor with AVX the whole search runs compiled for it, so that the exact test's
    /// `f64` plane tests take one instruction per four lanes instead of two (the same values).
    #[cfg_attr(
        target_arch = "x86_64",
        expect(
            unsafe_code,
            reason = "calls the search compiled for AVX; sound: only after the processor was found to have AVX"
        )
    )]
    fn closest_to_point(&self, p: &Point, radius: Real) -> Option<MeshClosest> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: AVX was found on this processor just above.
            return unsafe { self.closest_to_point_avx(p, radius) };
        }
        self.closest_to_point_in::<false>(p, radius)
    }

    /// [`Bvh::closest_to_point`] compiled for AVX.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn closest_to_point_avx(&self, p: &Point, radius: Real) -> Option<MeshClosest> {
        self.closest_to_point_in::<true>(p, radius)
    }

    /// The search of [`Bvh::closest_to_point`], with the AVX exact test where `AVX` (true only
    /// in [`Bvh::closest_to_point_avx`]).
    #[inline(always)]
    fn closest_to_point_in<const AVX: bool>(&self, p: &Point, radius: Real) -> Option<MeshClosest> {
        let q = [p.x, p.y, p.z];
        // Squared distances from `q` to the four boxes of a node, lane by lane (plain
        // comparisons rather than `max`, so that the lanes compile to packed instructions; the
        // values are the same for any point that is not NaN).
        let lanes_d2 = |w: &WideNode| {
            let mut d2 = [0.0 as Real; WIDE];
            for a in 0..3 {
                for k in 0..WIDE {
                    let below = w.lo[a][k] - q[a];
                    let above = q[a] - w.hi[a][k];
                    let e = if below > above { below } else { above };
                    let e = if e > 0.0 { e } else { 0.0 };
                    d2[k] += e * e;
                }
            }
            // A relative margin keeps rounding in the box distance from pruning a triangle
            // exactly as far as the best.
            d2.map(|d| d * BOX_ROUNDING)
        };
        // A NaN coordinate is within reach of nothing (and an infinite one of no box below).
        if q.iter().any(|x| x.is_nan()) {
            return None;
        }
        let mut best: Option<(u32, Closest)> = None;
        let mut best_d2 = Real::INFINITY;
        let mut stack = [(0u32, 0.0 as Real); 128];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let (index, bound) = stack[sp];
            if bound >= best_d2 {
                continue;
            }
            let node = &self.wide[index as usize];
            let d2 = lanes_d2(node);
            if node.leaf {
                // Each triangle's own box first: a point a few centimetres off the surface has
                // dozens of leaves within reach, and the boxes reject about 40 % of their
                // triangles. The exact test runs on the four lanes at once.
                if !d2.iter().any(|&d| d < best_d2) {
                    continue;
                }
                let (on_b, dist_sq) =
                    point_triangle_lanes_in::<AVX>(p, &self.leaf_tris[node.lanes as usize]);
                for k in 0..WIDE {
                    if d2[k] < best_d2 {
                        let on_b = Point::new(on_b[0][k], on_b[1][k], on_b[2][k]);
                        let c = Closest {
                            on_a: *p,
                            on_b,
                            dist_sq: dist_sq[k],
                        };
                        offer(
                            self.tri_ids[node.child[k] as usize],
                            c,
                            &mut best,
                            &mut best_d2,
                        );
                    }
                }
                continue;
            }
            // The children within reach, pushed farthest first (a five-comparison sorting
            // network; ties keep either order) so that the nearest is visited first.
            let mut order = [
                (d2[0], node.child[0]),
                (d2[1], node.child[1]),
                (d2[2], node.child[2]),
                (d2[3], node.child[3]),
            ];
            for (i, j) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                if order[i].0 < order[j].0 {
                    order.swap(i, j);
                }
            }
            if sp + WIDE > stack.len() {
                return self.closest_brute(&Ssv::Point(crate::Pss::new(*p, radius)));
            }
            for (d, child) in order {
                if d < best_d2 {
                    stack[sp] = (child, d);
                    sp += 1;
                }
            }
        }
        best.map(|(triangle, closest)| MeshClosest {
            triangle,
            closest,
            distance: closest.distance() - radius,
        })
    }

    /// The triangles of a leaf (`leaf`, in leaf order) against the best so far: a nearer one, or
    /// one as near with a lower input index, replaces it.
    #[inline(always)]
    fn scan_leaf(
        &self,
        leaf: std::ops::Range<usize>,
        closest: impl Fn(&[Point; 3]) -> Closest,
        best: &mut Option<(u32, Closest)>,
        best_d2: &mut Real,
    ) {
        for k in leaf {
            offer(self.tri_ids[k], closest(&self.tris[k]), best, best_d2);
        }
    }

    fn closest_brute(&self, ssv: &Ssv) -> Option<MeshClosest> {
        let mut best: Option<MeshClosest> = None;
        for (i, t) in self.input.iter().enumerate() {
            let c = ssv.closest_to_triangle(t);
            if best.is_none_or(|b| c.dist_sq < b.closest.dist_sq) {
                best = Some(MeshClosest {
                    triangle: i as u32,
                    closest: c,
                    distance: c.distance() - ssv.radius(),
                });
            }
        }
        best
    }

    /// Appends to `out` a contact for every triangle whose signed distance to `ssv` is at most
    /// `margin`, sorted by triangle index. Allocates only if `out` must grow.
    pub fn contacts(&self, ssv: &Ssv, margin: Real, out: &mut Vec<MeshContact>) {
        let start_len = out.len();
        let (mut lo, mut hi) = ssv.aabb();
        // the margin, plus a little so that rounding never rejects a triangle at the boundary
        let slack = 1e-6 * (1.0 + lo.coords.abs().max().max(hi.coords.abs().max()));
        let m = Vector::repeat(margin.max(0.0) + slack);
        lo -= m;
        hi += m;
        let reach = ssv.radius() + margin;
        if reach < 0.0 {
            return;
        }
        let reach2 = reach * reach;
        let reach_plane = reach * (1.0 + 1e-5) + slack;
        let mut stack = [0u32; 128];
        let mut sp = 1usize;
        let mut overflow = false;
        while sp > 0 {
            sp -= 1;
            let index = stack[sp];
            let node = &self.nodes[index as usize];
            if !aabb_overlap(&lo, &hi, &node.lo, &node.hi) {
                continue;
            }
            if node_lower_bound(ssv, &node.rss) > reach {
                continue;
            }
            if node.count > 0 {
                let start = node.first as usize;
                for k in start..start + node.count as usize {
                    let (tlo, thi) = &self.tri_bounds[k];
                    if !aabb_overlap(&lo, &hi, tlo, thi) {
                        continue;
                    }
                    // the triangle's plane separates by more than the reach: no contact
                    let (dmin, dmax) = core_interval(ssv, &self.tris[k][0], &self.tri_normals[k]);
                    if dmin > reach_plane || dmax < -reach_plane {
                        continue;
                    }
                    let c = ssv.closest_to_triangle(&self.tris[k]);
                    if c.dist_sq <= reach2 {
                        let contact = ssv.contact_from_triangle_closest(&c, &self.tris[k]);
                        out.push(MeshContact {
                            triangle: self.tri_ids[k],
                            contact,
                        });
                    }
                }
            } else if sp + 2 <= stack.len() {
                stack[sp] = node.first;
                stack[sp + 1] = index + 1;
                sp += 2;
            } else {
                overflow = true;
                break;
            }
        }
        if overflow {
            out.truncate(start_len);
            for (i, t) in self.input.iter().enumerate() {
                if let Some(contact) = ssv.contact_with_triangle(t, margin) {
                    out.push(MeshContact {
                        triangle: i as u32,
                        contact,
                    });
                }
            }
            return;
        }
        out[start_len..].sort_unstable_by_key(|c| c.triangle);
    }

    /// Contacts of every volume in `ssvs` (see [`Bvh::contacts`]), computed in parallel and
    /// returned in input order.
    pub fn contacts_batch(&self, ssvs: &[Ssv], margin: Real) -> ContactBatch {
        let chunks: Vec<(Vec<usize>, Vec<MeshContact>)> = ssvs
            .par_chunks(64)
            .map(|chunk| {
                let mut counts = Vec::with_capacity(chunk.len());
                let mut out = Vec::new();
                for s in chunk {
                    let before = out.len();
                    self.contacts(s, margin, &mut out);
                    counts.push(out.len() - before);
                }
                (counts, out)
            })
            .collect();
        let mut batch = ContactBatch {
            offsets: Vec::with_capacity(ssvs.len() + 1),
            contacts: Vec::new(),
        };
        batch.offsets.push(0);
        for (counts, contacts) in chunks {
            for c in counts {
                let last = *batch.offsets.last().unwrap_or(&0);
                batch.offsets.push(last + c);
            }
            batch.contacts.extend(contacts);
        }
        batch
    }

    /// The closest triangle to every volume in `ssvs`, in parallel, in input order.
    pub fn closest_batch(&self, ssvs: &[Ssv]) -> Vec<Option<MeshClosest>> {
        ssvs.par_iter()
            .with_min_len(64)
            .map(|s| self.closest(s))
            .collect()
    }
}

/// Offers triangle `id` at `c` to the best so far: a nearer one, or one as near with a lower
/// input index, replaces it (so the answer does not depend on the order of the offers).
#[inline(always)]
fn offer(id: u32, c: Closest, best: &mut Option<(u32, Closest)>, best_d2: &mut Real) {
    if c.dist_sq < *best_d2 || (c.dist_sq == *best_d2 && best.is_some_and(|(b, _)| id < b)) {
        *best_d2 = c.dist_sq;
        *best = Some((id, c));
    }
}

/// Factor below 1 on a squared box distance before it rejects a node: far above the relative
/// rounding of the distances compared.
const BOX_ROUNDING: Real = 1.0 - 1e-4;

#[inline(always)]
fn aabb_overlap(alo: &Point, ahi: &Point, blo: &Point, bhi: &Point) -> bool {
    alo.x <= bhi.x
        && blo.x <= ahi.x
        && alo.y <= bhi.y
        && blo.y <= ahi.y
        && alo.z <= bhi.z
        && blo.z <= ahi.z
}

/// Lower bound of the distance from `ssv`'s core to every triangle of a node: a lower bound of
/// the distance to the node's core rectangle (exact for points, a separation gap otherwise)
/// minus the node's radius.
#[inline]
fn node_lower_bound(ssv: &Ssv, rss: &Rss) -> Real {
    let core = match ssv {
        Ssv::Point(p) => point_rectangle(&p.center, rss).distance(),
        Ssv::Line(l) => segment_rectangle_lower_bound(&l.a, &l.b, rss),
        Ssv::Rect(r) => rectangle_rectangle_lower_bound(r, rss),
    };
    core - rss.radius
}

/// The squared lower bound, zero when it is negative.
#[inline]
fn node_lower_bound_sq(ssv: &Ssv, rss: &Rss) -> Real {
    let d = node_lower_bound(ssv, rss);
    if d > 0.0 { d * d } else { 0.0 }
}

/// The range of `(p - origin) . n` over the core of `ssv`.
#[inline(always)]
fn core_interval(ssv: &Ssv, origin: &Point, n: &Vector) -> (Real, Real) {
    match ssv {
        Ssv::Point(p) => {
            let d = (p.center - origin).dot(n);
            (d, d)
        }
        Ssv::Line(l) => {
            let (a, b) = ((l.a - origin).dot(n), (l.b - origin).dot(n));
            (a.min(b), a.max(b))
        }
        Ssv::Rect(r) => (rect_support_min(r, origin, n), rect_support(r, origin, n)),
    }
}

/// Recursive top-down build over `order[..]` (a slice of the global order starting at `base`).
fn build(
    tris: &[[Point; 3]],
    centroids: &[Point],
    order: &mut [u32],
    base: usize,
    nodes: &mut Vec<Node>,
) {
    let pts = order.iter().flat_map(|&i| tris[i as usize].iter().copied());
    let rss = fit_rss_iter(pts).unwrap_or(Rss::new(
        Point::origin(),
        [Vector::x(), Vector::y()],
        [0.0, 0.0],
        0.0,
    ));
    let (mut lo, mut hi) = (
        Point::from(Vector::repeat(Real::INFINITY)),
        Point::from(Vector::repeat(Real::NEG_INFINITY)),
    );
    for &i in order.iter() {
        let (a, b) = tri_bounds(&tris[i as usize]);
        lo = lo.inf(&a);
        hi = hi.sup(&b);
    }
    let me = nodes.len();
    nodes.push(Node {
        lo,
        hi,
        rss,
        first: base as u32,
        count: order.len() as u32,
    });
    if order.len() <= LEAF_SIZE {
        return;
    }
    // split along the longest RSS axis at the mean centroid; fall back to the median
    let axis = if rss.extents[0] >= rss.extents[1] {
        rss.axes[0]
    } else {
        rss.axes[1]
    };
    let key = |i: u32| centroids[i as usize].coords.dot(&axis);
    let mean = order.iter().map(|&i| key(i)).sum::<Real>() / order.len() as Real;
    let mut mid = partition(order, |i| key(i) < mean);
    // (also when the mean split is lopsided, which keeps the depth logarithmic)
    if mid == 0
        || mid == order.len()
        || mid < order.len() / 8
        || mid > order.len() - order.len() / 8
    {
        mid = order.len() / 2;
        order.select_nth_unstable_by(mid, |&a, &b| key(a).total_cmp(&key(b)));
    }
    let (left, right) = order.split_at_mut(mid);
    build(tris, centroids, left, base, nodes);
    let right_index = nodes.len() as u32;
    build(tris, centroids, right, base + mid, nodes);
    nodes[me].first = right_index;
    nodes[me].count = 0;
}

fn partition(v: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut k = 0;
    for i in 0..v.len() {
        if pred(v[i]) {
            v.swap(i, k);
            k += 1;
        }
    }
    k
}
