//! Cem Yuksel's `.hair` format: a 128-byte little-endian header, then optional arrays.
//!
//! Header: `"HAIR"`, u32 strand count, u32 point count, u32 bit field of the arrays present,
//! u32 default segments per strand, f32 default thickness, f32 default transparency, 3 x f32
//! default colour, 88 bytes of text. Then, each only if its bit is set and in this order:
//! segments (bit 0, u16 per strand), points (bit 1, 3 x f32 per point), thickness (bit 2, f32 per
//! point), transparency (bit 3, f32 per point), colours (bit 4, 3 x f32 per point).

use crate::strands::{Reader, f32s};
use crate::{IoError, Strands};

const HEADER: u64 = 128;
const SEGMENTS: u32 = 1;
const POINTS: u32 = 2;
const THICKNESS: u32 = 4;
const TRANSPARENCY: u32 = 8;
const COLORS: u32 = 16;

/// Parses a `.hair` image; `file` names it in errors.
pub fn from_bytes(bytes: &[u8], file: &str) -> Result<Strands, IoError> {
    let r = Reader { bytes, file };
    let magic = r.slice("header", 0, HEADER)?;
    if &magic[0..4] != b"HAIR" {
        return Err(IoError::BadMagic {
            file: file.into(),
            message: format!("expected \"HAIR\", found {:?}", &magic[0..4]),
        });
    }
    let strands = u64::from(r.u32_at("header", 4)?);
    let point_count = u64::from(r.u32_at("header", 8)?);
    let bits = r.u32_at("header", 12)?;
    let default_segments = u64::from(r.u32_at("header", 16)?);
    let default_thickness = r.f32_at("header", 20)?;
    let default_transparency = r.f32_at("header", 24)?;
    if bits & POINTS == 0 {
        return Err(IoError::BadHeader {
            file: file.into(),
            field: "arrays",
            value: u64::from(bits),
            expected: "the points bit (2) must be set",
        });
    }
    let mut at = HEADER;
    let segments: Vec<u64> = if bits & SEGMENTS != 0 {
        let raw = r.slice("segments", at, strands.saturating_mul(2))?;
        at += strands * 2;
        raw.chunks_exact(2)
            .map(|b| u64::from(u16::from_le_bytes([b[0], b[1]])))
            .collect()
    } else {
        if default_segments == 0 {
            return Err(IoError::BadHeader {
                file: file.into(),
                field: "default_segments",
                value: 0,
                expected: "at least 1 when there is no segments array",
            });
        }
        // Bound the allocation by what the file can hold before trusting the count.
        r.slice("points", at, strands.saturating_mul(12))?;
        vec![default_segments; strands as usize]
    };
    let total: u64 = segments.iter().map(|s| s + 1).sum();
    if total != point_count {
        return Err(IoError::BadHeader {
            file: file.into(),
            field: "point_count",
            value: point_count,
            expected: "the sum over strands of segments + 1",
        });
    }
    if let Some(s) = segments.iter().position(|&s| s == 0) {
        return Err(IoError::ShortStrand {
            file: file.into(),
            strand: s,
            count: 1,
        });
    }
    let raw = r.slice("points", at, point_count.saturating_mul(12))?;
    at += point_count * 12;
    let flat: Vec<f32> = f32s(raw).collect();
    let points: Vec<[f32; 3]> = flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut per_point = |bit: u32, what: &'static str| -> Result<Option<Vec<f32>>, IoError> {
        if bits & bit == 0 {
            return Ok(None);
        }
        let raw = r.slice(what, at, point_count * 4)?;
        at += point_count * 4;
        Ok(Some(f32s(raw).collect()))
    };
    let thickness = per_point(THICKNESS, "thickness")?;
    let transparency = per_point(TRANSPARENCY, "transparency")?;
    let colors = if bits & COLORS != 0 {
        let raw = r.slice("colours", at, point_count * 12)?;
        let flat: Vec<f32> = f32s(raw).collect();
        Some(flat.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    } else {
        None
    };
    let mut offsets = Vec::with_capacity(segments.len() + 1);
    offsets.push(0u32);
    let mut acc = 0u64;
    for s in &segments {
        acc += s + 1;
        offsets.push(acc as u32);
    }
    let _ = (default_thickness, default_transparency);
    let out = Strands {
        points,
        offsets,
        thickness,
        transparency,
        colors,
    };
    out.validate(file)?;
    Ok(out)
}

/// Writes a `.hair` image with the segments and points arrays, plus whichever optional arrays
/// the strands carry.
pub fn to_bytes(strands: &Strands) -> Vec<u8> {
    let n = strands.strand_count();
    let mut bits = SEGMENTS | POINTS;
    bits |= if strands.thickness.is_some() {
        THICKNESS
    } else {
        0
    };
    bits |= if strands.transparency.is_some() {
        TRANSPARENCY
    } else {
        0
    };
    bits |= if strands.colors.is_some() { COLORS } else { 0 };
    let mut out = Vec::with_capacity(HEADER as usize + n * 2 + strands.points.len() * 24);
    out.extend_from_slice(b"HAIR");
    for v in [n as u32, strands.points.len() as u32, bits, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for f in [1.0f32, 0.0, 0.5, 0.5, 0.5] {
        out.extend_from_slice(&f.to_le_bytes());
    }
    let mut info = [0u8; 88];
    let text = b"written by hair-io";
    info[..text.len()].copy_from_slice(text);
    out.extend_from_slice(&info);
    for s in 0..n {
        let segs = (strands.strand(s).len() - 1).min(usize::from(u16::MAX)) as u16;
        out.extend_from_slice(&segs.to_le_bytes());
    }
    for p in &strands.points {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for arr in [&strands.thickness, &strands.transparency]
        .into_iter()
        .flatten()
    {
        for v in arr {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    if let Some(c) = &strands.colors {
        for p in c {
            for v in p {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out
}
