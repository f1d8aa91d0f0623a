//! Mutable views of contiguous runs of skeletons, split at skeleton boundaries so that rayon
//! workers own disjoint slices of the state: the integrator and the collision response run in
//! parallel over skeletons without locks, and each skeleton's result does not depend on which
//! worker computed it.

use crate::state::RootState;
use crate::strand::{self, RootDyn, Scratch};
use crate::{Point, Real, StrandState, Vector};
use std::cell::RefCell;

/// Mutable views of a contiguous run of skeletons.
pub(crate) struct Run<'a> {
    pub(crate) first: usize,
    pub(crate) node_base: usize,
    pub(crate) theta: &'a mut [Real],
    pub(crate) phi: &'a mut [Real],
    pub(crate) omega_theta: &'a mut [Real],
    pub(crate) omega_phi: &'a mut [Real],
    pub(crate) prev_theta: &'a mut [Real],
    pub(crate) prev_phi: &'a mut [Real],
    pub(crate) prev_omega_theta: &'a mut [Real],
    pub(crate) prev_omega_phi: &'a mut [Real],
    pub(crate) length: &'a mut [Real],
    pub(crate) positions: &'a mut [Point],
    pub(crate) velocities: &'a mut [Vector],
    pub(crate) roots: &'a mut [RootState],
}

impl<'a> Run<'a> {
    pub(crate) fn split(self, mid: usize, at_node: usize) -> (Run<'a>, Run<'a>) {
        let k = at_node - self.node_base;
        let (t0, t1) = self.theta.split_at_mut(k);
        let (p0, p1) = self.phi.split_at_mut(k);
        let (a0, a1) = self.omega_theta.split_at_mut(k);
        let (b0, b1) = self.omega_phi.split_at_mut(k);
        let (pt0, pt1) = self.prev_theta.split_at_mut(k);
        let (pp0, pp1) = self.prev_phi.split_at_mut(k);
        let (pa0, pa1) = self.prev_omega_theta.split_at_mut(k);
        let (pb0, pb1) = self.prev_omega_phi.split_at_mut(k);
        let (l0, l1) = self.length.split_at_mut(k);
        let (x0, x1) = self.positions.split_at_mut(k);
        let (v0, v1) = self.velocities.split_at_mut(k);
        let (r0, r1) = self.roots.split_at_mut(mid - self.first);
        (
            Run {
                first: self.first,
                node_base: self.node_base,
                theta: t0,
                phi: p0,
                omega_theta: a0,
                omega_phi: b0,
                prev_theta: pt0,
                prev_phi: pp0,
                prev_omega_theta: pa0,
                prev_omega_phi: pb0,
                length: l0,
                positions: x0,
                velocities: v0,
                roots: r0,
            },
            Run {
                first: mid,
                node_base: at_node,
                theta: t1,
                phi: p1,
                omega_theta: a1,
                omega_phi: b1,
                prev_theta: pt1,
                prev_phi: pp1,
                prev_omega_theta: pa1,
                prev_omega_phi: pb1,
                length: l1,
                positions: x1,
                velocities: v1,
                roots: r1,
            },
        )
    }
}

/// The whole of a [`StrandState`] as one [`Run`], borrowing only the fields a run holds: a macro,
/// so that callers can hold other fields of the state at the same time.
macro_rules! whole_run {
    ($state:expr) => {
        $crate::run::Run {
            first: 0,
            node_base: 0,
            theta: &mut $state.theta,
            phi: &mut $state.phi,
            omega_theta: &mut $state.omega_theta,
            omega_phi: &mut $state.omega_phi,
            prev_theta: &mut $state.prev_theta,
            prev_phi: &mut $state.prev_phi,
            prev_omega_theta: &mut $state.prev_omega_theta,
            prev_omega_phi: &mut $state.prev_omega_phi,
            length: &mut $state.length,
            positions: &mut $state.positions,
            velocities: &mut $state.velocities,
            roots: &mut $state.roots,
        }
    };
}
pub(crate) use whole_run;

impl StrandState {
    /// The whole state as one run.
    pub(crate) fn run_all(&mut self) -> Run<'_> {
        self.run_with_layout().0
    }

    /// The whole state as one run, with the first node and node count of every skeleton.
    pub(crate) fn run_with_layout(&mut self) -> (Run<'_>, &[u32], &[u32]) {
        (whole_run!(self), &self.offsets, &self.counts)
    }
}

/// Skeletons per leaf of [`for_each_skeleton`]: enough work to amortise a fork.
pub(crate) const GRAIN_SKELETONS: usize = 16;

/// Calls `f(run, k)` for each `k` in `0..skeletons.len()`, where `skeletons` holds sorted,
/// unique skeleton indices and `run` contains skeleton `skeletons[k]`; in parallel over disjoint
/// runs. `offsets` are the state's first node per skeleton.
pub(crate) fn for_each_skeleton<F>(run: Run<'_>, skeletons: &[u32], offsets: &[u32], f: &F)
where
    F: Fn(&mut Run<'_>, usize) + Sync,
{
    split_skeletons(run, skeletons, 0, offsets, f);
}

fn split_skeletons<F>(mut run: Run<'_>, skeletons: &[u32], base: usize, offsets: &[u32], f: &F)
where
    F: Fn(&mut Run<'_>, usize) + Sync,
{
    if skeletons.len() > GRAIN_SKELETONS {
        let half = skeletons.len() / 2;
        let mid = skeletons[half] as usize;
        let (a, b) = run.split(mid, offsets[mid] as usize);
        let (left, right) = skeletons.split_at(half);
        rayon::join(
            || split_skeletons(a, left, base, offsets, f),
            || split_skeletons(b, right, base + half, offsets, f),
        );
        return;
    }
    for k in 0..skeletons.len() {
        f(&mut run, base + k);
    }
}

thread_local! {
    static FORWARD_SCRATCH: RefCell<(Scratch<Real>, Vec<Real>, Vec<Real>)> =
        RefCell::new(Default::default());
}

impl Run<'_> {
    /// Node range of skeleton `s` within this run's slices.
    pub(crate) fn local_nodes(
        &self,
        s: usize,
        offsets: &[u32],
        counts: &[u32],
    ) -> std::ops::Range<usize> {
        let lo = offsets[s] as usize - self.node_base;
        lo..lo + counts[s] as usize
    }

    /// Recomputes skeleton `s`'s node positions and velocities (`r`: its nodes within this
    /// run) from its root, angles, rates and lengths; one scratch per thread, as this runs inside
    /// the step loop.
    pub(crate) fn refresh(&mut self, s: usize, r: std::ops::Range<usize>) {
        let rs = &self.roots[s - self.first];
        let root = RootDyn {
            position: rs.position.coords,
            rotation: rs.rotation,
            velocity: rs.velocity,
            free: rs.free,
        };
        FORWARD_SCRATCH.with(|cell| {
            let mut guard = cell.borrow_mut();
            let (sc, q, w) = &mut *guard;
            sc.reserve(r.len(), false);
            q.clear();
            w.clear();
            for i in r.start + 1..r.end {
                q.extend([self.theta[i], self.phi[i]]);
                w.extend([self.omega_theta[i], self.omega_phi[i]]);
            }
            strand::forward(&root, q, w, &self.length[r.clone()], sc);
            for (k, i) in r.enumerate() {
                self.positions[i] = Point::from(sc.pos[k]);
                self.velocities[i] = sc.vel[k];
            }
        });
    }
}
