//! Forces that act on every node: gravity, the head's motion, wind and force fields.
//!
//! Kurihara et al. §2, eq. 6: the external force is `d (g + a) + d f` — gravity, the head's own
//! acceleration, and a force density such as wind. Strands are simulated in the head's frame, so
//! the head's motion enters as fictitious forces (linear acceleration, angular acceleration,
//! centrifugal and Coriolis), which is what makes a shaking head swing its hair.

use crate::error::{finite, finite_vec, non_negative};
use crate::{DynamicsError, Point, Real, Vector};
use nalgebra::{Rotation3, Vector3};

/// The head's rigid motion at the current time, in world coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadMotion {
    /// World position of the head frame's origin (m).
    pub position: Point,
    /// World-from-head rotation.
    pub rotation: Rotation3<Real>,
    /// Velocity of the head origin (m/s).
    pub linear_velocity: Vector,
    /// Acceleration of the head origin (m/s^2).
    pub linear_acceleration: Vector,
    /// Angular velocity (rad/s, world axes).
    pub angular_velocity: Vector,
    /// Angular acceleration (rad/s^2, world axes).
    pub angular_acceleration: Vector,
}

impl Default for HeadMotion {
    fn default() -> Self {
        Self {
            position: Point::origin(),
            rotation: Rotation3::identity(),
            linear_velocity: Vector::zeros(),
            linear_acceleration: Vector::zeros(),
            angular_velocity: Vector::zeros(),
            angular_acceleration: Vector::zeros(),
        }
    }
}

/// A wind field: a mean flow with gusts in time and a smooth turbulent perturbation in space.
///
/// The air velocity at world point `p` and time `t` is
/// `direction * speed * (1 + gust * sin(2 pi f t)) + speed * turbulence * n(p / scale, t)`, where
/// `n` is a divergence-free-looking sum of three seeded sine waves with unit amplitude. Drag acts
/// on the component of the air's velocity relative to the segment that is normal to the segment:
/// `F = drag * length * (u - (u . t) t)` (linear drag, N per m of segment per m/s).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct Wind {
    /// Mean flow direction (normalised on use; zero means no mean flow). Default `-z`: toward
    /// the face of a head that looks along `+z`.
    #[cfg_attr(feature = "serde", serde(with = "vector_as_array"))]
    pub direction: Vector,
    /// Mean speed (m/s).
    pub speed: Real,
    /// Gust amplitude as a fraction of the mean speed.
    pub gust: Real,
    /// Gust frequency (Hz).
    pub gust_frequency: Real,
    /// Turbulence amplitude as a fraction of the mean speed.
    pub turbulence: Real,
    /// Length scale of the turbulence (m).
    pub turbulence_scale: Real,
    /// Linear drag coefficient (N s / m^2: force per metre of segment per m/s of normal flow).
    pub drag: Real,
    /// Seed of the turbulence phases (a scene file leaves it to the scene's own seed).
    #[cfg_attr(feature = "serde", serde(skip))]
    pub seed: u64,
}

/// A vector as the three numbers `(x, y, z)` in a serialized file.
#[cfg(feature = "serde")]
mod vector_as_array {
    use crate::Vector;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &Vector, s: S) -> Result<S::Ok, S::Error> {
        [v.x, v.y, v.z].serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vector, D::Error> {
        <[f32; 3]>::deserialize(d).map(Vector::from)
    }
}

impl Default for Wind {
    fn default() -> Self {
        Self {
            direction: -Vector::z(),
            speed: 0.0,
            gust: 0.0,
            gust_frequency: 0.5,
            turbulence: 0.0,
            turbulence_scale: 0.1,
            drag: 0.0,
            seed: 0,
        }
    }
}

impl Wind {
    /// Air velocity (m/s, world) at world point `p` and time `t` (s).
    pub fn velocity(&self, p: &Point, t: Real) -> Vector {
        self.at_time(t).velocity(p)
    }

    /// The field at time `t`: what does not depend on the point, worked out once for the many
    /// points of a step.
    fn at_time(&self, t: Real) -> WindAt {
        let dir_norm = self.direction.norm();
        if self.speed == 0.0 || dir_norm == 0.0 {
            return WindAt::default();
        }
        let dir = self.direction / dir_norm;
        let gust = 1.0 + self.gust * (core::f32::consts::TAU * self.gust_frequency * t).sin();
        let turbulent = self.turbulence != 0.0 && self.turbulence_scale > 0.0;
        WindAt {
            mean: dir * (self.speed * gust),
            turbulence: turbulent.then(|| Turbulence {
                scale: self.turbulence_scale,
                phases: phases(self.seed),
                drift: t * self.speed / self.turbulence_scale,
                amplitude: self.speed * self.turbulence,
            }),
        }
    }

    fn validate(&self) -> Result<(), DynamicsError> {
        finite_vec("wind.direction", &self.direction)?;
        non_negative("wind.speed", self.speed)?;
        non_negative("wind.gust", self.gust)?;
        non_negative("wind.gust_frequency", self.gust_frequency)?;
        non_negative("wind.turbulence", self.turbulence)?;
        non_negative("wind.turbulence_scale", self.turbulence_scale)?;
        non_negative("wind.drag", self.drag)
    }
}

/// [`Wind`] at one time.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct WindAt {
    /// The mean flow with its gust (zero without wind).
    pub mean: Vector,
    pub turbulence: Option<Turbulence>,
}

/// The turbulent part of [`WindAt`]: `amplitude * (sin(q.y + phases[0] + drift),
/// sin(q.z + phases[1] + drift), sin(q.x + phases[2] + drift))` with `q = p / scale`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Turbulence {
    pub scale: Real,
    pub phases: [Real; 3],
    pub drift: Real,
    pub amplitude: Real,
}

impl WindAt {
    /// Air velocity (m/s, world) at world point `p`.
    fn velocity(&self, p: &Point) -> Vector {
        let mut v = self.mean;
        if let Some(tb) = &self.turbulence {
            let q = p.coords / tb.scale;
            let ph = tb.phases;
            // Three plane waves along the axes, each pushing across its own axis, so the field
            // varies smoothly in space and drifts with the mean flow in time.
            let a = (q.y + ph[0] + tb.drift).sin();
            let b = (q.z + ph[1] + tb.drift).sin();
            let c = (q.x + ph[2] + tb.drift).sin();
            v += Vector::new(a, b, c) * tb.amplitude;
        }
        v
    }
}

/// Seeded phases in [0, 2 pi) from a splitmix64 stream: deterministic on every platform.
fn phases(seed: u64) -> [Real; 3] {
    let mut s = seed;
    let mut next = || {
        s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 40) as Real / (1u64 << 24) as Real * core::f32::consts::TAU
    };
    [next(), next(), next()]
}

/// A force field acting on nodes (world coordinates): the hair dryer's cone and friends.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum ForceField {
    /// The same force per unit mass (m/s^2) everywhere.
    Uniform {
        /// Acceleration added to every node.
        acceleration: Vector,
    },
    /// A cone of force: nodes within `reach` of `apex` and within `half_angle` of `direction`
    /// are pushed along `direction` with `strength` N, fading linearly to zero at the reach.
    Cone {
        /// The cone's apex (world).
        apex: Point,
        /// The cone's axis (normalised on use).
        direction: Vector,
        /// Length of the cone (m).
        reach: Real,
        /// Half opening angle (rad), in (0, pi/2).
        half_angle: Real,
        /// Force at the apex (N per node).
        strength: Real,
    },
}

impl ForceField {
    /// Force (N, world) on a node of mass `mass` at world point `p`.
    pub fn force(&self, p: &Point, mass: Real) -> Vector {
        match *self {
            ForceField::Uniform { acceleration } => acceleration * mass,
            ForceField::Cone {
                apex,
                direction,
                reach,
                half_angle,
                strength,
            } => {
                let n = direction.norm();
                if n == 0.0 || reach <= 0.0 {
                    return Vector::zeros();
                }
                let axis = direction / n;
                let r = p - apex;
                let along = r.dot(&axis);
                if along <= 0.0 || along > reach {
                    return Vector::zeros();
                }
                let across = (r - axis * along).norm();
                if across > along * half_angle.tan() {
                    return Vector::zeros();
                }
                axis * (strength * (1.0 - along / reach))
            }
        }
    }

    fn validate(&self) -> Result<(), DynamicsError> {
        match self {
            ForceField::Uniform { acceleration } => finite_vec("field.acceleration", acceleration),
            ForceField::Cone {
                apex,
                direction,
                reach,
                half_angle,
                strength,
            } => {
                finite_vec("cone.apex", &apex.coords)?;
                finite_vec("cone.direction", direction)?;
                non_negative("cone.reach", *reach)?;
                non_negative("cone.strength", *strength)?;
                finite("cone.half_angle", *half_angle)?;
                if !(*half_angle > 0.0 && *half_angle < core::f32::consts::FRAC_PI_2) {
                    return Err(DynamicsError::OutOfRange {
                        name: "cone.half_angle",
                        value: f64::from(*half_angle),
                        expected: "in (0, pi/2)",
                    });
                }
                Ok(())
            }
        }
    }
}

/// Everything outside the strands that pushes on them during one step.
#[derive(Clone, Debug, PartialEq)]
pub struct Environment {
    /// Gravity (m/s^2, world).
    pub gravity: Vector,
    /// The head's motion at the start of the step.
    pub head: HeadMotion,
    /// Wind.
    pub wind: Wind,
    /// Force fields (hair dryer cones, ...).
    pub fields: Vec<ForceField>,
    /// Simulated time at the start of the step (s), for gusts.
    pub time: Real,
}

impl Default for Environment {
    fn default() -> Self {
        Self {
            gravity: Vector::new(0.0, -9.81, 0.0),
            head: HeadMotion::default(),
            wind: Wind::default(),
            fields: Vec::new(),
            time: 0.0,
        }
    }
}

impl Environment {
    /// Checks every value for finiteness and range.
    pub fn validate(&self) -> Result<(), DynamicsError> {
        finite_vec("gravity", &self.gravity)?;
        let h = &self.head;
        finite_vec("head.position", &h.position.coords)?;
        for c in h.rotation.matrix().iter() {
            finite("head.rotation", *c)?;
        }
        finite_vec("head.linear_velocity", &h.linear_velocity)?;
        finite_vec("head.linear_acceleration", &h.linear_acceleration)?;
        finite_vec("head.angular_velocity", &h.angular_velocity)?;
        finite_vec("head.angular_acceleration", &h.angular_acceleration)?;
        finite("time", self.time)?;
        self.wind.validate()?;
        for f in &self.fields {
            f.validate()?;
        }
        Ok(())
    }

    /// The environment seen from the head's frame, in the scalar type `T` of the kernel.
    pub(crate) fn local<T: nalgebra::RealField + Copy>(&self) -> LocalEnv<'_, T> {
        let rt = self.head.rotation.inverse();
        let g = rt * (self.gravity - self.head.linear_acceleration);
        let w = rt * self.head.angular_velocity;
        let a = rt * self.head.angular_acceleration;
        LocalEnv {
            gravity: cast(&g),
            omega: cast(&w),
            alpha: cast(&a),
            env: self,
            wind: self.wind.at_time(self.time),
            has_air: self.wind.drag > 0.0,
            has_frame_motion: w.norm_squared() > 0.0 || a.norm_squared() > 0.0,
        }
    }
}

fn cast<T: nalgebra::RealField + Copy>(v: &Vector) -> Vector3<T> {
    Vector3::new(
        T::from_f32(v.x).unwrap_or_else(T::zero),
        T::from_f32(v.y).unwrap_or_else(T::zero),
        T::from_f32(v.z).unwrap_or_else(T::zero),
    )
}

/// The environment prepared for the per-strand kernel: head-frame quantities in `T`.
pub(crate) struct LocalEnv<'a, T: nalgebra::RealField + Copy> {
    /// Gravity minus the head's linear acceleration, head frame.
    pub gravity: Vector3<T>,
    /// Head angular velocity, head frame.
    pub omega: Vector3<T>,
    /// Head angular acceleration, head frame.
    pub alpha: Vector3<T>,
    pub env: &'a Environment,
    /// The wind at the step's time.
    pub wind: WindAt,
    pub has_air: bool,
    pub has_frame_motion: bool,
}

impl<T: nalgebra::RealField + Copy> LocalEnv<'_, T> {
    /// Air velocity relative to the head frame at head-frame point `p` (head-frame coordinates).
    pub fn air_velocity(&self, p: &Vector3<T>) -> Vector3<T> {
        let h = &self.env.head;
        let pf = Vector::new(to_f32(p.x), to_f32(p.y), to_f32(p.z));
        let turned = h.rotation * pf;
        let pw = h.position + turned;
        let wind = self.wind.velocity(&pw);
        // Air velocity seen by an observer moving with the head: subtract the frame's velocity
        // at that point, then express in head coordinates.
        let frame_vel = h.linear_velocity + h.angular_velocity.cross(&turned);
        cast(&(h.rotation.inverse() * (wind - frame_vel)))
    }

    /// Sum of the force fields on a node (head frame).
    pub fn field_force(&self, p: &Vector3<T>, mass: T) -> Vector3<T> {
        let h = &self.env.head;
        let pw = h.position + h.rotation * Vector::new(to_f32(p.x), to_f32(p.y), to_f32(p.z));
        let mut f = Vector::zeros();
        for field in &self.env.fields {
            f += field.force(&pw, to_f32(mass));
        }
        cast(&(h.rotation.inverse() * f))
    }
}

fn to_f32<T: nalgebra::RealField + Copy>(x: T) -> f32 {
    // RealField is implemented for f32 and f64 here; SupersetOf<f64> gives a lossless route.
    nalgebra::try_convert::<T, f64>(x).map_or(f32::NAN, |v| v as f32)
}
