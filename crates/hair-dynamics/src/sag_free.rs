//! Sag-free initialisation: rest angles that make the skeletons' current shape a static
//! equilibrium (Hsu et al. 2023), so a groom does not sag on its first frames.
//!
//! At rest with no velocity, joint coordinate `c` balances `a_c . T_c = k_c (q_c - q_rest_c)`,
//! with `T_c` the moment of the load the joint carries (the torque model's). The load depends only
//! on the shape, not on the rest angles, so one pass per strand gives
//! `q_rest = q - (a . T) / k` exactly.

use crate::strand::{self, RootDyn, Scratch, StrandParams};
use crate::{DynamicsError, Environment, Real, SkeletonId, StrandState, TorqueModel, Vector};
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
        self.make_rest_equilibrium_on(env, torque, &[], &mut Vec::new())
    }

    /// [`StrandState::make_rest_equilibrium`] with a body under the hair: the body may push
    /// each node of `supports` (node, the body's outward unit normal there; in node order)
    /// outward with any force of at least 0. The pushes are those that leave the springs the
    /// least to hold (the sum of squared offsets of the rest angles from the current ones, in
    /// radians; a non-negative least-squares problem per skeleton, solved by an active set),
    /// so that hair lying on the body rests on it instead of being held up by bent joints.
    /// `pushes` gets each support's push (N, in the order of `supports`).
    pub fn make_rest_equilibrium_on(
        &mut self,
        env: &Environment,
        torque: TorqueModel,
        supports: &[(u32, Vector)],
        pushes: &mut Vec<Real>,
    ) -> Result<usize, DynamicsError> {
        env.validate()?;
        if supports.windows(2).any(|w| w[0].0 >= w[1].0)
            || supports
                .last()
                .is_some_and(|s| s.0 as usize >= self.node_count())
        {
            return Err(DynamicsError::OutOfRange {
                name: "supports",
                value: f64::NAN,
                expected: "nodes of the state in increasing order",
            });
        }
        for (_, normal) in supports {
            crate::error::finite_vec("support normal", normal)?;
        }
        pushes.clear();
        let local = env.local::<f64>();
        let bare_env = Environment {
            gravity: Vector::zeros(),
            ..Environment::default()
        };
        let bare = bare_env.local::<f64>();
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
            let mut external: Vec<Vector3<f64>> = self.external_force[r.clone()]
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
            // With the rest angles at the current ones the springs are silent: `tau` is the load.
            let load = |external: &[Vector3<f64>], local, sc: &mut Scratch<f64>| {
                let p = StrandParams {
                    rest_theta: &rest_theta,
                    rest_phi: &rest_phi,
                    mass: &mass,
                    wetness: &wetness,
                    k_theta: &k_theta,
                    k_phi: &k_phi,
                    damping: &damping,
                    rest_points: &rest_points,
                    external,
                };
                strand::forward(&root, &q, &w, &length, sc);
                strand::forces(&root, &p, &length, local, sc);
                strand::torques(&root, &p, &q, &w, &length, torque, false, sc);
                sc.tau[..q.len()].to_vec()
            };
            let mut tau = load(&external, &local, &mut sc);
            // Per joint coordinate, 1 / stiffness (0 where there is no spring): the weight that
            // turns a moment into a rest-angle offset.
            let compliance: Vec<f64> = (0..q.len())
                .map(|c| {
                    let (i, k) = (c / 2 + 1, [k_theta[c / 2 + 1], k_phi[c / 2 + 1]][c % 2]);
                    if k > 0.0 && !(root.free && i == 1) {
                        1.0 / k
                    } else {
                        0.0
                    }
                })
                .collect();
            let first = supports.partition_point(|x| (x.0 as usize) < r.start + 1);
            let last = supports.partition_point(|x| (x.0 as usize) < r.end);
            let mine = &supports[first..last];
            if !mine.is_empty() {
                external.iter_mut().for_each(|f| *f = Vector3::zeros());
                let mut columns = Vec::with_capacity(mine.len());
                for &(node, normal) in mine {
                    let j = node as usize - r.start;
                    external[j] = normal.cast();
                    let a = load(&external, &bare, &mut sc);
                    external[j] = Vector3::zeros();
                    columns.push(a.iter().zip(&compliance).map(|(a, c)| a * c).collect());
                }
                let offset: Vec<f64> = tau.iter().zip(&compliance).map(|(t, c)| t * c).collect();
                let lambda = least_preload(&columns, offset);
                for (column, l) in mine.iter().zip(&lambda) {
                    let j = column.0 as usize - r.start;
                    external[j] = column.1.cast() * *l;
                }
                // The load with the pushes, evaluated as one: gravity and the pushes together.
                for (f, own) in external
                    .iter_mut()
                    .zip(self.external_force[r.clone()].iter())
                {
                    *f += own.cast::<f64>();
                }
                tau = load(&external, &local, &mut sc);
                pushes.extend(lambda.iter().map(|l| *l as Real));
            }
            for i in 1..n {
                let c = 2 * (i - 1);
                let g = r.start + i;
                if root.free && i == 1 {
                    continue;
                }
                for (k, tau, rest, value) in [
                    (k_theta[i], tau[c], &mut self.rest_theta[g], q[c]),
                    (k_phi[i], tau[c + 1], &mut self.rest_phi[g], q[c + 1]),
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

/// The pushes `l >= 0` that minimise `|offset + sum_k l_k columns_k|^2`: non-negative least
/// squares by Lawson and Hanson's active set, on the normal equations (one unknown per support
/// of a skeleton, so the systems are small).
fn least_preload(columns: &[Vec<f64>], offset: Vec<f64>) -> Vec<f64> {
    let m = columns.len();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let gram: Vec<f64> = (0..m * m)
        .map(|ij| dot(&columns[ij / m], &columns[ij % m]))
        .collect();
    let b: Vec<f64> = columns.iter().map(|c| dot(c, &offset)).collect();
    let trace: f64 = (0..m).map(|k| gram[k * m + k]).sum();
    let tol = 1e-12 * (trace + b.iter().map(|x| x.abs()).sum::<f64>()).max(1e-300);
    let mut lambda = vec![0.0; m];
    let mut passive = vec![false; m];
    let mut z = vec![0.0; m];
    for _ in 0..3 * m + 3 {
        // The descent direction of each held-at-zero push.
        let w = |k: usize, l: &[f64]| -(b[k] + (0..m).map(|i| gram[k * m + i] * l[i]).sum::<f64>());
        let Some(j) = (0..m)
            .filter(|&k| !passive[k])
            .map(|k| (k, w(k, &lambda)))
            .filter(|&(_, wk)| wk > tol)
            .max_by(|a, c| a.1.total_cmp(&c.1))
            .map(|(k, _)| k)
        else {
            break;
        };
        passive[j] = true;
        for _ in 0..m + 1 {
            solve_passive(&gram, &b, &passive, 1e-12 * trace, &mut z);
            if (0..m).all(|k| !passive[k] || z[k] > 0.0) {
                lambda.copy_from_slice(&z);
                break;
            }
            let alpha = (0..m)
                .filter(|&k| passive[k] && z[k] <= 0.0)
                .map(|k| lambda[k] / (lambda[k] - z[k]))
                .fold(1.0, f64::min);
            for k in 0..m {
                lambda[k] += alpha * (z[k] - lambda[k]);
                if passive[k] && lambda[k] <= 0.0 {
                    passive[k] = false;
                    lambda[k] = 0.0;
                }
            }
        }
    }
    lambda
}

/// `z` on the passive set solves `G_PP z_P = -b_P` (Gaussian elimination with partial
/// pivoting, `ridge` on the diagonal for dependent columns); 0 elsewhere.
fn solve_passive(gram: &[f64], b: &[f64], passive: &[bool], ridge: f64, z: &mut [f64]) {
    let m = b.len();
    let idx: Vec<usize> = (0..m).filter(|&k| passive[k]).collect();
    let p = idx.len();
    let mut a: Vec<f64> = Vec::with_capacity(p * (p + 1));
    for &r in &idx {
        a.extend(
            idx.iter()
                .map(|&c| gram[r * m + c] + if r == c { ridge } else { 0.0 }),
        );
        a.push(-b[r]);
    }
    let w = p + 1;
    for col in 0..p {
        let pivot = (col..p)
            .max_by(|&x, &y| a[x * w + col].abs().total_cmp(&a[y * w + col].abs()))
            .unwrap_or(col);
        if pivot != col {
            for k in 0..w {
                a.swap(col * w + k, pivot * w + k);
            }
        }
        let d = a[col * w + col];
        if d.abs() <= f64::MIN_POSITIVE {
            continue;
        }
        for row in col + 1..p {
            let f = a[row * w + col] / d;
            for k in col..w {
                a[row * w + k] -= f * a[col * w + k];
            }
        }
    }
    z.iter_mut().for_each(|v| *v = 0.0);
    for row in (0..p).rev() {
        let d = a[row * w + row];
        let rest: f64 = (row + 1..p).map(|k| a[row * w + k] * z[idx[k]]).sum();
        z[idx[row]] = if d.abs() > f64::MIN_POSITIVE {
            (a[row * w + p] - rest) / d
        } else {
            0.0
        };
    }
}

#[cfg(test)]
mod tests {
    use crate::*;
    use nalgebra::Rotation3;

    /// One strand of `style` whose root sits at the origin and sends the hair along +x
    /// (horizontal, where gravity bends it most).
    fn sideways_strand(
        style: &Style,
        n: usize,
        length: Real,
    ) -> Result<StrandState, DynamicsError> {
        let mut state = StrandState::new();
        let frame = Rotation3::rotation_between(&Vector::z(), &Vector::x())
            .unwrap_or_else(Rotation3::identity);
        let points = style_points(Point::origin(), &frame, style, n, length)?;
        state.add_skeleton(&SkeletonDesc {
            root: Root::Attached {
                position: Point::origin(),
                frame,
            },
            points,
            material: Material::default(),
        })?;
        Ok(state)
    }

    /// A strand leaving its root sideways sags under gravity with its combed rest angles, and
    /// stays put (to a tenth of a millimetre over a second) once its rest angles are solved.
    #[test]
    fn a_sag_free_strand_stays_where_it_was_groomed() {
        let build = |solve: bool| -> Result<Real, DynamicsError> {
            let style = Style::Wavy {
                amplitude: 0.01,
                period: 0.1,
            };
            let mut state = sideways_strand(&style, 12, 0.25)?;
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

    /// A straight strand lying along a floor (root on it, hair along +x, the floor's normal +y
    /// under every node): the body can carry all of it, so the pushes are the nodes' weights
    /// (each node's share of gravity, the root's going to the root) and the rest angles stay
    /// the groom's; without the floor the springs alone hold it, bent by radians.
    #[test]
    fn a_strand_lying_on_a_floor_rests_on_it() -> Result<(), DynamicsError> {
        let build = || sideways_strand(&Style::Straight, 10, 0.3);
        let offset = |s: &StrandState| {
            (0..s.node_count())
                .map(|i| (s.rest_theta()[i] - s.theta()[i]).hypot(s.rest_phi()[i] - s.phi()[i]))
                .fold(0.0, Real::max)
        };
        let env = Environment::default();
        let torque = StepSettings::default().torque;
        let mut alone = build()?;
        alone.make_rest_equilibrium(&env, torque)?;
        let mut lying = build()?;
        let floor: Vec<(u32, Vector)> = (1..10).map(|i| (i, Vector::y())).collect();
        let mut pushes = Vec::new();
        lying.make_rest_equilibrium_on(&env, torque, &floor, &mut pushes)?;
        assert!(
            offset(&alone) > 0.5,
            "springs alone: {} rad",
            offset(&alone)
        );
        assert!(
            offset(&lying) < 1e-4,
            "on the floor: {} rad",
            offset(&lying)
        );
        assert_eq!(pushes.len(), 9);
        for (i, push) in pushes.iter().enumerate() {
            let node = i + 1;
            let weight = (lying.mass()[node] + lying.wetness()[node]) * env.gravity.norm();
            assert!(
                (push - weight).abs() <= 1e-3 * weight,
                "node {node}: push {push} N, weight {weight} N"
            );
        }
        // Out of order, or off the state: a typed error, nothing changed.
        let mut bad = build()?;
        let before = bad.rest_theta().to_vec();
        let swapped = [(2, Vector::y()), (1, Vector::y())];
        assert!(
            bad.make_rest_equilibrium_on(&env, torque, &swapped, &mut pushes)
                .is_err()
        );
        let off = [(10, Vector::y())];
        assert!(
            bad.make_rest_equilibrium_on(&env, torque, &off, &mut pushes)
                .is_err()
        );
        assert_eq!(bad.rest_theta(), &before[..]);
        Ok(())
    }
}
