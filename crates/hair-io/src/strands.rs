//! Plain strand data shared by every format.

use crate::IoError;

/// Strands as flat arrays: the points of strand `s` are `points[offsets[s]..offsets[s + 1]]`.
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

    /// Checks every point is finite and every strand has at least two points.
    pub(crate) fn validate(&self, file: &str) -> Result<(), IoError> {
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
