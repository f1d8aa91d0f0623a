//! The hair-hair stage: the scene's model ([`crate::HairHairModel`]) behind one call.

use crate::{CollideError, CollisionSettings, HairHairModel, HairPairs, HairVolume, Sections};
use hair_dynamics::StrandState;
use hair_grid::Grid;
use hair_ssv::Real;

/// What the hair-hair stage did this step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HairHairReport {
    /// `Pairs`: pairs tested exactly.
    pub pairs_tested: usize,
    /// `Pairs`: pairs in contact; `Volume`: nodes the density repulsion pushed.
    pub contacts: usize,
    /// `Volume`: points of the dense grid.
    pub volume_cells: usize,
}

/// Both hair-hair models with their buffers; each step runs the one the settings name.
#[derive(Debug, Default)]
pub struct HairHairStage {
    /// The exact model.
    pub pairs: HairPairs,
    /// The volume model.
    pub volume: HairVolume,
}

impl HairHairStage {
    /// A stage with empty buffers.
    pub fn new() -> Self {
        Self::default()
    }

    /// See [`HairPairs::plan`]: whether this step needs the pair grid (only `Pairs` does).
    pub fn plan(&mut self, settings: &CollisionSettings, reuse_allowed: bool) -> bool {
        self.pairs.plan(settings, reuse_allowed)
    }

    /// See [`HairPairs::forget`].
    pub fn forget(&mut self) {
        self.pairs.forget();
    }

    /// The step's response by the settings' model, on the skeletons of `front` over a step of
    /// `dt` (s); `grid` and `sections` as [`HairPairs::respond`] takes them.
    pub fn respond(
        &mut self,
        state: &mut StrandState,
        grid: &Grid,
        sections: &Sections,
        front: &[u32],
        settings: &CollisionSettings,
        dt: Real,
    ) -> Result<HairHairReport, CollideError> {
        Ok(match &settings.hair_hair {
            HairHairModel::Pairs => {
                let r = self.pairs.respond(state, grid, sections, settings)?;
                HairHairReport {
                    pairs_tested: r.pairs_tested,
                    contacts: r.contacts,
                    volume_cells: 0,
                }
            }
            HairHairModel::Volume(volume) => {
                let r = self.volume.respond(state, front, volume, dt)?;
                HairHairReport {
                    pairs_tested: 0,
                    contacts: r.repelled,
                    volume_cells: r.cells,
                }
            }
            HairHairModel::Off => HairHairReport::default(),
        })
    }
}
