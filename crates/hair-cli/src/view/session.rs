//! A recorded styling session: the simulation, the live gestures stamped into its tool script
//! and camera path, and the counters the HUD and the metrics show. Headless: the window only
//! feeds it gestures and camera moves and draws what it holds.
//!
//! Why the recording replays exactly: the simulation advances in whole frames of fixed steps,
//! and every gesture waiting when a step starts is stamped with a time mid-way through that step
//! ([`Simulation::next_event_time`]), the same time the salon compares when `hair run` plays the
//! recorded scene, so each event acts at the same step. Camera moves become keyframes the same
//! way (the held view at the step's start, the new one mid-step), so the adaptive LOD sees the
//! same views too.

use super::input::Gesture;
use anyhow::{Context, Result};
use hair::scene::CameraKey;
use hair::ssv::{Point, Real};
use hair::{LoadedScene, LodPolicy, Scene, Simulation, StepStats, Tool, ToolAction};
use serde::Serialize;
use std::path::Path;

/// Mean milliseconds per simulated frame in each stage.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StageMs {
    /// Drivers.
    pub drivers: f64,
    /// LOD selection and transitions.
    pub lod: f64,
    /// Grid build.
    pub grid: f64,
    /// Hair-hair collision.
    pub hair_hair: f64,
    /// Integration and the salon stage.
    pub dynamics: f64,
    /// The salon tools (part of `dynamics`).
    pub salon: f64,
    /// Hair-object collision.
    pub hair_object: f64,
    /// Render geometry.
    pub render_geometry: f64,
    /// The whole step.
    pub total: f64,
}

impl StageMs {
    fn add(&mut self, s: &StepStats) {
        self.drivers += s.ms_drivers;
        self.lod += s.ms_lod;
        self.grid += s.ms_grid;
        self.hair_hair += s.ms_hair_hair;
        self.dynamics += s.ms_dynamics;
        self.salon += s.salon.ms_salon;
        self.hair_object += s.ms_hair_object;
        self.render_geometry += s.ms_render_geometry;
        self.total += s.ms_total;
    }

    fn scaled(&self, k: f64) -> Self {
        Self {
            drivers: self.drivers * k,
            lod: self.lod * k,
            grid: self.grid * k,
            hair_hair: self.hair_hair * k,
            dynamics: self.dynamics * k,
            salon: self.salon * k,
            hair_object: self.hair_object * k,
            render_geometry: self.render_geometry * k,
            total: self.total * k,
        }
    }
}

/// A styling session over a scene.
pub struct Session {
    /// The scene as loaded, with its own tool events removed: the session's are recorded.
    loaded: LoadedScene,
    policy: LodPolicy,
    sim: Simulation,
    /// Gestures waiting for the next step.
    pending: Vec<Gesture>,
    /// A camera view waiting for the next step, and the one the simulation holds.
    pending_view: Option<(Point, Point)>,
    held_view: (Point, Point),
    frames: u32,
    stage_sum: StageMs,
    last: StepStats,
    /// Whether every new simulation (a reset, a replay) fills its body's distance field ahead.
    prefill: bool,
}

impl Session {
    /// A session over a loaded scene: its scripted events are dropped (the session records its
    /// own), its settings kept, and its camera path becomes the view's camera, starting where
    /// the path starts.
    pub fn new(mut loaded: LoadedScene, policy: LodPolicy) -> Result<Self> {
        loaded.scene.tools.events.clear();
        // The view's camera replaces the scene's path: it starts where the path starts.
        let held_view = hair::drivers::camera(&loaded.scene.camera, 0.0);
        loaded.scene.camera.keys = vec![CameraKey {
            time: 0.0,
            eye: held_view.0.coords.into(),
            target: held_view.1.coords.into(),
        }];
        let sim = Simulation::new(&loaded, policy)?;
        Ok(Self {
            loaded,
            policy,
            sim,
            pending: Vec::new(),
            pending_view: None,
            held_view,
            frames: 0,
            stage_sum: StageMs::default(),
            last: StepStats::default(),
            prefill: false,
        })
    }

    /// Fills the body's distance field ahead (`Simulation::prefill_body_field`), now and after
    /// every reset: the first frames then run at the pace of the later ones. Returns the
    /// samples computed now.
    pub fn prefill_body_field(&mut self) -> usize {
        self.prefill = true;
        self.sim.prefill_body_field()
    }

    /// The simulation.
    pub fn sim(&self) -> &Simulation {
        &self.sim
    }

    /// The LOD policy.
    pub fn policy(&self) -> LodPolicy {
        self.policy
    }

    /// Frames simulated so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Stats of the last step.
    pub fn last_step(&self) -> &StepStats {
        &self.last
    }

    /// Mean milliseconds per frame of each stage so far.
    pub fn mean_stage_ms(&self) -> StageMs {
        self.stage_sum.scaled(1.0 / f64::from(self.frames.max(1)))
    }

    /// Tool events recorded so far.
    pub fn event_count(&self) -> usize {
        self.sim.scene().tools.events.len()
    }

    /// Queues a gesture for the next step; consecutive moves of one tool keep only the last
    /// (the salon acts once a step, so the latest pose is the one that counts).
    pub fn queue(&mut self, g: Gesture) {
        if g.action == ToolAction::Move
            && let Some(last) = self.pending.last_mut()
            && last.action == ToolAction::Move
            && last.tool == g.tool
        {
            *last = g;
            return;
        }
        self.pending.push(g);
    }

    /// Queues the camera's view (eye, target) for the next step's LOD selection.
    pub fn queue_view(&mut self, eye: Point, target: Point) {
        if (eye, target) != self.held_view {
            self.pending_view = Some((eye, target));
        } else {
            self.pending_view = None;
        }
    }

    /// Stamps the waiting gestures and view at the next step and pushes them into the
    /// simulation.
    fn flush(&mut self) -> Result<()> {
        let time = self.sim.next_event_time();
        for g in self.pending.drain(..) {
            self.sim
                .push_tool_event(g.event(time))
                .with_context(|| format!("{} {:?}", g.tool.name(), g.action))?;
        }
        if let Some((eye, target)) = self.pending_view.take() {
            let key = |time: Real, (e, t): (Point, Point)| CameraKey {
                time,
                eye: e.coords.into(),
                target: t.coords.into(),
            };
            self.sim
                .push_camera_key(key(self.sim.time(), self.held_view))?;
            self.sim.push_camera_key(key(time, (eye, target)))?;
            self.held_view = (eye, target);
        }
        Ok(())
    }

    /// Simulates one frame (the scene's `substeps` fixed steps); waiting gestures act from its
    /// first step.
    pub fn step_frame(&mut self) -> Result<()> {
        for _ in 0..self.loaded.scene.substeps {
            self.flush()?;
            let s = self.sim.step()?;
            self.stage_sum.add(&s);
            self.last = s;
        }
        self.frames += 1;
        Ok(())
    }

    /// The tool pressed at the end of the recorded script, if any.
    fn pressed_at_end(&self) -> Option<Tool> {
        let mut pressed = None;
        for e in &self.sim.scene().tools.events {
            match e.action {
                ToolAction::Press => pressed = Some(e.tool),
                ToolAction::Release if pressed == Some(e.tool) => pressed = None,
                _ => {}
            }
        }
        pressed
    }

    /// The recorded session as a scene: the loaded scene with the recorded events as its tool
    /// script, the camera path the LOD saw, the frames simulated and the LOD policy used, so
    /// `hair run` replays it to the same state.
    pub fn recorded_scene(&self) -> Scene {
        let mut scene = self.sim.scene().clone();
        scene.frames = self.frames;
        scene.lod = self.policy;
        scene.name = format!("{} (recorded)", self.loaded.scene.name);
        absolute_paths(&mut scene, &self.loaded.base_dir);
        scene
    }

    /// Writes [`Session::recorded_scene`] as RON.
    pub fn write_recording(&self, path: &Path) -> Result<()> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        let text = format!(
            "// Recorded by `hair view` from {}: `hair run {}` replays it.\n{}\n",
            self.loaded.source,
            path.display(),
            self.recorded_scene().to_ron()
        );
        hair::io::write_whole(path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))
    }

    /// Undoes the last stroke (its press, moves and release): the session restarts without
    /// it and replays the rest to the frame it had reached. Refused while a tool is held.
    /// Returns whether there was a stroke to undo.
    pub fn undo_last_stroke(&mut self) -> Result<bool> {
        if self.pressed_at_end().is_some() || !self.pending.is_empty() {
            return Ok(false);
        }
        let mut scene = self.sim.scene().clone();
        let Some(last_press) = scene
            .tools
            .events
            .iter()
            .rposition(|e| e.action == ToolAction::Press)
        else {
            return Ok(false);
        };
        let tool = scene.tools.events[last_press].tool;
        // The stroke: the press and every later event of its tool (no other tool is held).
        let mut index = 0;
        scene.tools.events.retain(|e| {
            let keep = index < last_press || e.tool != tool;
            index += 1;
            keep
        });
        self.replay(scene, self.frames)?;
        Ok(true)
    }

    /// Back to the start with nothing recorded.
    pub fn reset(&mut self) -> Result<()> {
        self.replay(self.loaded.scene.clone(), 0)?;
        self.held_view = hair::drivers::camera(&self.loaded.scene.camera, 0.0);
        Ok(())
    }

    /// Restarts on `scene` (its tool script and camera path) and simulates `frames` frames.
    fn replay(&mut self, scene: Scene, frames: u32) -> Result<()> {
        let loaded = LoadedScene {
            scene,
            ..self.loaded.clone()
        };
        self.sim = Simulation::new(&loaded, self.policy)?;
        if self.prefill {
            self.sim.prefill_body_field();
        }
        self.pending.clear();
        self.pending_view = None;
        self.frames = 0;
        self.stage_sum = StageMs::default();
        self.last = StepStats::default();
        for _ in 0..frames {
            self.step_frame()?;
        }
        Ok(())
    }
}

/// Makes the scene's file paths absolute against `base`, so the recording can be written
/// anywhere.
fn absolute_paths(scene: &mut Scene, base: &Path) {
    let fix = |p: &mut String| {
        let path = Path::new(p.as_str());
        if path.is_relative() {
            *p = base.join(path).display().to_string();
        }
    };
    if let hair::scene::BodySpec::Obj { path, .. } = &mut scene.body {
        fix(path);
    }
    if let hair::scene::HairstyleSpec::File { path, .. } = &mut scene.hairstyle {
        fix(path);
    }
}

#[cfg(test)]
mod tests {
    use super::super::input::{Gesture, ToolSettings};
    use super::*;
    use hair::Pose;

    fn small_salon() -> LoadedScene {
        let mut loaded = Scene::load("salon").expect("built-in salon");
        if let hair::scene::HairstyleSpec::Procedural(p) = &mut loaded.scene.hairstyle {
            p.strands = 120;
        }
        loaded.scene.body = hair::scene::BodySpec::Head { resolution: 24 };
        loaded
    }

    fn gesture(tool: Tool, action: ToolAction, z: f32) -> Gesture {
        Gesture {
            tool,
            action,
            pose: Pose {
                position: [0.0, 0.0, z],
                direction: [0.0, 0.0, 1.0],
                up: [0.0, 1.0, 0.0],
            },
            settings: ToolSettings::default_for(tool),
        }
    }

    #[test]
    fn a_recorded_session_replays_to_the_same_state_hash() {
        let mut s = Session::new(small_salon(), LodPolicy::Fine).unwrap();
        s.step_frame().unwrap();
        s.queue(gesture(Tool::Water, ToolAction::Press, -0.35));
        s.step_frame().unwrap();
        s.step_frame().unwrap();
        s.queue(gesture(Tool::Water, ToolAction::Move, -0.34));
        s.queue(gesture(Tool::Water, ToolAction::Move, -0.33));
        s.queue_view(Point::new(0.3, 0.2, -0.8), Point::origin());
        s.step_frame().unwrap();
        s.queue(gesture(Tool::Water, ToolAction::Release, -0.33));
        s.queue(gesture(Tool::Scissors, ToolAction::Press, -0.3));
        s.step_frame().unwrap();
        s.queue(gesture(Tool::Scissors, ToolAction::Release, -0.3));
        for _ in 0..3 {
            s.step_frame().unwrap();
        }
        // Two moves in one frame coalesce.
        assert_eq!(s.event_count(), 5);
        assert!(s.last_step().salon.water_kg > 0.0, "water reached the hair");
        let hash = s.sim().state_hash();

        // Through RON and the loader `hair run` uses.
        let dir = std::env::temp_dir().join(format!("hair-view-session-{}", std::process::id()));
        let path = dir.join("session.ron");
        s.write_recording(&path).unwrap();
        let loaded = Scene::load(path.to_str().unwrap()).unwrap();
        assert_eq!(loaded.scene.frames, 8);
        assert_eq!(loaded.scene.tools.events, s.sim().scene().tools.events);
        let mut replay = Simulation::new(&loaded, loaded.scene.lod).unwrap();
        for _ in 0..loaded.scene.frames * loaded.scene.substeps {
            replay.step().unwrap();
        }
        assert_eq!(
            format!("{:016x}", replay.state_hash()),
            format!("{hash:016x}")
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn undo_replays_without_the_last_stroke() {
        let mut s = Session::new(small_salon(), LodPolicy::Fine).unwrap();
        s.step_frame().unwrap();
        let dry = {
            let mut d = Session::new(small_salon(), LodPolicy::Fine).unwrap();
            for _ in 0..4 {
                d.step_frame().unwrap();
            }
            d.sim().state_hash()
        };
        s.queue(gesture(Tool::Water, ToolAction::Press, -0.35));
        s.step_frame().unwrap();
        // Held: no undo.
        assert!(!s.undo_last_stroke().unwrap());
        s.queue(gesture(Tool::Water, ToolAction::Release, -0.35));
        s.step_frame().unwrap();
        s.step_frame().unwrap();
        assert!(s.undo_last_stroke().unwrap());
        assert_eq!(s.frames(), 4);
        assert_eq!(s.event_count(), 0);
        assert_eq!(s.sim().state_hash(), dry);
        assert!(!s.undo_last_stroke().unwrap());
    }
}
