//! `hair run --usd FILE.usda --positions FILE.npy`: the drawn strands of every frame, streamed to
//! an animated USD stage (with the body) and to a NumPy file of the same points, through
//! `hair-io`'s writers. A frame is written as it is simulated; nothing holds every frame.
//!
//! Time codes: the state after frame `k` (counting from 0, as `metrics.json` does) is time code
//! `k + 1`, at `timeCodesPerSecond` = the scene's frame rate, so a time code over the frame rate
//! is the simulated time in seconds.

use anyhow::{Context, Result, bail};
use hair::Simulation;
use hair::io::npy::NpyPointsWriter;
use hair::io::usda::{BodyPose, UpAxis, UsdStage, UsdaWriter};
use hair::io::{Existing, Mesh};
use hair::scene::HeadMotionSpec;
use std::path::{Path, PathBuf};

/// Where the export goes.
#[derive(Clone, Debug)]
pub struct Paths {
    /// The `.usda` stage, if asked for.
    pub usd: Option<PathBuf>,
    /// The `.npy` positions.
    pub positions: PathBuf,
    /// Whether an existing file may be replaced.
    pub existing: Existing,
}

impl Paths {
    /// The files `--usd` and `--positions` ask for: the positions beside the stage with its
    /// stem when only `--usd` is given; `None` when neither is.
    pub fn new(usd: Option<&Path>, positions: Option<&Path>, replace: bool) -> Option<Self> {
        let positions = match (usd, positions) {
            (_, Some(p)) => p.to_path_buf(),
            (Some(u), None) => u.with_extension("npy"),
            (None, None) => return None,
        };
        Some(Self {
            usd: usd.map(Path::to_path_buf),
            positions,
            existing: if replace {
                Existing::Replace
            } else {
                Existing::Keep
            },
        })
    }

    /// Refuses, before any simulation, a file that exists when it may not be replaced or two
    /// outputs that are the same file; creates the files' directories (as `--out` does).
    pub fn prepare(&self) -> Result<()> {
        if let Some(usd) = &self.usd {
            let ext = usd.extension().and_then(|e| e.to_str()).unwrap_or("");
            if !["usda", "usd"].contains(&ext.to_ascii_lowercase().as_str()) {
                bail!(
                    "--usd {}: the stage is written as text, so its name ends in .usda (or .usd)",
                    usd.display()
                );
            }
        }
        if self.usd.as_deref() == Some(self.positions.as_path()) {
            bail!(
                "--usd and --positions are the same file ({})",
                self.positions.display()
            );
        }
        for path in self.usd.iter().chain([&self.positions]) {
            if self.existing == Existing::Keep && path.exists() {
                bail!(
                    "{} exists; it is kept (give --replace to write over it)",
                    path.display()
                );
            }
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating {}", dir.display()))?;
            }
        }
        Ok(())
    }
}

/// The open writers, created from the first frame's strands.
pub struct Export {
    usd: Option<UsdaWriter>,
    npy: NpyPointsWriter,
    /// The first frame's curve offsets: every frame must draw the same curves.
    offsets: Vec<u32>,
    /// Whether the body moves (its pose is written with every frame).
    posed: bool,
}

impl Export {
    /// Opens the writers for the curves `sim` draws now, with its body and the scene's frame
    /// rate.
    pub fn create(paths: &Paths, sim: &Simulation) -> Result<Self> {
        let geometry = sim.render_geometry();
        let counts: Vec<u32> = geometry.offsets.windows(2).map(|w| w[1] - w[0]).collect();
        let scene = sim.scene();
        let usd = match &paths.usd {
            Some(path) => {
                let stage = UsdStage {
                    up_axis: UpAxis::Y,
                    meters_per_unit: 1.0,
                    time_codes_per_second: f64::from(scene.frame_rate),
                };
                let body = sim.body().map(|b| Mesh {
                    vertices: b.vertices.iter().map(|p| [p.x, p.y, p.z]).collect(),
                    triangles: b.triangles.clone(),
                });
                let width = 2.0 * scene.drawn_strand_radius();
                Some(UsdaWriter::create(
                    path,
                    &stage,
                    body.as_ref(),
                    &counts,
                    &[width],
                    paths.existing,
                )?)
            }
            None => None,
        };
        let npy = NpyPointsWriter::create(&paths.positions, &counts, paths.existing)?;
        Ok(Self {
            usd,
            npy,
            offsets: geometry.offsets.clone(),
            posed: sim.body().is_some() && !matches!(scene.head_motion, HeadMotionSpec::Still),
        })
    }

    /// Appends the strands `sim` draws after frame `frame` (time code `frame + 1`).
    pub fn write(&mut self, frame: u32, sim: &Simulation) -> Result<()> {
        let geometry = sim.render_geometry();
        if geometry.offsets != self.offsets {
            bail!(
                "frame {frame}: the drawn strands changed ({} strands of {} points, were {} of \
                 {}): the export holds the same curves in every frame",
                geometry.strand_count(),
                geometry.vertex_count(),
                self.offsets.len().saturating_sub(1),
                self.offsets.last().copied().unwrap_or(0)
            );
        }
        let points = || geometry.positions.iter().map(|p| [p.x, p.y, p.z]);
        let time_code = f64::from(frame) + 1.0;
        if let Some(usd) = &mut self.usd {
            if self.posed {
                usd.write_frame_posed(time_code, points(), &body_pose(sim))?;
            } else {
                usd.write_frame(time_code, points())?;
            }
        }
        self.npy.write_frame(points())?;
        Ok(())
    }

    /// Completes the files and moves them into place; returns the frames written.
    pub fn finish(self) -> Result<usize> {
        let frames = self.npy.frames();
        if let Some(usd) = self.usd {
            usd.finish()?;
        }
        self.npy.finish()?;
        Ok(frames)
    }
}

/// The body's pose now: the head track's pose, then the simulation's teleport offset.
fn body_pose(sim: &Simulation) -> BodyPose {
    let head = sim.head_track().motion();
    let teleport = sim.teleport_offset();
    let rotation = teleport.rotation.to_rotation_matrix() * head.rotation;
    let translation = teleport * head.position;
    let m = rotation.matrix();
    BodyPose {
        rotation: [0, 1, 2].map(|r| [m[(r, 0)], m[(r, 1)], m[(r, 2)]]),
        translation: [translation.x, translation.y, translation.z],
    }
}
