//! Pixar's USD as ASCII `.usda`: an animated hair export, streamed frame by frame.
//!
//! The layer holds one root `Xform` prim, `/Hair` (the default prim), with
//!
//! - `/Hair/Strands`, a `BasisCurves` prim: `type = "linear"`, `wrap = "nonperiodic"`, the
//!   `curveVertexCounts` and `widths` (diameters; constant, per curve or per vertex), and
//!   `points.timeSamples` with one sample per frame. The drawn strands are polylines already
//!   subdivided along a Catmull-Rom curve, so linear curves through their points draw exactly
//!   what the simulation drew; no basis applies to linear curves and none is written.
//! - `/Hair/Body`, a `Mesh` prim (triangles), static; if frames give the body's pose, its
//!   `xformOp:transform` is time sampled too.
//!
//! Layer metadata: `upAxis`, `metersPerUnit`, `timeCodesPerSecond` (and `framesPerSecond`, the
//! same), `startTimeCode` and `endTimeCode` (the first and last frames' time codes).
//!
//! Why the layout streams: a USD attribute keeps all its time samples in one dictionary, so the
//! curves' points samples are the last thing written in their prim and each frame appends one
//! entry. The body comes after the curves, written by [`UsdaWriter::finish`] with the body's
//! poses (16 numbers a frame, kept in memory; the points are never kept). The start and end
//! time codes are written as fixed-width fields in the layer header and filled in at the end.
//!
//! Numbers: an `f32` is printed as the shortest decimal that reads back as the same `f32` when
//! parsed as a double and then narrowed, which is how USD reads `float` and `point3f` text. That
//! is Rust's shortest round-trip text for every finite `f32` but one (checked over all of them
//! by the ignored test `every_f32_survives_a_double_parse`); that one is written with more
//! digits.

use crate::frames::CurveLayout;
use crate::partial::{Existing, PartialFile};
use crate::{IoError, Mesh};
use std::fmt::Write as _;
use std::path::Path;

/// The stage's up axis.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UpAxis {
    /// +y up (hair-io's scenes).
    #[default]
    Y,
    /// +z up.
    Z,
}

/// The stage's metadata that does not depend on the frames.
#[derive(Clone, Debug, PartialEq)]
pub struct UsdStage {
    /// Which axis points up.
    pub up_axis: UpAxis,
    /// Metres per stage unit (1 for points in metres).
    pub meters_per_unit: f64,
    /// Time codes per second; with one time code per frame, the frame rate. Also written as
    /// `framesPerSecond`, so players step one time code per frame.
    pub time_codes_per_second: f64,
}

impl Default for UsdStage {
    /// +y up, metres, 60 time codes per second (a scene's default frame rate).
    fn default() -> Self {
        Self {
            up_axis: UpAxis::Y,
            meters_per_unit: 1.0,
            time_codes_per_second: 60.0,
        }
    }
}

/// A rigid pose of the body at one frame: a body point `p` is at `rotation * p + translation` in
/// the stage (column vectors; `rotation` is row major).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyPose {
    /// The rotation matrix, row major.
    pub rotation: [[f32; 3]; 3],
    /// The translation (stage units).
    pub translation: [f32; 3],
}

impl BodyPose {
    /// The pose that leaves the body where it is.
    pub const IDENTITY: Self = Self {
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        translation: [0.0; 3],
    };
}

/// Streams an animated hair export to a `.usda` file; see the [module](self) for its layout.
///
/// The file is written beside its destination (`.NAME.partial-*`) and moved there by
/// [`finish`](Self::finish); dropped unfinished, it leaves nothing. A frame that is refused
/// (a non-finite value, the wrong number of points, a time code out of order) writes nothing
/// and the writer can go on.
pub struct UsdaWriter {
    out: PartialFile,
    layout: CurveLayout,
    /// Byte offsets of the padded start and end time code fields in the header.
    start_at: u64,
    end_at: u64,
    time_codes: Option<(f64, f64)>,
    frames: usize,
    body: Option<String>,
    poses: Option<Vec<(f64, BodyPose)>>,
    text: String,
}

/// Width reserved for a time code in the header: the longest text [`push_f64`] makes is 24.
const TIME_FIELD: usize = 32;

impl UsdaWriter {
    /// Opens `path` for a stage of the given curves and body and writes everything but the
    /// frames' points and the body.
    ///
    /// `curve_vertex_counts` gives each curve's point count (at least 2); `widths` are
    /// diameters in stage units, one (for all), one per curve, or one per point. The body's
    /// triangles index its vertices. Refuses an existing `path` unless `existing` is
    /// [`Existing::Replace`].
    pub fn create(
        path: &Path,
        stage: &UsdStage,
        body: Option<&Mesh>,
        curve_vertex_counts: &[u32],
        widths: &[f32],
        existing: Existing,
    ) -> Result<Self, IoError> {
        let name = path.display().to_string();
        let layout = CurveLayout::new(curve_vertex_counts, &name)?;
        for (field, value) in [
            ("meters_per_unit", stage.meters_per_unit),
            ("time_codes_per_second", stage.time_codes_per_second),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(IoError::BadInput {
                    file: name,
                    field,
                    index: 0,
                    message: format!("{value}; a positive number is needed"),
                });
            }
        }
        let interpolation = match widths.len() {
            1 => "constant",
            n if n == layout.curves() => "uniform",
            n if n == layout.points() => "vertex",
            n => {
                return Err(IoError::BadInput {
                    file: name,
                    field: "widths",
                    index: n,
                    message: format!(
                        "{n} widths; give 1, one per curve ({}) or one per point ({})",
                        layout.curves(),
                        layout.points()
                    ),
                });
            }
        };
        if let Some(i) = widths.iter().position(|w| !(w.is_finite() && *w >= 0.0)) {
            return Err(IoError::BadInput {
                file: name,
                field: "widths",
                index: i,
                message: format!("{}; a width is finite and not negative", widths[i]),
            });
        }
        let body = body.map(|m| body_text(m, &name)).transpose()?;

        let mut head = String::new();
        let tcps = stage.time_codes_per_second;
        head.push_str("#usda 1.0\n(\n    defaultPrim = \"Hair\"\n");
        head.push_str("    doc = \"Hair strands and body written by hair-io\"\n");
        head.push_str("    metersPerUnit = ");
        push_f64(&mut head, stage.meters_per_unit);
        let axis = match stage.up_axis {
            UpAxis::Y => "Y",
            UpAxis::Z => "Z",
        };
        let _ = write!(head, "\n    upAxis = \"{axis}\"\n    timeCodesPerSecond = ");
        push_f64(&mut head, tcps);
        head.push_str("\n    framesPerSecond = ");
        push_f64(&mut head, tcps);
        head.push_str("\n    startTimeCode = ");
        let start_at = head.len() as u64;
        let _ = write!(head, "{:TIME_FIELD$}", 0);
        head.push_str("\n    endTimeCode = ");
        let end_at = head.len() as u64;
        let _ = write!(head, "{:TIME_FIELD$}", 0);
        head.push_str("\n)\n\ndef Xform \"Hair\"\n{\n");
        head.push_str("    def BasisCurves \"Strands\" (\n");
        head.push_str(
            "        doc = \"The drawn strands: polylines subdivided along Catmull-Rom curves, \
             exact as linear curves\"\n    )\n    {\n",
        );
        head.push_str("        uniform token type = \"linear\"\n");
        head.push_str("        uniform token wrap = \"nonperiodic\"\n");
        head.push_str("        int[] curveVertexCounts = [");
        push_list(&mut head, curve_vertex_counts, |s, n| {
            let _ = write!(s, "{n}");
        });
        head.push_str("]\n        float[] widths = [");
        push_list(&mut head, widths, |s, w| push_f32(s, *w));
        let _ = write!(
            head,
            "] (\n            interpolation = \"{interpolation}\"\n        )\n"
        );
        head.push_str("        point3f[] points.timeSamples = {\n");

        let mut out = PartialFile::create(path, existing)?;
        out.write(head.as_bytes())?;
        Ok(Self {
            out,
            layout,
            start_at,
            end_at,
            time_codes: None,
            frames: 0,
            body,
            poses: None,
            text: String::new(),
        })
    }

    /// Frames written so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Appends the curves' points at `time_code` (after the previous frame's), in the order of
    /// the curves. The body, if any, stays where it is.
    pub fn write_frame(
        &mut self,
        time_code: f64,
        points: impl IntoIterator<Item = [f32; 3]>,
    ) -> Result<(), IoError> {
        self.frame(time_code, points, None)
    }

    /// As [`write_frame`](Self::write_frame), with the body's pose at `time_code`. Every frame
    /// of a file gives a pose, or none does.
    pub fn write_frame_posed(
        &mut self,
        time_code: f64,
        points: impl IntoIterator<Item = [f32; 3]>,
        body_pose: &BodyPose,
    ) -> Result<(), IoError> {
        self.frame(time_code, points, Some(body_pose))
    }

    fn frame(
        &mut self,
        time_code: f64,
        points: impl IntoIterator<Item = [f32; 3]>,
        pose: Option<&BodyPose>,
    ) -> Result<(), IoError> {
        let frame = self.frames;
        let bad = |message: String| IoError::BadFrame {
            file: self.out.name.clone(),
            frame,
            message,
        };
        if !time_code.is_finite() {
            return Err(bad(format!("time code {time_code} is not finite")));
        }
        if let Some((_, last)) = self.time_codes
            && time_code <= last
        {
            return Err(bad(format!(
                "time code {time_code} does not follow the previous frame's {last}"
            )));
        }
        if frame > 0 && pose.is_some() != self.poses.is_some() {
            return Err(bad(
                "every frame gives the body's pose or none does; frame 0 did not match".into(),
            ));
        }
        if let Some(p) = pose {
            let values = p.rotation.iter().flatten().chain(&p.translation);
            if values.into_iter().any(|v| !v.is_finite()) {
                return Err(bad("the body pose is not finite".into()));
            }
        }
        let mut text = std::mem::take(&mut self.text);
        text.clear();
        text.push_str("            ");
        push_f64(&mut text, time_code);
        text.push_str(": [");
        let mut first = true;
        let checked = self.layout.check_frame(&self.out.name, frame, points, |p| {
            if !first {
                text.push_str(", ");
            }
            first = false;
            push_point(&mut text, p);
        });
        text.push_str("],\n");
        let written = checked.and_then(|()| self.out.write(text.as_bytes()));
        self.text = text;
        written?;
        self.frames += 1;
        self.time_codes = Some(match self.time_codes {
            Some((start, _)) => (start, time_code),
            None => (time_code, time_code),
        });
        if let Some(p) = pose {
            self.poses
                .get_or_insert_with(Vec::new)
                .push((time_code, *p));
        }
        Ok(())
    }

    /// Writes the body and the time code range, and moves the file into place.
    pub fn finish(mut self) -> Result<(), IoError> {
        let mut tail = String::from("        }\n    }\n");
        if let Some(body) = self.body.take() {
            tail.push_str("\n    def Mesh \"Body\"\n    {\n");
            tail.push_str(&body);
            if let Some(poses) = &self.poses {
                tail.push_str("        matrix4d xformOp:transform.timeSamples = {\n");
                for (t, pose) in poses {
                    tail.push_str("            ");
                    push_f64(&mut tail, *t);
                    tail.push_str(": ");
                    push_matrix(&mut tail, pose);
                    tail.push_str(",\n");
                }
                tail.push_str("        }\n");
                tail.push_str("        uniform token[] xformOpOrder = [\"xformOp:transform\"]\n");
            }
            tail.push_str("    }\n");
        }
        tail.push_str("}\n");
        self.out.write(tail.as_bytes())?;
        let (start, end) = self.time_codes.unwrap_or((0.0, 0.0));
        for (at, value) in [(self.start_at, start), (self.end_at, end)] {
            let mut field = String::new();
            push_f64(&mut field, value);
            let field = format!("{field:TIME_FIELD$}");
            self.out.patch(at, field.as_bytes())?;
        }
        self.out.commit()
    }
}

/// The body's `Mesh` properties (without its pose), checked.
fn body_text(mesh: &Mesh, file: &str) -> Result<String, IoError> {
    let n = mesh.vertices.len();
    if let Some(i) = mesh
        .vertices
        .iter()
        .position(|v| !v.iter().all(|c| c.is_finite()))
    {
        return Err(IoError::BadInput {
            file: file.into(),
            field: "body.vertices",
            index: i,
            message: "a coordinate is not finite".into(),
        });
    }
    if let Some(t) = mesh
        .triangles
        .iter()
        .position(|t| t.iter().any(|&i| i as usize >= n || i > i32::MAX as u32))
    {
        return Err(IoError::BadInput {
            file: file.into(),
            field: "body.triangles",
            index: t,
            message: format!(
                "vertex indices {:?} out of range ({n} vertices)",
                mesh.triangles[t]
            ),
        });
    }
    let mut s = String::new();
    s.push_str("        uniform token subdivisionScheme = \"none\"\n");
    s.push_str("        int[] faceVertexCounts = [");
    push_list(&mut s, &mesh.triangles, |s, _| s.push('3'));
    s.push_str("]\n        int[] faceVertexIndices = [");
    push_list(&mut s, &mesh.triangles, |s, t| {
        let _ = write!(s, "{}, {}, {}", t[0], t[1], t[2]);
    });
    s.push_str("]\n        point3f[] points = [");
    push_list(&mut s, &mesh.vertices, |s, p| push_point(s, *p));
    s.push_str("]\n");
    Ok(s)
}

fn push_list<T>(s: &mut String, items: &[T], mut each: impl FnMut(&mut String, &T)) {
    for (i, item) in items.iter().enumerate() {
        if i > 0 {
            s.push_str(", ");
        }
        each(s, item);
    }
}

fn push_point(s: &mut String, p: [f32; 3]) {
    s.push('(');
    push_f32(s, p[0]);
    s.push_str(", ");
    push_f32(s, p[1]);
    s.push_str(", ");
    push_f32(s, p[2]);
    s.push(')');
}

/// USD's `matrix4d` multiplies row vectors from the left (`p' = p M`), so its upper 3x3 block
/// is the transposed rotation and its last row the translation.
fn push_matrix(s: &mut String, pose: &BodyPose) {
    let r = &pose.rotation;
    s.push_str("( ");
    for row in 0..4 {
        let values = if row < 3 {
            [r[0][row], r[1][row], r[2][row], 0.0]
        } else {
            let [x, y, z] = pose.translation;
            [x, y, z, 1.0]
        };
        s.push('(');
        for (i, v) in values.into_iter().enumerate() {
            if i > 0 {
                s.push_str(", ");
            }
            push_f32(s, v);
        }
        s.push_str(if row < 3 { "), " } else { ") )" });
    }
}

/// The one finite `f32` magnitude whose shortest round-trip text is read back as its neighbour
/// by a parser that reads a double and then narrows it (double rounding); found by the
/// exhaustive test.
const DOUBLE_ROUNDED: u32 = 0x15ae_43fd;

/// Appends a finite `f32` as text that reads back as the same `f32` through a double: Rust's
/// shortest round-trip text, with an exponent outside the range where plain digits stay short.
pub(crate) fn push_f32(s: &mut String, x: f32) {
    let a = x.abs();
    let _ = if a.to_bits() == DOUBLE_ROUNDED {
        // The double nearest this f32 is the f32 itself; its text is exact.
        write!(s, "{:e}", f64::from(x))
    } else if a == 0.0 || (1e-5..1e9).contains(&a) {
        write!(s, "{x}")
    } else {
        write!(s, "{x:e}")
    };
}

/// Appends a finite `f64` as its shortest round-trip text (an exponent outside plain digits'
/// short range): at most 24 characters.
pub(crate) fn push_f64(s: &mut String, x: f64) {
    let a = x.abs();
    let _ = if a == 0.0 || (1e-5..1e15).contains(&a) {
        write!(s, "{x}")
    } else {
        write!(s, "{x:e}")
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every finite `f32`, printed by [`push_f32`], parsed as a double and narrowed, is itself.
    /// About 13 minutes in a release build on the 2-core machine:
    /// `cargo test -p hair-io --release --lib -- --ignored every_f32_survives_a_double_parse`.
    #[test]
    #[ignore = "scans all 4 billion f32 values"]
    fn every_f32_survives_a_double_parse() {
        let mut s = String::new();
        let mut bad = Vec::new();
        for bits in 0..=u32::MAX {
            let x = f32::from_bits(bits);
            if !x.is_finite() {
                continue;
            }
            s.clear();
            push_f32(&mut s, x);
            let back = s.parse::<f64>().map(|d| d as f32);
            if back.map(f32::to_bits) != Ok(bits) {
                bad.push(bits);
            }
        }
        assert!(
            bad.is_empty(),
            "{} values fail, first {:#x?}",
            bad.len(),
            &bad[..bad.len().min(8)]
        );
    }

    /// The exception the scan found: Rust's shortest text fails through a double, ours does not.
    #[test]
    fn the_double_rounded_f32_is_written_exactly() {
        for x in [
            f32::from_bits(DOUBLE_ROUNDED),
            -f32::from_bits(DOUBLE_ROUNDED),
        ] {
            let shortest = format!("{x}");
            assert_ne!(
                (shortest.parse::<f64>().unwrap() as f32).to_bits(),
                x.to_bits()
            );
            let mut s = String::new();
            push_f32(&mut s, x);
            assert_eq!(
                (s.parse::<f64>().unwrap() as f32).to_bits(),
                x.to_bits(),
                "{s}"
            );
        }
    }

    #[test]
    fn time_codes_fit_their_field() {
        for x in [
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            -5e-324,
            123456789.125,
            -0.0,
        ] {
            let mut s = String::new();
            push_f64(&mut s, x);
            assert!(s.len() <= 24, "{s}");
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits());
        }
    }
}
