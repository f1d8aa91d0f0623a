//! Sag-free initialisation: rest angles that make the skeletons' current shape a static
//! equilibrium (Hsu et al. 2023), so a groom does not sag on its first frames.
//!
//! At rest with no velocity, joint coordinate `c` balances `a_c . T_c = k_c (q_c - q_rest_c)`,
//! with `T_c` the moment of the load the joint carries (the torque model's). The load depends only
//! on the shape, not on the rest angles, so one pass per strand gives
//! `q_rest = q - (a . T) / k` exactly.

use crate::strand::{self, RootDyn, Scratch, StrandParams};
use crate::{DynamicsError, Environment, SkeletonId, StrandState, TorqueModel};
use nalgebra::Vector3;

impl StrandState {
    /// Sets every skeleton's rest angles so that its current shape is in static equilibrium
    /// under `env`'s loads (gravity, fields, external forces; still air) with the `torque` model.
    /// Joints without a spring (a free root's first joint, a zero stiffness) keep their rest
    /// angles. Angular velocities are zeroed. Returns the joints whose rest angles changed.
    pub fn make_rest_equilibrium(
        &mut self,
        env: &Environment,
        torque: TorqueModel,
    ) -> Result<usize, DynamicsError> {
        env.validate()?;
        let local = env.local::<f64>();
        let mut sc = Scratch::<f64>::default();
        let mut changed = 0;
        for s in 0..self.offsets.len() {
            let r = self.nodes(SkeletonId(s as u32));
            let n = r.len();
            sc.reserve(n, false);
            let up = |v: &[f32]| v.iter().map(|x| f64::from(*x)).collect::<Vec<f64>>();
            let mut q = Vec::with_capacity(2 * n);
            for i in r.start + 1..r.end {
                q.extend([f64::from(self.theta[i]), f64::from(self.phi[i])]);
            }
            let w = vec![0.0; q.len()];
            let rest_theta: Vec<f64> = q.iter().step_by(2).copied().collect();
            let rest_phi: Vec<f64> = q.iter().skip(1).step_by(2).copied().collect();
            // Rest angles indexed by node (node 0 has none).
            let rest_theta: Vec<f64> = std::iter::once(0.0).chain(rest_theta).collect();
            let rest_phi: Vec<f64> = std::iter::once(0.0).chain(rest_phi).collect();
            let (mass, wetness) = (up(&self.mass[r.clone()]), up(&self.wetness[r.clone()]));
            let (k_theta, k_phi) = (up(&self.k_theta[r.clone()]), up(&self.k_phi[r.clone()]));
            let damping = up(&self.damping[r.clone()]);
            let length = up(&self.length[r.clone()]);
            let rest_points: Vec<Vector3<f64>> = self.rest_points[r.clone()]
                .iter()
                .map(|v| v.cast())
                .collect();
            let external: Vec<Vector3<f64>> = self.external_force[r.clone()]
                .iter()
                .map(|f| f.cast())
                .collect();
            let root = self.root_dyn(s);
            let root = RootDyn {
                position: root.position.cast(),
                rotation: root.rotation.cast(),
                velocity: Vector3::zeros(),
                free: root.free,
            };
            let p = StrandParams {
                rest_theta: &rest_theta,
                rest_phi: &rest_phi,
                mass: &mass,
                wetness: &wetness,
                k_theta: &k_theta,
                k_phi: &k_phi,
                damping: &damping,
                rest_points: &rest_points,
                external: &external,
            };
            strand::forward(&root, &q, &w, &length, &mut sc);
            strand::forces(&root, &p, &length, &local, &mut sc);
            // With the rest angles at the current ones the springs are silent: `tau` is the load.
            strand::torques(&root, &p, &q, &w, &length, torque, false, &mut sc);
            for i in 1..n {
                let c = 2 * (i - 1);
                let g = r.start + i;
                if root.free && i == 1 {
                    continue;
                }
                for (k, tau, rest, value) in [
                    (k_theta[i], sc.tau[c], &mut self.rest_theta[g], q[c]),
                    (k_phi[i], sc.tau[c + 1], &mut self.rest_phi[g], q[c + 1]),
                ] {
                    if k > 0.0 {
                        let solved = value - tau / k;
                        if !solved.is_finite() {
                            return Err(DynamicsError::NonFiniteState {
                                step: self.steps,
                                skeleton: s,
                                node: i,
                            });
                        }
                        *rest = solved as f32;
                        changed += 1;
                    }
                }
            }
            for i in r.clone() {
                self.omega_theta[i] = 0.0;
                self.omega_phi[i] = 0.0;
            }
            self.refresh_positions(SkeletonId(s as u32));
        }
        Ok(changed)
    }
}

#[cfg(test)]
mod tests {
    use crate::*;
    use nalgebra::Rotation3;

    /// A strand leaving its root sideways sags under gravity with its combed rest angles, and
    /// stays put (to a tenth of a millimetre over a second) once its rest angles are solved.
    #[test]
    fn a_sag_free_strand_stays_where_it_was_groomed() {
        let build = |solve: bool| -> Result<Real, DynamicsError> {
            let mut state = StrandState::new();
            // Hair leaves the root along +x (horizontal): gravity bends it most.
            let frame = Rotation3::rotation_between(&Vector::z(), &Vector::x())
                .unwrap_or_else(Rotation3::identity);
            let style = Style::Wavy {
                amplitude: 0.01,
                period: 0.1,
            };
            let points = style_points(Point::origin(), &frame, &style, 12, 0.25)?;
            state.add_skeleton(&SkeletonDesc {
                root: Root::Attached {
                    position: Point::origin(),
                    frame,
                },
                points,
                material: Material::default(),
            })?;
            let env = Environment::default();
            let settings = StepSettings::default();
            if solve {
                state.make_rest_equilibrium(&env, settings.torque)?;
            }
            let start = state.positions().to_vec();
            for _ in 0..60 {
                state.step(&env, &settings)?;
            }
            let drift = state
                .positions()
                .iter()
                .zip(&start)
                .map(|(a, b)| (a - b).norm())
                .sum::<Real>()
                / start.len() as Real;
            Ok(drift)
        };
        let sagging = build(false).unwrap_or(Real::NAN);
        let held = build(true).unwrap_or(Real::NAN);
        assert!(
            sagging > 0.01,
            "without the solve the strand sags: {sagging} m"
        );
        assert!(held < 1e-4, "with the solve it holds its shape: {held} m");
    }
}
