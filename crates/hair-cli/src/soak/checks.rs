//! What the soak checks after each step: finite values and the hair's mechanical energy.

use hair::Simulation;
use hair::dynamics::{SkeletonId, StrandState};
use serde::Serialize;

/// A value of the state that is not finite: which field, at which node.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct NonFinite {
    /// The field (`positions`, `theta`, ..., `salon.stiffness`).
    pub field: &'static str,
    /// Its node (global index in the state).
    pub node: usize,
}

/// A non-finite value after a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct NonFiniteAt {
    /// The step.
    pub step: u64,
    /// The value.
    #[serde(flatten)]
    pub value: NonFinite,
}

/// The first value of `state` (every node, active or not) or of the salon's per-node factors
/// that is not finite.
pub fn first_non_finite(state: &StrandState, salon: Option<&hair::Salon>) -> Option<NonFinite> {
    fn scan<T: Copy>(
        field: &'static str,
        values: &[T],
        finite: impl Fn(T) -> bool,
    ) -> Option<NonFinite> {
        let node = values.iter().position(|&v| !finite(v))?;
        Some(NonFinite { field, node })
    }
    let scalar = |v: f32| v.is_finite();
    let vector = |v: hair::dynamics::Vector| v.iter().all(|x| x.is_finite());
    let point = |p: hair::ssv::Point| p.iter().all(|x| x.is_finite());
    let s = state;
    scan("positions", s.positions(), point)
        .or_else(|| scan("velocities", s.velocities(), vector))
        .or_else(|| scan("theta", s.theta(), scalar))
        .or_else(|| scan("phi", s.phi(), scalar))
        .or_else(|| scan("omega_theta", s.omega_theta(), scalar))
        .or_else(|| scan("omega_phi", s.omega_phi(), scalar))
        .or_else(|| scan("rest_theta", s.rest_theta(), scalar))
        .or_else(|| scan("rest_phi", s.rest_phi(), scalar))
        .or_else(|| scan("length", s.length(), scalar))
        .or_else(|| scan("rest_length", s.rest_length(), scalar))
        .or_else(|| scan("mass", s.mass(), scalar))
        .or_else(|| scan("wetness", s.wetness(), scalar))
        .or_else(|| scan("k_theta", s.k_theta(), scalar))
        .or_else(|| scan("k_phi", s.k_phi(), scalar))
        .or_else(|| scan("k_stretch", s.k_stretch(), scalar))
        .or_else(|| scan("damping", s.damping(), scalar))
        .or_else(|| scan("radius", s.radius(), scalar))
        .or_else(|| scan("external_force", s.external_force(), vector))
        .or_else(|| {
            scan(
                "salon.stiffness",
                salon.map_or(&[][..], |x| x.stiffness()),
                scalar,
            )
        })
        .or_else(|| {
            scan(
                "salon.thickness",
                salon.map_or(&[][..], |x| x.thickness()),
                scalar,
            )
        })
}

/// Mechanical energy of the simulated hair (J): kinetic plus the potential of gravity above
/// `floor` (m, along `-gravity`), over the front's skeletons and the unswept fallen pieces,
/// each node's mass its dry mass plus its water, times the strands its skeleton stands for.
pub(super) fn mechanical_energy(sim: &Simulation, gravity: [f32; 3], floor: f64) -> f64 {
    let (state, h) = (sim.state(), sim.hierarchy());
    let g = nalgebra::Vector3::from(gravity).cast::<f64>();
    let g_norm = g.norm();
    let up = if g_norm > 0.0 {
        -g / g_norm
    } else {
        nalgebra::Vector3::zeros()
    };
    let (m, w, x, v) = (
        state.mass(),
        state.wetness(),
        state.positions(),
        state.velocities(),
    );
    let skeleton = |id: SkeletonId, strands: u32| -> f64 {
        let e: f64 = state
            .nodes(id)
            .map(|i| {
                let mass = f64::from(m[i] + w[i]);
                let height = up.dot(&x[i].coords.cast::<f64>()) - floor;
                mass * (0.5 * f64::from(v[i].norm_squared()) + g_norm * height)
            })
            .sum();
        e * f64::from(strands)
    };
    let front: f64 = sim
        .front_nodes()
        .iter()
        .map(|&n| skeleton(SkeletonId(n), h.strand_count(n)))
        .sum();
    let fallen: f64 = sim
        .salon()
        .fallen_pieces()
        .filter(|f| !f.swept)
        .map(|f| skeleton(f.skeleton, h.strand_count(f.source)))
        .sum();
    front + fallen
}

/// The lowest height (m, along `-gravity`) of the front's nodes: the energy's zero.
pub(super) fn lowest_height(sim: &Simulation, gravity: [f32; 3]) -> f64 {
    let g = nalgebra::Vector3::from(gravity).cast::<f64>();
    let up = g
        .try_normalize(0.0)
        .map_or_else(nalgebra::Vector3::zeros, |g| -g);
    let state = sim.state();
    sim.front_nodes()
        .iter()
        .flat_map(|&n| state.nodes(SkeletonId(n)))
        .map(|i| up.dot(&state.positions()[i].coords.cast::<f64>()))
        .fold(f64::INFINITY, f64::min)
}

/// The first non-finite value after a step: of the state, the salon's factors or the step's
/// own figures (penetration, kinetic energy).
pub(super) fn first_non_finite_of(sim: &Simulation, stats: &hair::StepStats) -> Option<NonFinite> {
    first_non_finite(sim.state(), Some(sim.salon())).or_else(|| {
        let figures = [
            ("stats.max_penetration_m", stats.max_penetration_m),
            ("stats.kinetic_energy", stats.kinetic_energy),
        ];
        let (field, _) = figures.into_iter().find(|(_, v)| !v.is_finite())?;
        Some(NonFinite { field, node: 0 })
    })
}
