//! What a study run leaves in the hair besides its distance from the reference: how deep its
//! crossing sections overlap ([`crossing_overlap`]) and how thick its layer stands over the
//! scalp ([`layer_thickness`]).

use anyhow::{Context, Result};
use hair::grid::{Grid, GridError, PairSet, Section};
use hair::ssv::{Point, Real, Ssv};
use hair::{Scene, Simulation};
use rayon::prelude::*;

/// Frames from one sample of overlap and thickness to the next (the last frame of every such
/// run of frames is sampled). On `wardlin` (a dev build, two cores) a sample of overlap costs
/// about 50 ms and one of thickness about 90 ms per thousand strands, where a frame costs 20 to
/// 180 ms: every fourth frame with a thousand strands made the study 34% longer (145 s against
/// 108 s), every sixth with [`THICKNESS_STRANDS`] keeps it near a fifth longer.
pub const SAMPLE_EVERY: u32 = 6;

/// Rendered strands at most whose control vertices a thickness sample reads: every `k`th
/// strand, `k` the fewest that keeps to this many, since each vertex costs an exact distance
/// query. A bin's thickness is its farthest vertex, which a subset may miss: on `wardlin` the
/// reference's layer measured 21.2 mm on all 9,350 strands and 18.9 mm on 1,024 of them; the
/// rows are compared on the same subset.
pub const THICKNESS_STRANDS: usize = 512;

/// Equal-area bands of the direction's height (`+y` up, the scenes' convention) by which
/// [`layer_thickness`] bins the hair.
pub const THICKNESS_BANDS: usize = 8;

/// Sectors of azimuth about `+y` of each band.
pub const THICKNESS_SECTORS: usize = 16;

/// The crossing pairs of one sample that overlap.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overlap {
    /// Pairs whose swept spheres overlap (depth above zero).
    pub pairs: u64,
    /// Their depths summed (m).
    pub depth_sum: f64,
}

impl Overlap {
    /// Mean depth over the overlapping pairs (m; 0 when none overlaps).
    pub fn mean_depth(&self) -> f64 {
        if self.pairs > 0 {
            self.depth_sum / self.pairs as f64
        } else {
            0.0
        }
    }
}

/// Whether two segments are near-parallel by the hair-hair response's test (`|cos|` of the
/// angle between them at least `cos_parallel`; a point has no direction and is not parallel).
fn parallel(a: &Ssv, b: &Ssv, cos_parallel: Real) -> bool {
    match (a, b) {
        (Ssv::Line(a), Ssv::Line(b)) => {
            match (
                (a.b - a.a).try_normalize(0.0),
                (b.b - b.a).try_normalize(0.0),
            ) {
                (Some(u), Some(v)) => u.dot(&v).abs() >= cos_parallel,
                _ => false,
            }
        }
        _ => false,
    }
}

/// The overlap of `sections`' crossing pairs: the grid's pair search with its exact SSV test
/// finds every pair of sections within the sum of their radii (same-skeleton neighbours,
/// which share a node, skipped), the exact contact of hair-ssv ([`Ssv::contact`]) gives each
/// pair's depth (the sum of the radii less the distance of the cores), and the near-parallel
/// pairs are left out: the exact model does not push those apart (they share their velocity),
/// since hair lying side by side within the radii is how a fine skeleton's group packs, not
/// hair passing through hair. The pairs are summed in the pair set's order, so the result does
/// not depend on the thread count.
pub fn crossing_overlap(
    sections: &[Section],
    cos_parallel: Real,
    grid: &mut Grid,
    pairs: &mut PairSet,
) -> Result<Overlap, GridError> {
    grid.rebuild(sections)?;
    grid.overlapping_pairs(pairs);
    let chunks: Vec<Overlap> = (0..pairs.chunk_count())
        .into_par_iter()
        .map(|chunk| {
            let mut o = Overlap::default();
            for &[a, b] in pairs.chunk(chunk) {
                let (a, b) = (&sections[a as usize].shape, &sections[b as usize].shape);
                if parallel(a, b, cos_parallel) {
                    continue;
                }
                if let Some(c) = a.contact(b).filter(|c| c.depth > 0.0) {
                    o.pairs += 1;
                    o.depth_sum += f64::from(c.depth);
                }
            }
            o
        })
        .collect();
    Ok(chunks.iter().fold(Overlap::default(), |s, c| Overlap {
        pairs: s.pairs + c.pairs,
        depth_sum: s.depth_sum + c.depth_sum,
    }))
}

/// The bin of the direction from `centre` to `p`: equal-area bands of its height `y`, sectors
/// of its azimuth; `None` at the centre.
fn direction_bin(p: &Point, centre: &Point) -> Option<usize> {
    let d = (p - centre).try_normalize(0.0)?;
    let band = (((d.y + 1.0) * 0.5 * THICKNESS_BANDS as Real) as usize).min(THICKNESS_BANDS - 1);
    let turn = (d.z.atan2(d.x) / std::f32::consts::TAU).rem_euclid(1.0);
    let sector = ((turn * THICKNESS_SECTORS as Real) as usize).min(THICKNESS_SECTORS - 1);
    Some(band * THICKNESS_SECTORS + sector)
}

/// The hair layer's mean thickness over the body (m): every point binned by its direction from
/// `centre` (a point inside the head, [`THICKNESS_BANDS`] equal-area bands of height by
/// [`THICKNESS_SECTORS`] sectors of azimuth), each bin's thickness the largest signed distance
/// `distance` gives of its points from the body's surface (how far out the layer reaches
/// there), and the mean over the bins that hold hair. A layer that collapses onto the head or
/// puffs up shows as a change of it. `None` when no point has a distance (or a direction).
pub fn layer_thickness(
    points: &[Point],
    centre: &Point,
    distance: impl Fn(&Point) -> Option<Real> + Sync,
) -> Option<f64> {
    let distances: Vec<Option<Real>> = points.par_iter().map(&distance).collect();
    let mut reach = [Real::NEG_INFINITY; THICKNESS_BANDS * THICKNESS_SECTORS];
    for (p, d) in points.iter().zip(distances) {
        if let (Some(bin), Some(d)) = (direction_bin(p, centre), d.filter(|d| d.is_finite())) {
            reach[bin] = reach[bin].max(d);
        }
    }
    let held: Vec<f64> = reach
        .iter()
        .filter(|r| r.is_finite())
        .map(|&r| f64::from(r))
        .collect();
    (!held.is_empty()).then(|| held.iter().sum::<f64>() / held.len() as f64)
}

/// The sections whose overlap a run's samples measure, and the buffers of the measure: the
/// hair-hair radii capped where the groom packs crossing hair closer than them, as the exact
/// model caps them whatever model the run uses, so that every row is measured alike.
pub(super) struct Sampler {
    sections: hair::collide::Sections,
    grid: hair::grid::Grid,
    pairs: hair::grid::PairSet,
    cos_parallel: f32,
    /// The centre of the hair's roots (head frame): the origin of the thickness's directions.
    centre: hair::ssv::Point,
    points: Vec<hair::ssv::Point>,
    pub(super) overlap: Overlap,
    pub(super) thickness_sum: f64,
    pub(super) samples: u32,
    /// Milliseconds spent capping the radii, measuring overlap and measuring thickness.
    pub(super) ms: [f64; 3],
}

impl Sampler {
    pub(super) fn new(scene: &Scene, sim: &Simulation) -> Result<Self> {
        let settings = hair::collide::CollisionSettings {
            hair_hair: hair::collide::HairHairModel::Pairs,
            ..scene.collision.clone()
        };
        let loads = scene.groom_is_its_rest().then_some((
            hair::ssv::Vector::from(scene.dynamics.gravity),
            scene.dynamics.torque,
        ));
        let clock = std::time::Instant::now();
        // The simulation made this state its rest already: again, the groom moves no further
        // and only the caps are kept.
        let mut groom = sim.state().clone();
        let (sections, _, _) = hair::collide::make_groom_rest(
            &mut groom,
            sim.body(),
            sim.front_nodes(),
            &settings,
            loads,
        )
        .context("capping the study's hair-hair radii")?;
        let g = sim.render_geometry();
        let to_head = sim.head_pose().inverse();
        let (mut lo, mut hi) = (
            hair::ssv::Vector::repeat(f32::INFINITY),
            hair::ssv::Vector::repeat(f32::NEG_INFINITY),
        );
        for s in 0..g.strand_count() {
            if let Some(root) = g.strand(s).first() {
                let r = (to_head * root).coords;
                lo = lo.inf(&r);
                hi = hi.sup(&r);
            }
        }
        let centre = hair::ssv::Point::from(if lo.x <= hi.x {
            (lo + hi) * 0.5
        } else {
            hair::ssv::Vector::zeros()
        });
        Ok(Self {
            sections,
            grid: hair::grid::Grid::new(hair::grid::GridConfig::default()),
            pairs: hair::grid::PairSet::default(),
            cos_parallel: settings.parallel_angle.cos(),
            centre,
            points: Vec::new(),
            overlap: Overlap::default(),
            thickness_sum: 0.0,
            samples: 0,
            ms: [clock.elapsed().as_secs_f64() * 1e3, 0.0, 0.0],
        })
    }

    /// One sample of the simulation as it stands.
    pub(super) fn sample(&mut self, sim: &Simulation) -> Result<()> {
        let clock = std::time::Instant::now();
        self.sections.build(sim.state(), sim.front_nodes());
        let o = crossing_overlap(
            &self.sections.sections,
            self.cos_parallel,
            &mut self.grid,
            &mut self.pairs,
        )
        .context("the study's overlap sample")?;
        self.overlap.pairs += o.pairs;
        self.overlap.depth_sum += o.depth_sum;
        self.ms[1] += clock.elapsed().as_secs_f64() * 1e3;
        let clock = std::time::Instant::now();
        if let Some(body) = sim.body() {
            let to_head = sim.head_pose().inverse();
            let g = sim.render_geometry();
            let (n, sub) = (g.strand_count(), g.subdivisions.max(1));
            self.points.clear();
            for s in (0..n).step_by(n.div_ceil(THICKNESS_STRANDS).max(1)) {
                let control = g.strand(s).iter().step_by(sub);
                self.points.extend(control.map(|p| to_head * p));
            }
            let thickness = layer_thickness(&self.points, &self.centre, |p| {
                body.signed_distance(p).map(|(d, _, _)| d)
            });
            self.thickness_sum += thickness.unwrap_or(0.0);
        }
        self.ms[2] += clock.elapsed().as_secs_f64() * 1e3;
        self.samples += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hair::grid::GridConfig;
    use hair::ssv::{Lss, Vector};

    fn section(skeleton: u32, a: [Real; 3], b: [Real; 3], radius: Real) -> Section {
        Section {
            skeleton,
            segment: 0,
            shape: Ssv::Line(Lss::new(Point::from(a), Point::from(b), radius)),
        }
    }

    fn overlap(sections: &[Section]) -> Overlap {
        let mut grid = Grid::new(GridConfig::default());
        crossing_overlap(sections, 0.3f32.cos(), &mut grid, &mut PairSet::default()).unwrap()
    }

    /// Two crossing segments of radii 1 mm and 0.6 mm whose cores pass 1.2 mm apart overlap by
    /// 1.6 - 1.2 = 0.4 mm; moved 2 mm apart they do not overlap at all.
    #[test]
    fn crossing_segments_overlap_by_their_radii_less_their_distance() {
        let crossing = |gap: Real| {
            [
                section(0, [-0.01, 0.0, 0.0], [0.01, 0.0, 0.0], 0.001),
                section(1, [0.002, -0.01, gap], [0.002, 0.01, gap], 0.0006),
            ]
        };
        let o = overlap(&crossing(0.0012));
        assert_eq!(o.pairs, 1);
        assert!((o.mean_depth() - 0.0004).abs() < 1e-7, "{}", o.mean_depth());
        let apart = overlap(&crossing(0.002));
        assert_eq!((apart.pairs, apart.mean_depth()), (0, 0.0));
    }

    /// Three crossing pairs of known depths give their mean; a near-parallel pair, however deep,
    /// and two neighbouring segments of one skeleton are not counted.
    #[test]
    fn the_mean_is_over_the_overlapping_crossing_pairs_only() {
        let mut sections = Vec::new();
        for (k, depth) in [0.0001, 0.0002, 0.0006].into_iter().enumerate() {
            let x = 0.1 * k as Real;
            let gap = 0.002 - depth;
            sections.push(section(
                2 * k as u32,
                [x - 0.01, 0.0, 0.0],
                [x + 0.01, 0.0, 0.0],
                0.001,
            ));
            sections.push(section(
                2 * k as u32 + 1,
                [x, -0.01, gap],
                [x, 0.01, gap],
                0.001,
            ));
        }
        // Parallel, 1.5 mm deep: hair lying side by side.
        sections.push(section(10, [1.0, 0.0, 0.0], [1.0, 0.02, 0.0], 0.001));
        sections.push(section(11, [1.0005, 0.0, 0.0], [1.0005, 0.02, 0.0], 0.001));
        // Two segments of one skeleton meeting at a node.
        sections.push(Section {
            segment: 1,
            ..section(12, [2.0, 0.0, 0.0], [2.0, 0.02, 0.0], 0.001)
        });
        sections.push(Section {
            segment: 2,
            ..section(12, [2.0, 0.02, 0.0], [2.02, 0.02, 0.0], 0.001)
        });
        let o = overlap(&sections);
        assert_eq!(o.pairs, 3);
        assert!((o.mean_depth() - 0.0003).abs() < 1e-7, "{}", o.mean_depth());
    }

    /// Points on a shell `t` outside a sphere, with others nearer the surface in the same
    /// directions, give the thickness `t`; half the directions at `t` and half at `3t` give
    /// `2t` when the bins hold as many of each, whatever bins the other half of the sphere
    /// leaves empty.
    #[test]
    fn a_shell_over_a_sphere_is_as_thick_as_it_stands_out() {
        let (centre, radius) = (Point::new(0.01, 0.02, -0.03), 0.1);
        let sphere = |p: &Point| Some((p - centre).norm() - radius);
        // One direction through the middle of every bin.
        let directions: Vec<Vector> = (0..THICKNESS_BANDS)
            .flat_map(|band| {
                (0..THICKNESS_SECTORS).map(move |sector| {
                    let y = ((band as Real + 0.5) / THICKNESS_BANDS as Real) * 2.0 - 1.0;
                    let a =
                        (sector as Real + 0.5) / THICKNESS_SECTORS as Real * std::f32::consts::TAU;
                    let s = (1.0 - y * y).sqrt();
                    Vector::new(s * a.cos(), y, s * a.sin())
                })
            })
            .collect();
        let t = 0.02;
        let at = |d: &Vector, out: Real| centre + d * (radius + out);
        let shell: Vec<Point> = directions
            .iter()
            .flat_map(|d| [at(d, t), at(d, 0.3 * t), at(d, -0.001)])
            .collect();
        let thick = layer_thickness(&shell, &centre, sphere).unwrap();
        assert!((thick - f64::from(t)).abs() < 1e-6, "{thick}");
        // The upper half only, at t in one half of its sectors and 3t in the other.
        let cap: Vec<Point> = directions
            .iter()
            .enumerate()
            .filter(|(_, d)| d.y > 0.0)
            .map(|(k, d)| at(d, if k % 2 == 0 { t } else { 3.0 * t }))
            .collect();
        let thick = layer_thickness(&cap, &centre, sphere).unwrap();
        assert!((thick - f64::from(2.0 * t)).abs() < 1e-6, "{thick}");
        assert_eq!(layer_thickness(&[], &centre, sphere), None);
    }
}
