//! Hairstyles: procedural hair grown on the scalp with Poisson-disc roots, or strands read from a
//! `.tfx` / `.hair` file, as the plain `hair_lod::Hairstyle` every layer starts from.

use crate::HairError;
use crate::scene::{HairstyleSpec, ProceduralHair, StyleSpec};
use hair_dynamics::{Style, resample_polyline, style_points};
use hair_lod::{Hairstyle, Strand};
use hair_ssv::scalp::{DRAPE_CLEARANCE, ScalpRegion, comb_direction, lay_styled, scalp_roots};
use hair_ssv::{Point, Real, Vector};
use nalgebra::Rotation3;
use std::path::Path;

/// Builds the hairstyle a scene asks for.
pub fn from_spec(spec: &HairstyleSpec, seed: u64, base_dir: &Path) -> Result<Hairstyle, HairError> {
    match spec {
        HairstyleSpec::Procedural(p) => procedural(p, seed),
        HairstyleSpec::File {
            path,
            scale,
            offset,
            points,
        } => {
            let file = base_dir.join(path);
            let strands = hair_io::read_strands(&file)?;
            let file = file.display().to_string();
            from_strands(&strands, (*scale, *offset, *points), &file)
        }
    }
}

/// The hairstyle of a groom (`hair_io::Strands`, read from a file named `file` or built in
/// memory): each strand scaled, offset and resampled by arc length to `points` control points.
pub fn from_strands(
    strands: &hair_io::Strands,
    (scale, offset, points): (f32, [f32; 3], u32),
    file: &str,
) -> Result<Hairstyle, HairError> {
    let off = Vector::from(offset);
    let mut out = Vec::with_capacity(strands.strand_count());
    for (strand, s) in strands.iter().enumerate() {
        let pts: Vec<Point> = s
            .iter()
            .map(|p| Point::from(Vector::from(*p) * scale + off))
            .collect();
        let pts = resample_polyline(&pts, points as usize);
        // The dynamics would reject it too, but could not name the file and the strand.
        for (segment, w) in pts.windows(2).enumerate() {
            let length = (w[1] - w[0]).norm();
            if !(length.is_finite() && length > 0.0) {
                return Err(HairError::DegenerateStrand {
                    file: file.into(),
                    strand,
                    segment,
                    length,
                    scale,
                    points,
                });
            }
        }
        let dir = (pts[1] - pts[0])
            .try_normalize(1e-12)
            .unwrap_or_else(|| -Vector::y());
        out.push(Strand {
            root: pts[0],
            frame: frame_along(&dir),
            points: pts,
        });
    }
    Ok(Hairstyle { strands: out })
}

/// A root frame whose z axis points along `dir`.
pub fn frame_along(dir: &Vector) -> Rotation3<Real> {
    Rotation3::rotation_between(&Vector::z(), dir)
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector::x_axis(), std::f32::consts::PI))
}

/// Procedural hair: roots spread over the scalp region, each strand styled and laid combed over
/// the head (`combed`), or grown straight out along the comb direction.
pub fn procedural(p: &ProceduralHair, seed: u64) -> Result<Hairstyle, HairError> {
    let region = ScalpRegion {
        min_height: p.scalp_min_height,
        max_forward: p.scalp_max_forward,
        parting_width: p.parting_width,
    };
    let roots = scalp_roots(p.strands as usize, &region, seed ^ 0x5CA1_9000);
    if roots.is_empty() {
        return Err(HairError::SceneValue {
            file: String::new(),
            field: "hairstyle.scalp_min_height".into(),
            message: "the scalp region holds no roots".into(),
        });
    }
    let style = match p.style {
        StyleSpec::Straight | StyleSpec::Draped => Style::Straight,
        StyleSpec::Wavy { amplitude, period } => Style::Wavy { amplitude, period },
        StyleSpec::Curly { radius, pitch } => Style::Curly { radius, pitch },
    };
    let n = p.points as usize;
    let local = style_points(Point::origin(), &Rotation3::identity(), &style, n, p.length)?;
    let clearance = DRAPE_CLEARANCE + 2.0 * p.strand_radius;
    let mut strands = Vec::with_capacity(roots.len());
    for (root, normal) in roots {
        let frame = frame_along(&comb_direction(&root, &normal));
        let points = if p.combed || p.style == StyleSpec::Draped {
            lay_styled(root, &frame, &local, clearance)
        } else {
            local.iter().map(|q| root + frame * q.coords).collect()
        };
        strands.push(Strand {
            root,
            frame,
            points,
        });
    }
    Ok(Hairstyle { strands })
}
