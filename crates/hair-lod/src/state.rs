//! The dynamic state and styling properties of every node, one `Vec` per field.
//!
//! Every node of the hierarchy has slots for its control points (at
//! [`Hierarchy::control_point_start`]); only active nodes' slots are meaningful. Dynamic state is
//! stored as the bend *away from the node's rest angles* plus angular velocities, so a child
//! inherits its parent's motion exactly (copies of the same numbers) while its own rest shape
//! (the parent's plus the stored offsets) places it; merging averages those same numbers, so a
//! split followed by a merge of untouched children gives back the parent's state bit for bit.

use crate::{Hierarchy, LodError, Real};
use hair_dynamics::{SkeletonId, StrandState};

/// One end of a [`LodBond`]: a control point of a node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct BondEnd {
    /// The node.
    pub node: u32,
    /// The control point within the node's skeleton.
    pub point: u16,
}

/// A hairspray bond between two control points of active nodes (Ward, Galoppo & Lin §6.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LodBond {
    /// First end (after normalisation, the smaller).
    pub a: BondEnd,
    /// Second end.
    pub b: BondEnd,
    /// Rest distance (m).
    pub rest: Real,
    /// Stiffness (N/m).
    pub stiffness: Real,
    /// Breaks past this distance (m).
    pub break_distance: Real,
}

/// Dynamic state and styling properties per control point of every node, and the bonds.
///
/// Units: deviations in radians, angular velocities in rad/s. `wetness` is intensive: water per
/// strand at that control point (the salon paper's percentage), so a skeleton standing for `m`
/// strands holds `m` times it, and the water of the hair is
/// `sum over active nodes of m * sum over live control points of wetness`
/// ([`LodState::total_water`]). `stiffness`, `thickness` and `length` are factors on the
/// node's own spring constants, radius and rest segment lengths (1 = as built); a cut leaves a
/// fraction in `length` on the new last segment.
#[derive(Clone, Debug, PartialEq)]
pub struct LodState {
    /// Bend about the parent frame's x axis, minus the rest value (rad).
    pub d_theta: Vec<Real>,
    /// Bend about the parent frame's y axis, minus the rest value (rad).
    pub d_phi: Vec<Real>,
    /// The groom's theta minus the rest value, where the rest was solved to hold the groom
    /// still under gravity ([`LodState::hold_groom`]); 0 otherwise. Deviations are measured
    /// from the groom, so a child split from its parent takes its own groom plus the parent's
    /// motion, not its rest (which a sag-free rest bends against gravity) plus the parent's sag.
    pub sag_theta: Vec<Real>,
    /// The groom's phi minus the rest value (rad); see `sag_theta`.
    pub sag_phi: Vec<Real>,
    /// Angular velocity of theta (rad/s).
    pub omega_theta: Vec<Real>,
    /// Angular velocity of phi (rad/s).
    pub omega_phi: Vec<Real>,
    /// Water per strand (0 = dry; the unit is the caller's, e.g. kg per strand node or a fraction).
    pub wetness: Vec<Real>,
    /// Factor on spring constants (hairspray raises it).
    pub stiffness: Vec<Real>,
    /// Factor on the radius (mousse raises it, water lowers it).
    pub thickness: Vec<Real>,
    /// Factor on the rest length of the segment ending at the control point (a cut lowers it).
    pub length: Vec<Real>,
    /// Live control points per node (a cut lowers it; never below 2).
    pub count: Vec<u16>,
    /// Bonds between control points of active nodes, sorted, no duplicates.
    pub bonds: Vec<LodBond>,
}

impl LodState {
    /// Every node at rest, dry, with unit factors, uncut, no bonds.
    pub fn new(h: &Hierarchy) -> Self {
        let n = h.control_point_total();
        Self {
            d_theta: vec![0.0; n],
            d_phi: vec![0.0; n],
            sag_theta: vec![0.0; n],
            sag_phi: vec![0.0; n],
            omega_theta: vec![0.0; n],
            omega_phi: vec![0.0; n],
            wetness: vec![0.0; n],
            stiffness: vec![1.0; n],
            thickness: vec![1.0; n],
            length: vec![1.0; n],
            count: (0..h.node_count() as u32)
                .map(|v| h.control_points(v).min(u16::MAX as usize) as u16)
                .collect(),
            bonds: Vec::new(),
        }
    }

    pub(crate) fn check(&self, h: &Hierarchy) -> Result<(), LodError> {
        let n = h.control_point_total();
        if [
            self.d_theta.len(),
            self.d_phi.len(),
            self.sag_theta.len(),
            self.sag_phi.len(),
            self.omega_theta.len(),
            self.omega_phi.len(),
            self.wetness.len(),
            self.stiffness.len(),
            self.thickness.len(),
            self.length.len(),
        ]
        .iter()
        .any(|&l| l != n)
            || self.count.len() != h.node_count()
        {
            return Err(LodError::Mismatch { what: "state" });
        }
        Ok(())
    }

    /// Water of the hair: over active nodes, strands times the sum of live control points'
    /// wetness (f64). Splits and merges leave it unchanged up to f32 rounding of the averages.
    pub fn total_water(&self, h: &Hierarchy, front: &crate::Front) -> f64 {
        let mut w = 0.0;
        for n in front.active_nodes() {
            let s = h.control_point_start(n);
            let live: f64 = self.wetness[s..s + self.count[n as usize] as usize]
                .iter()
                .map(|&x| f64::from(x))
                .sum();
            w += f64::from(h.strand_count(n)) * live;
        }
        w
    }

    /// Takes every node's angles in `strands` (skeleton `n` for node `n`, as built from
    /// [`Hierarchy::skeleton_desc`]) as its groom: `sag_theta` and `sag_phi` become the angles
    /// minus the rest angles. Call it once the rest is solved and before any motion.
    pub fn hold_groom(&mut self, h: &Hierarchy, strands: &StrandState) -> Result<(), LodError> {
        for node in 0..h.node_count() as u32 {
            let (s, range) = self.matching(h, node, strands, SkeletonId(node))?;
            for (j, i) in range.enumerate() {
                self.sag_theta[s + j] = strands.theta()[i] - strands.rest_theta()[i];
                self.sag_phi[s + j] = strands.phi()[i] - strands.rest_phi()[i];
            }
        }
        Ok(())
    }

    /// Writes a node's motion into a `hair-dynamics` skeleton made from
    /// [`Hierarchy::skeleton_desc`] for the same node: angles are the skeleton's rest angles plus the sag and
    /// the deviations, angular velocities are copied, and positions are refreshed.
    pub fn write_motion(
        &self,
        h: &Hierarchy,
        node: u32,
        strands: &mut StrandState,
        id: SkeletonId,
    ) -> Result<(), LodError> {
        let (s, range) = self.matching(h, node, strands, id)?;
        let n = range.len();
        for j in 0..n {
            let i = range.start + j;
            let theta = (strands.rest_theta()[i] + self.sag_theta[s + j]) + self.d_theta[s + j];
            let phi = (strands.rest_phi()[i] + self.sag_phi[s + j]) + self.d_phi[s + j];
            strands.theta_mut()[i] = theta;
            strands.phi_mut()[i] = phi;
            strands.omega_theta_mut()[i] = self.omega_theta[s + j];
            strands.omega_phi_mut()[i] = self.omega_phi[s + j];
        }
        strands.refresh_positions(id);
        Ok(())
    }

    /// Reads a node's motion back from its `hair-dynamics` skeleton after a step (the inverse
    /// of [`LodState::write_motion`]).
    pub fn read_motion(
        &mut self,
        h: &Hierarchy,
        node: u32,
        strands: &StrandState,
        id: SkeletonId,
    ) -> Result<(), LodError> {
        let (s, range) = self.matching(h, node, strands, id)?;
        for j in 0..range.len() {
            let i = range.start + j;
            self.d_theta[s + j] =
                strands.theta()[i] - (strands.rest_theta()[i] + self.sag_theta[s + j]);
            self.d_phi[s + j] = strands.phi()[i] - (strands.rest_phi()[i] + self.sag_phi[s + j]);
            self.omega_theta[s + j] = strands.omega_theta()[i];
            self.omega_phi[s + j] = strands.omega_phi()[i];
        }
        Ok(())
    }

    fn matching(
        &self,
        h: &Hierarchy,
        node: u32,
        strands: &StrandState,
        id: SkeletonId,
    ) -> Result<(usize, core::ops::Range<usize>), LodError> {
        h.check(node)?;
        self.check(h)?;
        strands.check(id).map_err(|_| LodError::Mismatch {
            what: "skeleton id",
        })?;
        let range = strands.nodes(id);
        if range.len() > h.control_points(node) {
            return Err(LodError::Mismatch {
                what: "skeleton has more control points than the node",
            });
        }
        Ok((h.control_point_start(node), range))
    }
}
