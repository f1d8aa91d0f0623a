//! The head's motion estimated from the rigid poses a caller gives, one a step.
//!
//! Strands are simulated in the head's frame, so the head's velocity and acceleration enter the
//! step as fictitious forces ([`HeadMotion`]). A game engine knows only poses: where the head is
//! each frame. [`HeadPoseTrack`] keeps the pose a step ago, the pose now and the pose the head
//! reaches at the end of the next step, and differentiates them by central differences at the
//! step's start: velocity `(x+ - x-) / 2h`, acceleration `(x+ - 2x + x-) / h^2`, and for the
//! rotation the same over the rotation vectors of the two relative rotations `R+ R^T` and
//! `R R-^T`. Both are second order in the step `h` (and computed in f64). A pose that jumps
//! farther than [`TeleportLimits`] in one step is a teleport: the track moves on as if the head
//! had kept its velocity and hands back the rigid offset that carries the hair to the new pose.

use crate::error::{finite, non_negative};
use crate::{DynamicsError, HeadMotion, Point, Real};
use nalgebra::{Isometry3, Rotation3, UnitQuaternion, Vector3};

/// A rigid pose: world from head (rotation, then translation of the head frame's origin).
pub type HeadPose = Isometry3<Real>;

/// How far the head may move in one step before the move counts as a teleport.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TeleportLimits {
    /// Largest distance of the head origin in one step (m). Default 0.2.
    pub distance: Real,
    /// Largest rotation in one step (rad). Default 0.5.
    pub angle: Real,
}

impl TeleportLimits {
    /// Whether a move from `from` to `to` in one step goes beyond the limits (a teleport).
    pub fn exceeded_by(&self, from: &HeadPose, to: &HeadPose) -> bool {
        let distance = (to.translation.vector - from.translation.vector).norm();
        distance > self.distance || from.rotation.angle_to(&to.rotation) > self.angle
    }
}

impl Default for TeleportLimits {
    fn default() -> Self {
        Self {
            distance: 0.2,
            angle: 0.5,
        }
    }
}

/// What [`HeadPoseTrack::set_next`] made of a pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PoseJump {
    /// Within the limits: the next step's motion is estimated with it.
    Smooth,
    /// Beyond them: the track went on at its last velocity instead, and `offset` carries that
    /// pose rigidly to the one given (`offset * next = pose`); composed onto the caller's own
    /// offset from the track's frame to the world (`world = old_offset * offset * track`), it
    /// moves the head and the hair with it, the hair's motion relative to the head untouched.
    Teleport {
        /// The rigid offset to compose.
        offset: HeadPose,
    },
}

/// The poses a step ago, now and at the end of the next step, and the motion they give.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadPoseTrack {
    dt: Real,
    limits: TeleportLimits,
    previous: HeadPose,
    current: HeadPose,
    next: Option<HeadPose>,
}

/// An error unless every number of the pose is finite.
fn check_pose(name: &'static str, pose: &HeadPose) -> Result<(), DynamicsError> {
    let q = pose.rotation.quaternion();
    let t = &pose.translation.vector;
    for x in q.coords.iter().chain(t.iter()) {
        finite(name, *x)?;
    }
    Ok(())
}

/// The rotation vector (axis times angle, the shorter way round) of a unit quaternion.
fn log(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let (mut v, mut w) = (q.imag(), q.w);
    if w < 0.0 {
        (v, w) = (-v, -w);
    }
    let n = v.norm();
    if n == 0.0 {
        return Vector3::zeros();
    }
    v * (2.0 * n.atan2(w) / n)
}

impl HeadPoseTrack {
    /// A head at rest at `pose` (it was there a step ago too), stepped every `dt` seconds.
    pub fn new(dt: Real, pose: HeadPose) -> Result<Self, DynamicsError> {
        Self::with_previous(dt, pose, pose)
    }

    /// A head at `current` that was at `previous` a step of `dt` seconds ago: a head already
    /// moving when the simulation starts.
    pub fn with_previous(
        dt: Real,
        previous: HeadPose,
        current: HeadPose,
    ) -> Result<Self, DynamicsError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(DynamicsError::InvalidTimeStep { dt: f64::from(dt) });
        }
        check_pose("head pose (previous)", &previous)?;
        check_pose("head pose (current)", &current)?;
        Ok(Self {
            dt,
            limits: TeleportLimits::default(),
            previous,
            current,
            next: None,
        })
    }

    /// Sets the teleport limits (finite and non-negative, else an error and no change).
    pub fn set_limits(&mut self, limits: TeleportLimits) -> Result<(), DynamicsError> {
        non_negative("teleport.distance", limits.distance)?;
        non_negative("teleport.angle", limits.angle)?;
        self.limits = limits;
        Ok(())
    }

    /// The teleport limits.
    pub fn limits(&self) -> TeleportLimits {
        self.limits
    }

    /// The pose now (the start of the next step).
    pub fn current(&self) -> &HeadPose {
        &self.current
    }

    /// The pose given for the end of the next step, if any.
    pub fn next(&self) -> Option<&HeadPose> {
        self.next.as_ref()
    }

    /// The pose a step ago.
    pub fn previous(&self) -> &HeadPose {
        &self.previous
    }

    /// The pose the head reaches at the end of the next step. Non-finite: an error and the
    /// track unchanged. A jump from the current pose beyond the limits is a teleport (see
    /// [`PoseJump::Teleport`]). A later call before the step replaces an earlier one.
    pub fn set_next(&mut self, pose: HeadPose) -> Result<PoseJump, DynamicsError> {
        check_pose("head pose", &pose)?;
        if !self.limits.exceeded_by(&self.current, &pose) {
            self.next = Some(pose);
            return Ok(PoseJump::Smooth);
        }
        // On at the last velocity: the same relative motion again from the current pose.
        let (p, c) = (&self.previous, &self.current);
        let turn = c.rotation * p.rotation.inverse();
        let mut ahead = *c;
        ahead.rotation = turn * c.rotation;
        ahead.translation.vector = c.translation.vector * 2.0 - p.translation.vector;
        self.next = Some(ahead);
        Ok(PoseJump::Teleport {
            offset: pose * ahead.inverse(),
        })
    }

    /// The head's motion at the start of the next step: the current pose, and velocities and
    /// accelerations by central differences over the previous, current and next poses (with no
    /// next pose given, the head holds still over the step).
    pub fn motion(&self) -> HeadMotion {
        let (p, c) = (&self.previous, &self.current);
        let n = self.next.as_ref().unwrap_or(c);
        let h = f64::from(self.dt);
        let x = |q: &HeadPose| q.translation.vector.cast::<f64>();
        let r = |q: &HeadPose| q.rotation.cast::<f64>();
        let (xp, xc, xn) = (x(p), x(c), x(n));
        let ahead = log(&(r(n) * r(c).inverse())) / h;
        let behind = log(&(r(c) * r(p).inverse())) / h;
        HeadMotion {
            position: Point::from(c.translation.vector),
            rotation: Rotation3::from(c.rotation),
            linear_velocity: ((xn - xp) / (2.0 * h)).cast(),
            linear_acceleration: ((xn - xc * 2.0 + xp) / (h * h)).cast(),
            angular_velocity: ((ahead + behind) * 0.5).cast(),
            angular_acceleration: ((ahead - behind) / h).cast(),
        }
    }

    /// Moves on by one step: the current pose becomes the previous, the next (or the current,
    /// when none was given) the current.
    pub fn advance(&mut self) {
        let next = self.next.take().unwrap_or(self.current);
        self.previous = self.current;
        self.current = next;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, Vector3};

    /// A head swaying along x by `a sin(w t)` and turning about y by `b sin(w t)`.
    fn sway(t: f64) -> HeadPose {
        let (a, b, w) = (0.1, 0.6, 7.5);
        let s = (w * t).sin();
        Isometry3::from_parts(
            Translation3::new((a * s) as Real, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), (b * s) as Real),
        )
    }

    /// The largest error of the estimated velocity and acceleration (linear and angular) at
    /// `t` with step `h`, against the analytic derivatives of [`sway`].
    fn worst_error(t: f64, h: f64) -> f64 {
        let (a, b, w) = (0.1, 0.6, 7.5);
        let mut track = HeadPoseTrack::with_previous(h as Real, sway(t - h), sway(t)).unwrap();
        assert_eq!(track.set_next(sway(t + h)).unwrap(), PoseJump::Smooth);
        let m = track.motion();
        let (c, s) = ((w * t).cos(), (w * t).sin());
        let errors = [
            f64::from(m.linear_velocity.x) - a * w * c,
            f64::from(m.linear_acceleration.x) + a * w * w * s,
            f64::from(m.angular_velocity.y) - b * w * c,
            f64::from(m.angular_acceleration.y) + b * w * w * s,
            f64::from(m.linear_velocity.yz().norm() + m.angular_velocity.xz().norm()),
        ];
        errors.iter().fold(0.0, |e, x| e.max(x.abs()))
    }

    #[test]
    fn a_sine_is_differentiated_to_second_order() {
        for t in [0.0, 0.13, 0.37, 0.5] {
            let coarse = worst_error(t, 0.01);
            let fine = worst_error(t, 0.005);
            // Truncation: at most max(a, b) w^4 h^2 / 12 for the accelerations.
            let bound = 0.6 * 7.5f64.powi(4) * 0.01f64.powi(2) / 12.0;
            assert!(coarse < bound * 1.05, "t = {t}: {coarse} over {bound}");
            assert!(
                fine < coarse / 3.0,
                "t = {t}: {fine} is not a quarter of {coarse}"
            );
        }
    }

    #[test]
    fn a_still_head_has_exactly_no_motion() {
        let pose = sway(0.2);
        let mut track = HeadPoseTrack::new(1.0 / 60.0, pose).unwrap();
        track.set_next(pose).unwrap();
        let m = track.motion();
        assert_eq!(m.linear_velocity, nalgebra::Vector3::zeros());
        assert_eq!(m.angular_acceleration, nalgebra::Vector3::zeros());
        assert_eq!(m.position, Point::from(pose.translation.vector));
    }

    #[test]
    fn a_non_finite_pose_is_refused_and_changes_nothing() {
        let mut track = HeadPoseTrack::new(0.01, sway(0.0)).unwrap();
        track.set_next(sway(0.01)).unwrap();
        let before = track.clone();
        let mut bad = sway(0.02);
        bad.translation.vector.y = Real::NAN;
        assert!(track.set_next(bad).is_err());
        assert_eq!(track, before);
    }

    #[test]
    fn a_jump_beyond_the_limits_is_a_teleport_not_a_whip() {
        let h = 0.01;
        let mut track = HeadPoseTrack::with_previous(h, sway(-0.01), sway(0.0)).unwrap();
        let far = Isometry3::translation(3.0, 0.0, 0.0) * sway(0.01);
        let PoseJump::Teleport { offset } = track.set_next(far).unwrap() else {
            panic!("a 3 m jump is a teleport");
        };
        // The offset carries the extrapolated pose to the one given.
        let ahead = *track.next().unwrap();
        let landed = offset * ahead;
        assert!((landed.translation.vector - far.translation.vector).norm() < 1e-5);
        // The motion is the one the head had: no acceleration beyond the sway's own.
        let m = track.motion();
        assert!(
            m.linear_acceleration.norm() < 1e-3,
            "{}",
            m.linear_acceleration
        );
        assert!((f64::from(m.linear_velocity.x) - 0.75).abs() < 0.01);
        // A smaller limit makes a small move a teleport too.
        track
            .set_limits(TeleportLimits {
                distance: 1e-4,
                angle: 0.5,
            })
            .unwrap();
        assert!(matches!(
            track.set_next(sway(0.01)).unwrap(),
            PoseJump::Teleport { .. }
        ));
        assert!(
            track
                .set_limits(TeleportLimits {
                    distance: -1.0,
                    angle: 0.5
                })
                .is_err()
        );
    }
}
