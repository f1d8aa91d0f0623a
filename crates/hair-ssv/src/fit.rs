//! Fitting swept sphere volumes around point and triangle sets: principal axes from the
//! covariance, then the extents and radius that enclose every point (Ward & Lin 2003 §5.1, with
//! the RSS fit of Larsen et al.'s SSV paper (Ward & Lin's reference 15) as the model).

use nalgebra::{Matrix3, SymmetricEigen};

use crate::contact::{any_perpendicular, try_unit};
use crate::{Lss, Point, Real, Rss, SsvError, Vector};

/// Relative padding added to fitted radii so that rounding never leaves a point outside.
const PAD: Real = 4e-6;

/// Mean and principal axes (largest variance first) of a point set; `None` when it is empty.
fn principal_axes<I>(points: I) -> Option<(Point, [Vector; 3], Real)>
where
    I: Iterator<Item = Point> + Clone,
{
    let mut n = 0usize;
    let mut sum = nalgebra::Vector3::<f64>::zeros();
    for p in points.clone() {
        sum += p.coords.cast::<f64>();
        n += 1;
    }
    if n == 0 {
        return None;
    }
    let mean64 = sum / n as f64;
    let mean = Point::from(mean64.cast::<Real>());
    let mut cov = Matrix3::<f64>::zeros();
    let mut scale: Real = 0.0;
    for p in points {
        let d = p.coords.cast::<f64>() - mean64;
        cov += d * d.transpose();
        scale = scale.max(p.coords.abs().max());
    }
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let col = |i: usize| -> Vector {
        eig.eigenvectors
            .column(order[i])
            .into_owned()
            .cast::<Real>()
    };
    let u = try_unit(&col(0)).unwrap_or_else(Vector::x);
    let v = col(1);
    let v = try_unit(&(v - u * u.dot(&v))).unwrap_or_else(|| any_perpendicular(&u));
    let w = u.cross(&v);
    Some((mean, [u, v, w], scale))
}

fn check_finite(what: &'static str, points: &[Point]) -> Result<(), SsvError> {
    match points
        .iter()
        .position(|p| !p.coords.iter().all(|x| x.is_finite()))
    {
        Some(index) => Err(SsvError::NonFinitePoint { what, index }),
        None => Ok(()),
    }
}

/// The tightest-practical LSS around `points`: the core lies on the principal axis through the
/// mean, the radius is the largest distance from that axis, and the ends are pulled in as far as
/// the spherical caps still cover every point.
pub fn fit_lss(points: &[Point]) -> Result<Lss, SsvError> {
    check_finite("fit_lss", points)?;
    let (mean, [u, _, _], scale) =
        principal_axes(points.iter().copied()).ok_or(SsvError::EmptyInput { what: "fit_lss" })?;
    let mut r2: Real = 0.0;
    for p in points {
        let d = p - mean;
        let t = d.dot(&u);
        r2 = r2.max((d - u * t).norm_squared());
    }
    // the ends are placed with a slightly smaller radius than the one reported, so that the
    // rounding of `sqrt(r^2 - rho^2)` cannot leave a point outside a cap
    let r_ends = r2.sqrt() * (1.0 + PAD) + scale * PAD;
    let r = r2.sqrt() * (1.0 + 2.0 * PAD) + scale * 2.0 * PAD;
    let (mut lo, mut hi) = (Real::INFINITY, Real::NEG_INFINITY);
    for p in points {
        let d = p - mean;
        let t = d.dot(&u);
        let h = (r_ends * r_ends - (d - u * t).norm_squared())
            .max(0.0)
            .sqrt();
        lo = lo.min(t + h);
        hi = hi.max(t - h);
    }
    if lo > hi {
        let m = 0.5 * (lo + hi);
        lo = m;
        hi = m;
    }
    Ok(Lss::new(mean + u * lo, mean + u * hi, r))
}

/// The tightest-practical RSS around `points`: the rectangle spans the two principal axes, the
/// radius is half the thickness along the third, and the rectangle is shrunk as far as the
/// rounded sides and corners still cover every point.
pub fn fit_rss(points: &[Point]) -> Result<Rss, SsvError> {
    check_finite("fit_rss", points)?;
    fit_rss_iter(points.iter().copied()).ok_or(SsvError::EmptyInput { what: "fit_rss" })
}

/// [`fit_rss`] around the vertices of a triangle set (an RSS holding the vertices holds the
/// triangles: it is convex).
pub fn fit_rss_triangles(triangles: &[[Point; 3]]) -> Result<Rss, SsvError> {
    for (i, t) in triangles.iter().enumerate() {
        check_finite("fit_rss_triangles", t).map_err(|_| SsvError::NonFinitePoint {
            what: "fit_rss_triangles",
            index: i,
        })?;
    }
    fit_rss_iter(triangles.iter().flat_map(|t| t.iter().copied())).ok_or(SsvError::EmptyInput {
        what: "fit_rss_triangles",
    })
}

/// RSS fit over any re-iterable point source (finite points assumed); `None` when empty.
pub(crate) fn fit_rss_iter<I>(points: I) -> Option<Rss>
where
    I: Iterator<Item = Point> + Clone,
{
    let (mean, [u, v, w], scale) = principal_axes(points.clone())?;
    // thickness along w
    let (mut wmin, mut wmax) = (Real::INFINITY, Real::NEG_INFINITY);
    for p in points.clone() {
        let z = (p - mean).dot(&w);
        wmin = wmin.min(z);
        wmax = wmax.max(z);
    }
    // sides and corners are placed with a slightly smaller radius than the one reported
    let r = 0.5 * (wmax - wmin) * (1.0 + PAD) + scale * PAD;
    let r_final = 0.5 * (wmax - wmin) * (1.0 + 2.0 * PAD) + scale * 2.0 * PAD;
    let wmid = 0.5 * (wmin + wmax);
    // shrink each side by the room the sphere leaves at that point's height
    let (mut ulo, mut uhi, mut vlo, mut vhi) = (
        Real::INFINITY,
        Real::NEG_INFINITY,
        Real::INFINITY,
        Real::NEG_INFINITY,
    );
    for p in points.clone() {
        let d = p - mean;
        let (x, y, z) = (d.dot(&u), d.dot(&v), d.dot(&w) - wmid);
        let h = (r * r - z * z).max(0.0).sqrt();
        ulo = ulo.min(x + h);
        uhi = uhi.max(x - h);
        vlo = vlo.min(y + h);
        vhi = vhi.max(y - h);
    }
    if ulo > uhi {
        let m = 0.5 * (ulo + uhi);
        (ulo, uhi) = (m, m);
    }
    if vlo > vhi {
        let m = 0.5 * (vlo + vhi);
        (vlo, vhi) = (m, m);
    }
    // corners: grow the side that needs the smaller move until the point is covered
    for p in points {
        let d = p - mean;
        let (x, y, z) = (d.dot(&u), d.dot(&v), d.dot(&w) - wmid);
        let h2 = (r * r - z * z).max(0.0);
        let dx = if x < ulo {
            ulo - x
        } else if x > uhi {
            x - uhi
        } else {
            0.0
        };
        let dy = if y < vlo {
            vlo - y
        } else if y > vhi {
            y - vhi
        } else {
            0.0
        };
        if dx * dx + dy * dy <= h2 {
            continue;
        }
        // move the u side so that the corner distance becomes h, or the v side, whichever is
        // less; a side the point is not beyond never moves (it could only shrink)
        let need_u = dx - (h2 - dy * dy).max(0.0).sqrt();
        let need_v = dy - (h2 - dx * dx).max(0.0).sqrt();
        if dx > 0.0 && (dy <= 0.0 || need_u <= need_v) {
            let room = (h2 - dy * dy).max(0.0).sqrt();
            if x < ulo {
                ulo = ulo.min(x + room);
            } else {
                uhi = uhi.max(x - room);
            }
        } else if dy > 0.0 {
            let room = (h2 - dx * dx).max(0.0).sqrt();
            if y < vlo {
                vlo = vlo.min(y + room);
            } else {
                vhi = vhi.max(y - room);
            }
        }
    }
    let origin = mean + u * ulo + v * vlo + w * wmid;
    Some(Rss::new(
        origin,
        [u, v],
        [(uhi - ulo).max(0.0), (vhi - vlo).max(0.0)],
        r_final,
    ))
}
