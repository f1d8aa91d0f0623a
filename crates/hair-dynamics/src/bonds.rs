//! Dynamic bonds between nodes of different skeletons (hairspray), with a break distance.
//!
//! Ward, Galoppo & Lin §6.3: spray adds springs between sections in contact at that moment;
//! they break when pulled past a distance.

use crate::error::non_negative;
use crate::{DynamicsError, Real, StrandState, Vector};

/// A spring between two nodes (global node indices) that breaks past `break_distance`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bond {
    /// First node.
    pub a: u32,
    /// Second node.
    pub b: u32,
    /// Rest distance (m).
    pub rest: Real,
    /// Stiffness (N/m).
    pub stiffness: Real,
    /// The bond breaks when the nodes are farther apart than this (m).
    pub break_distance: Real,
}

impl StrandState {
    /// Adds a bond; both nodes must exist and the values be finite and non-negative.
    pub fn add_bond(&mut self, bond: Bond) -> Result<(), DynamicsError> {
        let count = self.theta.len();
        for node in [bond.a, bond.b] {
            if node as usize >= count {
                return Err(DynamicsError::UnknownNode {
                    node: node as usize,
                    count,
                });
            }
        }
        non_negative("bond.rest", bond.rest)?;
        non_negative("bond.stiffness", bond.stiffness)?;
        non_negative("bond.break_distance", bond.break_distance)?;
        self.bonds.push(bond);
        Ok(())
    }

    /// The live bonds.
    pub fn bonds(&self) -> &[Bond] {
        &self.bonds
    }

    /// Removes every bond.
    pub fn clear_bonds(&mut self) {
        self.bonds.clear();
    }

    pub(crate) fn accumulate_bond_forces(&self, force: &mut [Vector]) {
        for b in &self.bonds {
            let d = self.positions[b.b as usize] - self.positions[b.a as usize];
            let len = d.norm();
            if len > 0.0 {
                let f = d * (b.stiffness * (len - b.rest) / len);
                force[b.a as usize] += f;
                force[b.b as usize] -= f;
            }
        }
    }

    /// Removes bonds stretched past their break distance; returns how many broke.
    pub(crate) fn break_stretched_bonds(&mut self) -> usize {
        let before = self.bonds.len();
        let positions = &self.positions;
        self.bonds.retain(|b| {
            (positions[b.b as usize] - positions[b.a as usize]).norm() <= b.break_distance
        });
        before - self.bonds.len()
    }
}
