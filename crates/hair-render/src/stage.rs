//! The render stage of a simulation (feature `stage`): every rendered strand follows the
//! skeleton that represents it, at its fixed offset in that skeleton's local frame, subdivided
//! into a smooth Catmull-Rom curve.
//!
//! Ward & Lin §3: skeletons are the simulation's base curves; strands, clusters and strips are
//! built around them for rendering only.

pub use crate::follow::RenderGeometry;
use crate::follow::{catmull_rom, catmull_rom_into, transport_frames, transport_frames_into};
use crate::guides::Followers;
use crate::{Point, Real, Vector};
use hair_dynamics::{HeadMotion, SkeletonId, StrandState};
use hair_lod::Hierarchy;
use nalgebra::{Matrix3, Rotation3};
use rayon::prelude::*;

/// The render stage: every rendered strand follows the front node that holds it, at its
/// offsets from that node's control points in their transport frames, drawn as a Catmull-Rom
/// curve in world coordinates; cuts end strands and fallen pieces are drawn. With followers
/// ([`DrawnStrands::set_followers`]) the strands are guides and the output is their followers.
/// Buffers are reused: an update allocates nothing once grown.
#[derive(Clone, Debug)]
pub struct DrawnStrands {
    /// The strands' polylines.
    geometry: RenderGeometry,
    /// Control points per strand.
    per: usize,
    /// Every strand's rest points (`per` each).
    strand_rest: Vec<Point>,
    /// Per strand, the front node that draws it.
    strand_node: Vec<u32>,
    /// Transport frames of the front skeletons' nodes, by global node index.
    node_frames: Vec<Matrix3<Real>>,
    /// The node ranges and ids `(start, end, node)` of the front skeletons that draw a strand
    /// off their own points, ascending: the frames are filled by splitting `node_frames` along
    /// them.
    front_ranges: Vec<(usize, usize, u32)>,
    /// Per node, whether a strand it draws lies off its points (an offset over
    /// [`OFFSET_DRAWN`]): only those need transport frames. A skeleton that is its own strand
    /// (a scene of as many skeletons as strands) needs none.
    node_framed: Vec<bool>,
    /// Per node, where its strands' offsets start in `strand_local`.
    node_local_start: Vec<u32>,
    /// Each strand's offset from each node containing it, per control point, in that node's
    /// rest transport frames (so the offset turns with the skeleton).
    strand_local: Vec<Vector>,
    /// Where the offsets of each strand from its current front node start.
    strand_slot: Vec<u32>,
    /// The strands grouped by front node (in the front's order), and each strand's place in
    /// that order: the render pass reads each skeleton's nodes once for all its strands.
    strand_order: Vec<u32>,
    strand_rank: Vec<u32>,
    /// The strands' curves in `strand_order`, before they are copied out in strand order.
    render_scratch: Vec<Point>,
    cuts: CutRender,
    /// The strands' followers, if the strands are guides, and the rotation of the last update.
    followers: Option<Followers>,
    rotation: Matrix3<Real>,
}

impl DrawnStrands {
    /// The stage for strands of `per` control points at rest at `strand_rest`, drawn with
    /// `subdivisions` points per segment.
    pub fn new(strand_rest: Vec<Point>, per: usize, subdivisions: usize) -> Self {
        Self {
            geometry: RenderGeometry {
                subdivisions,
                ..RenderGeometry::default()
            },
            per,
            strand_rest,
            strand_node: Vec::new(),
            node_frames: Vec::new(),
            front_ranges: Vec::new(),
            node_framed: Vec::new(),
            node_local_start: Vec::new(),
            strand_local: Vec::new(),
            strand_slot: Vec::new(),
            strand_order: Vec::new(),
            strand_rank: Vec::new(),
            render_scratch: Vec::new(),
            cuts: CutRender::default(),
            followers: None,
            rotation: Matrix3::identity(),
        }
    }

    /// From now on the strands are guides and the output is `count` followers of them, sampled
    /// deterministically from `seed` ([`crate::guides::sample_links`]); `count` 0 draws the
    /// strands themselves again. Call before the next update.
    pub fn set_followers(&mut self, count: usize, seed: u64) {
        if count == 0 {
            self.followers = None;
            return;
        }
        let per = self.per.max(1);
        let roots: Vec<Point> = self.strand_rest.iter().step_by(per).copied().collect();
        let links = crate::guides::sample_links(&roots, count, seed);
        let sub = self.geometry.subdivisions;
        self.followers = Some(Followers::new(&self.strand_rest, per, links, sub));
    }

    /// The followers, if the strands are guides.
    pub fn followers(&self) -> Option<&Followers> {
        self.followers.as_ref()
    }

    /// What is drawn: the followers' polylines if the strands are guides, else the strands'.
    pub fn output(&self) -> &RenderGeometry {
        self.followers
            .as_ref()
            .map_or(&self.geometry, |f| &f.geometry)
    }

    /// The strands' own polylines (the guides' when there are followers).
    pub fn strands(&self) -> &RenderGeometry {
        &self.geometry
    }

    /// The followers again from the strands as drawn.
    fn follow(&mut self) {
        if let Some(f) = &mut self.followers {
            f.update(&self.geometry, &self.rotation);
        }
    }

    /// Every strand's offsets from every node that contains it, then the assignment of strands
    /// to the current front.
    pub fn prepare(&mut self, h: &Hierarchy, state: &StrandState, front: &[u32]) {
        let per = self.per;
        let mut frames = Vec::new();
        let mut rest = Vec::new();
        self.node_local_start.clear();
        self.strand_local.clear();
        self.node_framed.clear();
        for node in 0..h.node_count() as u32 {
            self.node_local_start.push(self.strand_local.len() as u32);
            h.rest_points_into(node, &mut rest);
            let first = state.root_frame(SkeletonId(node));
            transport_frames(&rest, first.matrix(), &mut frames);
            for &s in h.strands(node) {
                let s = s as usize;
                for k in 0..per {
                    let k_node = k.min(rest.len() - 1);
                    let d = self.strand_rest[s * per + k] - rest[k_node];
                    self.strand_local.push(frames[k_node].transpose() * d);
                }
            }
            let start = self.node_local_start[node as usize] as usize;
            let offsets = &self.strand_local[start..];
            self.node_framed.push(
                offsets
                    .iter()
                    .any(|d| d.norm_squared() > OFFSET_DRAWN * OFFSET_DRAWN),
            );
        }
        self.assign(h, state, front);
    }

    /// Which front node draws each strand.
    pub fn assign(&mut self, h: &Hierarchy, state: &StrandState, front: &[u32]) {
        let per = self.per as u32;
        let n_strands = h.strand_total();
        self.strand_node.resize(n_strands, 0);
        self.strand_slot.resize(n_strands, 0);
        self.strand_order.clear();
        for &node in front {
            let start = self.node_local_start[node as usize];
            for (j, &s) in h.strands(node).iter().enumerate() {
                self.strand_node[s as usize] = node;
                self.strand_slot[s as usize] = start + j as u32 * per;
                self.strand_order.push(s);
            }
        }
        // A front is a cut of the hierarchy, so it holds every strand once; should the count
        // ever differ, the strands are drawn in their own order.
        if self.strand_order.len() != n_strands {
            self.strand_order.clear();
            self.strand_order.extend(0..n_strands as u32);
        }
        self.strand_rank.resize(n_strands, 0);
        for (k, &s) in self.strand_order.iter().enumerate() {
            self.strand_rank[s as usize] = k as u32;
        }
        self.front_ranges.clear();
        let framed = &self.node_framed;
        self.front_ranges
            .extend(front.iter().filter(|&&n| framed[n as usize]).map(|&n| {
                let r = state.nodes(SkeletonId(n));
                (r.start, r.end, n)
            }));
        self.front_ranges.sort_unstable();
    }

    /// The first drawn strand with a point not within 1e36 m of the origin (0 if none).
    pub fn first_undrawable(&self) -> usize {
        let verts = self.geometry.offsets.get(1).copied().unwrap_or(1).max(1) as usize;
        self.geometry
            .positions
            .iter()
            .position(|p| !p.coords.iter().all(|c| c.abs() < DRAWABLE))
            .map_or(0, |i| i / verts)
    }

    /// Rebuilds every rendered strand from its front node, in world coordinates; false when a
    /// control point is not within 1e36 m of the origin (non-finite included).
    #[must_use]
    pub fn update(
        &mut self,
        h: &Hierarchy,
        state: &StrandState,
        rot: &Rotation3<Real>,
        origin: &Point,
    ) -> bool {
        let n_strands = h.strand_total();
        let sub = self.geometry.subdivisions.max(1);
        // Frames of every front node along its current polyline, into disjoint ranges of one
        // buffer (no allocation once it has grown).
        self.node_frames
            .resize(state.node_count(), Matrix3::identity());
        fill_frames(state, &mut self.node_frames, 0, &self.front_ranges);
        let per = self.per;
        let verts = sub * (per - 1) + 1;
        self.geometry.lay_out(n_strands, verts);
        let strand_node = &self.strand_node;
        let node_frames = &self.node_frames;
        let local = &self.strand_local;
        let slot = &self.strand_slot;
        let framed = &self.node_framed;
        // Curves in the front's order first: consecutive strands then share their skeleton's
        // nodes and frames, where strand order reads them from all over the state (a strand's
        // neighbours in number almost never share its skeleton). Then copied out in strand
        // order, one contiguous run per strand.
        let (order, rot, origin) = (&self.strand_order, *rot, *origin);
        self.render_scratch
            .resize(n_strands * verts, Point::origin());
        // Each strand's control points are checked as they are made (in registers, no branch):
        // a curve through points within `DRAWABLE` of the origin stays finite.
        let drawable = self
            .render_scratch
            .par_chunks_mut(verts)
            .zip(order.par_iter())
            .map(|(out, &s)| {
                let s = s as usize;
                let node = strand_node[s];
                let r = state.nodes(SkeletonId(node));
                let p = &state.positions()[r.clone()];
                let frames = &node_frames[r.clone()];
                let mut control = [Point::origin(); 64];
                let count = p.len().min(per).min(64);
                let mut ok = true;
                let framed = framed[node as usize];
                for k in 0..count {
                    control[k] = if framed {
                        origin + rot * (p[k].coords + frames[k] * local[slot[s] as usize + k])
                    } else {
                        origin + rot * p[k].coords
                    };
                    let c = control[k];
                    // False for NaN too.
                    ok &= (c.x.abs() < DRAWABLE) & (c.y.abs() < DRAWABLE) & (c.z.abs() < DRAWABLE);
                }
                catmull_rom_into(&control[..count], sub, out);
                ok
            })
            .reduce(|| true, |a, b| a && b);
        let (scratch, rank) = (&self.render_scratch, &self.strand_rank);
        self.geometry
            .positions
            .par_chunks_mut(verts)
            .zip(rank.par_iter())
            .for_each(|(out, &k)| {
                let k = k as usize * verts;
                out.copy_from_slice(&scratch[k..k + verts]);
            });
        self.rotation = *rot.matrix();
        self.follow();
        drawable
    }

    /// Cut strands end at the cut; `fallen` pieces are drawn. Nothing to do while `fallen` is
    /// `None` (no cut yet).
    pub fn apply_cuts(
        &mut self,
        fallen: Option<impl Iterator<Item = FallenPiece>>,
        state: &StrandState,
        h: &Hierarchy,
        head: &HeadMotion,
    ) {
        let strands = CutStrands {
            strand_node: &self.strand_node,
            node_local_start: &self.node_local_start,
            strand_local: &self.strand_local,
            per: self.per,
        };
        let cut = fallen.is_some();
        self.cuts
            .apply(fallen, state, h, &strands, head, &mut self.geometry);
        if cut {
            self.follow();
        }
    }
}

/// Offsets of a strand from its skeleton up to this (m) are drawn as none: a skeleton that is
/// its own strand lies off it by the rounding of its resampling (well under a micrometre), and
/// following it needs no transport frames.
const OFFSET_DRAWN: Real = 1e-6;

/// Drawn control points farther than this from the origin (m) stop a step with
/// an error: hair there has left any scene, and the curves through such
/// points (sums of a few multiples of them) could overflow `f32`.
const DRAWABLE: Real = 1e36;

/// The transport frames of the skeletons whose node ranges are `ranges` (ascending, disjoint,
/// inside `base..base + frames.len()`) into `frames`, split in halves across threads.
fn fill_frames(
    state: &StrandState,
    frames: &mut [Matrix3<Real>],
    base: usize,
    ranges: &[(usize, usize, u32)],
) {
    if ranges.len() <= 16 {
        for &(start, end, node) in ranges {
            transport_frames_into(
                &state.positions()[start..end],
                state.root_frame(SkeletonId(node)).matrix(),
                &mut frames[start - base..end - base],
            );
        }
        return;
    }
    let mid = ranges.len() / 2;
    let (low, high) = frames.split_at_mut(ranges[mid].0 - base);
    rayon::join(
        || fill_frames(state, low, base, &ranges[..mid]),
        || fill_frames(state, high, ranges[mid].0, &ranges[mid..]),
    );
}

/// A piece of hair cut off a skeleton and not swept away: the render stage draws the strands of
/// the node it was cut from along it.
#[derive(Clone, Copy, Debug)]
pub struct FallenPiece {
    /// Its skeleton in the state.
    pub skeleton: SkeletonId,
    /// The hierarchy node it was cut from (whose strands it draws).
    pub source: u32,
    /// The control point of the source its first point was.
    pub first_source: u32,
}

/// The rendered strands' offsets from their skeletons, as the render stage holds them.
#[derive(Clone, Copy, Debug)]
struct CutStrands<'a> {
    /// Per strand, the front node that draws it.
    strand_node: &'a [u32],
    /// Per node, where its strands' offsets start in `strand_local`.
    node_local_start: &'a [u32],
    /// Each strand's offset per control point in its node's rest transport frames.
    strand_local: &'a [Vector],
    /// Control points per strand.
    per: usize,
}

/// The drawn strands after the salon's cuts, with their scratch buffers.
#[derive(Clone, Debug, Default)]
struct CutRender {
    frames: Vec<Matrix3<Real>>,
    curve: Vec<Point>,
    control: Vec<Point>,
}

impl CutRender {
    /// Render geometry after cuts: every cut strand ends where its skeleton now ends, and every
    /// fallen piece that is not swept draws the strands of the node it was cut from, at their
    /// offsets from the original control points. Nothing to do before the first cut.
    fn apply(
        &mut self,
        fallen: Option<impl Iterator<Item = FallenPiece>>,
        state: &StrandState,
        h: &Hierarchy,
        strands: &CutStrands<'_>,
        head: &HeadMotion,
        out: &mut RenderGeometry,
    ) {
        let Some(fallen) = fallen else {
            return;
        };
        let CutStrands {
            strand_node,
            node_local_start,
            strand_local,
            per,
        } = *strands;
        let sub = out.subdivisions.max(1);
        let verts_of = |n: usize| {
            if sub <= 1 || n < 2 {
                n
            } else {
                sub * (n - 1) + 1
            }
        };
        // Compact: strand s keeps the vertices of its live control points.
        let strands = out.strand_count();
        let mut write = 0usize;
        for s in 0..strands.min(strand_node.len()) {
            let start = out.offsets[s] as usize;
            let full = out.offsets[s + 1] as usize - start;
            let live = state.nodes(SkeletonId(strand_node[s])).len().min(per);
            let keep = verts_of(live).min(full);
            out.positions.copy_within(start..start + keep, write);
            out.offsets[s] = write as u32;
            write += keep;
        }
        out.offsets.truncate(strands.min(strand_node.len()) + 1);
        if let Some(last) = out.offsets.last_mut() {
            *last = write as u32;
        }
        out.positions.truncate(write);
        // Fallen pieces.
        let rot = head.rotation;
        let origin = head.position;
        for f in fallen {
            if (f.source as usize) >= h.node_count() {
                continue;
            }
            let id = f.skeleton;
            let r = state.nodes(id);
            let p = &state.positions()[r.clone()];
            transport_frames(p, state.root_frame(id).matrix(), &mut self.frames);
            // Offsets of the source node's strands start here, `per` per strand.
            let base = node_local_start
                .get(f.source as usize)
                .map_or(usize::MAX, |&b| b as usize);
            for slot in 0..h.strands(f.source).len() {
                self.control.clear();
                for (j, pj) in p.iter().enumerate() {
                    let k = (f.first_source as usize + j).saturating_sub(1).min(per - 1);
                    let local = strand_local
                        .get(base.saturating_add(slot * per + k))
                        .copied()
                        .unwrap_or_default();
                    self.control
                        .push(origin + rot * (pj.coords + self.frames[j] * local));
                }
                self.curve.clear();
                catmull_rom(&self.control, sub, &mut self.curve);
                out.positions.extend_from_slice(&self.curve);
                out.offsets.push(out.positions.len() as u32);
            }
        }
    }
}
