//! The collision settings: one struct for both stages, as a scene file's `collision` block.

use crate::{HairHairModel, PushCombine};
use hair_ssv::{CollisionMethod, Real};

/// How hair collides with the body and with itself (SI units). Every field has a documented
/// default; a scene file names only what differs.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(deny_unknown_fields, default)
)]
pub struct CollisionSettings {
    /// How the body answers distance queries: `Field` (default), `Bvh` or `Maps`.
    pub method: CollisionMethod,
    /// Coulomb friction against the body, in [0, 1]. Default 0.3.
    pub friction: Real,
    /// The hair-hair model: `Volume(..)`, `Pairs` or `Off`. Default `Pairs`, the exact model,
    /// so that scenes keep their results (`docs/scene-format.md`; the old `true` and `false`
    /// read as `Pairs` and `Off`).
    pub hair_hair: HairHairModel,
    /// Hair-hair sections closer than this angle (rad) are parallel: they share their velocity
    /// instead of being pushed apart. Default 0.3.
    pub parallel_angle: Real,
    /// How a node combines the pushes of the hair-hair pairs it is in. Default `Mean`.
    pub hair_hair_push: PushCombine,
    /// Steps from one hair-hair pair search to the next (at least 1): in between, the pairs the
    /// last search found are tested again at the new positions, and pairs that have come
    /// together since are missed until the next search. Default 1: every step.
    pub pair_search_interval: u32,
    /// The penetration tolerated after the hard constraint (m). Default 1 mm.
    pub tolerance: Real,
    /// Steps of the depenetration ramp: hair that starts inside the body comes out linearly
    /// over them instead of in one jump. Default 10.
    pub depenetration_steps: u32,
    /// Regular passes (sweeps) of the hard constraint per step; late passes follow for
    /// whatever is still inside. Default 8.
    pub body_passes: usize,
    /// Most passes of the hard constraint in a step, late ones included. Default 32.
    pub max_body_passes: usize,
    /// How many times a sweep tests a corrected node's target again, and moves it again while
    /// it is still inside, before leaving it to the next sweep. Default 2.
    pub sweep_retests: usize,
    /// Largest number of nodes the late passes query by the exact distance instead of
    /// `method` (an approximate field can send a node back and forth across a thin part).
    /// Default 256.
    pub exact_late_nodes: usize,
    /// Depth, as a fraction of `tolerance`, below which a node in contact is not moved (its
    /// approach is still removed). Default 0.01.
    pub contact_skin: Real,
}

impl Default for CollisionSettings {
    fn default() -> Self {
        Self {
            method: CollisionMethod::Field,
            friction: 0.3,
            hair_hair: HairHairModel::default(),
            parallel_angle: 0.3,
            hair_hair_push: PushCombine::Mean,
            pair_search_interval: 1,
            tolerance: 1e-3,
            depenetration_steps: 10,
            body_passes: 8,
            max_body_passes: 32,
            sweep_retests: 2,
            exact_late_nodes: 256,
            contact_skin: 0.01,
        }
    }
}

/// A setting out of its range: the field's name and what it must be.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {message}")]
#[non_exhaustive]
pub struct SettingsError {
    /// The field, as named in a scene file's `collision` block.
    pub field: &'static str,
    /// What the value must be, and what it was.
    pub message: String,
}

impl CollisionSettings {
    /// Checks every value's range; the error names the first field out of range.
    pub fn validate(&self) -> Result<(), SettingsError> {
        let bad = |field, message: String| Err(SettingsError { field, message });
        if !(self.friction.is_finite() && (0.0..=1.0).contains(&self.friction)) {
            return bad(
                "friction",
                format!("must be in [0, 1], got {}", self.friction),
            );
        }
        if !(self.parallel_angle.is_finite() && self.parallel_angle >= 0.0) {
            return bad(
                "parallel_angle",
                format!(
                    "must be non-negative and finite, got {}",
                    self.parallel_angle
                ),
            );
        }
        if let HairHairModel::Volume(volume) = &self.hair_hair
            && let Some((field, message)) = volume.check()
        {
            return bad(field, message);
        }
        if self.pair_search_interval == 0 {
            return bad(
                "pair_search_interval",
                "must be at least 1 (1 searches every step)".into(),
            );
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad(
                "tolerance",
                format!("must be positive and finite, got {}", self.tolerance),
            );
        }
        if self.body_passes == 0 || self.max_body_passes < self.body_passes {
            return bad(
                "max_body_passes",
                format!(
                    "body_passes must be at least 1 and max_body_passes at least body_passes, got {} and {}",
                    self.body_passes, self.max_body_passes
                ),
            );
        }
        if !(self.contact_skin.is_finite() && (0.0..1.0).contains(&self.contact_skin)) {
            return bad(
                "contact_skin",
                format!("must be in [0, 1), got {}", self.contact_skin),
            );
        }
        Ok(())
    }
}
