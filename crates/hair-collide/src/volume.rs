//! Hair-hair interaction as a volume (Petrovic, Henne & Anderson 2005, "Volumetric methods for
//! simulation and rendering of hair", §3; McAdams et al. 2009 for the grid transfer): node mass
//! and momentum splatted onto a dense grid over the active hair, each node's velocity blended
//! toward the grid's velocity at its place (friction between neighbouring strands), and a push
//! down the density gradient where the hair is packed more densely than a target.
//!
//! Sums over nodes are order-independent: each node's share is rounded to a fixed-point integer
//! (a power-of-two scale chosen from the step's largest value, so the rounding is relative) and
//! integers add exactly in any order. The splat runs in parallel over slabs of grid planes; any
//! thread count gives the same bits.

use crate::{CollideError, VolumeSettings};
use hair_dynamics::{SkeletonId, StrandState};
use hair_ssv::{Point, Real, Vector};
use rayon::prelude::*;

/// Slabs of grid planes the splat is cut into: the parallel grain (the result does not depend
/// on it, the integers add exactly).
const SLABS: usize = 16;

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
    /// Each listed node's friction rate (1/s), from the root-to-tip profile.
    rate: Vec<Real>,
    corners: Vec<Corner>,
    /// Node slots (into `nodes`) ordered by slab, and where each slab's run starts.
    order: Vec<u32>,
    slab_start: Vec<u32>,
    /// Per lattice point: mass and momentum in fixed point.
    sums: Vec<[i64; 4]>,
    /// Per lattice point: velocity (m/s) and density (kg/m³).
    velocity: Vec<Vector>,
    density: Vec<Real>,
    /// The blended velocities and whether the repulsion pushed the node.
    blended: Vec<(Vector, bool)>,
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

    /// Per lattice point of the last splat: its velocity (m/s; zero where no hair is).
    pub fn lattice_velocity(&self) -> &[Vector] {
        &self.velocity
    }

    /// Per lattice point of the last splat: its density (kg/m³).
    pub fn lattice_density(&self) -> &[Real] {
        &self.density
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
        let report = self.blend(state, front, settings, dt)?;
        let (mass, wetness, velocity) = (state.mass(), state.wetness(), state.velocities());
        self.forces.clear();
        self.forces.extend(self.targets.iter().map(|&(i, target)| {
            let n = i as usize;
            (i, (target - velocity[n]) * ((mass[n] + wetness[n]) / dt))
        }));
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
        self.targets.clear();
        let Some((lo, hi, mean_length, max_mass, max_momentum)) =
            self.gather(state, front, settings)?
        else {
            self.lattice = Lattice::default();
            self.velocity.clear();
            self.density.clear();
            return Ok(VolumeReport::default());
        };
        self.lattice = lattice_over(lo, hi, settings.cell_size * mean_length, settings.max_cells);
        self.place(state);
        self.splat(state, max_mass, max_momentum);
        self.sample(state, settings, dt);
        self.targets.extend(
            self.nodes
                .iter()
                .zip(&self.blended)
                .map(|(&i, &(v, _))| (i, v)),
        );
        Ok(VolumeReport {
            nodes: self.nodes.len(),
            cells: self.velocity.len(),
            repelled: self.blended.iter().filter(|b| b.1).count(),
        })
    }

    /// The velocities of the last [`HairVolume::blend`], by node.
    pub fn targets(&self) -> &[(u32, Vector)] {
        &self.targets
    }

    /// Lists the nodes and their rates; returns the bounds of their positions, their mean
    /// segment length, their largest mass and largest momentum component, or `None` when there
    /// is no node.
    #[allow(clippy::type_complexity)]
    fn gather(
        &mut self,
        state: &StrandState,
        front: &[u32],
        settings: &VolumeSettings,
    ) -> Result<Option<(Point, Point, Real, Real, Real)>, CollideError> {
        self.nodes.clear();
        self.rate.clear();
        let (p, v, mass, length) = (
            state.positions(),
            state.velocities(),
            state.mass(),
            state.length(),
        );
        let (mut lo, mut hi) = (Point::from([Real::MAX; 3]), Point::from([Real::MIN; 3]));
        let (mut total_length, mut max_mass, mut max_momentum) = (0.0f64, 0.0 as Real, 0.0 as Real);
        for &s in front {
            let id = SkeletonId(s);
            if !state.is_active(id) {
                continue;
            }
            let r = state.nodes(id);
            let last = (r.len().max(2) - 1) as Real;
            for (k, i) in r.enumerate().skip(1) {
                let t = k as Real / last;
                if !(p[i].coords.iter().all(|x| x.is_finite())
                    && v[i].iter().all(|x| x.is_finite()))
                {
                    return Err(CollideError::NonFiniteNode { node: i });
                }
                self.nodes.push(i as u32);
                self.rate.push(
                    settings.friction_root + (settings.friction_tip - settings.friction_root) * t,
                );
                lo = lo.inf(&p[i]);
                hi = hi.sup(&p[i]);
                total_length += f64::from(length[i]);
                max_mass = max_mass.max(mass[i]);
                max_momentum = max_momentum.max(v[i].amax() * mass[i]);
            }
        }
        if self.nodes.is_empty() {
            return Ok(None);
        }
        let mean = (total_length / self.nodes.len() as f64) as Real;
        // A front of zero-length segments still gets a grid of some size.
        let mean = if mean > 0.0 { mean } else { 1e-3 };
        Ok(Some((lo, hi, mean, max_mass, max_momentum)))
    }

    /// Each node's cell and place in it, and the nodes ordered by slab of planes.
    fn place(&mut self, state: &StrandState) {
        let Lattice {
            origin,
            spacing,
            dims,
        } = self.lattice;
        let p = state.positions();
        let inv = 1.0 / spacing;
        self.nodes
            .par_iter()
            .map(|&i| {
                let local = (p[i as usize] - origin) * inv;
                let mut cell = [0u32; 3];
                let mut frac = [0.0; 3];
                for k in 0..3 {
                    // Within the lattice by construction; clamped so that rounding cannot
                    // take a node on the far face out of it.
                    let c = (local[k].floor().max(0.0) as usize).min(dims[k] - 2);
                    cell[k] = c as u32;
                    frac[k] = (local[k] - c as Real).clamp(0.0, 1.0);
                }
                let [x, y, z] = cell.map(|c| c as usize);
                Corner {
                    base: ((z * dims[1] + y) * dims[0] + x) as u32,
                    z: cell[2],
                    frac,
                }
            })
            .collect_into_vec(&mut self.corners);
        // A counting sort of the nodes by slab.
        let thickness = slab_thickness(dims[2]);
        let slabs = dims[2].div_ceil(thickness);
        self.slab_start.clear();
        self.slab_start.resize(slabs + 1, 0);
        for c in &self.corners {
            self.slab_start[c.z as usize / thickness + 1] += 1;
        }
        for s in 1..=slabs {
            self.slab_start[s] += self.slab_start[s - 1];
        }
        self.order.clear();
        self.order.resize(self.corners.len(), 0);
        // `cursor` runs through each slab's run; the starts are rebuilt after.
        for (slot, c) in self.corners.iter().enumerate() {
            let s = c.z as usize / thickness;
            self.order[self.slab_start[s] as usize] = slot as u32;
            self.slab_start[s] += 1;
        }
        for s in (1..=slabs).rev() {
            self.slab_start[s] = self.slab_start[s - 1];
        }
        self.slab_start[0] = 0;
    }

    /// Mass and momentum onto the lattice (fixed point), then each point's velocity and
    /// density.
    fn splat(&mut self, state: &StrandState, max_mass: Real, max_momentum: Real) {
        let dims = self.lattice.dims;
        let cells = dims[0] * dims[1] * dims[2];
        let (mass_scale, momentum_scale) = (
            fixed_scale(max_mass, self.nodes.len()),
            fixed_scale(max_momentum, self.nodes.len()),
        );
        self.sums.clear();
        self.sums.resize(cells, [0; 4]);
        let plane = dims[0] * dims[1];
        let slab_len = slab_thickness(dims[2]) * plane;
        let (v, mass) = (state.velocities(), state.mass());
        let (nodes, corners, order, starts) =
            (&self.nodes, &self.corners, &self.order, &self.slab_start);
        let slabs = starts.len() - 1;
        // A slab's nodes write its planes and the first plane of the next slab: even slabs
        // in parallel, then odd ones, each over its own two slabs of the lattice.
        let splat_slab = |slab: usize, chunk: &mut [[i64; 4]]| {
            if slab >= slabs {
                return;
            }
            let offset = slab * slab_len;
            for &slot in &order[starts[slab] as usize..starts[slab + 1] as usize] {
                let (i, c) = (nodes[slot as usize] as usize, &corners[slot as usize]);
                let m = f64::from(mass[i]);
                let mv = v[i].map(f64::from) * m;
                for (w, corner) in weights(&c.frac).into_iter().zip(corner_offsets(dims)) {
                    let w = f64::from(w);
                    let cell = &mut chunk[c.base as usize + corner - offset];
                    cell[0] += to_fixed(m * w * mass_scale);
                    for k in 0..3 {
                        cell[k + 1] += to_fixed(mv[k] * w * momentum_scale);
                    }
                }
            }
        };
        if slab_len > 0 {
            self.sums
                .par_chunks_mut(2 * slab_len)
                .enumerate()
                .for_each(|(c, chunk)| splat_slab(2 * c, chunk));
            let odd = self.sums.len().min(slab_len);
            self.sums[odd..]
                .par_chunks_mut(2 * slab_len)
                .enumerate()
                .for_each(|(c, chunk)| splat_slab(2 * c + 1, chunk));
        }
        let volume = f64::from(self.lattice.spacing).powi(3);
        self.sums
            .par_iter()
            .map(|s| {
                let m = s[0] as f64 / mass_scale;
                if m > 0.0 {
                    let to_velocity = 1.0 / (momentum_scale * m);
                    Vector::new(
                        (s[1] as f64 * to_velocity) as Real,
                        (s[2] as f64 * to_velocity) as Real,
                        (s[3] as f64 * to_velocity) as Real,
                    )
                } else {
                    Vector::zeros()
                }
            })
            .collect_into_vec(&mut self.velocity);
        self.sums
            .par_iter()
            .map(|s| (s[0] as f64 / mass_scale / volume) as Real)
            .collect_into_vec(&mut self.density);
        // In lattice order, serially: the same sum on any thread count.
        let (mut m2, mut m1) = (0.0f64, 0.0f64);
        for s in &self.sums {
            let m = s[0] as f64 / mass_scale;
            m2 += m * m;
            m1 += m;
        }
        self.mean_density = if m1 > 0.0 {
            (m2 / (m1 * volume)) as Real
        } else {
            0.0
        };
    }

    /// The lattice's mass-weighted mean density at the last splat (kg/m³): the density a unit
    /// of the hair's mass sits in, on average.
    pub fn mean_density(&self) -> Real {
        self.mean_density
    }

    /// Each node's velocity blended toward the lattice's at its place, plus the repulsion.
    fn sample(&mut self, state: &StrandState, settings: &VolumeSettings, dt: Real) {
        let dims = self.lattice.dims;
        let inv_spacing = 1.0 / self.lattice.spacing;
        let v = state.velocities();
        let (grid_v, density) = (&self.velocity, &self.density);
        let target = settings.density_limit * self.mean_density;
        let repulsion = settings.repulsion && target > 0.0;
        let speed = settings.repulsion_rate * self.lattice.spacing;
        self.nodes
            .par_iter()
            .zip(&self.corners)
            .zip(&self.rate)
            .map(|((&i, c), &rate)| {
                let ws = weights(&c.frac);
                let offsets = corner_offsets(dims);
                let mut grid = Vector::zeros();
                for (w, o) in ws.iter().zip(offsets) {
                    grid += grid_v[c.base as usize + o] * *w;
                }
                let alpha = 1.0 - (-rate.max(0.0) * dt).exp();
                let own = v[i as usize];
                let mut out = own + (grid - own) * alpha;
                let mut pushed = false;
                if repulsion {
                    let (rho, gradient) = density_and_gradient(density, c, offsets, inv_spacing);
                    let norm = gradient.norm();
                    if rho > target && norm > 0.0 {
                        // Decompress only: out of the over-dense place, never into a thin one.
                        let excess = ((rho - target) / target).min(1.0);
                        out -= gradient * (speed * excess / norm);
                        pushed = true;
                    }
                }
                (out, pushed)
            })
            .collect_into_vec(&mut self.blended);
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

/// `x` to the nearest integer, halves away from zero: an add and a truncation, where
/// `f64::round` is a library call in the splat's inner loop; the same bits on every CPU.
fn to_fixed(x: f64) -> i64 {
    (x + 0.5f64.copysign(x)) as i64
}

/// Planes per slab: at least two, so that a slab's nodes reach only the next slab.
fn slab_thickness(planes: usize) -> usize {
    planes.div_ceil(SLABS).max(2)
}

/// The power-of-two scale that turns values up to `max` into integers whose sum over `count`
/// of them fits an `i64` with room to spare.
fn fixed_scale(max: Real, count: usize) -> f64 {
    let max = f64::from(max);
    if !(max > 0.0 && max.is_finite()) {
        return 1.0;
    }
    let headroom = (count.max(1) as f64 * 8.0).log2().ceil();
    (60.0 - headroom - max.log2().ceil()).exp2()
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

/// The trilinear density at a node's place and its gradient (kg/m⁴).
#[inline]
fn density_and_gradient(
    density: &[Real],
    c: &Corner,
    offsets: [usize; 8],
    inv_spacing: Real,
) -> (Real, Vector) {
    let d = offsets.map(|o| density[c.base as usize + o]);
    let [x, y, z] = c.frac;
    let rho = weights(&c.frac)
        .iter()
        .zip(&d)
        .map(|(w, d)| w * d)
        .sum::<Real>();
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

#[cfg(test)]
mod tests {
    use super::to_fixed;

    #[test]
    fn to_fixed_rounds_like_round_away_from_ties() {
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..100_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let unit = (x >> 11) as f64 / (1u64 << 53) as f64;
            let value = (unit - 0.5) * 2.0f64.powi((x % 60) as i32);
            assert_eq!(to_fixed(value), value.round() as i64, "{value}");
        }
        for tie in [0.5f64, 1.5, 2.5, -0.5, -1.5, -2.5] {
            assert_eq!(to_fixed(tie), tie.round() as i64, "{tie}");
        }
    }
}
