//! AMD TressFX `.tfx`: a 160-byte little-endian header, then fixed-size strands.
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | f32 | version |
//! | 4 | u32 | strand count |
//! | 8 | u32 | vertices per strand |
//! | 12 | u32 | byte offset of vertex positions (x, y, z, w as f32, root first; w = 0 pins) |
//! | 16, 20 | u32 | byte offsets of per-strand and per-vertex UVs (0 = absent; not read) |
//! | 24 | u32 | byte offset of per-strand thickness (f32 each; 0 = absent) |
//! | 28 | u32 | byte offset of per-vertex colours (0 = absent; not read) |

use crate::strands::{Reader, f32s};
use crate::{IoError, Lost, Strands, cyhair};

const HEADER: u64 = 160;

/// Parses a `.tfx` image; `file` names it in errors.
pub fn from_bytes(bytes: &[u8], file: &str) -> Result<Strands, IoError> {
    let r = Reader { bytes, file };
    let version = r.f32_at("header", 0)?;
    if !(version.is_finite() && version > 0.0 && version < 100.0) {
        return Err(IoError::BadMagic {
            file: file.into(),
            message: format!("version {version} is not a TressFX version"),
        });
    }
    let strands = u64::from(r.u32_at("header", 4)?);
    let per = u64::from(r.u32_at("header", 8)?);
    let pos_at = u64::from(r.u32_at("header", 12)?);
    let thick_at = u64::from(r.u32_at("header", 24)?);
    if !(2..=64).contains(&per) {
        return Err(IoError::BadHeader {
            file: file.into(),
            field: "vertices_per_strand",
            value: per,
            expected: "between 2 and 64",
        });
    }
    if strands == 0 {
        return Err(IoError::BadHeader {
            file: file.into(),
            field: "strand_count",
            value: 0,
            expected: "at least 1",
        });
    }
    if pos_at < 32 {
        return Err(IoError::BadHeader {
            file: file.into(),
            field: "vertex_offset",
            value: pos_at,
            expected: "past the header",
        });
    }
    let count = strands.saturating_mul(per);
    let raw = r.slice("vertex positions", pos_at, count.saturating_mul(16))?;
    let mut points = Vec::with_capacity(count as usize);
    let mut inverse_mass = Vec::with_capacity(count as usize);
    let mut it = f32s(raw);
    while let (Some(x), Some(y), Some(z), Some(w)) = (it.next(), it.next(), it.next(), it.next()) {
        points.push([x, y, z]);
        inverse_mass.push(w);
    }
    let offsets = (0..=strands).map(|s| (s * per) as u32).collect();
    let thickness = if thick_at != 0 {
        let raw = r.slice("strand thickness", thick_at, strands * 4)?;
        let per_strand: Vec<f32> = f32s(raw).collect();
        Some(
            per_strand
                .iter()
                .flat_map(|t| std::iter::repeat_n(*t, per as usize))
                .collect(),
        )
    } else {
        None
    };
    let out = Strands {
        points,
        offsets,
        thickness,
        transparency: None,
        colors: None,
        inverse_mass: Some(inverse_mass),
        hair_header: cyhair::Header::default(),
    };
    out.validate(file)?;
    Ok(out)
}

/// What writing `strands` as `.tfx` would drop: thickness varying along a strand (`.tfx` holds
/// one per strand), transparency and colours (not written), and the `.hair` header's
/// transparency, colour and text where they differ from hair-io's defaults.
pub fn losses(strands: &Strands) -> Vec<Lost> {
    let mut lost = Vec::new();
    if let Some(t) = &strands.thickness
        && let Some(strand) = (0..strands.strand_count()).find(|&s| {
            let range = strands.offsets[s] as usize..strands.offsets[s + 1] as usize;
            t[range.clone()]
                .iter()
                .any(|v| v.to_bits() != t[range.start].to_bits())
        })
    {
        lost.push(Lost::ThicknessAlongStrand { strand });
    }
    let standard = cyhair::Header::default();
    let h = &strands.hair_header;
    if strands.transparency.is_some() {
        lost.push(Lost::Array {
            field: "transparency",
        });
    } else if h.default_transparency.to_bits() != standard.default_transparency.to_bits() {
        lost.push(Lost::Default {
            field: "transparency",
        });
    }
    if strands.colors.is_some() {
        lost.push(Lost::Array { field: "colour" });
    } else if h.default_color.map(f32::to_bits) != standard.default_color.map(f32::to_bits) {
        lost.push(Lost::Default { field: "colour" });
    }
    if h.info != standard.info && h.info.iter().any(|&b| b != 0) {
        lost.push(Lost::HeaderText);
    }
    lost
}

/// Writes a `.tfx` image. Every strand must have the same number of points (2 to 64).
///
/// Thickness is written per strand from each strand's root value, or from the `.hair` header's
/// default thickness when there is no thickness array and that default is not 1. The w of each
/// point is [`Strands::inverse_mass`], or 0 at the roots and 1 elsewhere when it is `None`.
/// What `.tfx` cannot hold is dropped here; [`losses`] names it.
pub fn to_bytes(strands: &Strands, file: &str) -> Result<Vec<u8>, IoError> {
    strands.validate(file)?;
    let n = strands.strand_count();
    if n == 0 {
        return Err(IoError::Unwritable {
            file: file.into(),
            message: "no strands".into(),
        });
    }
    let per = strands.strand(0).len();
    if let Some(s) = (0..n).find(|&s| strands.strand(s).len() != per) {
        return Err(IoError::Unwritable {
            file: file.into(),
            message: format!(
                "strand {s} has {} points but strand 0 has {per}: .tfx needs one count for all",
                strands.strand(s).len()
            ),
        });
    }
    if !(2..=64).contains(&per) {
        return Err(IoError::Unwritable {
            file: file.into(),
            message: format!("{per} points per strand; .tfx allows 2 to 64"),
        });
    }
    let pos_bytes = (n * per * 16) as u64;
    let default_thickness = strands.hair_header.default_thickness;
    let write_thickness = strands.thickness.is_some() || default_thickness != 1.0;
    if HEADER + pos_bytes + (n as u64) * 4 > u64::from(u32::MAX) {
        return Err(IoError::Unwritable {
            file: file.into(),
            message: format!("{n} strands of {per} points exceed .tfx's 32-bit offsets"),
        });
    }
    let thick_at = if write_thickness {
        HEADER + pos_bytes
    } else {
        0
    };
    let mut out = Vec::with_capacity((HEADER + pos_bytes) as usize + n * 4);
    out.extend_from_slice(&4.0f32.to_le_bytes());
    for v in [
        n as u32,
        per as u32,
        HEADER as u32,
        0,
        0,
        thick_at as u32,
        0,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.resize(HEADER as usize, 0);
    for (i, p) in strands.points.iter().enumerate() {
        let w = match &strands.inverse_mass {
            Some(w) => w[i],
            None if i % per == 0 => 0.0,
            None => 1.0,
        };
        for c in [p[0], p[1], p[2], w] {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    if write_thickness {
        for s in 0..n {
            let root = strands.offsets[s] as usize;
            out.extend_from_slice(&strands.thickness_at(root).to_le_bytes());
        }
    }
    Ok(out)
}
