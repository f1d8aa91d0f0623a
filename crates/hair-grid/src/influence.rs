//! Influence volumes of the salon tools (salon paper §4.3.1, §4.3.2): a cone whose radius grows
//! along its axis (water, spray, mousse, dryer, grab) and a triangle (scissors), inserted into the
//! grid to find the sections they touch: cells first, then the exact test.

use crate::cell_key::CellKey;
use crate::cover::CellBox;
use crate::grid::{EPS_CELLS, Grid, cells_of};
use crate::{GridError, Point, Real, Ssv, Vector};

/// A volume's cells, and the polygon cover's working list.
type VolumeScratch = (Vec<[i64; 3]>, Vec<[i64; 3]>);

thread_local! {
    /// Kept per thread between queries: the salon's tools and the activity's wake-ups query
    /// volumes every step, and the step loop takes no memory.
    static VOLUME_SCRATCH: std::cell::RefCell<VolumeScratch> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// A truncated cone: from `apex` along the unit `axis` for `length` metres, with radius
/// `radius + spread * s` at distance `s` along the axis (`spread` is the tangent of the cut-off
/// angle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    /// Tip of the tool, on the axis.
    pub apex: Point,
    /// Direction the tool points (normalised when used; must not be zero).
    pub axis: Vector,
    /// Reach along the axis, metres (>= 0).
    pub length: Real,
    /// Radius at the apex, metres (>= 0).
    pub radius: Real,
    /// Growth of the radius per metre along the axis (>= 0): `tan(cut-off angle)`.
    pub spread: Real,
}

impl Cone {
    /// A cone from the tool's position, direction, reach and cut-off angle (radians, in
    /// `[0, pi/2)`), with a point apex.
    pub fn from_angle(apex: Point, axis: Vector, length: Real, cutoff: Real) -> Self {
        Self {
            apex,
            axis,
            length,
            radius: 0.0,
            spread: cutoff.tan(),
        }
    }

    /// Radius at distance `s` along the axis.
    pub fn radius_at(&self, s: Real) -> Real {
        self.radius + self.spread * s
    }

    /// Whether `p` lies in the cone (boundary included).
    pub fn contains_point(&self, p: &Point) -> bool {
        let u = self.axis.normalize();
        let w = p - self.apex;
        let s = w.dot(&u);
        if !(0.0..=self.length).contains(&s) {
            return false;
        }
        let q2 = (w - u * s).norm_squared();
        let r = self.radius_at(s);
        q2 <= r * r
    }

    /// Distance from `p` to the solid cone (0 inside).
    pub fn distance_to_point(&self, p: &Point) -> Real {
        self.frame()
            .distance([f64::from(p.x), f64::from(p.y), f64::from(p.z)]) as Real
    }

    fn frame(&self) -> ConeFrame {
        let u = self.axis.normalize();
        ConeFrame {
            apex: [
                f64::from(self.apex.x),
                f64::from(self.apex.y),
                f64::from(self.apex.z),
            ],
            u: [f64::from(u.x), f64::from(u.y), f64::from(u.z)],
            length: f64::from(self.length),
            r0: f64::from(self.radius),
            r1: f64::from(self.radius) + f64::from(self.spread) * f64::from(self.length),
        }
    }
}

/// A cone in `f64`, for the exact tests.
struct ConeFrame {
    apex: [f64; 3],
    u: [f64; 3],
    length: f64,
    r0: f64,
    r1: f64,
}

/// Distance from a 2-D point to a 2-D segment.
fn dist_2d(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let d = [b[0] - a[0], b[1] - a[1]];
    let w = [p[0] - a[0], p[1] - a[1]];
    let dd = d[0] * d[0] + d[1] * d[1];
    let t = if dd > 0.0 {
        ((w[0] * d[0] + w[1] * d[1]) / dd).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let e = [w[0] - t * d[0], w[1] - t * d[1]];
    (e[0] * e[0] + e[1] * e[1]).sqrt()
}

impl ConeFrame {
    /// Distance from a point to the solid cone: in the (axial, radial) half-plane the cone is the
    /// trapezoid `0 <= s <= L, q <= r0 + (r1 - r0) s / L`.
    fn distance(&self, p: [f64; 3]) -> f64 {
        let w = [
            p[0] - self.apex[0],
            p[1] - self.apex[1],
            p[2] - self.apex[2],
        ];
        let s = w[0] * self.u[0] + w[1] * self.u[1] + w[2] * self.u[2];
        let q2 = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2] - s * s).max(0.0);
        let q = q2.sqrt();
        let l = self.length;
        let r_at = if l > 0.0 {
            self.r0 + (self.r1 - self.r0) * (s / l)
        } else {
            self.r0
        };
        if (0.0..=l).contains(&s) && q <= r_at {
            return 0.0;
        }
        let pt = [s, q];
        let top = dist_2d(pt, [0.0, self.r0], [l, self.r1]);
        let cap0 = dist_2d(pt, [0.0, 0.0], [0.0, self.r0]);
        let cap1 = dist_2d(pt, [l, 0.0], [l, self.r1]);
        top.min(cap0).min(cap1)
    }
}

/// Minimum of a convex function on `[0, 1]` by golden-section search.
fn min_convex(f: impl Fn(f64) -> f64) -> f64 {
    let g = 0.618_033_988_749_894_9_f64;
    let (mut a, mut b) = (0.0f64, 1.0f64);
    let mut best = f(0.0).min(f(1.0));
    let mut x1 = b - g * (b - a);
    let mut x2 = a + g * (b - a);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 <= f2 {
            b = x2;
            x2 = x1;
            f2 = f1;
            x1 = b - g * (b - a);
            f1 = f(x1);
        } else {
            a = x1;
            x1 = x2;
            f1 = f2;
            x2 = a + g * (b - a);
            f2 = f(x2);
        }
        best = best.min(f1).min(f2);
        if best <= 0.0 {
            break;
        }
    }
    best
}

fn p64(p: &Point) -> [f64; 3] {
    [f64::from(p.x), f64::from(p.y), f64::from(p.z)]
}

fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

/// The area a salon tool acts on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InfluenceVolume {
    /// Water, spray, mousse, dryer, grab.
    Cone(Cone),
    /// Scissors: the triangle between the open blades.
    Triangle([Point; 3]),
}

impl InfluenceVolume {
    /// Distance (metres, >= 0) from the core of `shape` to the volume: 0 when they meet.
    /// The cone distance is minimised over the core by golden-section search on a convex
    /// function (to about 1e-12 of the core's size); the triangle distance is hair-ssv's.
    pub fn core_distance(&self, shape: &Ssv) -> Real {
        match self {
            InfluenceVolume::Cone(c) => {
                let f = c.frame();
                let d = match shape {
                    Ssv::Point(p) => f.distance(p64(&p.center)),
                    Ssv::Line(l) => {
                        let (a, b) = (p64(&l.a), p64(&l.b));
                        min_convex(|t| f.distance(lerp(a, b, t)))
                    }
                    Ssv::Rect(q) => {
                        let k = q.corners().map(|c| p64(&c));
                        min_convex(|s| {
                            let a = lerp(k[0], k[1], s);
                            let b = lerp(k[3], k[2], s);
                            min_convex(|t| f.distance(lerp(a, b, t)))
                        })
                    }
                };
                d as Real
            }
            InfluenceVolume::Triangle(t) => {
                let core = match shape {
                    Ssv::Point(p) => Ssv::Point(hair_ssv::Pss::new(p.center, 0.0)),
                    Ssv::Line(l) => Ssv::Line(hair_ssv::Lss::new(l.a, l.b, 0.0)),
                    Ssv::Rect(q) => {
                        let mut q = *q;
                        q.radius = 0.0;
                        Ssv::Rect(q)
                    }
                };
                core.distance_to_triangle(t).max(0.0)
            }
        }
    }

    /// The exact test: whether the volume `shape` (core grown by its radius) meets the volume.
    pub fn touches(&self, shape: &Ssv) -> bool {
        self.core_distance(shape) <= shape.radius()
    }

    fn invalid_field(&self) -> Option<&'static str> {
        let fp = |p: &Point| p.iter().all(|v| v.is_finite());
        match self {
            InfluenceVolume::Cone(c) => {
                if !fp(&c.apex) {
                    Some("apex")
                } else if !(c.axis.iter().all(|v| v.is_finite()) && c.axis.norm() > 0.0) {
                    Some("axis")
                } else if !(c.length.is_finite() && c.length >= 0.0) {
                    Some("length")
                } else if !(c.radius.is_finite() && c.radius >= 0.0) {
                    Some("radius")
                } else if !(c.spread.is_finite()
                    && c.spread >= 0.0
                    && c.radius_at(c.length).is_finite())
                {
                    Some("spread")
                } else {
                    None
                }
            }
            InfluenceVolume::Triangle(t) => (!t.iter().all(fp)).then_some("vertices"),
        }
    }
}

impl Grid {
    /// Non-empty cells that the volume covers (conservatively), ascending, into `cells`.
    fn volume_cells(
        &self,
        volume: &InfluenceVolume,
        cells: &mut Vec<[i64; 3]>,
        scratch: &mut Vec<[i64; 3]>,
    ) -> Result<(), GridError> {
        cells.clear();
        if let Some(field) = volume.invalid_field() {
            return Err(GridError::InvalidShape {
                what: "influence volume",
                index: 0,
                field,
            });
        }
        if self.is_empty() {
            return Ok(());
        }
        let clip: CellBox = self.cell_box();
        let inv = self.inv;
        let limit = self.config.max_cells_per_volume;
        let too_many = || GridError::TooManyCells {
            what: "influence volume",
            index: 0,
            limit,
            cell_size: self.cell_size,
        };
        let mut emit = |c: [i64; 3]| {
            if !self.range_of(c).is_empty() {
                cells.push(c);
            }
        };
        match volume {
            InfluenceVolume::Cone(c) => {
                let u = c.axis.normalize();
                let pieces = ((f64::from(c.length) * inv).ceil() as usize).clamp(1, 256);
                let mut total = 0u64;
                for k in 0..pieces {
                    let s0 = c.length * k as Real / pieces as Real;
                    let s1 = c.length * (k + 1) as Real / pieces as Real;
                    let a = cells_of(&(c.apex + u * s0), inv);
                    let b = cells_of(&(c.apex + u * s1), inv);
                    let r = f64::from(c.radius_at(s1)) * inv * (1.0 + 1e-6) + EPS_CELLS;
                    total +=
                        crate::cover::segment(a, b, r, &clip, limit - total.min(limit), &mut emit)
                            .map_err(|_| too_many())?;
                }
            }
            InfluenceVolume::Triangle(t) => {
                let v = t.map(|p| cells_of(&p, inv));
                crate::cover::polygon(&v, EPS_CELLS, &clip, limit, scratch, &mut emit)
                    .map_err(|_| too_many())?;
            }
        }
        cells.sort_unstable();
        cells.dedup();
        Ok(())
    }

    /// The non-empty cells the volume touches (conservatively: every cell holding a point of the
    /// volume), in increasing key order, into `out`.
    ///
    /// # Errors
    /// [`GridError::InvalidShape`] for a non-finite or negative field, or a zero axis;
    /// [`GridError::TooManyCells`] beyond `max_cells_per_volume` cells around the hair.
    pub fn cells_touched_by(
        &self,
        volume: &InfluenceVolume,
        out: &mut Vec<CellKey>,
    ) -> Result<(), GridError> {
        VOLUME_SCRATCH.with_borrow_mut(|(cells, scratch)| {
            self.volume_cells(volume, cells, scratch)?;
            out.clear();
            out.extend(
                cells
                    .iter()
                    .map(|c| CellKey::new(c[0] as i32, c[1] as i32, c[2] as i32)),
            );
            Ok(())
        })
    }

    /// The sections the volume touches (salon paper §4.3.2): the sections of the cells the
    /// volume covers, then the exact test [`InfluenceVolume::touches`]. Ascending, into `out`.
    ///
    /// # Errors
    /// As [`Grid::cells_touched_by`].
    pub fn sections_in(
        &self,
        volume: &InfluenceVolume,
        out: &mut Vec<u32>,
    ) -> Result<(), GridError> {
        VOLUME_SCRATCH.with_borrow_mut(|(cells, scratch)| {
            self.volume_cells(volume, cells, scratch)?;
            out.clear();
            for &c in cells.iter() {
                out.extend_from_slice(&self.sorted_items[self.range_of(c)]);
            }
            Ok::<(), GridError>(())
        })?;
        out.sort_unstable();
        out.dedup();
        out.retain(|&i| volume.touches(&self.shape_at(i as usize)));
        Ok(())
    }
}
