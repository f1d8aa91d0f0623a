//! Per-node operations of the salon tools: cutting a skeleton in two and holding a control point
//! (Ward, Galoppo & Lin, *Interactive Virtual Hair Salon*, §6.1 haircutting, §6.4 grabbing).
//!
//! They live here, beside the state, because they rewrite the structure-of-arrays directly: a
//! cut shortens one skeleton in place and appends the fallen piece as a new free skeleton whose
//! angles, rest angles (the curl), water, stiffness and radius are copied from the part it
//! replaces, so the piece starts exactly where the hair was. The facade decides *where* to cut
//! and *what* to hold; these functions only keep the state consistent.

use crate::bend::Bend;
use crate::{DynamicsError, Point, Real, Root, SkeletonDesc, SkeletonId, StrandState, Vector};
use nalgebra::{Matrix3, Rotation3};

/// Where a skeleton is cut: on the segment that ends at local node `segment` (1-based, the
/// segment from node `segment - 1` to node `segment`), at the fraction `t` of it from its start.
/// `t == 1` cuts exactly at node `segment`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutPoint {
    /// Local index of the node that ends the cut segment (>= 1).
    pub segment: usize,
    /// Fraction along the segment, in `(0, 1]`.
    pub t: Real,
}

/// What a cut did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutResult {
    /// Control points the cut skeleton keeps (>= 2).
    pub kept: usize,
    /// The fallen piece, if one was made (see [`StrandState::cut`]).
    pub fallen: Option<SkeletonId>,
    /// Local index, in the original skeleton, of the node that became the fallen piece's node 1;
    /// the piece's node `j >= 1` is the original node `first_source + j - 1`.
    pub first_source: usize,
}

impl CutPoint {
    /// Snaps a crossing to what a stylist expects on a skeleton of `count` points with segment
    /// lengths `length` (local, `length[0]` unused): a crossing closer than `min_length` to a
    /// node moves onto it; a crossing at the root leaves a stub of `min_length` on the scalp; a
    /// crossing at (or snapped to) the tip cuts nothing (`None`). Pieces are never shorter than
    /// `min_length` unless the segment itself is.
    pub fn snapped(self, length: &[Real], min_length: Real) -> Option<CutPoint> {
        let count = length.len();
        let k = self.segment;
        if k == 0 || k >= count || !self.t.is_finite() {
            return None;
        }
        let l = length[k];
        let mut cut = CutPoint {
            segment: k,
            t: self.t.clamp(0.0, 1.0),
        };
        if (1.0 - cut.t) * l < min_length {
            cut.t = 1.0;
        } else if cut.t * l < min_length {
            if k >= 2 {
                cut = CutPoint {
                    segment: k - 1,
                    t: 1.0,
                };
            } else {
                cut.t = (min_length / l).min(1.0);
            }
        }
        if cut.t >= 1.0 && cut.segment + 1 >= count {
            return None; // at the tip: nothing falls
        }
        Some(cut)
    }
}

impl StrandState {
    /// Total length of a skeleton's live segments (m).
    pub fn skeleton_length(&self, id: SkeletonId) -> Real {
        let r = self.nodes(id);
        self.length[r.start + 1..r.end].iter().sum()
    }

    /// Frame of the segment that ends at local node `k` (its z axis points along the segment);
    /// `k = 0` gives the root frame.
    pub fn segment_frame(&self, id: SkeletonId, k: usize) -> Matrix3<Real> {
        let r = self.nodes(id);
        let mut rot = self.roots[id.0 as usize].rotation;
        for i in r.start + 1..(r.start + k + 1).min(r.end) {
            rot *= Bend::new(self.theta[i], self.phi[i]).rotation;
        }
        rot
    }

    /// Cuts a skeleton at `at` (Ward, Galoppo & Lin §6.1): the skeleton `S` keeps its root and
    /// ends at a new point on the cut (`S1`); when `spawn` is set, the part below becomes a new
    /// free skeleton `S2` that starts at the same point, with both ends loose.
    ///
    /// What is conserved: the total length (`S1 + S2 = S`, segment by segment), the dry mass
    /// (lumped from the lengths at the skeleton's mean linear density) and the water (the cut
    /// segment's end node shares its water between the two pieces in proportion to the two
    /// parts of the segment). `S2` copies the angles, rest angles (the curl), angular rates,
    /// stiffness, damping, radius and stretch stiffness of the nodes it takes over; bonds on
    /// those nodes follow them into `S2` (or are dropped without `spawn`). Without `spawn` the
    /// tail is simply removed (the cut inherited by an inactive level of detail).
    ///
    /// `at` must already be snapped ([`CutPoint::snapped`]); both pieces keep at least two
    /// points.
    pub fn cut(
        &mut self,
        id: SkeletonId,
        at: CutPoint,
        spawn: bool,
    ) -> Result<CutResult, DynamicsError> {
        self.check(id)?;
        let range = self.nodes(id);
        let n = range.len();
        let o = range.start;
        let k = at.segment;
        let t = at.t;
        if k == 0 || k >= n || !(t > 0.0 && t <= 1.0) || (t >= 1.0 && k + 1 >= n) {
            return Err(DynamicsError::OutOfRange {
                name: "cut.at",
                value: k as f64 + f64::from(t),
                expected: "a snapped cut point leaving both pieces two points",
            });
        }
        let total_len: Real = self.length[o + 1..o + n].iter().sum();
        let total_mass: Real = self.mass[o..o + n].iter().sum();
        let density = if total_len > 0.0 {
            total_mass / total_len
        } else {
            0.0
        };
        // The fallen piece: the cut point, then original nodes first_source..n.
        let first_source = if t < 1.0 { k } else { k + 1 };
        let lk = self.length[o + k];
        let rlk = self.rest_length[o + k];
        let (first_len, first_rest) = if t < 1.0 {
            (lk - t * lk, rlk - t * rlk)
        } else {
            (self.length[o + k + 1], self.rest_length[o + k + 1])
        };
        let cut_pos =
            self.positions[o + k - 1] + (self.positions[o + k] - self.positions[o + k - 1]) * t;
        let cut_vel =
            self.velocities[o + k - 1] + (self.velocities[o + k] - self.velocities[o + k - 1]) * t;
        let cut_rest = self.rest_points[o + k - 1]
            + (self.rest_points[o + k] - self.rest_points[o + k - 1]) * t;
        // Water of the cut segment's end node, shared between the pieces.
        let w = self.wetness[o + k];
        let (w_keep, w_fall_root, w_fall_first) = if t < 1.0 {
            (t * w, 0.0, w - t * w)
        } else {
            let right = self.length[o + k + 1];
            let share = if lk + right > 0.0 {
                lk / (lk + right)
            } else {
                0.5
            };
            (share * w, w - share * w, self.wetness[o + k + 1])
        };
        let mut fallen = None;
        if spawn {
            let frame = self.segment_frame(id, first_source);
            let mut points = Vec::with_capacity(n - first_source + 1);
            points.push(cut_pos);
            points.extend_from_slice(&self.positions[o + first_source..o + n]);
            // Guard the polyline check of add_skeleton against coincident points by spacing them
            // along the frame; the real lengths are written just after.
            let mut desc_points = points.clone();
            for j in 1..desc_points.len() {
                if (desc_points[j] - desc_points[j - 1]).norm() <= 0.0 {
                    desc_points[j] = desc_points[j - 1] + frame.column(2) * 1e-6;
                }
            }
            let sid = self.add_skeleton(&SkeletonDesc {
                root: Root::Free {
                    position: cut_pos,
                    velocity: cut_vel,
                    frame: Rotation3::from_matrix_unchecked(frame),
                },
                points: desc_points,
                material: crate::Material {
                    linear_density: density.max(Real::MIN_POSITIVE),
                    ..crate::Material::default()
                },
            })?;
            let s2 = self.nodes(sid);
            let b = s2.start;
            let m = s2.len();
            // Node 0 (root) and node 1: the first joint is free and starts unbent in `frame`.
            for j in 0..m {
                let src = if j == 0 {
                    o + k
                } else {
                    o + first_source + j - 1
                };
                let i = b + j;
                if j >= 2 {
                    self.theta[i] = self.theta[src];
                    self.phi[i] = self.phi[src];
                    self.omega_theta[i] = self.omega_theta[src];
                    self.omega_phi[i] = self.omega_phi[src];
                    self.rest_theta[i] = self.rest_theta[src];
                    self.rest_phi[i] = self.rest_phi[src];
                    self.length[i] = self.length[src];
                    self.rest_length[i] = self.rest_length[src];
                } else {
                    self.theta[i] = 0.0;
                    self.phi[i] = 0.0;
                    self.omega_theta[i] = 0.0;
                    self.omega_phi[i] = 0.0;
                    self.rest_theta[i] = 0.0;
                    self.rest_phi[i] = 0.0;
                    let (l, rl) = if j == 0 {
                        (0.0, 0.0)
                    } else {
                        (first_len, first_rest)
                    };
                    self.length[i] = l;
                    self.rest_length[i] = rl;
                }
                self.k_theta[i] = self.k_theta[src];
                self.k_phi[i] = self.k_phi[src];
                self.k_stretch[i] = self.k_stretch[src];
                self.damping[i] = if j == 0 { 0.0 } else { self.damping[src] };
                self.radius[i] = self.radius[src];
                self.rest_points[i] = if j == 0 {
                    cut_rest
                } else {
                    self.rest_points[src]
                };
                self.external_force[i] = Vector::zeros();
                self.wetness[i] = if j == 0 {
                    w_fall_root
                } else if j == 1 {
                    w_fall_first
                } else {
                    self.wetness[src]
                };
            }
            lump_masses(&self.length[b..b + m], density, &mut self.mass[b..b + m]);
            self.refresh_positions(sid);
            // Bonds on the nodes that moved follow them.
            for bond in &mut self.bonds {
                for end in [&mut bond.a, &mut bond.b] {
                    let e = *end as usize;
                    if e >= o + first_source && e < o + n {
                        *end = (b + 1 + (e - o - first_source)) as u32;
                    }
                }
            }
            fallen = Some(sid);
        }
        // S1: the kept part, ending at the cut point.
        let kept = k + 1;
        if t < 1.0 {
            self.length[o + k] = t * lk;
            self.rest_length[o + k] = t * rlk;
            self.rest_points[o + k] = cut_rest;
        }
        self.wetness[o + k] = w_keep;
        let (lengths, masses) = (&self.length[o..o + kept], &mut self.mass[o..o + kept]);
        lump_masses(lengths, density, masses);
        self.counts[id.0 as usize] = kept as u32;
        // Bonds left on dead slots of S go (without a spawned piece to follow).
        let dead = o + kept..o + n;
        self.bonds
            .retain(|b| !dead.contains(&(b.a as usize)) && !dead.contains(&(b.b as usize)));
        self.refresh_positions(id);
        Ok(CutResult {
            kept,
            fallen,
            first_source,
        })
    }

    /// Holds local node `j` of a skeleton at `target` (Ward, Galoppo & Lin §6.4): the target is
    /// first pulled back within the node's reach (the length of hair between it and the root),
    /// then the segments from the root to the node are re-aimed so the node reaches it with every
    /// length kept (forward-and-backward reaching), the segments below follow with their lengths
    /// kept, and the joints above the node stop (they move with the tool, not on their own).
    /// Returns where the node ended up.
    pub fn hold_node(
        &mut self,
        id: SkeletonId,
        j: usize,
        target: Point,
        scratch: &mut Vec<Point>,
    ) -> Result<Point, DynamicsError> {
        self.check(id)?;
        let r = self.nodes(id);
        if j == 0 || j >= r.len() {
            return Err(DynamicsError::OutOfRange {
                name: "hold.node",
                value: j as f64,
                expected: "a non-root live node of the skeleton",
            });
        }
        crate::error::finite_vec("hold.target", &target.coords)?;
        let o = r.start;
        let root = self.roots[id.0 as usize].position;
        let reach: Real = self.length[o + 1..=o + j].iter().sum();
        let mut goal = target;
        let d = goal - root;
        let dn = d.norm();
        scratch.clear();
        scratch.extend_from_slice(&self.positions[r.clone()]);
        let len = &self.length[r.clone()];
        let straight = dn >= reach && dn > 0.0;
        if straight {
            // At or past its reach: the hair above the node is pulled straight towards the target.
            goal = root + d * (reach / dn);
            let dir = d / dn;
            let mut arc = 0.0;
            for i in 1..=j {
                arc += len[i];
                scratch[i] = root + dir * arc;
            }
        }
        for _ in 0..if straight { 0 } else { 32 } {
            // Backward: from the goal to the root.
            scratch[j] = goal;
            for i in (0..j).rev() {
                let v = scratch[i] - scratch[i + 1];
                let dir = v.try_normalize(1e-12).unwrap_or_else(|| -Vector::z());
                scratch[i] = scratch[i + 1] + dir * len[i + 1];
            }
            // Forward: from the root back out.
            scratch[0] = root;
            for i in 1..=j {
                let v = scratch[i] - scratch[i - 1];
                let dir = v.try_normalize(1e-12).unwrap_or_else(Vector::z);
                scratch[i] = scratch[i - 1] + dir * len[i];
            }
            if (scratch[j] - goal).norm() < 1e-6 {
                break;
            }
        }
        let root_state = self.roots[id.0 as usize];
        crate::response::fit_angles(
            &root_state.rotation,
            root_state.position,
            scratch,
            &self.length[r.clone()],
            &mut self.theta[r.clone()],
            &mut self.phi[r.clone()],
        );
        for i in o + 1..=o + j {
            self.omega_theta[i] = 0.0;
            self.omega_phi[i] = 0.0;
        }
        self.refresh_positions(id);
        Ok(self.positions[o + j])
    }
}

/// Trapezoid lumping of a uniform density over the segments (`length[0]` unused).
fn lump_masses(length: &[Real], density: Real, mass: &mut [Real]) {
    let n = length.len();
    for i in 0..n {
        let left = if i > 0 { length[i] } else { 0.0 };
        let right = if i + 1 < n { length[i + 1] } else { 0.0 };
        mass[i] = density * 0.5 * (left + right);
    }
}
