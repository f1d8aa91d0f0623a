//! Plain strand data shared by every format.

use crate::IoError;
use crate::cyhair;

/// Strands as flat arrays: the points of strand `s` are `points[offsets[s]..offsets[s + 1]]`.
///
/// Besides the points, a strand set keeps what its file said so that writing it back says the
/// same: the optional per-point arrays, TressFX's per-point w and the `.hair` header.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Strands {
    /// Every point, root first within each strand (file units).
    pub points: Vec<[f32; 3]>,
    /// `strand_count + 1` offsets into `points`.
    pub offsets: Vec<u32>,
    /// Per-point thickness, if the file has it.
    pub thickness: Option<Vec<f32>>,
    /// Per-point transparency, if the file has it.
    pub transparency: Option<Vec<f32>>,
    /// Per-point colour, if the file has it.
    pub colors: Option<Vec<[f32; 3]>>,
    /// TressFX's per-point w, the inverse mass (0 pins a point, 1 leaves it free), as a `.tfx`
    /// file gave it. `None` when the file has none (`.hair`): the roots are pinned and nothing
    /// else, which is also what the `.tfx` writer then writes.
    pub inverse_mass: Option<Vec<f32>>,
    /// The `.hair` header's defaults and text ([`cyhair::Header::default`] for strands from
    /// elsewhere).
    pub hair_header: cyhair::Header,
}

/// Something a format cannot hold, named before a file is written without it.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Lost {
    /// TressFX pins other than "roots pinned, the rest free" (the first point that differs).
    Pins {
        /// The strand.
        strand: usize,
        /// The point within the strand.
        point: usize,
        /// Its w.
        value: f32,
    },
    /// Thickness that varies along a strand (the first such strand).
    ThicknessAlongStrand {
        /// The strand.
        strand: usize,
    },
    /// A per-point array the format has no room for.
    Array {
        /// Which array.
        field: &'static str,
    },
    /// A `.hair` header default that stands for every point and differs from hair-io's
    /// default.
    Default {
        /// Which default.
        field: &'static str,
    },
    /// The `.hair` header's text.
    HeaderText,
}

impl std::fmt::Display for Lost {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Lost::Pins {
                strand,
                point,
                value,
            } => write!(
                f,
                "TressFX pins (w = {value} at strand {strand}, point {point}; without them \
                 only the roots are pinned)"
            ),
            Lost::ThicknessAlongStrand { strand } => {
                write!(f, "thickness varying along strand {strand}")
            }
            Lost::Array { field } => write!(f, "the per-point {field} array"),
            Lost::Default { field } => write!(f, "the header's default {field}"),
            Lost::HeaderText => write!(f, "the header text"),
        }
    }
}

impl Strands {
    /// Strands from polylines; each needs at least two points, all finite.
    pub fn from_polylines(polylines: Vec<Vec<[f32; 3]>>) -> Result<Self, IoError> {
        let mut points = Vec::new();
        let mut offsets = vec![0u32];
        for (s, line) in polylines.into_iter().enumerate() {
            if line.len() < 2 {
                return Err(IoError::ShortStrand {
                    file: "<memory>".into(),
                    strand: s,
                    count: line.len(),
                });
            }
            for (i, p) in line.iter().enumerate() {
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(IoError::NonFinite {
                        file: "<memory>".into(),
                        strand: s,
                        point: i,
                        field: "point",
                    });
                }
            }
            points.extend(line);
            offsets.push(points.len() as u32);
        }
        Ok(Self {
            points,
            offsets,
            ..Self::default()
        })
    }

    /// The thickness of point `i` (an index into `points`): its own, or the `.hair` header's
    /// default when there is no thickness array.
    pub fn thickness_at(&self, i: usize) -> f32 {
        self.thickness
            .as_ref()
            .and_then(|t| t.get(i).copied())
            .unwrap_or(self.hair_header.default_thickness)
    }

    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The points of strand `s`.
    pub fn strand(&self, s: usize) -> &[[f32; 3]] {
        &self.points[self.offsets[s] as usize..self.offsets[s + 1] as usize]
    }

    /// Iterates over the strands' points.
    pub fn iter(&self) -> impl Iterator<Item = &[[f32; 3]]> + '_ {
        (0..self.strand_count()).map(|s| self.strand(s))
    }

    /// Checks the arrays agree in length, the offsets rise from 0 to the point count, every
    /// value is finite and every strand has at least two points.
    pub fn validate(&self, file: &str) -> Result<(), IoError> {
        let inconsistent = |message: String| IoError::Inconsistent {
            file: file.into(),
            message,
        };
        let n = self.points.len();
        if self.offsets.first().is_some_and(|&o| o != 0) {
            return Err(inconsistent(format!(
                "offsets[0] is {}, not 0",
                self.offsets[0]
            )));
        }
        if let Some(s) = self.offsets.windows(2).position(|w| w[1] < w[0]) {
            return Err(inconsistent(format!(
                "offsets[{}] = {} is below offsets[{s}] = {}",
                s + 1,
                self.offsets[s + 1],
                self.offsets[s]
            )));
        }
        let last = self.offsets.last().map_or(0, |&o| o as usize);
        if last != n {
            return Err(inconsistent(format!(
                "the offsets end at {last} but there are {n} points"
            )));
        }
        for (field, len) in [
            ("thickness", self.thickness.as_ref().map(Vec::len)),
            ("transparency", self.transparency.as_ref().map(Vec::len)),
            ("colors", self.colors.as_ref().map(Vec::len)),
            ("inverse_mass", self.inverse_mass.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len.filter(|&len| len != n) {
                return Err(inconsistent(format!(
                    "`{field}` has {len} values for {n} points"
                )));
            }
        }
        for s in 0..self.strand_count() {
            let strand = self.strand(s);
            if strand.len() < 2 {
                return Err(IoError::ShortStrand {
                    file: file.into(),
                    strand: s,
                    count: strand.len(),
                });
            }
            let base = self.offsets[s] as usize;
            for (i, p) in strand.iter().enumerate() {
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(IoError::NonFinite {
                        file: file.into(),
                        strand: s,
                        point: i,
                        field: "point",
                    });
                }
                let extra = [
                    ("thickness", self.thickness.as_ref().map(|t| t[base + i])),
                    (
                        "transparency",
                        self.transparency.as_ref().map(|t| t[base + i]),
                    ),
                    (
                        "inverse_mass",
                        self.inverse_mass.as_ref().map(|t| t[base + i]),
                    ),
                ];
                for (field, v) in extra {
                    if v.is_some_and(|v| !v.is_finite()) {
                        return Err(IoError::NonFinite {
                            file: file.into(),
                            strand: s,
                            point: i,
                            field,
                        });
                    }
                }
                if self
                    .colors
                    .as_ref()
                    .is_some_and(|c| !c[base + i].iter().all(|x| x.is_finite()))
                {
                    return Err(IoError::NonFinite {
                        file: file.into(),
                        strand: s,
                        point: i,
                        field: "color",
                    });
                }
            }
        }
        Ok(())
    }
}

/// A little-endian cursor over a byte slice that reports truncation with the block's name.
pub(crate) struct Reader<'a> {
    pub bytes: &'a [u8],
    pub file: &'a str,
}

impl Reader<'_> {
    pub fn slice(&self, what: &'static str, start: u64, len: u64) -> Result<&[u8], IoError> {
        let end = start.saturating_add(len);
        let file_len = self.bytes.len() as u64;
        if end > file_len {
            return Err(IoError::Truncated {
                file: self.file.into(),
                what,
                start,
                end,
                len: file_len,
            });
        }
        Ok(&self.bytes[start as usize..end as usize])
    }

    pub fn u32_at(&self, what: &'static str, at: u64) -> Result<u32, IoError> {
        let b = self.slice(what, at, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    pub fn f32_at(&self, what: &'static str, at: u64) -> Result<f32, IoError> {
        Ok(f32::from_bits(self.u32_at(what, at)?))
    }
}

pub(crate) fn f32s(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}
