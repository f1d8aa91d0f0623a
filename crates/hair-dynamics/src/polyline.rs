//! Polylines resampled by arc length: a groom read from a file at the skeletons' point count,
//! a hierarchy node's mean of its strands.

use crate::{Point, Real};

/// Resamples a polyline to `n` points at equal arc length (root and tip kept). A polyline of
/// one point gives `n` copies of it, an empty one nothing; `n` = 1 gives the root.
pub fn resample_polyline(points: &[Point], n: usize) -> Vec<Point> {
    if points.len() < 2 || n < 2 {
        let first = points.first().copied();
        return first.map_or_else(Vec::new, |p| {
            vec![p; if points.len() < 2 { n } else { n.min(1) }]
        });
    }
    let mut arc = Vec::with_capacity(points.len());
    let mut total = 0.0;
    arc.push(0.0);
    for w in points.windows(2) {
        total += (w[1] - w[0]).norm();
        arc.push(total);
    }
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for i in 0..n {
        let target = total * i as Real / (n - 1) as Real;
        while j + 2 < points.len() && arc[j + 1] < target {
            j += 1;
        }
        let (a0, a1) = (arc[j], arc[j + 1]);
        let t = if a1 > a0 {
            ((target - a0) / (a1 - a0)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        out.push(points[j] + (points[j + 1] - points[j]) * t);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Equal arc length on a bent polyline, root and tip kept; degenerate inputs give no panic.
    #[test]
    fn points_are_spaced_evenly_along_the_arc() {
        let bent = [
            Point::new(0.0, 0.0, 0.0),
            Point::new(1.0, 0.0, 0.0),
            Point::new(1.0, 3.0, 0.0),
        ];
        let even = resample_polyline(&bent, 5);
        assert_eq!(even.len(), 5);
        assert_eq!(even[0], bent[0]);
        assert!((even[4] - bent[2]).norm() < 1e-6);
        for w in even.windows(2) {
            assert!(((w[1] - w[0]).norm() - 1.0).abs() < 1e-5, "{w:?}");
        }
        assert!(resample_polyline(&[], 4).is_empty());
        assert_eq!(resample_polyline(&bent[..1], 3), vec![bent[0]; 3]);
        assert_eq!(resample_polyline(&bent, 1), vec![bent[0]]);
        assert_eq!(resample_polyline(&bent, 0), Vec::<Point>::new());
    }
}
