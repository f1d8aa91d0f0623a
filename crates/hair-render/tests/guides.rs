//! Followers of guides (`hair_render::guides`) against their exact model: barycentric weights,
//! rigid motion carried exactly, coinciding guides, cuts, determinism.

use hair_render::follow::{RenderGeometry, catmull_rom};
use hair_render::guides::{Followers, Link, sample_links};
use hair_render::{Point, Real, Vector};
use nalgebra::{Matrix3, Rotation3};

const PER: usize = 8;
const SUB: usize = 3;

/// Guide roots on the upper half of a 10 cm sphere (a scalp), deterministic.
fn roots(n: usize) -> Vec<Point> {
    (0..n)
        .map(|i| {
            let t = i as Real / n as Real;
            let (theta, phi) = (t * 1.3, i as Real * 2.399_963);
            Point::new(
                0.1 * theta.sin() * phi.cos(),
                0.1 * theta.cos(),
                0.1 * theta.sin() * phi.sin(),
            )
        })
        .collect()
}

/// Guides of `PER` points hanging from `roots` with a little curl, one after another.
fn guide_rest(roots: &[Point]) -> Vec<Point> {
    roots
        .iter()
        .enumerate()
        .flat_map(|(g, r)| {
            let out = r.coords.normalize();
            (0..PER).map(move |k| {
                let s = k as Real * 0.02;
                r + out * s * 0.5 - Vector::y() * s + Vector::x() * (s * (g as Real)).sin() * 0.01
            })
        })
        .collect()
}

/// The guides as drawn: each a Catmull-Rom curve through its control points mapped by `map`,
/// the first `live[g]` of them.
fn drawn(rest: &[Point], live: &[usize], map: impl Fn(&Point) -> Point) -> RenderGeometry {
    let mut g = RenderGeometry {
        subdivisions: SUB,
        offsets: vec![0],
        positions: Vec::new(),
    };
    for (i, chunk) in rest.chunks(PER).enumerate() {
        let control: Vec<Point> = chunk[..live[i]].iter().map(&map).collect();
        catmull_rom(&control, SUB, &mut g.positions);
        g.offsets.push(g.positions.len() as u32);
    }
    g
}

/// Follower `f`'s control points (every `SUB`-th vertex).
fn control(out: &RenderGeometry, f: usize) -> Vec<Point> {
    out.strand(f).iter().step_by(SUB).copied().collect()
}

#[test]
fn sampled_links_count_weights_and_seed() {
    let r = roots(60);
    let links = sample_links(&r, 500, 7);
    assert_eq!(links.len(), 500);
    for l in &links {
        assert!(l.guides.iter().all(|&g| (g as usize) < r.len()));
        assert!(l.weights.iter().all(|&w| w >= 0.0), "{l:?}");
        let sum: Real = l.weights.iter().sum();
        assert!((sum - 1.0).abs() < 1e-5, "weights sum to {sum}");
        // The three guides are the nearest to the root (brute force).
        let mut by: Vec<Real> = r.iter().map(|p| (p - l.root).norm()).collect();
        by.sort_by(Real::total_cmp);
        let far = l
            .guides
            .iter()
            .map(|&g| (r[g as usize] - l.root).norm())
            .fold(0.0, Real::max);
        assert!(
            far <= by[2] + 1e-7,
            "a guide is not among the three nearest"
        );
        // The root lies near the scalp, between guide roots.
        assert!((l.root.coords.norm() - 0.1).abs() < 0.01);
    }
    assert_eq!(links, sample_links(&r, 500, 7), "same seed, same links");
    assert_ne!(links, sample_links(&r, 500, 8), "another seed, other links");
}

#[test]
fn at_rest_each_follower_is_the_weighted_guides_offset_to_its_root() {
    let r = roots(40);
    let rest = guide_rest(&r);
    let links = sample_links(&r, 200, 3);
    let mut f = Followers::new(&rest, PER, links.clone(), SUB);
    f.update(&drawn(&rest, &[PER; 40], |p| *p), &Matrix3::identity());
    assert_eq!(f.geometry.strand_count(), 200);
    for (i, l) in links.iter().enumerate() {
        let blend = |k: usize| {
            (0..3).fold(Vector::zeros(), |a, j| {
                a + rest[l.guides[j] as usize * PER + k].coords * l.weights[j]
            })
        };
        let d = l.root.coords - blend(0);
        let c = control(&f.geometry, i);
        assert_eq!(c.len(), PER);
        assert!((c[0] - l.root).norm() < 1e-6, "root off its own root");
        for k in 0..PER {
            assert!((c[k].coords - (blend(k) + d)).norm() < 1e-5);
        }
    }
}

#[test]
fn rigid_motion_of_every_guide_moves_the_followers_with_it() {
    let r = roots(40);
    let rest = guide_rest(&r);
    let links = sample_links(&r, 200, 5);
    let mut still = Followers::new(&rest, PER, links.clone(), SUB);
    still.update(&drawn(&rest, &[PER; 40], |p| *p), &Matrix3::identity());
    // A translation.
    let t = Vector::new(0.3, -0.7, 1.1);
    let mut moved = Followers::new(&rest, PER, links.clone(), SUB);
    moved.update(&drawn(&rest, &[PER; 40], |p| p + t), &Matrix3::identity());
    for (a, b) in still
        .geometry
        .positions
        .iter()
        .zip(&moved.geometry.positions)
    {
        assert!((b - (a + t)).norm() < 2e-6, "{a} moved to {b}");
    }
    // A rotation (the head's), which the offsets follow.
    let rot = Rotation3::from_euler_angles(0.4, -0.9, 0.2);
    let mut turned = Followers::new(&rest, PER, links, SUB);
    turned.update(&drawn(&rest, &[PER; 40], |p| rot * p), rot.matrix());
    for (a, b) in still
        .geometry
        .positions
        .iter()
        .zip(&turned.geometry.positions)
    {
        assert!((b - rot * a).norm() < 5e-6, "{a} turned to {b}");
    }
}

#[test]
fn a_follower_of_three_coinciding_guides_is_that_guide_moved_to_its_root() {
    let r = roots(10);
    let rest = guide_rest(&r);
    let root = r[4] + Vector::new(0.004, 0.001, -0.003);
    let link = Link {
        guides: [4, 4, 4],
        weights: [0.2, 0.5, 0.3],
        root,
    };
    let mut f = Followers::new(&rest, PER, vec![link], SUB);
    let t = Vector::new(0.05, 0.02, -0.01);
    let guides = drawn(&rest, &[PER; 10], |p| p + t);
    f.update(&guides, &Matrix3::identity());
    let c = control(&f.geometry, 0);
    for k in 0..PER {
        let want = rest[4 * PER + k] + t + (root - r[4]);
        assert!((c[k] - want).norm() < 1e-6, "point {k}: {} vs {want}", c[k]);
    }
}

#[test]
fn followers_are_as_long_as_their_cut_guides() {
    let r = roots(12);
    let rest = guide_rest(&r);
    let links = sample_links(&r, 100, 9);
    let live: Vec<usize> = (0..12).map(|g| 2 + g % 6).collect();
    let mut f = Followers::new(&rest, PER, links.clone(), SUB);
    f.update(&drawn(&rest, &live, |p| *p), &Matrix3::identity());
    for (i, l) in links.iter().enumerate() {
        let n: Real = (0..3)
            .map(|j| l.weights[j] * live[l.guides[j] as usize] as Real)
            .sum();
        let n = (n.round() as usize).clamp(1, PER);
        assert_eq!(f.geometry.strand(i).len(), SUB * (n - 1) + 1);
    }
    // Grown again, every follower is whole.
    f.update(&drawn(&rest, &[PER; 12], |p| *p), &Matrix3::identity());
    assert!((0..100).all(|i| f.geometry.strand(i).len() == SUB * (PER - 1) + 1));
}

#[test]
fn followers_do_not_depend_on_the_thread_count() {
    let r = roots(50);
    let rest = guide_rest(&r);
    let rot = Rotation3::from_euler_angles(0.1, 0.2, 0.3);
    let guides = drawn(&rest, &[PER; 50], |p| rot * p + Vector::x());
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut f = Followers::new(&rest, PER, sample_links(&r, 300, 11), SUB);
            f.update(&guides, rot.matrix());
            f.geometry.positions
        })
    };
    assert_eq!(run(1), run(4));
}
