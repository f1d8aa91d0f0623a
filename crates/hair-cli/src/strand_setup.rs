//! The standard strand of the stability, accuracy and throughput studies, and small helpers they
//! share (output files, log-spaced values).
//!
//! The standard strand: 20 points, 25 cm, 0.02 kg/m, attached at the origin with its root frame's
//! z axis (the direction the hair leaves the scalp) 60 degrees away from straight down, rest angles
//! zero, so both the joint springs and gravity (-y, [`Environment::default`]) act from the start.

use std::path::Path;

use anyhow::Context as _;
use hair::dynamics::{
    Environment, Material, Point, Real, Root, SkeletonDesc, SkeletonId, StrandState, Style, Vector,
    style_points,
};
use nalgebra::{Rotation3, Unit};

/// Control points of the standard strand.
pub const POINTS: usize = 20;
/// Length of the standard strand (m).
pub const LENGTH: Real = 0.25;
/// Mass per unit length of the standard strand (kg/m).
pub const LINEAR_DENSITY: Real = 0.02;
/// Angle between the root direction and straight down at release (degrees).
pub const RELEASE_DEG: Real = 60.0;
/// Gravity of [`Environment::default`] (m/s^2).
pub const GRAVITY: Real = 9.81;
/// Simulated time of the stability and accuracy runs (s).
pub const DURATION: f64 = 2.0;

/// How the joints of a strand are damped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damping {
    /// The same damping on every joint (N m s / rad).
    Fixed(Real),
    /// A damping ratio of each joint's stiffest mode: the joint gets `2 zeta sqrt((k + k_g) I)`,
    /// with `I = m d^2` the inertia of its own node about it (the smallest inertia a joint drives,
    /// so the highest frequency) and `k_g = M g d` the stiffness that the tension of the distal
    /// mass `M` under gravity adds to a zigzag of the chain at that joint.
    Ratio(Real),
}

impl Damping {
    /// Damping coefficient (N m s / rad) of a joint of stiffness `k` driving a node of mass `m`
    /// on a segment of length `d`, with `distal` kg of strand beyond the joint.
    pub fn coefficient(self, k: Real, m: Real, d: Real, distal: Real) -> Real {
        match self {
            Damping::Fixed(g) => g,
            Damping::Ratio(zeta) => {
                let k_g = distal * GRAVITY * d;
                2.0 * zeta * ((k + k_g) * m * d * d).sqrt()
            }
        }
    }
}

/// Root frame of the standard strand: its z axis points `RELEASE_DEG` away from straight down
/// (-y), leaning towards +x.
pub fn release_frame() -> Rotation3<Real> {
    let a = RELEASE_DEG.to_radians();
    let dir = Vector::new(a.sin(), -a.cos(), 0.0);
    // z is never antiparallel to dir here; the axis-angle form avoids an Option.
    let axis = Vector::z().cross(&dir);
    let angle = Vector::z().angle(&dir);
    match Unit::try_new(axis, 1e-12) {
        Some(axis) => Rotation3::from_axis_angle(&axis, angle),
        None => Rotation3::identity(),
    }
}

/// Adds one standard strand rooted at `root` with joint stiffness `k` (N m / rad, the same on
/// every joint and on both angles) and the given damping. Returns its handle.
pub fn add_standard_strand(
    state: &mut StrandState,
    root: Point,
    frame: &Rotation3<Real>,
    k: Real,
    damping: Damping,
) -> anyhow::Result<SkeletonId> {
    let points = style_points(root, frame, &Style::Straight, POINTS, LENGTH)
        .context("building the standard strand's rest polyline")?;
    let id = state
        .add_skeleton(&SkeletonDesc {
            root: Root::Attached {
                position: root,
                frame: *frame,
            },
            points,
            material: Material {
                linear_density: LINEAR_DENSITY,
                ..Material::default()
            },
        })
        .context("adding the standard strand")?;
    let range = state.nodes(id);
    let d = LENGTH / (POINTS - 1) as Real;
    for i in range.start + 1..range.end {
        let m = state.mass()[i];
        let distal: Real = state.mass()[i..range.end].iter().sum();
        state.k_theta_mut()[i] = k;
        state.k_phi_mut()[i] = k;
        state.damping_mut()[i] = damping.coefficient(k, m, d, distal);
    }
    Ok(id)
}

/// A state holding one standard strand released at [`RELEASE_DEG`].
pub fn single_strand(k: Real, damping: Damping) -> anyhow::Result<(StrandState, SkeletonId)> {
    let mut state = StrandState::new();
    let id = add_standard_strand(&mut state, Point::origin(), &release_frame(), k, damping)?;
    Ok((state, id))
}

/// The environment of every study: gravity along -y, nothing else.
pub fn environment() -> Environment {
    Environment::default()
}

/// `count` values spaced evenly in log10 from `10^lo` to `10^hi` (both included).
pub fn log_space(lo: f64, hi: f64, count: usize) -> Vec<f64> {
    if count < 2 {
        return vec![10f64.powf(lo)];
    }
    (0..count)
        .map(|i| 10f64.powf(lo + (hi - lo) * i as f64 / (count - 1) as f64))
        .collect()
}

/// Creates the parent directory of an output file.
pub fn create_parent(path: &Path) -> anyhow::Result<()> {
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("creating the directory {}", dir.display()))?;
    }
    Ok(())
}

/// Writes `value` as pretty JSON to `path`, creating its directory.
pub fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> anyhow::Result<()> {
    create_parent(path)?;
    let text = serde_json::to_string_pretty(value).context("serialising the results")?;
    std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))
}
