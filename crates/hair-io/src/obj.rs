//! Wavefront OBJ bodies as indexed triangle meshes (parsed by `tobj`, checked here).

use crate::IoError;
use std::path::Path;

/// An indexed triangle mesh in file units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub vertices: Vec<[f32; 3]>,
    /// Triangles as vertex indices.
    pub triangles: Vec<[u32; 3]>,
}

/// Reads every object of an OBJ file into one mesh (polygons are triangulated).
///
/// Errors name the file: a parse failure, no triangles, an index out of range, a non-finite
/// coordinate.
pub fn read(path: &Path) -> Result<Mesh, IoError> {
    let file = path.display().to_string();
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj(path, &options).map_err(|e| IoError::Obj {
        file: file.clone(),
        message: e.to_string(),
    })?;
    let mut mesh = Mesh::default();
    for m in models {
        let base = mesh.vertices.len() as u32;
        let pos = &m.mesh.positions;
        for (i, c) in pos.chunks_exact(3).enumerate() {
            if !c.iter().all(|x| x.is_finite()) {
                return Err(IoError::Obj {
                    file,
                    message: format!("object `{}`, vertex {i}: coordinate is not finite", m.name),
                });
            }
            mesh.vertices.push([c[0], c[1], c[2]]);
        }
        let count = (pos.len() / 3) as u32;
        for (t, tri) in m.mesh.indices.chunks_exact(3).enumerate() {
            if let Some(bad) = tri.iter().find(|&&i| i >= count) {
                return Err(IoError::Obj {
                    file,
                    message: format!(
                        "object `{}`, triangle {t}: vertex index {bad} out of range ({count} vertices)",
                        m.name
                    ),
                });
            }
            mesh.triangles
                .push([base + tri[0], base + tri[1], base + tri[2]]);
        }
    }
    if mesh.triangles.is_empty() {
        return Err(IoError::Obj {
            file,
            message: "no triangles".into(),
        });
    }
    Ok(mesh)
}
