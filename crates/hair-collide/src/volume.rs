//! Hair-hair interaction as a volume (Petrovic, Henne & Anderson 2005, "Volumetric methods for
//! simulation and rendering of hair", §3; McAdams et al. 2009 for the grid transfer): node mass
//! and momentum splatted onto a dense grid over the active hair, each node's velocity blended
//! toward the grid's velocity at its place (friction between neighbouring strands), and a push
//! down the density gradient where the hair is packed more densely than a target.
//!
//! The splat runs in parallel over slabs of grid planes, each slab's nodes in a fixed order
//! and the slabs in a fixed two-phase order, so every lattice point adds the same numbers in
//! the same order on any thread count: the same bits.

use crate::{CollideError, VolumeSettings};
use hair_dynamics::{SkeletonId, StrandState};
use hair_ssv::{Point, Real, Vector};
use rayon::prelude::*;

/// Slabs of grid planes the splat is cut into: the parallel grain. It fixes the order of the
/// sums, so it is a constant, never the thread count.
const SLABS: usize = 16;

/// Nodes per chunk of the gathering's sums and of the sort by slab: a constant, so that the
/// segment lengths add in the same order on any thread count.
const CHUNK: usize = 4096;

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

/// Where a node falls in the lattice: the index of its cell's lowest corner and its fractional
/// place in the cell, each in [0, 1].
#[derive(Clone, Copy, Debug, Default)]
struct Corner {
    base: u32,
    z: u32,
    frac: [Real; 3],
}

/// The volume model with its scratch buffers (no allocation once grown).
#[derive(Debug, Default)]
pub struct HairVolume {
    lattice: Lattice,
    /// The nodes splatted (every node of an active skeleton but its root), skeleton by
    /// skeleton in front order.
    nodes: Vec<u32>,
    /// Per chunk of [`CHUNK`] nodes: bounds, summed segment length, first non-finite node.
    chunk_sums: Vec<ChunkSums>,
    /// Each listed node's blend fraction this step, `1 - exp(-rate dt)`, the rate (1/s) from
    /// the root-to-tip profile.
    alpha: Vec<Real>,
    corners: Vec<Corner>,
    /// Node slots (into `nodes`), each chunk of [`CHUNK`] slots ordered by slab within the
    /// chunk; per chunk, where each slab's run starts (`slabs + 1` entries, from the chunk's
    /// start). Slab `s`'s nodes in slot order are the chunks' runs of `s` in chunk order.
    order: Vec<u32>,
    chunk_runs: Vec<u32>,
    /// Per lattice point: mass and momentum while splatting, then velocity (m/s, zero where no
    /// hair is) and density (kg/m³).
    points: Vec<[Real; 4]>,
    /// Per node, whether the repulsion pushed it.
    pushed: Vec<bool>,
    targets: Vec<(u32, Vector)>,
    /// The forces that make the targets' changes over a step.
    forces: Vec<(u32, Vector)>,
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
    /// over the coming step ([`StrandState::add_forces_for_next_step`]): the step carries it to
    /// the joints through the strand model's inertia, so the friction takes energy out of the
    /// model as it does out of the nodes. Setting the velocities and fitting rates to them
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
        let report = self.blend_nodes(state, front, settings, dt, Output::Forces)?;
        state.add_forces_for_next_step(&self.forces)?;
        Ok(report)
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
        self.blend_nodes(state, front, settings, dt, Output::Targets)
    }

    /// [`HairVolume::blend`] into `targets`, or into `forces` as [`HairVolume::respond`] takes
    /// them.
    fn blend_nodes(
        &mut self,
        state: &StrandState,
        front: &[u32],
        settings: &VolumeSettings,
        dt: Real,
        output: Output,
    ) -> Result<VolumeReport, CollideError> {
        self.targets.clear();
        self.forces.clear();
        let Some((lo, hi, mean_length)) = self.gather(state, front, settings, dt)? else {
            self.lattice = Lattice::default();
            self.points.clear();
            self.pushed.clear();
            return Ok(VolumeReport::default());
        };
        self.lattice = lattice_over(lo, hi, settings.cell_size * mean_length, settings.max_cells);
        self.place(state);
        self.splat(state);
        self.sample(state, settings, dt, output);
        Ok(VolumeReport {
            nodes: self.nodes.len(),
            cells: self.points.len(),
            repelled: self.pushed.par_iter().filter(|&&p| p).count(),
        })
    }

    /// The velocities of the last [`HairVolume::blend`], by node.
    pub fn targets(&self) -> &[(u32, Vector)] {
        &self.targets
    }

    /// Lists the nodes and their blend fractions over `dt`; returns the bounds of their
    /// positions and their mean segment length, or `None` when there is no node.
    fn gather(
        &mut self,
        state: &StrandState,
        front: &[u32],
        settings: &VolumeSettings,
        dt: Real,
    ) -> Result<Option<(Point, Point, Real)>, CollideError> {
        self.nodes.clear();
        self.alpha.clear();
        let (root, tip) = (
            settings.friction_root.max(0.0),
            settings.friction_tip.max(0.0),
        );
        for &s in front {
            let id = SkeletonId(s);
            if !state.is_active(id) {
                continue;
            }
            let r = state.nodes(id);
            let last = (r.len().max(2) - 1) as Real;
            self.nodes.extend((r.start + 1..r.end).map(|i| i as u32));
            // The rate is linear in the node's index, so `exp(-rate dt)` is geometric in it:
            // two exponentials a skeleton instead of one a node.
            let step = (-(tip - root) * dt / last).exp();
            let mut decay = (-root * dt).exp();
            self.alpha.extend((1..r.len()).map(|_| {
                decay *= step;
                (1.0 - decay).clamp(0.0, 1.0)
            }));
        }
        if self.nodes.is_empty() {
            return Ok(None);
        }
        let (p, v, length) = (state.positions(), state.velocities(), state.length());
        self.nodes
            .par_chunks(CHUNK)
            .map(|chunk| {
                let mut sums = ChunkSums::default();
                for &i in chunk {
                    let i = i as usize;
                    if !(p[i].coords.iter().all(|x| x.is_finite())
                        && v[i].iter().all(|x| x.is_finite()))
                    {
                        sums.non_finite.get_or_insert(i);
                        continue;
                    }
                    sums.lo = sums.lo.inf(&p[i]);
                    sums.hi = sums.hi.sup(&p[i]);
                    sums.length += f64::from(length[i]);
                }
                sums
            })
            .collect_into_vec(&mut self.chunk_sums);
        // In chunk order: the first non-finite node in front order, and the same sum on any
        // thread count.
        let mut total = ChunkSums::default();
        for c in &self.chunk_sums {
            if let Some(node) = c.non_finite {
                return Err(CollideError::NonFiniteNode { node });
            }
            total.lo = total.lo.inf(&c.lo);
            total.hi = total.hi.sup(&c.hi);
            total.length += c.length;
        }
        let mean = (total.length / self.nodes.len() as f64) as Real;
        // A front of zero-length segments still gets a grid of some size.
        let mean = if mean > 0.0 { mean } else { 1e-3 };
        Ok(Some((total.lo, total.hi, mean)))
    }

    /// Each node's cell and place in it, and the nodes ordered by slab of planes: a counting
    /// sort within each chunk of slots, the chunks in parallel.
    fn place(&mut self, state: &StrandState) {
        let Lattice {
            origin,
            spacing,
            dims,
        } = self.lattice;
        let p = state.positions();
        let inv = 1.0 / spacing;
        let thickness = slab_thickness(dims[2]);
        let slabs = dims[2].div_ceil(thickness);
        let n = self.nodes.len();
        self.corners.resize(n, Corner::default());
        self.order.resize(n, 0);
        self.chunk_runs.resize(n.div_ceil(CHUNK) * (slabs + 1), 0);
        self.nodes
            .par_chunks(CHUNK)
            .zip(self.corners.par_chunks_mut(CHUNK))
            .zip(self.order.par_chunks_mut(CHUNK))
            .zip(self.chunk_runs.par_chunks_mut(slabs + 1))
            .enumerate()
            .for_each(|(k, (((nodes, corners), order), runs))| {
                runs.fill(0);
                for (&i, corner) in nodes.iter().zip(corners.iter_mut()) {
                    let local = (p[i as usize] - origin) * inv;
                    let mut cell = [0u32; 3];
                    let mut frac = [0.0; 3];
                    for a in 0..3 {
                        // Within the lattice by construction; clamped so that rounding cannot
                        // take a node on the far face out of it.
                        let c = (local[a].floor().max(0.0) as usize).min(dims[a] - 2);
                        cell[a] = c as u32;
                        frac[a] = (local[a] - c as Real).clamp(0.0, 1.0);
                    }
                    let [x, y, z] = cell.map(|c| c as usize);
                    *corner = Corner {
                        base: ((z * dims[1] + y) * dims[0] + x) as u32,
                        z: cell[2],
                        frac,
                    };
                    runs[z / thickness + 1] += 1;
                }
                for s in 1..=slabs {
                    runs[s] += runs[s - 1];
                }
                // `runs[s]` runs through slab `s`'s places; the starts are put back after.
                let first = (k * CHUNK) as u32;
                for (j, c) in corners.iter().enumerate() {
                    let s = c.z as usize / thickness;
                    order[runs[s] as usize] = first + j as u32;
                    runs[s] += 1;
                }
                for s in (1..=slabs).rev() {
                    runs[s] = runs[s - 1];
                }
                runs[0] = 0;
            });
    }

    /// Mass and momentum onto the lattice, then each point's velocity and density.
    fn splat(&mut self, state: &StrandState) {
        let dims = self.lattice.dims;
        self.points.clear();
        self.points.resize(dims[0] * dims[1] * dims[2], [0.0; 4]);
        let thickness = slab_thickness(dims[2]);
        let slabs = dims[2].div_ceil(thickness);
        let slab_len = thickness * dims[0] * dims[1];
        let (v, mass) = (state.velocities(), state.mass());
        let (nodes, corners, order, runs) =
            (&self.nodes, &self.corners, &self.order, &self.chunk_runs);
        // A slab's nodes write its planes and the first plane of the next slab: even slabs
        // in parallel, then odd ones, each over its own two slabs of the lattice.
        let splat_slab = |slab: usize, chunk: &mut [[Real; 4]]| {
            if slab >= slabs {
                return;
            }
            let offset = slab * slab_len;
            for (k, run) in runs.chunks_exact(slabs + 1).enumerate() {
                let first = k * CHUNK;
                let slots = &order[first + run[slab] as usize..first + run[slab + 1] as usize];
                for &slot in slots {
                    let (i, c) = (nodes[slot as usize] as usize, &corners[slot as usize]);
                    let m = mass[i];
                    let share = [m, v[i].x * m, v[i].y * m, v[i].z * m];
                    for (w, corner) in weights(&c.frac).into_iter().zip(corner_offsets(dims)) {
                        let point = &mut chunk[c.base as usize + corner - offset];
                        for (sum, x) in point.iter_mut().zip(share) {
                            *sum += x * w;
                        }
                    }
                }
            }
        };
        if slab_len > 0 {
            self.points
                .par_chunks_mut(2 * slab_len)
                .enumerate()
                .for_each(|(c, chunk)| splat_slab(2 * c, chunk));
            let odd = self.points.len().min(slab_len);
            self.points[odd..]
                .par_chunks_mut(2 * slab_len)
                .enumerate()
                .for_each(|(c, chunk)| splat_slab(2 * c + 1, chunk));
        }
        let inv_volume = 1.0 / self.lattice.spacing.powi(3);
        // In lattice order, serially: the same sum on any thread count.
        let (mut m2, mut m1) = (0.0f64, 0.0f64);
        for s in &self.points {
            let m = f64::from(s[0]);
            m2 += m * m;
            m1 += m;
        }
        self.mean_density = if m1 > 0.0 {
            (m2 * f64::from(inv_volume) / m1) as Real
        } else {
            0.0
        };
        self.points.par_iter_mut().for_each(|s| {
            let m = s[0];
            *s = if m > 0.0 {
                [s[1] / m, s[2] / m, s[3] / m, m * inv_volume]
            } else {
                [0.0; 4]
            };
        });
    }

    /// The lattice's mass-weighted mean density at the last splat (kg/m³): the density a unit
    /// of the hair's mass sits in, on average.
    pub fn mean_density(&self) -> Real {
        self.mean_density
    }

    /// Each node's velocity blended toward the lattice's at its place, plus the repulsion, into
    /// `targets`, or as the force that makes the change over `dt` into `forces`.
    fn sample(&mut self, state: &StrandState, settings: &VolumeSettings, dt: Real, output: Output) {
        let dims = self.lattice.dims;
        let inv_spacing = 1.0 / self.lattice.spacing;
        let v = state.velocities();
        let points = &self.points;
        let target = settings.density_limit * self.mean_density;
        let repulsion = settings.repulsion && target > 0.0;
        let speed = settings.repulsion_rate * self.lattice.spacing;
        let blend = |((&i, c), &alpha): ((&u32, &Corner), &Real)| {
            let ws = weights(&c.frac);
            let corner = corner_offsets(dims).map(|o| points[c.base as usize + o]);
            let mut grid = Vector::zeros();
            for (w, p) in ws.iter().zip(&corner) {
                grid += Vector::new(p[0], p[1], p[2]) * *w;
            }
            let own = v[i as usize];
            let mut out = own + (grid - own) * alpha;
            let mut pushed = false;
            if repulsion {
                let d = corner.map(|p| p[3]);
                let (rho, gradient) = density_and_gradient(&d, &ws, &c.frac, inv_spacing);
                let norm = gradient.norm();
                if rho > target && norm > 0.0 {
                    // Decompress only: out of the over-dense place, never into a thin one.
                    let excess = ((rho - target) / target).min(1.0);
                    out -= gradient * (speed * excess / norm);
                    pushed = true;
                }
            }
            ((i, out), pushed)
        };
        let nodes = self.nodes.par_iter().zip(&self.corners).zip(&self.alpha);
        match output {
            Output::Targets => nodes
                .map(blend)
                .unzip_into_vecs(&mut self.targets, &mut self.pushed),
            Output::Forces => {
                let (mass, wetness) = (state.mass(), state.wetness());
                nodes
                    .map(blend)
                    .map(|((i, target), pushed)| {
                        let n = i as usize;
                        let force = (target - v[n]) * ((mass[n] + wetness[n]) / dt);
                        ((i, force), pushed)
                    })
                    .unzip_into_vecs(&mut self.forces, &mut self.pushed)
            }
        }
    }
}

/// What the blend writes: the velocities ([`HairVolume::blend`]) or the forces
/// ([`HairVolume::respond`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Output {
    Targets,
    Forces,
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

/// Planes per slab: at least two, so that a slab's nodes reach only the next slab.
fn slab_thickness(planes: usize) -> usize {
    planes.div_ceil(SLABS).max(2)
}

/// One chunk's share of the gathering: bounds, summed segment length (m) and its first
/// non-finite node.
#[derive(Clone, Copy, Debug)]
struct ChunkSums {
    lo: Point,
    hi: Point,
    length: f64,
    non_finite: Option<usize>,
}

impl Default for ChunkSums {
    fn default() -> Self {
        Self {
            lo: Point::from([Real::MAX; 3]),
            hi: Point::from([Real::MIN; 3]),
            length: 0.0,
            non_finite: None,
        }
    }
}

/// The trilinear weights of the cell's eight corners, in [`corner_offsets`] order.
#[inline]
fn weights(f: &[Real; 3]) -> [Real; 8] {
    let [x, y, z] = *f;
    let (a, b, c) = (1.0 - x, 1.0 - y, 1.0 - z);
    [
        a * b * c,
        x * b * c,
        a * y * c,
        x * y * c,
        a * b * z,
        x * b * z,
        a * y * z,
        x * y * z,
    ]
}

/// Index offsets of a cell's eight corners from its lowest one.
#[inline]
fn corner_offsets(dims: [usize; 3]) -> [usize; 8] {
    let (dy, dz) = (dims[0], dims[0] * dims[1]);
    [0, 1, dy, dy + 1, dz, dz + 1, dz + dy, dz + dy + 1]
}

/// The trilinear density at a node's place and its gradient (kg/m⁴), from the densities at its
/// cell's corners and their weights.
#[inline]
fn density_and_gradient(
    d: &[Real; 8],
    weights: &[Real; 8],
    frac: &[Real; 3],
    inv_spacing: Real,
) -> (Real, Vector) {
    let [x, y, z] = *frac;
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
