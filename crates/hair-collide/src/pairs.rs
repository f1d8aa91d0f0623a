//! The papers' hair-hair model (Ward & Lin §5.4): exact distances between the swept-sphere
//! sections of the grid's candidate pairs; near-parallel sections in contact share their
//! velocity, crossing ones are pushed apart by half their overlap each.

use crate::{CollisionSettings, HairHairModel};
use hair_dynamics::{DynamicsError, NodeCorrection, SkeletonId, StrandState};
use hair_grid::{Grid, PairSet, Section};
use hair_ssv::{Lss, Point, Real, Ssv, Vector};
use rayon::prelude::*;

/// How a node combines the pushes of its overlapping hair-hair pairs; each pair asks for its
/// two sections to move apart by half their overlap each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum PushCombine {
    /// The node moves by the sum of its pairs' pushes. A wisp in dense hair overlaps dozens of
    /// others, and each pair's push alone separates that pair: summed, they overshoot by up to
    /// the number of pairs, which makes the hair far more sensitive to its initial state and
    /// keeps it gaining kinetic energy in a steady wind (`docs/perf/collide.md`).
    Sum,
    /// The node moves by their mean (the default): a Jacobi average of what its pairs ask.
    /// Dense hair then overlaps more but settles.
    #[default]
    Mean,
}

/// The hair sections of a front: one line swept sphere per segment of every listed skeleton
/// (radius: the larger of its two nodes'), each with its end node.
#[derive(Clone, Debug, Default)]
pub struct Sections {
    /// The sections, skeleton by skeleton in front order, root to tip.
    pub sections: Vec<Section>,
    /// Each section's end node (the one a push moves).
    pub nodes: Vec<u32>,
    /// Per node of the state, the most its hair-hair radius may be (empty: no cap): where a
    /// groom packs crossing hair closer than its radii, the groom's own clearance
    /// ([`crate::make_groom_rest`]), so that the hair at rest pushes nothing apart.
    pub radius_cap: Vec<Real>,
    /// Per node, the radius the sections were built with (the state's, capped).
    radius: Vec<Real>,
}

impl Sections {
    /// The sections of the skeletons in `front` at their present positions.
    pub fn build(&mut self, state: &StrandState, front: &[u32]) {
        self.sections.clear();
        self.nodes.clear();
        self.radius.clear();
        self.radius.extend_from_slice(state.radius());
        for (r, cap) in self.radius.iter_mut().zip(&self.radius_cap) {
            *r = r.min(*cap);
        }
        let (p, radius) = (state.positions(), &self.radius);
        for &node in front {
            let r = state.nodes(SkeletonId(node));
            for (k, i) in (r.start + 1..r.end).enumerate() {
                self.sections.push(Section {
                    skeleton: node,
                    segment: k as u32,
                    shape: Ssv::Line(Lss::new(p[i - 1], p[i], radius[i].max(radius[i - 1]))),
                });
                self.nodes.push(i as u32);
            }
        }
    }

    /// Per node of the state, the radius the last [`Sections::build`] gave its sections.
    pub fn radius(&self) -> &[Real] {
        &self.radius
    }
}

/// What one hair-hair response did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PairsReport {
    /// Pairs tested exactly.
    pub pairs_tested: usize,
    /// Pairs in contact (shares and pushes).
    pub contacts: usize,
}

/// The exact hair-hair model with its scratch buffers (no allocation once grown).
#[derive(Debug, Default)]
pub struct HairPairs {
    pairs: PairSet,
    /// The sections as the response reads them, one cache line each.
    contact_sections: Vec<ContactSection>,
    /// The narrow phase's decisions, one buffer per chunk of the pair set.
    responses: Vec<ResponseChunk>,
    /// Chunks of `responses` whose `kept` pairs the steps between pair searches test
    /// (`pair_search_interval`), and the steps since they were found; `None` when there are
    /// none to reuse (a new front, a reset, a tool script).
    kept_pairs: Option<(usize, u32)>,
    /// This step's plan: the kept pairs to test again, or `None` to search.
    reuse: Option<(usize, u32)>,
    /// Pushes per node: their sum and their number (zero between steps).
    node_push: Vec<(Vector, u32)>,
    corrections: Vec<NodeCorrection>,
}

impl HairPairs {
    /// A model with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// Drops the pairs kept from the last search: the next step searches. Call it when the
    /// hair changes under them (another front, a reset).
    pub fn forget(&mut self) {
        self.kept_pairs = None;
    }

    /// Decides whether this step searches the grid for pairs or tests again the pairs of the
    /// last search (young enough, and `reuse_allowed`: the hair is the same hair, no tool
    /// acting). Returns whether the step needs the grid rebuilt for a search: never when the
    /// model is not `Pairs`.
    pub fn plan(&mut self, settings: &CollisionSettings, reuse_allowed: bool) -> bool {
        let interval = settings.pair_search_interval.max(1);
        let pairs = settings.hair_hair == HairHairModel::Pairs;
        self.reuse = match self.kept_pairs {
            Some((chunks, age)) if pairs && age + 1 < interval && reuse_allowed => {
                Some((chunks, age + 1))
            }
            _ => None,
        };
        pairs && self.reuse.is_none()
    }

    /// The response of the step planned by [`HairPairs::plan`]: shares change the joints'
    /// rates, pushes move nodes (through [`StrandState::apply_corrections`]). `grid` holds
    /// `sections` when the plan searches.
    pub fn respond(
        &mut self,
        state: &mut StrandState,
        grid: &Grid,
        sections: &Sections,
        settings: &CollisionSettings,
    ) -> Result<PairsReport, DynamicsError> {
        let mut report = PairsReport::default();
        if settings.hair_hair != HairHairModel::Pairs {
            return Ok(report);
        }
        let interval = settings.pair_search_interval.max(1);
        let cos_parallel = settings.parallel_angle.cos();
        let chunks = if let Some((chunks, age)) = self.reuse {
            self.kept_pairs = Some((chunks, age));
            let (p, radius) = (state.positions(), sections.radius());
            let state = &*state;
            self.responses[..chunks]
                .par_iter_mut()
                .for_each(|out| out.retest(state, p, radius, cos_parallel));
            report.pairs_tested = self.responses[..chunks].iter().map(|r| r.kept.len()).sum();
            chunks
        } else {
            self.search(state, grid, sections, cos_parallel, interval > 1);
            report.pairs_tested = self.pairs.len();
            let chunks = self.pairs.chunk_count();
            self.kept_pairs = (interval > 1).then_some((chunks, 0));
            chunks
        };
        let responses = &self.responses[..chunks];
        report.contacts = responses
            .iter()
            .map(|r| r.shares.len() + r.pushes.len())
            .sum::<usize>();
        self.corrections.clear();
        self.node_push
            .resize(state.node_count(), (Vector::zeros(), 0));
        // Shares change only the rates and pushes only the push sums: each kind applied in
        // pair order, the two side by side, gives the state of applying them interleaved.
        let (theta, phi) = state.rates_mut();
        let node_push = &mut self.node_push;
        rayon::join(
            || {
                for &[a, b] in responses.iter().flat_map(|r| &r.shares) {
                    // The mean never raises the sum of squared rates: no energy is added.
                    let (a, b) = (a as usize, b as usize);
                    let mean_t = 0.5 * (theta[a] + theta[b]);
                    let mean_p = 0.5 * (phi[a] + phi[b]);
                    theta[a] = mean_t;
                    theta[b] = mean_t;
                    phi[a] = mean_p;
                    phi[b] = mean_p;
                }
            },
            || {
                for &(a, b, half) in responses.iter().flat_map(|r| &r.pushes) {
                    let (a, b) = (a as usize, b as usize);
                    node_push[a].0 -= half;
                    node_push[a].1 += 1;
                    node_push[b].0 += half;
                    node_push[b].1 += 1;
                }
            },
        );
        // One correction per pushed node (a section has dozens of neighbours in dense hair):
        // its pairs' pushes summed in pair order, or their mean (`PushCombine`).
        let mean = settings.hair_hair_push == PushCombine::Mean;
        for (node, entry) in self.node_push.iter_mut().enumerate() {
            let (push, pushes) = std::mem::replace(entry, (Vector::zeros(), 0));
            if push != Vector::zeros() {
                let delta = if mean {
                    push / pushes.max(1) as Real
                } else {
                    push
                };
                self.corrections.push(NodeCorrection {
                    node: node as u32,
                    delta,
                });
            }
        }
        state.apply_corrections(&self.corrections)?;
        Ok(report)
    }

    /// The pair search and narrow phase, into `self.responses` chunk by chunk of the pair set;
    /// with `keep`, each chunk also keeps its pairs of segments (by end node) for
    /// [`ResponseChunk::retest`] on the steps until the next search.
    fn search(
        &mut self,
        state: &StrandState,
        grid: &Grid,
        sections: &Sections,
        cos_parallel: Real,
        keep: bool,
    ) {
        grid.overlapping_pairs_by_rank(&mut self.pairs);
        // In the pair search's order, so that the pairs, which come cell by cell, read
        // nearby records.
        let (nodes, sections) = (&sections.nodes, &sections.sections);
        grid.search_order()
            .par_iter()
            .map(|&i| {
                let (s, i) = (&sections[i as usize], i as usize);
                // Every section built above is a segment; any other shape gets no response.
                let (line, segment) = match s.shape {
                    Ssv::Line(l) => (l, true),
                    _ => (Lss::new(Point::origin(), Point::origin(), 0.0), false),
                };
                ContactSection {
                    a: line.a,
                    b: line.b,
                    radius: line.radius,
                    tangent: (line.b - line.a)
                        .try_normalize(0.0)
                        .unwrap_or_else(Vector::zeros),
                    node: nodes[i],
                    active: state.is_active(SkeletonId(s.skeleton)),
                    segment,
                }
            })
            .collect_into_vec(&mut self.contact_sections);
        // The narrow phase, chunk by chunk of the pair set (its chunks do not depend on the
        // thread count), into short records: the shares' two nodes, the pushes' nodes and
        // vector.
        let chunks = self.pairs.chunk_count();
        if self.responses.len() < chunks {
            self.responses.resize_with(chunks, ResponseChunk::default);
        }
        let (pairs, sections) = (&self.pairs, &self.contact_sections);
        self.responses[..chunks]
            .par_iter_mut()
            .enumerate()
            .for_each(|(chunk, out)| {
                out.shares.clear();
                out.pushes.clear();
                out.kept.clear();
                for &[a, b] in pairs.chunk(chunk) {
                    let (sa, sb) = (&sections[a as usize], &sections[b as usize]);
                    if keep && sa.segment && sb.segment {
                        out.kept.push([sa.node, sb.node]);
                    }
                    if !(sa.segment && sb.segment && (sa.active || sb.active)) {
                        continue;
                    }
                    if sa.tangent.dot(&sb.tangent).abs() >= cos_parallel {
                        out.shares.push([sa.node, sb.node]);
                        continue;
                    }
                    let c = hair_ssv::query::segment_segment(&sa.a, &sa.b, &sb.a, &sb.b);
                    let d = c.on_b - c.on_a;
                    let dist = d.norm();
                    let overlap = sa.radius + sb.radius - dist;
                    if overlap > 0.0 && dist > 1e-9 {
                        out.pushes
                            .push((sa.node, sb.node, d * (0.5 * overlap / dist)));
                    }
                }
            });
    }
}

/// One section as the hair-hair response reads it: one cache line, instead of the section, its
/// node, its direction and its skeleton's activity from four arrays.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct ContactSection {
    a: Point,
    b: Point,
    radius: Real,
    /// Unit direction (zero for a degenerate section).
    tangent: Vector,
    /// The section's end node (the one a push moves).
    node: u32,
    /// Whether its skeleton is integrated this step.
    active: bool,
    /// Whether it is a segment (the only shape the response handles).
    segment: bool,
}

/// The hair-hair narrow phase's decisions for one chunk of the pair set, in pair order.
#[derive(Debug, Default)]
struct ResponseChunk {
    /// Near-parallel sections in contact: their joints share their rates.
    shares: Vec<[u32; 2]>,
    /// Crossing sections overlapping: the second node's push, half the overlap along the line
    /// between the closest points (the first is pushed the opposite way).
    pushes: Vec<(u32, u32, Vector)>,
    /// With `collision.pair_search_interval` above 1: every pair of segments of the chunk, by
    /// their end nodes, in pair order, for the steps until the next search.
    kept: Vec<[u32; 2]>,
}

impl ResponseChunk {
    /// The narrow phase on the kept pairs at the present positions (`p`, per-node `radius`):
    /// the sections rebuilt from their end nodes as the step builds them, a pair now apart
    /// dropped, the others shared or pushed as after a search. Eight pairs at a time, in
    /// lanes with no branch, so that the loops compile to packed instructions: one pair at a
    /// time, with its divisions and branches, the test cost more than the search it replaces
    /// (28.5 ms a step against 23.5 ms on `wardlin`).
    fn retest(&mut self, state: &StrandState, p: &[Point], radius: &[Real], cos_parallel: Real) {
        const L: usize = 8;
        self.shares.clear();
        self.pushes.clear();
        let cos2 = cos_parallel * cos_parallel.abs();
        let active = |i: usize| state.is_active(SkeletonId(state.skeleton_of(i)));
        let mut block = [[0u32; 2]; L];
        for group in self.kept.chunks(L) {
            // The pairs of an active skeleton; padded with the first of them.
            let mut n = 0;
            for &pair in group {
                if active(pair[0] as usize) || active(pair[1] as usize) {
                    block[n] = pair;
                    n += 1;
                }
            }
            if n == 0 {
                continue;
            }
            for k in n..L {
                block[k] = block[0];
            }
            // The sections' ends and radii, lane by lane.
            let (mut a0, mut u, mut b0, mut v) =
                ([[0.0; L]; 3], [[0.0; L]; 3], [[0.0; L]; 3], [[0.0; L]; 3]);
            let mut radii = [0.0; L];
            for (l, &[a, b]) in block.iter().enumerate() {
                let (i, j) = (a as usize, b as usize);
                for k in 0..3 {
                    a0[k][l] = p[i - 1][k];
                    u[k][l] = p[i][k] - p[i - 1][k];
                    b0[k][l] = p[j - 1][k];
                    v[k][l] = p[j][k] - p[j - 1][k];
                }
                radii[l] = radius[i].max(radius[i - 1]) + radius[j].max(radius[j - 1]);
            }
            let mut r = [[0.0; L]; 3];
            for k in 0..3 {
                for l in 0..L {
                    r[k][l] = a0[k][l] - b0[k][l];
                }
            }
            let (s, t) = hair_ssv::segment_segment_params_lanes(&u, &v, &r);
            let (mut d, mut dist, mut parallel) = ([[0.0; L]; 3], [0.0; L], [false; L]);
            for l in 0..L {
                // From the first section's closest point to the second's.
                for k in 0..3 {
                    d[k][l] = (b0[k][l] + v[k][l] * t[l]) - (a0[k][l] + u[k][l] * s[l]);
                }
                dist[l] = (d[0][l] * d[0][l] + d[1][l] * d[1][l] + d[2][l] * d[2][l]).sqrt();
                // |cos| of the angle between them at least `cos_parallel`, without the roots; a
                // point section has no direction (its cosine is taken as 0, as the search does).
                let dot = |x: &[[Real; L]; 3], y: &[[Real; L]; 3]| {
                    x[0][l] * y[0][l] + x[1][l] * y[1][l] + x[2][l] * y[2][l]
                };
                let (a, e, b) = (dot(&u, &u), dot(&v, &v), dot(&u, &v));
                parallel[l] = (b * b >= cos2 * a * e && a > 0.0 && e > 0.0) || cos_parallel <= 0.0;
            }
            for l in 0..n {
                let overlap = radii[l] - dist[l];
                // What the search keeps: the segments within the sum of their radii.
                if overlap.is_nan() || overlap < 0.0 {
                    continue;
                }
                let [a, b] = block[l];
                if parallel[l] {
                    self.shares.push([a, b]);
                } else if overlap > 0.0 && dist[l] > 1e-9 {
                    let d = Vector::new(d[0][l], d[1][l], d[2][l]);
                    self.pushes.push((a, b, d * (0.5 * overlap / dist[l])));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hair_dynamics::{Material, Root, SkeletonDesc};
    use hair_grid::GridConfig;
    use nalgebra::Rotation3;

    /// `count` straight strands of 8 nodes rooted in a 4 cm box, each along its own direction, so that many cross and some run parallel.
    fn tangle(count: usize, seed: u64) -> StrandState {
        let mut state = StrandState::new();
        let mut rng = hair_ssv::test_meshes::SplitMix::new(seed);
        let mut unit = move || rng.unit();
        for _ in 0..count {
            let root = Point::new(unit() * 0.04, unit() * 0.04, unit() * 0.04);
            let axis = Vector::new(unit() - 0.5, unit() - 0.5, unit() - 0.5);
            let frame = Rotation3::new(axis * 2.0);
            let dir = frame * Vector::z();
            let points = (0..8).map(|k| root + dir * (0.006 * k as Real)).collect();
            state
                .add_skeleton(&SkeletonDesc {
                    root: Root::Attached {
                        position: root,
                        frame,
                    },
                    points,
                    material: Material {
                        radius: 0.002,
                        ..Material::default()
                    },
                })
                .expect("a valid strand");
        }
        state
    }

    /// The kept pairs tested again at the positions the search found them at give what the
    /// search's narrow phase gave: the same shares and the same pushes, bit for bit (the lanes
    /// compute hair-ssv's segment-segment expressions in the same order), save a pair on the
    /// edge of the parallel angle, which the lanes decide on squared cosines.
    #[test]
    fn kept_pairs_retested_where_they_were_found_respond_as_the_search_did() {
        let cos = CollisionSettings::default().parallel_angle.cos();
        let mut compared = (0, 0);
        for seed in 0..6 {
            let state = tangle(120, seed);
            let front: Vec<u32> = (0..state.skeleton_count() as u32).collect();
            let mut sections = Sections::default();
            sections.build(&state, &front);
            let mut grid = Grid::new(GridConfig::default());
            grid.rebuild(&sections.sections).expect("grid");
            let mut pairs = HairPairs::new();
            pairs.search(&state, &grid, &sections, cos, true);
            let chunks = pairs.pairs.chunk_count();
            let found: Vec<_> = pairs.responses[..chunks]
                .iter()
                .map(|r| (r.shares.clone(), r.pushes.clone()))
                .collect();
            let (p, radius) = (state.positions(), state.radius());
            for (r, (shares, pushes)) in pairs.responses[..chunks].iter_mut().zip(&found) {
                r.retest(&state, p, radius, cos);
                let bits = |v: &[(u32, u32, Vector)]| -> Vec<(u32, u32, [u32; 3])> {
                    v.iter()
                        .map(|(a, b, d)| (*a, *b, [d.x, d.y, d.z].map(f32::to_bits)))
                        .collect()
                };
                if r.shares == *shares {
                    assert_eq!(bits(&r.pushes), bits(pushes));
                } else {
                    // Only a pair on the edge of the parallel angle moves between the lists.
                    let moved = r.shares.len().abs_diff(shares.len());
                    assert!(moved <= 2 && moved == r.pushes.len().abs_diff(pushes.len()));
                }
                compared.0 += r.shares.len();
                compared.1 += r.pushes.len();
            }
        }
        assert!(compared.0 > 0 && compared.1 > 0, "{compared:?}");
    }
}
