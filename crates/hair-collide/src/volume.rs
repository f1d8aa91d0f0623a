//! Hair-hair interaction as a volume (Petrovic, Henne & Anderson 2005, "Volumetric methods for
//! simulation and rendering of hair", §3; McAdams et al. 2009 for the grid transfer): node mass
//! and momentum splatted onto a dense grid over the active hair, each node's velocity blended
//! toward the grid's velocity at its place (friction between neighbouring strands), and a push
//! down the density gradient where the hair is packed more densely than a target.
//!
//! The work runs in parallel over fixed parts of the active skeletons, and the splat into a
//! few private copies of the lattice, each over fixed parts, summed in a fixed order: every
//! lattice point adds the same numbers in the same order on any thread count, so the same bits.

use crate::{CollideError, VolumeSettings};
use hair_dynamics::{SkeletonId, StrandState};
use hair_ssv::{Point, Real, Vector};
use rayon::prelude::*;
use wide::{f32x4, f32x8};

/// Nodes per part of the skeletons (whole skeletons, so a little more): the parallel grain of
/// the gathering and the sampling, and the unit the splat's copies are cut along. A constant,
/// so that the sums' order never depends on the thread count.
const PART_NODES: usize = 4096;

/// The splat's private copies of the lattice: at most this many, and no more than one per
/// [`COPY_NODES`] nodes or per lattice's worth of nodes, so that zeroing and summing the copies
/// costs less than the splat they spare from sorting.
const MAX_COPIES: usize = 4;
const COPY_NODES: usize = 8192;

/// Lattice points are summed from the copies in this many fixed ranges (and the mean density's
/// sums with them).
const POINT_RANGES: usize = 64;

/// What one volume response did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VolumeReport {
    /// Nodes splatted and blended.
    pub nodes: usize,
    /// Grid nodes (lattice points) of the dense grid this step.
    pub cells: usize,
    /// Nodes pushed by the density repulsion.
    pub repelled: usize,
}

/// The dense grid of one step: where its lattice starts, its spacing and its size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice {
    /// The lattice point of index (0, 0, 0) (m, head frame).
    pub origin: Point,
    /// Distance between neighbouring lattice points (m).
    pub spacing: Real,
    /// Lattice points along x, y and z; point (x, y, z) has index `(z * ny + y) * nx + x`.
    pub dims: [usize; 3],
}

impl Default for Lattice {
    fn default() -> Self {
        Self {
            origin: Point::origin(),
            spacing: 1.0,
            dims: [0; 3],
        }
    }
}

/// Finds nodes' cells in one [`Lattice`], with what every look-up shares worked out once.
#[derive(Clone, Copy)]
struct Locator {
    origin: Point,
    inv_spacing: Real,
    /// The highest cell's lowest corner along each axis (`dims - 2`).
    top: f32x4,
    /// Index offsets from a lattice point to the next along y and along z.
    dy: usize,
    dz: usize,
}

impl Locator {
    fn new(lattice: &Lattice) -> Self {
        let [nx, ny, nz] = lattice.dims.map(|d| (d - 2) as Real);
        Self {
            origin: lattice.origin,
            inv_spacing: 1.0 / lattice.spacing,
            top: f32x4::new([nx, ny, nz, 0.0]),
            dy: lattice.dims[0],
            dz: lattice.dims[0] * lattice.dims[1],
        }
    }

    /// The index of the lowest corner of the cell holding `p`, and `p`'s place in that cell,
    /// each coordinate in [0, 1].
    #[inline]
    fn cell_of(&self, p: &Point) -> (usize, [Real; 3]) {
        let local = (p - self.origin) * self.inv_spacing;
        let local = f32x4::new([local.x, local.y, local.z, 0.0]);
        // Within the lattice by construction; clamped so that rounding cannot take a node on
        // the far face out of it. The cell's coordinates are small whole numbers, so they
        // convert exactly.
        let cell = local.floor().fast_max(f32x4::ZERO).fast_min(self.top);
        let frac = (local - cell).fast_max(f32x4::ZERO).fast_min(f32x4::ONE);
        let [x, y, z, _] = cell.fast_trunc_int().to_array().map(|c| c as usize);
        let [fx, fy, fz, _] = frac.to_array();
        (z * self.dz + y * self.dy + x, [fx, fy, fz])
    }
}

/// A run of whole skeletons (indices into [`HairVolume`]'s sorted skeleton list).
#[derive(Clone, Copy, Debug, Default)]
struct Part {
    start: usize,
    end: usize,
}

/// The volume model with its scratch buffers (no allocation once grown).
#[derive(Debug, Default)]
pub struct HairVolume {
    lattice: Lattice,
    /// The active skeletons of the front, ascending (their nodes but the roots are splatted).
    skeletons: Vec<u32>,
    /// The skeletons cut into parts of about [`PART_NODES`] nodes.
    parts: Vec<Part>,
    /// Nodes splatted.
    nodes: usize,
    /// Per part: bounds, summed segment length, first non-finite node.
    part_sums: Vec<PartSums>,
    /// Per lattice point: velocity (m/s, zero where no hair is) and density (kg/m³).
    points: Vec<[Real; 4]>,
    /// The splat's copies of the lattice, one after the other: mass and momentum.
    copies: Vec<[Real; 4]>,
    targets: Vec<(u32, Vector)>,
    /// The lattice's mass-weighted mean density (kg/m³): the repulsion's reference.
    mean_density: Real,
}

impl HairVolume {
    /// A model with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// The lattice of the last splat.
    pub fn lattice(&self) -> Lattice {
        self.lattice
    }

    /// The velocity (m/s; zero where no hair is) of lattice point `j` at the last splat.
    pub fn lattice_velocity(&self, j: usize) -> Option<Vector> {
        self.points.get(j).map(|p| Vector::new(p[0], p[1], p[2]))
    }

    /// The density (kg/m³) at lattice point `j` at the last splat.
    pub fn lattice_density(&self, j: usize) -> Option<Real> {
        self.points.get(j).map(|p| p[3])
    }

    /// The response: every active node's velocity blended toward the grid's and pushed out of
    /// over-dense places ([`HairVolume::blend`]), applied as the force that makes that change
    /// over the coming step ([`StrandState::add_node_forces_for_next_step`]): the step carries
    /// it to the joints through the strand model's inertia, so the friction takes energy out of
    /// the model as it does out of the nodes. Setting the velocities and fitting rates to them
    /// instead (the first form of this model) fed the model energy it never had: a velocity
    /// change at one node is met by counter-rotating neighbouring joints whose rates each carry
    /// the inertia of the whole hair beyond them.
    pub fn respond(
        &mut self,
        state: &mut StrandState,
        front: &[u32],
        settings: &VolumeSettings,
        dt: Real,
    ) -> Result<VolumeReport, CollideError> {
        self.targets.clear();
        if !self.splat_front(state, front, settings)? {
            return Ok(VolumeReport::default());
        }
        let sampler = Sampler::new(self, settings, dt);
        let inv_dt = 1.0 / dt;
        let repelled = state.add_node_forces_for_next_step(|state, forces| {
            let first = |part: &Part| state.nodes(SkeletonId(self.skeletons[part.start])).start;
            let (mass, wetness, v) = (state.mass(), state.wetness(), state.velocities());
            let parts = &self.parts;
            // Each part's nodes lie between its first skeleton's first node and the next
            // part's, so the parts split the forces into disjoint runs.
            let sample_parts = |parts: &[Part], forces: &mut [Vector], base: usize| {
                let mut repelled = 0;
                for part in parts {
                    for &s in &self.skeletons[part.start..part.end] {
                        sampler.skeleton(state, s, |i, target, pushed| {
                            let force = (target - v[i]) * ((mass[i] + wetness[i]) * inv_dt);
                            forces[i - base] += force;
                            repelled += usize::from(pushed);
                        });
                    }
                }
                repelled
            };
            split_parts(parts, forces, 0, &first, &sample_parts)
        });
        Ok(self.report(repelled))
    }

    /// The velocity each active node of `front` (its root excepted) is to take this step, into
    /// [`HairVolume::targets`], without changing the state: the splat, the blend by the friction
    /// rate over `dt` and the density repulsion.
    pub fn blend(
        &mut self,
        state: &StrandState,
        front: &[u32],
        settings: &VolumeSettings,
        dt: Real,
    ) -> Result<VolumeReport, CollideError> {
        self.targets.clear();
        if !self.splat_front(state, front, settings)? {
            return Ok(VolumeReport::default());
        }
        let mut targets = std::mem::take(&mut self.targets);
        let sampler = Sampler::new(self, settings, dt);
        let mut repelled = 0;
        for &s in &self.skeletons {
            sampler.skeleton(state, s, |i, target, pushed| {
                targets.push((i as u32, target));
                repelled += usize::from(pushed);
            });
        }
        self.targets = targets;
        Ok(self.report(repelled))
    }

    fn report(&self, repelled: usize) -> VolumeReport {
        VolumeReport {
            nodes: self.nodes,
            cells: self.points.len(),
            repelled,
        }
    }

    /// The velocities of the last [`HairVolume::blend`], by node.
    pub fn targets(&self) -> &[(u32, Vector)] {
        &self.targets
    }

    /// Gathers the front's active skeletons, places the lattice over them and splats them;
    /// false when there is no node to splat.
    fn splat_front(
        &mut self,
        state: &StrandState,
        front: &[u32],
        settings: &VolumeSettings,
    ) -> Result<bool, CollideError> {
        let Some((lo, hi, mean_length)) = self.gather(state, front)? else {
            self.lattice = Lattice::default();
            self.points.clear();
            return Ok(false);
        };
        self.lattice = lattice_over(lo, hi, settings.cell_size * mean_length, settings.max_cells);
        self.splat(state);
        Ok(true)
    }

    /// Lists the active skeletons and cuts them into parts; returns the bounds of their nodes'
    /// positions and their mean segment length, or `None` when there is no node.
    fn gather(
        &mut self,
        state: &StrandState,
        front: &[u32],
    ) -> Result<Option<(Point, Point, Real)>, CollideError> {
        self.skeletons.clear();
        self.skeletons.extend(
            front.iter().copied().filter(|&s| {
                state.is_active(SkeletonId(s)) && state.nodes(SkeletonId(s)).len() > 1
            }),
        );
        // Ascending, each once, so that the parts own disjoint runs of nodes.
        self.skeletons.sort_unstable();
        self.skeletons.dedup();
        self.parts.clear();
        self.nodes = 0;
        let mut part = Part::default();
        let mut in_part = 0;
        for (k, &s) in self.skeletons.iter().enumerate() {
            let n = state.nodes(SkeletonId(s)).len() - 1;
            self.nodes += n;
            in_part += n;
            if in_part >= PART_NODES {
                part.end = k + 1;
                self.parts.push(part);
                part.start = k + 1;
                in_part = 0;
            }
        }
        if in_part > 0 {
            part.end = self.skeletons.len();
            self.parts.push(part);
        }
        if self.nodes == 0 {
            return Ok(None);
        }
        let (p, v, length) = (state.positions(), state.velocities(), state.length());
        let skeletons = &self.skeletons;
        self.parts
            .par_iter()
            .map(|part| {
                let mut sums = PartSums::default();
                // Without a branch a node: a non-finite coordinate makes its product with zero
                // NaN, and then the part is searched again for the first such node.
                let mut finite = true;
                for &s in &skeletons[part.start..part.end] {
                    let r = state.nodes(SkeletonId(s));
                    for i in r.start + 1..r.end {
                        let (q, u) = (p[i], v[i]);
                        let zero = q.coords * 0.0 + u * 0.0;
                        finite &= (zero.x == 0.0) & (zero.y == 0.0) & (zero.z == 0.0);
                        sums.lo = sums.lo.inf(&q);
                        sums.hi = sums.hi.sup(&q);
                        sums.length += f64::from(length[i]);
                    }
                }
                if !finite {
                    let finite = |x: &Real| x.is_finite();
                    sums.non_finite = skeletons[part.start..part.end]
                        .iter()
                        .flat_map(|&s| state.nodes(SkeletonId(s)).skip(1))
                        .find(|&i| !(p[i].coords.iter().all(finite) && v[i].iter().all(finite)));
                }
                sums
            })
            .collect_into_vec(&mut self.part_sums);
        // In part order: the first non-finite node, and the same sum on any thread count.
        let mut total = PartSums::default();
        for c in &self.part_sums {
            if let Some(node) = c.non_finite {
                return Err(CollideError::NonFiniteNode { node });
            }
            total.lo = total.lo.inf(&c.lo);
            total.hi = total.hi.sup(&c.hi);
            total.length += c.length;
        }
        let mean = (total.length / self.nodes as f64) as Real;
        // A front of zero-length segments still gets a grid of some size.
        let mean = if mean > 0.0 { mean } else { 1e-3 };
        Ok(Some((total.lo, total.hi, mean)))
    }

    /// Mass and momentum onto the lattice, then each point's velocity and density. Each copy
    /// of the lattice takes a fixed run of parts, its nodes in order; the copies are summed in
    /// order.
    fn splat(&mut self, state: &StrandState) {
        let lattice = self.lattice;
        let len = lattice.dims.iter().product::<usize>();
        let copies = (self.nodes / COPY_NODES)
            .min(self.nodes / len.max(1))
            .clamp(1, MAX_COPIES);
        // Only what a resize adds is written by it; the copies are zeroed in parallel below.
        self.copies.resize(copies * len, [0.0; 4]);
        self.points.resize(len, [0.0; 4]);
        let (p, v, mass) = (state.positions(), state.velocities(), state.mass());
        let (parts, skeletons) = (&self.parts, &self.skeletons);
        let locator = Locator::new(&lattice);
        let (dy, dz) = (locator.dy, locator.dz);
        self.copies
            .par_chunks_mut(len)
            .enumerate()
            .for_each(|(c, grid)| {
                grid.fill([0.0; 4]);
                let own = &parts[c * parts.len() / copies..(c + 1) * parts.len() / copies];
                for part in own {
                    for &s in &skeletons[part.start..part.end] {
                        let r = state.nodes(SkeletonId(s));
                        for i in r.start + 1..r.end {
                            let (base, frac) = locator.cell_of(&p[i]);
                            let cell = CellWeights::new(&frac);
                            let (m, u) = (mass[i], v[i] * mass[i]);
                            // Mass and momentum twice over, times the weights along x, added to
                            // the cell's four rows (pairs of points along x).
                            let share = f32x8::new([m, u.x, u.y, u.z, m, u.x, u.y, u.z]) * cell.x;
                            let (low, high) = grid[base..].split_at_mut(dz);
                            let halves = [(&mut low[..dy + 2], 0), (&mut high[..dy + 2], 2)];
                            for (half, k) in halves {
                                let (near, far) = half.split_at_mut(dy);
                                let (near, far) = (&mut near[..2], &mut far[..2]);
                                store_pair(near, load_pair(near) + share * cell.yz[k]);
                                store_pair(far, load_pair(far) + share * cell.yz[k + 1]);
                            }
                        }
                    }
                }
            });
        let inv_volume = 1.0 / lattice.spacing.powi(3);
        // The mean density's sums per fixed range, then in range order: the same on any
        // thread count.
        let mut sums = [(0.0f64, 0.0f64); POINT_RANGES];
        let range = len.div_ceil(POINT_RANGES).max(1);
        let copies_of = &self.copies;
        self.points
            .par_chunks_mut(range)
            .zip(sums.par_iter_mut())
            .enumerate()
            .for_each(|(k, (points, (m1, m2)))| {
                for (j, out) in (k * range..).zip(points.iter_mut()) {
                    let mut s = copies_of[j];
                    for c in 1..copies {
                        let t = copies_of[c * len + j];
                        for (a, b) in s.iter_mut().zip(t) {
                            *a += b;
                        }
                    }
                    let m = s[0];
                    *m1 += f64::from(m);
                    *m2 += f64::from(m) * f64::from(m);
                    *out = if m > 0.0 {
                        [s[1] / m, s[2] / m, s[3] / m, m * inv_volume]
                    } else {
                        [0.0; 4]
                    };
                }
            });
        let (m1, m2) = sums
            .iter()
            .fold((0.0f64, 0.0f64), |(a, b), (m1, m2)| (a + m1, b + m2));
        self.mean_density = if m1 > 0.0 {
            (m2 * f64::from(inv_volume) / m1) as Real
        } else {
            0.0
        };
    }

    /// The lattice's mass-weighted mean density at the last splat (kg/m³): the density a unit
    /// of the hair's mass sits in, on average.
    pub fn mean_density(&self) -> Real {
        self.mean_density
    }
}

/// Runs `sample` on runs of `parts` in parallel, each with the run of `forces` its nodes lie
/// in (`forces[0]` is node `base`; `first` gives a part's first node), and adds up what they
/// return.
fn split_parts<F, S>(
    parts: &[Part],
    forces: &mut [Vector],
    base: usize,
    first: &F,
    sample: &S,
) -> usize
where
    F: Fn(&Part) -> usize + Sync,
    S: Fn(&[Part], &mut [Vector], usize) -> usize + Sync,
{
    if parts.len() <= 1 {
        return sample(parts, forces, base);
    }
    let mid = parts.len() / 2;
    let at = first(&parts[mid]);
    let (left, right) = forces.split_at_mut(at - base);
    let (a, b) = rayon::join(
        || split_parts(&parts[..mid], left, base, first, sample),
        || split_parts(&parts[mid..], right, at, first, sample),
    );
    a + b
}

/// The sampling of one step: each node's velocity blended toward the lattice's at its place,
/// plus the repulsion.
struct Sampler<'a> {
    locator: Locator,
    points: &'a [[Real; 4]],
    /// The repulsion's density target (kg/m³), whether it acts, and its speed (m/s).
    target: Real,
    near_target: Real,
    repulsion: bool,
    speed: Real,
    /// The friction rates at the root and the tip (1/s), and the step (s).
    root_rate: Real,
    tip_rate: Real,
    dt: Real,
}

impl<'a> Sampler<'a> {
    fn new(volume: &'a HairVolume, settings: &VolumeSettings, dt: Real) -> Self {
        let lattice = volume.lattice;
        let target = settings.density_limit * volume.mean_density;
        Self {
            locator: Locator::new(&lattice),
            points: &volume.points,
            target,
            near_target: target * (1.0 - 1e-4),
            repulsion: settings.repulsion && target > 0.0,
            speed: settings.repulsion_rate * lattice.spacing,
            root_rate: settings.friction_root.max(0.0),
            tip_rate: settings.friction_tip.max(0.0),
            dt,
        }
    }

    /// Calls `out(node, velocity, pushed)` for every node of skeleton `s` but its root, root
    /// to tip.
    #[inline]
    fn skeleton(&self, state: &StrandState, s: u32, mut out: impl FnMut(usize, Vector, bool)) {
        let (p, v) = (state.positions(), state.velocities());
        let r = state.nodes(SkeletonId(s));
        let last = (r.len().max(2) - 1) as Real;
        // The rate is linear in the node's index, so `exp(-rate dt)` is geometric in it: two
        // exponentials a skeleton instead of one a node.
        let step = (-(self.tip_rate - self.root_rate) * self.dt / last).exp();
        let mut decay = (-self.root_rate * self.dt).exp();
        let (dy, dz) = (self.locator.dy, self.locator.dz);
        for i in r.start + 1..r.end {
            decay *= step;
            let alpha = (1.0 - decay).clamp(0.0, 1.0);
            let (base, frac) = self.locator.cell_of(&p[i]);
            let cell = CellWeights::new(&frac);
            // Velocity and density side by side, a pair of corners along x at once: the four
            // rows weighted along y and z, then the two ends along x, then the ends summed.
            // The densest corner too.
            let mut sum = f32x8::ZERO;
            let mut densest = f32x8::ZERO;
            let halves = [
                (&self.points[base..base + dy + 2], 0),
                (&self.points[base + dz..base + dz + dy + 2], 2),
            ];
            for (half, k) in halves {
                for (pair, w) in [
                    (&half[..2], cell.yz[k]),
                    (&half[dy..dy + 2], cell.yz[k + 1]),
                ] {
                    let pair = load_pair(pair);
                    sum += pair * w;
                    densest = densest.fast_max(pair);
                }
            }
            let [x0, y0, z0, _, x1, y1, z1, _] = (sum * cell.x).to_array();
            let densest = densest.to_array();
            let grid = Vector::new(x0 + x1, y0 + y1, z0 + z1);
            let own = v[i];
            let mut blended = own + (grid - own) * alpha;
            let mut pushed = false;
            // The density at the node is a weighted mean of its corners' (weights summing to
            // one within rounding, which the margin covers): where none comes near the target,
            // it does not exceed it, and the gradient is not needed.
            if self.repulsion && densest[3].max(densest[7]) > self.near_target {
                let d = corner_offsets(dy, dz).map(|o| self.points[base + o][3]);
                let (rho, gradient) = density_and_gradient(&d, &frac, self.locator.inv_spacing);
                let norm = gradient.norm();
                if rho > self.target && norm > 0.0 {
                    // Decompress only: out of the over-dense place, never into a thin one.
                    let excess = ((rho - self.target) / self.target).min(1.0);
                    blended -= gradient * (self.speed * excess / norm);
                    pushed = true;
                }
            }
            out(i, blended, pushed);
        }
    }
}

/// The lattice over `lo..hi` with spacing `spacing` (widened until it has at most `max_points`
/// points), with one point to spare beyond `hi` on each axis.
fn lattice_over(lo: Point, hi: Point, spacing: Real, max_points: u32) -> Lattice {
    let extent = hi - lo;
    let mut spacing = if spacing.is_finite() && spacing > 0.0 {
        spacing
    } else {
        1e-3
    };
    let max_points = (max_points as usize).max(8);
    loop {
        let dims = extent.map(|e| (e / spacing).floor() as usize + 2);
        let points = dims.iter().product::<usize>();
        if points <= max_points && dims.iter().all(|&d| d < u32::MAX as usize / 4) {
            return Lattice {
                origin: lo,
                spacing,
                dims: [dims[0], dims[1], dims[2]],
            };
        }
        // Widened in proportion, plus a little, until the points fit.
        let ratio = (points as f64 / max_points as f64).cbrt().max(1.01) as Real;
        spacing *= ratio * 1.01;
    }
}

/// One part's share of the gathering: bounds, summed segment length (m) and its first
/// non-finite node.
#[derive(Clone, Copy, Debug)]
struct PartSums {
    lo: Point,
    hi: Point,
    length: f64,
    non_finite: Option<usize>,
}

impl Default for PartSums {
    fn default() -> Self {
        Self {
            lo: Point::from([Real::MAX; 3]),
            hi: Point::from([Real::MIN; 3]),
            length: 0.0,
            non_finite: None,
        }
    }
}

/// A cell's trilinear weights as the splat and the sampling take them: a pair of corners
/// along x at a time, each pair a row of the cell.
struct CellWeights {
    /// The weights along x, of the low corner in lanes 0-3 and the high one in lanes 4-7.
    x: f32x8,
    /// The rows' weights along y and z: rows at (y, z), (y + 1, z), (y, z + 1), (y + 1, z + 1).
    yz: [f32x8; 4],
}

impl CellWeights {
    #[inline]
    fn new(f: &[Real; 3]) -> Self {
        let [x, y, z] = *f;
        let (a, b, c) = (1.0 - x, 1.0 - y, 1.0 - z);
        Self {
            x: f32x8::new([a, a, a, a, x, x, x, x]),
            yz: [b * c, y * c, b * z, y * z].map(f32x8::splat),
        }
    }
}

/// Two neighbouring lattice points as lanes.
#[inline(always)]
fn load_pair(pair: &[[Real; 4]]) -> f32x8 {
    let (a, b) = (pair[0], pair[1]);
    f32x8::new([a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]])
}

#[inline(always)]
fn store_pair(pair: &mut [[Real; 4]], lanes: f32x8) {
    let x = lanes.to_array();
    pair[0] = [x[0], x[1], x[2], x[3]];
    pair[1] = [x[4], x[5], x[6], x[7]];
}

/// Index offsets of a cell's eight corners from its lowest one.
#[inline]
fn corner_offsets(dy: usize, dz: usize) -> [usize; 8] {
    [0, 1, dy, dy + 1, dz, dz + 1, dz + dy, dz + dy + 1]
}

/// The trilinear density at a node's place and its gradient (kg/m⁴), from the densities at its
/// cell's corners ([`corner_offsets`] order) and its place in the cell.
#[inline]
fn density_and_gradient(d: &[Real; 8], frac: &[Real; 3], inv_spacing: Real) -> (Real, Vector) {
    let [x, y, z] = *frac;
    let (a, b, c) = (1.0 - x, 1.0 - y, 1.0 - z);
    let weights = [
        a * b * c,
        x * b * c,
        a * y * c,
        x * y * c,
        a * b * z,
        x * b * z,
        a * y * z,
        x * y * z,
    ];
    let rho = weights.iter().zip(d).map(|(w, d)| w * d).sum::<Real>();
    // Differences along each axis, bilinear in the other two.
    let lerp = |a: Real, b: Real, t: Real| a + (b - a) * t;
    let gx = lerp(
        lerp(d[1] - d[0], d[3] - d[2], y),
        lerp(d[5] - d[4], d[7] - d[6], y),
        z,
    );
    let gy = lerp(
        lerp(d[2] - d[0], d[3] - d[1], x),
        lerp(d[6] - d[4], d[7] - d[5], x),
        z,
    );
    let gz = lerp(
        lerp(d[4] - d[0], d[5] - d[1], x),
        lerp(d[6] - d[2], d[7] - d[3], x),
        y,
    );
    (rho, Vector::new(gx, gy, gz) * inv_spacing)
}
