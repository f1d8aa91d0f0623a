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

/// Reads every object of an OBJ file into one mesh (polygons are triangulated; materials are
/// not read).
///
/// Errors name the file: a parse failure, no triangles, a non-finite coordinate, and a face
/// whose vertex index is out of range by its line and its number among the file's faces.
pub fn read(path: &Path) -> Result<Mesh, IoError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| IoError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    check_faces(&String::from_utf8_lossy(&bytes), &file)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut bytes.as_slice(), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| IoError::Obj {
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

/// Finds the first face (`f` line) that names a vertex the file does not have, so the error can
/// give its line: `tobj` reports only that some index is out of bounds. Positive indices count
/// the file's vertices from 1; negative ones count back from the last vertex read so far.
fn check_faces(text: &str, file: &str) -> Result<(), IoError> {
    let is = |line: &str, key: &str| line.split_whitespace().next() == Some(key);
    let vertices = text.lines().filter(|l| is(l, "v")).count();
    let mut seen = 0usize;
    let mut face = 0usize;
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => seen += 1,
            Some("f") => {
                face += 1;
                for word in words {
                    let first = word.split('/').next().unwrap_or("");
                    let Ok(index) = first.parse::<i64>() else {
                        return Err(IoError::Obj {
                            file: file.into(),
                            message: format!(
                                "line {}: face {face} (`{}`): `{word}` is not a vertex index",
                                n + 1,
                                line.trim()
                            ),
                        });
                    };
                    let in_range = match index {
                        i if i > 0 => i as u64 <= vertices as u64,
                        i if i < 0 => i.unsigned_abs() <= seen as u64,
                        _ => false,
                    };
                    if !in_range {
                        return Err(IoError::ObjFaceIndex {
                            file: file.into(),
                            line: n + 1,
                            face,
                            text: line.trim().into(),
                            index,
                            vertices,
                        });
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}
