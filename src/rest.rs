//! Rest on the first frame: the groom as its own static equilibrium (`sag_free`).

use crate::HairError;
use crate::scene::Scene;
use hair_collide::Sections;
use hair_dynamics::{Environment, StrandState};
use hair_ssv::MeshBody;

/// With the scene's `sag_free`, settles the groom's contacts and solves every skeleton's rest
/// angles so that it holds still under gravity (a still head, no wind) on `body`; returns the
/// hair-hair sections with the groom's radius caps (`hair_collide::make_groom_rest`).
pub(crate) fn make_groom_rest(
    state: &mut StrandState,
    body: Option<&MeshBody>,
    front: &[u32],
    scene: &Scene,
) -> Result<Sections, HairError> {
    let mut sections = Sections::default();
    if !scene.sag_free {
        return Ok(sections);
    }
    let env = Environment {
        gravity: scene.dynamics.gravity.into(),
        ..Environment::default()
    };
    let loads = (&env, scene.dynamics.torque);
    let hair = (front, &mut sections);
    hair_collide::make_groom_rest(state, body, hair, &scene.collision, loads)?;
    Ok(sections)
}
