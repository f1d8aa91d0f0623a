//! The body a scene asks for: the procedural head and shoulders (with Kurihara's cylinder and
//! sphere tables), a wrinkled torus (Ward & Lin's brushing scene) or an OBJ file, as a
//! [`MeshBody`].

use crate::HairError;
use crate::scene::BodySpec;
use hair_ssv::{MeshBody, Point, Vector, cap_holes, wrinkled_torus};
use std::path::Path;

/// Builds the body a scene asks for; `None` for `BodySpec::None`.
pub fn from_spec(spec: &BodySpec, base_dir: &Path) -> Result<Option<MeshBody>, HairError> {
    let (vertices, triangles, maps_wanted) = match spec {
        BodySpec::None => return Ok(None),
        BodySpec::Head { resolution } => {
            let (v, t) = hair_ssv::head::head_and_shoulders(*resolution as usize);
            (v, t, true)
        }
        BodySpec::Torus {
            center,
            major,
            minor,
            wrinkles,
            depth,
        } => {
            let (v, t) = wrinkled_torus(
                Point::from(*center),
                *major,
                *minor,
                *wrinkles,
                *depth,
                96,
                32,
            );
            (v, t, false)
        }
        BodySpec::Obj {
            path,
            scale,
            offset,
            close_holes,
        } => {
            let mesh = hair_io::obj::read(&base_dir.join(path))?;
            let off = Vector::from(*offset);
            let mut v = mesh
                .vertices
                .iter()
                .map(|p| Point::from(Vector::from(*p) * *scale + off))
                .collect();
            let mut t = mesh.triangles;
            if *close_holes {
                cap_holes(&mut v, &mut t);
            }
            (v, t, false)
        }
    };
    let mut body = MeshBody::new(vertices, triangles).map_err(|source| match spec {
        BodySpec::Obj { path, scale, .. } => HairError::BodyMesh {
            file: base_dir.join(path).display().to_string(),
            scale: *scale,
            source,
        },
        _ => HairError::Ssv(source),
    })?;
    if maps_wanted {
        body.maps = Some(hair_ssv::head::head_and_shoulders_body(&body.bvh, 64)?);
    }
    Ok(Some(body))
}
