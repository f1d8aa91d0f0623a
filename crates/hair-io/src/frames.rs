//! What the streaming writers share: the curves' layout, checked once, and a frame's points,
//! checked as they are encoded so that a bad frame is refused before any of it is written.

use crate::IoError;

/// Curve vertex counts validated for writing, with their running offsets.
pub(crate) struct CurveLayout {
    /// `counts.len() + 1` offsets: curve `c` holds points `offsets[c]..offsets[c + 1]`.
    pub offsets: Vec<usize>,
}

impl CurveLayout {
    /// Every curve needs two points (a linear curve's least), and counts fit USD's `int`.
    pub fn new(counts: &[u32], file: &str) -> Result<Self, IoError> {
        let mut offsets = Vec::with_capacity(counts.len() + 1);
        offsets.push(0usize);
        for (c, &n) in counts.iter().enumerate() {
            if n < 2 || n > i32::MAX as u32 {
                return Err(IoError::BadInput {
                    file: file.into(),
                    field: "curve_vertex_counts",
                    index: c,
                    message: format!("{n} vertices; a curve has 2 to {}", i32::MAX),
                });
            }
            let total = offsets[c] + n as usize;
            offsets.push(total);
        }
        Ok(Self { offsets })
    }

    pub fn curves(&self) -> usize {
        self.offsets.len() - 1
    }

    pub fn points(&self) -> usize {
        self.offsets[self.curves()]
    }

    fn curve_of(&self, point: usize) -> usize {
        self.offsets
            .partition_point(|&o| o <= point)
            .saturating_sub(1)
    }

    /// Hands each point of a frame to `sink`, refusing a non-finite value or a count other than
    /// the layout's. The caller discards what `sink` gathered when this fails.
    pub fn check_frame(
        &self,
        file: &str,
        frame: usize,
        points: impl IntoIterator<Item = [f32; 3]>,
        mut sink: impl FnMut([f32; 3]),
    ) -> Result<(), IoError> {
        let expected = self.points();
        let mut count = 0usize;
        for p in points {
            if count == expected {
                return Err(IoError::BadFrame {
                    file: file.into(),
                    frame,
                    message: format!(
                        "more than the {expected} points the curves have ({} curves)",
                        self.curves()
                    ),
                });
            }
            if !p.iter().all(|c| c.is_finite()) {
                return Err(IoError::NonFiniteFrame {
                    file: file.into(),
                    frame,
                    point: count,
                    curve: self.curve_of(count),
                    field: "points",
                });
            }
            sink(p);
            count += 1;
        }
        if count != expected {
            return Err(IoError::BadFrame {
                file: file.into(),
                frame,
                message: format!(
                    "{count} points, but the curves have {expected} ({} curves)",
                    self.curves()
                ),
            });
        }
        Ok(())
    }
}
