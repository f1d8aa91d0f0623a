//! The volume hair-hair model against oracles: the splat and the sample against a brute-force
//! f64 sum over every node, the blend's kinetic energy, and the same bits on 1, 2 and 5 threads.

use hair_collide::{HairVolume, VolumeSettings};
use hair_dynamics::{
    Environment, Material, Root, SkeletonDesc, SkeletonId, StepSettings, StrandState,
};
use hair_ssv::test_meshes::SplitMix;
use hair_ssv::{Point, Real, Vector};
use nalgebra::{Rotation3, Vector3};
use proptest::prelude::*;

/// `count` strands of `points` nodes rooted in a 6 cm box, each along its own direction, their
/// joints turning at random rates (up to `spin` rad/s), so that the nodes move every which way.
fn moving_tangle(count: usize, points: usize, seed: u64, spin: Real) -> StrandState {
    let mut state = StrandState::new();
    let mut rng = SplitMix::new(seed);
    for _ in 0..count {
        let root = Point::new(rng.unit() * 0.06, rng.unit() * 0.06, rng.unit() * 0.06);
        let axis = Vector::new(rng.unit() - 0.5, rng.unit() - 0.5, rng.unit() - 0.5);
        let frame = Rotation3::new(axis * 2.0);
        let dir = frame * Vector::z();
        let pts = (0..points)
            .map(|k| root + dir * (0.008 * k as Real))
            .collect();
        state
            .add_skeleton(&SkeletonDesc {
                root: Root::Attached {
                    position: root,
                    frame,
                },
                points: pts,
                material: Material::default(),
            })
            .expect("a valid strand");
    }
    for s in 0..count {
        let id = SkeletonId(s as u32);
        for i in state.nodes(id).skip(1) {
            state.omega_theta_mut()[i] = rng.range(-spin, spin);
            state.omega_phi_mut()[i] = rng.range(-spin, spin);
        }
        state.refresh_positions(id);
    }
    state
}

fn all(state: &StrandState) -> Vec<u32> {
    (0..state.skeleton_count() as u32).collect()
}

fn no_repulsion() -> VolumeSettings {
    VolumeSettings {
        repulsion: false,
        ..VolumeSettings::default()
    }
}

/// Trilinear weights of the eight lattice points around `p`, by index, in f64.
fn brute_weights(p: &Point, origin: &Point, h: f64, dims: [usize; 3]) -> Vec<(usize, f64)> {
    let local: Vector3<f64> = (p - origin).map(f64::from) / h;
    let cell = local.map(|x| x.floor().max(0.0) as usize);
    let cell = [0, 1, 2].map(|k| cell[k].min(dims[k] - 2));
    let frac = [0, 1, 2].map(|k| (local[k] - cell[k] as f64).clamp(0.0, 1.0));
    let mut out = Vec::new();
    for dz in 0..2 {
        for dy in 0..2 {
            for dx in 0..2 {
                let w = [dx, dy, dz]
                    .iter()
                    .zip(frac)
                    .map(|(&d, f)| if d == 1 { f } else { 1.0 - f })
                    .product::<f64>();
                let index = ((cell[2] + dz) * dims[1] + cell[1] + dy) * dims[0] + cell[0] + dx;
                out.push((index, w));
            }
        }
    }
    out
}

/// The lattice's velocity and density, and every node's blended velocity, agree with the
/// same transfer summed node by node in f64.
#[test]
fn splat_and_sample_match_a_brute_force_sum() {
    for seed in 0..4 {
        let state = moving_tangle(150, 10, seed, 3.0);
        let front = all(&state);
        let settings = no_repulsion();
        let dt = 1.0 / 60.0;
        let mut volume = HairVolume::new();
        let report = volume.blend(&state, &front, &settings, dt).unwrap();
        assert_eq!(report.nodes, 150 * 9);
        let lattice = volume.lattice();
        let (h, dims) = (f64::from(lattice.spacing), lattice.dims);
        let cells = dims.iter().product::<usize>();
        assert_eq!(report.cells, cells);
        let mut mass = vec![0.0f64; cells];
        let mut momentum = vec![Vector3::<f64>::zeros(); cells];
        let (p, v, m) = (state.positions(), state.velocities(), state.mass());
        let nodes: Vec<usize> = front
            .iter()
            .flat_map(|&s| state.nodes(SkeletonId(s)).skip(1))
            .collect();
        for &i in &nodes {
            for (j, w) in brute_weights(&p[i], &lattice.origin, h, dims) {
                mass[j] += w * f64::from(m[i]);
                momentum[j] += v[i].map(f64::from) * (w * f64::from(m[i]));
            }
        }
        let grid_v: Vec<Vector3<f64>> = mass
            .iter()
            .zip(&momentum)
            .map(|(&m, p)| if m > 0.0 { p / m } else { Vector3::zeros() })
            .collect();
        let vmax = v.iter().map(|x| f64::from(x.norm())).fold(0.0, f64::max);
        let mass_max = mass.iter().copied().fold(0.0, f64::max);
        let rho_max = mass_max / h.powi(3);
        for j in 0..cells {
            // By momentum: where a point holds only a sliver of a node (a weight of 1e-6),
            // the f32 weight's relative error shows in its velocity, not in what it carries.
            let got = volume.lattice_velocity(j).unwrap().map(f64::from);
            assert!(
                (got - grid_v[j]).norm() * mass[j] <= 1e-5 * vmax * mass_max,
                "point {j}: {got} vs {}",
                grid_v[j]
            );
            let rho = mass[j] / h.powi(3);
            assert!((f64::from(volume.lattice_density(j).unwrap()) - rho).abs() <= 1e-5 * rho_max);
        }
        let rate = |k: usize| {
            let t = k as f64 / 9.0;
            f64::from(settings.friction_root)
                + (f64::from(settings.friction_tip) - f64::from(settings.friction_root)) * t
        };
        let targets = volume.targets();
        assert_eq!(targets.len(), nodes.len());
        for (&(node, got), &i) in targets.iter().zip(&nodes) {
            assert_eq!(node as usize, i);
            let k = i - state.nodes(SkeletonId(state.skeleton_of(i))).start;
            let sampled: Vector3<f64> = brute_weights(&p[i], &lattice.origin, h, dims)
                .into_iter()
                .map(|(j, w)| grid_v[j] * w)
                .sum();
            let alpha = 1.0 - (-rate(k) * f64::from(dt)).exp();
            let own = v[i].map(f64::from);
            let want = own + (sampled - own) * alpha;
            assert!(
                (got.map(f64::from) - want).norm() <= 1e-5 * vmax,
                "node {i}"
            );
        }
    }
}

/// The repulsion pushes nodes only where the density is over the limit, and down its
/// gradient: with no friction, a small step along each node's change lowers the brute-force
/// density there.
#[test]
fn repulsion_pushes_out_of_dense_hair_only() {
    let state = moving_tangle(300, 10, 11, 0.0);
    let front = all(&state);
    let settings = VolumeSettings {
        friction_root: 0.0,
        friction_tip: 0.0,
        density_limit: 1.0,
        ..VolumeSettings::default()
    };
    let mut volume = HairVolume::new();
    let report = volume.blend(&state, &front, &settings, 1.0 / 60.0).unwrap();
    assert!(
        report.repelled > 0 && report.repelled < report.nodes,
        "{report:?}"
    );
    let lattice = volume.lattice();
    let h = f64::from(lattice.spacing);
    let density = |j: usize| volume.lattice_density(j).unwrap();
    let limit = f64::from(volume.mean_density());
    let rho_at = |q: &Point| -> f64 {
        brute_weights(q, &lattice.origin, h, lattice.dims)
            .into_iter()
            .map(|(j, w)| w * f64::from(density(j)))
            .sum()
    };
    let (p, v) = (state.positions(), state.velocities());
    let mut pushed = 0;
    for &(node, target) in volume.targets() {
        let i = node as usize;
        let change = target - v[i];
        if change.norm() == 0.0 {
            assert!(
                rho_at(&p[i]) <= limit * (1.0 + 1e-4),
                "node {i} over the limit, not pushed"
            );
            continue;
        }
        pushed += 1;
        assert!(
            rho_at(&p[i]) >= limit * (1.0 - 1e-4),
            "node {i} pushed below the limit"
        );
        let step = change.normalize() * (1e-3 * lattice.spacing);
        assert!(
            rho_at(&(p[i] + step)) <= rho_at(&p[i]) + 1e-9 * limit,
            "node {i} pushed uphill"
        );
    }
    assert_eq!(pushed, report.repelled);
}

/// Whatever the rayon pool's size, the lattice, the blended velocities and the response's
/// forces are the same bits.
#[test]
fn volume_is_bit_identical_on_1_2_and_5_threads() {
    // 33,000 nodes on about 1,400 lattice points: 9 parts splatted into 4 copies.
    let state = moving_tangle(3000, 12, 5, 2.0);
    let front = all(&state);
    let settings = VolumeSettings {
        cell_size: 2.5,
        ..VolumeSettings::default()
    };
    type Bits = (Vec<[u32; 3]>, Vec<u32>, Vec<[u32; 3]>, u64);
    let bits = |threads: usize| -> Bits {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut volume = HairVolume::new();
            let report = volume.blend(&state, &front, &settings, 1.0 / 60.0).unwrap();
            assert!(report.repelled > 0);
            let b = |v: &Vector| [v.x, v.y, v.z].map(f32::to_bits);
            let points = 0..report.cells;
            (
                points
                    .clone()
                    .map(|j| b(&volume.lattice_velocity(j).unwrap()))
                    .collect(),
                points
                    .map(|j| volume.lattice_density(j).unwrap().to_bits())
                    .collect(),
                volume.targets().iter().map(|t| b(&t.1)).collect(),
                {
                    // The response's forces, through the step they act in.
                    let mut moved = state.clone();
                    volume
                        .respond(&mut moved, &front, &settings, 1.0 / 60.0)
                        .unwrap();
                    moved
                        .step(&Environment::default(), &StepSettings::default())
                        .unwrap();
                    moved.state_hash()
                },
            )
        })
    };
    let one = bits(1);
    assert!(
        (1000..4000).contains(&one.0.len()),
        "{} points",
        one.0.len()
    );
    assert!(one == bits(2), "2 threads differ from 1");
    assert!(one == bits(5), "5 threads differ from 1");
}

/// Non-finite hair is refused with the node named, not splatted.
#[test]
fn a_non_finite_node_is_an_error() {
    let mut state = moving_tangle(3, 5, 1, 1.0);
    let front = all(&state);
    state.omega_theta_mut()[7] = f32::NAN;
    state.refresh_positions(SkeletonId(1));
    let mut volume = HairVolume::new();
    let err = volume
        .blend(&state, &front, &VolumeSettings::default(), 0.01)
        .unwrap_err();
    assert!(err.to_string().contains("node"), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The blend toward the grid's velocity never raises the nodes' kinetic energy (the
    /// transfer to the grid and back is an average, and the blend a convex combination), for
    /// any friction rates and step, on hair spread out or piled into one cell.
    #[test]
    fn the_blend_never_raises_kinetic_energy(
        seed in 0u64..1000,
        count in 1usize..80,
        points in 2usize..12,
        spin in 0.0f32..20.0,
        root_rate in 0.0f32..500.0,
        tip_rate in 0.0f32..500.0,
        dt in 1e-4f32..0.1,
        cell_size in 0.1f32..40.0,
    ) {
        let state = moving_tangle(count, points, seed, spin);
        let front = all(&state);
        let settings = VolumeSettings {
            friction_root: root_rate,
            friction_tip: tip_rate,
            cell_size,
            ..no_repulsion()
        };
        let mut volume = HairVolume::new();
        volume.blend(&state, &front, &settings, dt).unwrap();
        let (v, m) = (state.velocities(), state.mass());
        let energy = |pairs: &mut dyn Iterator<Item = (usize, Vector)>| -> f64 {
            pairs.map(|(i, x)| 0.5 * f64::from(m[i]) * f64::from(x.norm_squared())).sum()
        };
        let targets = volume.targets();
        let before = energy(&mut targets.iter().map(|&(i, _)| (i as usize, v[i as usize])));
        let after = energy(&mut targets.iter().map(|&(i, x)| (i as usize, x)));
        prop_assert!(after <= before * (1.0 + 1e-5) + 1e-12, "{} > {}", after, before);
    }
}

/// The response taken with the coupled step never raises the strand model's energy (kinetic
/// with the model's inertia, plus the springs') by more than 0.5% of the start's in a step: the friction acts as the force that makes the
/// blend's velocity change, so its power on the model is its power on the nodes. Setting the
/// velocities and fitting rates to them instead raised it several fold within a few steps.
#[test]
fn the_response_takes_energy_out_of_the_strand_model() {
    let env = Environment {
        gravity: Vector::zeros(),
        ..Environment::default()
    };
    let step = StepSettings::default();
    for seed in 0..6u64 {
        let mut state = moving_tangle(60, 12, seed, 8.0);
        state.damping_mut().fill(0.0);
        let front = all(&state);
        let settings = VolumeSettings {
            friction_root: 40.0,
            friction_tip: 40.0,
            ..no_repulsion()
        };
        let mut volume = HairVolume::new();
        let first = state.model_energy(&env, step.torque);
        let mut last = first;
        for k in 0..40 {
            volume
                .respond(&mut state, &front, &settings, step.dt)
                .unwrap();
            state.step(&env, &step).unwrap();
            let e = state.model_energy(&env, step.torque);
            assert!(
                e <= last + 5e-3 * first,
                "seed {seed} step {k}: model energy {e:e} J after {last:e} J (start {first:e} J)"
            );
            last = e;
        }
        assert!(
            last < 0.5 * first,
            "seed {seed}: friction took too little: {last:e} of {first:e} J"
        );
    }
}
