//! Render geometry: every rendered strand follows the skeleton that represents it, at its fixed
//! offset in that skeleton's local frame, subdivided into a smooth Catmull-Rom curve.
//!
//! Ward & Lin §3: skeletons are the simulation's base curves; strands, clusters and strips are
//! built around them for rendering only.

use hair_dynamics::{HeadMotion, SkeletonId, StrandState};
use hair_lod::Hierarchy;
use hair_salon::Salon;
use hair_ssv::{Point, Real, Vector};
use nalgebra::Matrix3;

/// Rendered strands around skeletons, with their output polylines (world frame).
#[derive(Clone, Debug, Default)]
pub struct RenderGeometry {
    /// Subdivisions per skeleton segment (1 = the control points themselves).
    pub subdivisions: usize,
    /// Output: strand `s` occupies `positions[offsets[s]..offsets[s + 1]]`.
    pub offsets: Vec<u32>,
    /// Output positions (m, world).
    pub positions: Vec<Point>,
}

/// Parallel-transport frames along a polyline, starting from `first`.
pub(crate) fn transport_frames(
    points: &[Point],
    first: &Matrix3<Real>,
    out: &mut Vec<Matrix3<Real>>,
) {
    out.clear();
    out.resize(points.len(), Matrix3::identity());
    transport_frames_into(points, first, out);
}

/// [`transport_frames`] into a slice: frame `k` of the polyline into `out[k]`, for as many
/// points as `out` holds.
pub(crate) fn transport_frames_into(
    points: &[Point],
    first: &Matrix3<Real>,
    out: &mut [Matrix3<Real>],
) {
    let mut frame = *first;
    for (k, o) in out.iter_mut().enumerate().take(points.len()) {
        if k > 0 {
            // The same minimal rotation between tangents as the strand kinematics uses.
            if let Some(t) = (points[k] - points[k - 1]).try_normalize(1e-12) {
                frame *= minimal_rotation(&(frame.transpose() * t));
            }
        }
        *o = frame;
    }
}

/// The rotation that turns `+z` into the direction of `t` about `z x t`: the bend
/// `hair_dynamics::bend_between(t)` (the strand kinematics' minimal rotation between tangents),
/// written without its angle. With `k = 1 / (1 + t_z)` for the unit `t`, Rodrigues' formula
/// gives `[[1 - k tx^2, -k tx ty, tx], [-k tx ty, 1 - k ty^2, ty], [-tx, -ty, tz]]`: no arctangent
/// and no sine or cosine, which were most of the cost of the render frames. For `t_z < 0`, `k` is
/// taken as `(1 - t_z) / (tx^2 + ty^2)`, the same for a unit vector but without the cancellation
/// in `1 + t_z`; a fold straight back takes the bend's own form. `t` is normalised first: a
/// tangent seen from a frame that has drifted from orthonormal is not quite unit, and near a
/// fold the two forms of `k` then disagree (the bend, from an angle and an axis, never sees the
/// length), so frames would compound the error down a long strand.
#[inline]
pub(crate) fn minimal_rotation(t: &nalgebra::Vector3<Real>) -> Matrix3<Real> {
    let t = t / t.norm();
    let side = t.x * t.x + t.y * t.y;
    let k = if t.z >= 0.0 {
        1.0 / (1.0 + t.z)
    } else if side > 1e-12 {
        (1.0 - t.z) / side
    } else {
        let (x, y) = hair_dynamics::bend_between(&t);
        return hair_dynamics::Bend::new(x, y).rotation;
    };
    let kxy = -k * t.x * t.y;
    Matrix3::new(
        1.0 - k * t.x * t.x,
        kxy,
        t.x,
        kxy,
        1.0 - k * t.y * t.y,
        t.y,
        -t.x,
        -t.y,
        t.z,
    )
}

/// Catmull-Rom through `control` with `sub` points per segment, into `out` (appended).
pub(crate) fn catmull_rom(control: &[Point], sub: usize, out: &mut Vec<Point>) {
    catmull_rom_each(control, sub, |p| out.push(p));
}

/// [`catmull_rom`] into a slice, from its start; points past its end are dropped.
pub(crate) fn catmull_rom_into(control: &[Point], sub: usize, out: &mut [Point]) {
    let mut slots = out.iter_mut();
    catmull_rom_each(control, sub, |p| {
        if let Some(o) = slots.next() {
            *o = p;
        }
    });
}

/// The points of the Catmull-Rom curve through `control`, `sub` per segment, in order.
fn catmull_rom_each(control: &[Point], sub: usize, mut emit: impl FnMut(Point)) {
    let n = control.len();
    if n < 2 || sub <= 1 {
        control.iter().for_each(|&p| emit(p));
        return;
    }
    for i in 0..n - 1 {
        let p0 = if i == 0 {
            control[0] + (control[0] - control[1])
        } else {
            control[i - 1]
        };
        let p1 = control[i];
        let p2 = control[i + 1];
        let p3 = if i + 2 < n {
            control[i + 2]
        } else {
            p2 + (p2 - p1)
        };
        for k in 0..sub {
            let t = k as Real / sub as Real;
            let t2 = t * t;
            let t3 = t2 * t;
            let c = p1.coords * 2.0
                + (p2.coords - p0.coords) * t
                + (p0.coords * 2.0 - p1.coords * 5.0 + p2.coords * 4.0 - p3.coords) * t2
                + (p1.coords * 3.0 - p0.coords - p2.coords * 3.0 + p3.coords) * t3;
            emit(Point::from(c * 0.5));
        }
    }
    emit(control[n - 1]);
}

impl RenderGeometry {
    /// Number of output vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of rendered strands.
    pub fn strand_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// The output polyline of strand `s`.
    pub fn strand(&self, s: usize) -> &[Point] {
        &self.positions[self.offsets[s] as usize..self.offsets[s + 1] as usize]
    }
}

/// The rendered strands' offsets from their skeletons, as the render stage holds them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct CutStrands<'a> {
    /// Per strand, the front node that draws it.
    pub strand_node: &'a [u32],
    /// Per node, where its strands' offsets start in `strand_local`.
    pub node_local_start: &'a [u32],
    /// Each strand's offset per control point in its node's rest transport frames.
    pub strand_local: &'a [Vector],
    /// Control points per strand.
    pub per: usize,
}

/// The drawn strands after the salon's cuts, with their scratch buffers.
#[derive(Clone, Debug, Default)]
pub(crate) struct CutRender {
    frames: Vec<Matrix3<Real>>,
    curve: Vec<Point>,
    control: Vec<Point>,
}

impl CutRender {
    /// Render geometry after cuts: every cut strand ends where its skeleton now ends, and every
    /// fallen piece that is not swept draws the strands of the node it was cut from, at their
    /// offsets from the original control points. Nothing to do before the first cut.
    pub(crate) fn apply(
        &mut self,
        salon: &Salon,
        state: &StrandState,
        h: &Hierarchy,
        strands: &CutStrands<'_>,
        head: &HeadMotion,
        out: &mut RenderGeometry,
    ) {
        if salon.stats().cuts == 0 {
            return;
        }
        let CutStrands {
            strand_node,
            node_local_start,
            strand_local,
            per,
        } = *strands;
        let sub = out.subdivisions.max(1);
        let verts_of = |n: usize| {
            if sub <= 1 || n < 2 {
                n
            } else {
                sub * (n - 1) + 1
            }
        };
        // Compact: strand s keeps the vertices of its live control points.
        let strands = out.strand_count();
        let mut write = 0usize;
        for s in 0..strands.min(strand_node.len()) {
            let start = out.offsets[s] as usize;
            let full = out.offsets[s + 1] as usize - start;
            let live = state.nodes(SkeletonId(strand_node[s])).len().min(per);
            let keep = verts_of(live).min(full);
            out.positions.copy_within(start..start + keep, write);
            out.offsets[s] = write as u32;
            write += keep;
        }
        out.offsets.truncate(strands.min(strand_node.len()) + 1);
        if let Some(last) = out.offsets.last_mut() {
            *last = write as u32;
        }
        out.positions.truncate(write);
        // Fallen pieces.
        let rot = head.rotation;
        let origin = head.position;
        for f in salon.fallen_pieces() {
            if f.swept || (f.source as usize) >= h.node_count() {
                continue;
            }
            let id = f.skeleton;
            let r = state.nodes(id);
            let p = &state.positions()[r.clone()];
            transport_frames(p, state.root_frame(id).matrix(), &mut self.frames);
            // Offsets of the source node's strands start here, `per` per strand.
            let base = node_local_start
                .get(f.source as usize)
                .map_or(usize::MAX, |&b| b as usize);
            for slot in 0..h.strands(f.source).len() {
                self.control.clear();
                for (j, pj) in p.iter().enumerate() {
                    let k = (f.first_source as usize + j).saturating_sub(1).min(per - 1);
                    let local = strand_local
                        .get(base.saturating_add(slot * per + k))
                        .copied()
                        .unwrap_or_default();
                    self.control
                        .push(origin + rot * (pj.coords + self.frames[j] * local));
                }
                self.curve.clear();
                catmull_rom(&self.control, sub, &mut self.curve);
                out.positions.extend_from_slice(&self.curve);
                out.offsets.push(out.positions.len() as u32);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn the_minimal_rotation_is_the_strands_bend() {
        // Tangents all around the sphere: near +z, near -z (the `(1 - t_z) / side` form) and
        // between; the exact fold, where the bend's own form is taken, is checked below.
        let mut worst: Real = 0.0;
        for i in 0..=40 {
            for j in 0..24 {
                let polar = std::f32::consts::PI * (i as Real / 40.0).min(0.99999);
                let az = std::f32::consts::TAU * j as Real / 24.0;
                let t = Vector3::new(polar.sin() * az.cos(), polar.sin() * az.sin(), polar.cos());
                let (x, y) = hair_dynamics::bend_between(&t);
                let bend = hair_dynamics::Bend::new(x, y).rotation;
                let r = minimal_rotation(&t);
                worst = worst.max((r - bend).abs().max());
                // It turns +z into t, and it is a rotation.
                assert!((r * Vector3::z() - t).norm() < 1e-6, "{t:?}");
                assert!(
                    (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-5,
                    "{t:?}"
                );
                assert!((r.determinant() - 1.0).abs() < 1e-5, "{t:?}");
            }
        }
        assert!(worst < 2e-6, "largest difference from the bend: {worst}");
        // A tangent that is not quite unit (seen from a frame drifted from orthonormal) still
        // gives a rotation, near a fold too.
        for t in [
            Vector3::new(1e-4, 2e-4, -1.0) * 1.001,
            Vector3::new(0.3, -0.2, -0.9).normalize() * 0.999,
            Vector3::new(0.3, 0.2, 0.9).normalize() * 1.002,
        ] {
            let r = minimal_rotation(&t);
            assert!(
                (r.transpose() * r - Matrix3::identity()).abs().max() < 1e-5,
                "{t:?}"
            );
            assert!((r * Vector3::z() - t.normalize()).norm() < 1e-5, "{t:?}");
        }
        // Folded straight back: the bend's own half turn about x.
        let back = Vector3::new(0.0, 0.0, -1.0);
        let (x, y) = hair_dynamics::bend_between(&back);
        assert_eq!(
            minimal_rotation(&back),
            hair_dynamics::Bend::new(x, y).rotation
        );
    }
}
