//! Cem Yuksel's `.hair` format: a 128-byte little-endian header, then optional arrays.
//!
//! Header: `"HAIR"`, u32 strand count, u32 point count, u32 bit field of the arrays present,
//! u32 default segments per strand, f32 default thickness, f32 default transparency, 3 x f32
//! default colour, 88 bytes of text. Then, each only if its bit is set and in this order:
//! segments (bit 0, u16 per strand), points (bit 1, 3 x f32 per point), thickness (bit 2, f32 per
//! point), transparency (bit 3, f32 per point), colours (bit 4, 3 x f32 per point). A default
//! stands for every point when its array is absent, so the header is kept in [`Header`] and a
//! file read and written back is the same file.

use crate::strands::{Reader, f32s};
use crate::{IoError, Lost, Strands};

const HEADER: u64 = 128;
const SEGMENTS: u32 = 1;
const POINTS: u32 = 2;
const THICKNESS: u32 = 4;
const TRANSPARENCY: u32 = 8;
const COLORS: u32 = 16;
/// Bytes of free text at the end of the header.
pub const INFO_LEN: usize = 88;

/// What a `.hair` header says beyond its counts: the values every point takes when its array
/// is absent, and the header text.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    /// Whether the segments array is present; without it every strand has `default_segments`
    /// segments.
    pub segments_array: bool,
    /// Segments per strand when the segments array is absent.
    pub default_segments: u32,
    /// Thickness of every point when the thickness array is absent (file units).
    pub default_thickness: f32,
    /// Transparency of every point when the transparency array is absent (0 = opaque).
    pub default_transparency: f32,
    /// Colour of every point when the colour array is absent (linear RGB, 0 to 1).
    pub default_color: [f32; 3],
    /// The header's free text, zero padded.
    pub info: [u8; INFO_LEN],
}

impl Default for Header {
    /// The header hair-io writes for strands that were not read from a `.hair` file: a segments
    /// array, thickness 1, opaque, mid grey, "written by hair-io".
    fn default() -> Self {
        let mut info = [0u8; INFO_LEN];
        let text = b"written by hair-io";
        info[..text.len()].copy_from_slice(text);
        Self {
            segments_array: true,
            default_segments: 0,
            default_thickness: 1.0,
            default_transparency: 0.0,
            default_color: [0.5; 3],
            info,
        }
    }
}

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
    let default_segments = r.u32_at("header", 16)?;
    let mut info = [0u8; INFO_LEN];
    info.copy_from_slice(&magic[40..]);
    let header = Header {
        segments_array: bits & SEGMENTS != 0,
        default_segments,
        default_thickness: r.f32_at("header", 20)?,
        default_transparency: r.f32_at("header", 24)?,
        default_color: [
            r.f32_at("header", 28)?,
            r.f32_at("header", 32)?,
            r.f32_at("header", 36)?,
        ],
        info,
    };
    if bits & POINTS == 0 {
        return Err(IoError::BadHeader {
            file: file.into(),
            field: "arrays",
            value: u64::from(bits),
            expected: "the points bit (2) must be set",
        });
    }
    let mut at = HEADER;
    let segments: Vec<u64> = if header.segments_array {
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
        vec![u64::from(default_segments); strands as usize]
    };
    let total: u64 = segments.iter().map(|s| s + 1).sum();
    if total != point_count {
        return Err(IoError::CountMismatch {
            file: file.into(),
            field: "point_count",
            header: point_count,
            found: total,
            counted: if header.segments_array {
                "the segments array's (segments + 1) per strand"
            } else {
                "strand_count x (default_segments + 1)"
            },
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
    let out = Strands {
        points,
        offsets,
        thickness,
        transparency,
        colors,
        inverse_mass: None,
        hair_header: header,
    };
    out.validate(file)?;
    Ok(out)
}

/// What writing `strands` as `.hair` would drop: TressFX pins other than the roots, which
/// `.hair` cannot hold (a reader of `.hair` pins the roots and nothing else).
pub fn losses(strands: &Strands) -> Vec<Lost> {
    let Some(w) = &strands.inverse_mass else {
        return Vec::new();
    };
    for s in 0..strands.strand_count() {
        let base = strands.offsets[s] as usize;
        let end = strands.offsets[s + 1] as usize;
        for (i, &value) in w[base..end].iter().enumerate() {
            let roots_pinned = if i == 0 { 0.0f32 } else { 1.0 };
            if value.to_bits() != roots_pinned.to_bits() {
                return vec![Lost::Pins {
                    strand: s,
                    point: i,
                    value,
                }];
            }
        }
    }
    Vec::new()
}

/// Writes a `.hair` image, checked: the strands are validated (finite, consistent arrays, at
/// most 65,536 points per strand when a segments array is needed) and nothing the format cannot
/// hold is dropped without saying so (the [`losses`] are returned, and the caller decides).
pub fn try_to_bytes(strands: &Strands, file: &str) -> Result<(Vec<u8>, Vec<Lost>), IoError> {
    strands.validate(file)?;
    let segments_array = needs_segments_array(strands);
    if segments_array
        && let Some(s) = (0..strands.strand_count())
            .find(|&s| strands.strand(s).len() - 1 > usize::from(u16::MAX))
    {
        return Err(IoError::Unwritable {
            file: file.into(),
            message: format!(
                "strand {s} has {} points; a .hair segments array holds at most {}",
                strands.strand(s).len(),
                usize::from(u16::MAX) + 1
            ),
        });
    }
    if u32::try_from(strands.points.len()).is_err() {
        return Err(IoError::Unwritable {
            file: file.into(),
            message: format!(
                "{} points; .hair counts them in 32 bits",
                strands.points.len()
            ),
        });
    }
    Ok((write(strands, segments_array), losses(strands)))
}

/// Writes a `.hair` image with the points array, a segments array unless the header had none
/// and every strand still has its default segment count, the optional arrays the strands carry,
/// and the header's defaults and text from [`Strands::hair_header`].
///
/// For strands from a reader or [`Strands::from_polylines`]; [`try_to_bytes`] checks strands
/// built by hand and reports what `.hair` cannot hold (here silently dropped: TressFX pins).
pub fn to_bytes(strands: &Strands) -> Vec<u8> {
    write(strands, needs_segments_array(strands))
}

fn needs_segments_array(strands: &Strands) -> bool {
    let h = &strands.hair_header;
    h.segments_array
        || h.default_segments == 0
        || strands
            .iter()
            .any(|s| s.len() as u64 != u64::from(h.default_segments) + 1)
}

fn write(strands: &Strands, segments_array: bool) -> Vec<u8> {
    let h = &strands.hair_header;
    let n = strands.strand_count();
    let mut bits = POINTS;
    for (present, bit) in [
        (segments_array, SEGMENTS),
        (strands.thickness.is_some(), THICKNESS),
        (strands.transparency.is_some(), TRANSPARENCY),
        (strands.colors.is_some(), COLORS),
    ] {
        if present {
            bits |= bit;
        }
    }
    let mut out = Vec::with_capacity(HEADER as usize + n * 2 + strands.points.len() * 24);
    out.extend_from_slice(b"HAIR");
    for v in [
        n as u32,
        strands.points.len() as u32,
        bits,
        h.default_segments,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let [r, g, b] = h.default_color;
    for f in [h.default_thickness, h.default_transparency, r, g, b] {
        out.extend_from_slice(&f.to_le_bytes());
    }
    out.extend_from_slice(&h.info);
    if segments_array {
        for s in 0..n {
            let segs = (strands.strand(s).len() - 1).min(usize::from(u16::MAX)) as u16;
            out.extend_from_slice(&segs.to_le_bytes());
        }
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
