//! The eframe app of `hair view`: the palette and tool settings on the left, the scene rendered
//! by `hair-render` in the middle with the tool's area drawn over it, the HUD in the corner.
//!
//! Each window frame: read the keys and the mouse, turn them into gestures and camera moves
//! (`input`), let the fixed-step clock run the session's whole frames that are due, render the
//! scene when it changed, and draw. The simulation never depends on the window's frame rate:
//! the clock runs on wall time, and a slow window only means fewer, larger catch-ups (capped).

use super::ExitOptions;
use super::input::{
    Aim, GestureMapper, HeadSphere, OrbitCamera, Outline, PaletteItem, ToolSettings,
    influence_outline, tool_pose,
};
use super::session::{Session, StageMs};
use anyhow::{Context, Result};
use eframe::egui::{self, Color32, Pos2, Rect, Sense, Stroke, Vec2};
use hair::ssv::{Point, Real, Vector};
use hair::{Pose, SalonStats, Tool};
use serde::Serialize;
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

/// Largest rendered image (pixels): llvmpipe keeps a frame interactive at about this size.
const MAX_RENDER: [f32; 2] = [800.0, 600.0];
/// Most simulated frames per window frame, and the time after which no further one starts:
/// past these the simulation falls behind wall time rather than freezing the window.
const MAX_FRAMES_PER_PAINT: u32 = 4;
const SIMULATION_BUDGET: Duration = Duration::from_millis(40);
/// How long the exit waits for the window's screenshot before saving the render alone.
const SCREENSHOT_TIMEOUT: Duration = Duration::from_secs(5);

/// Where the app is in its life.
enum Phase {
    Running,
    /// Asked for the window's screenshot at this time; writing the outputs once it arrives.
    Exiting(Instant),
    Closed,
}

/// Exponential mean of a duration (ms), for the HUD.
#[derive(Default)]
struct Mean {
    value: f64,
    count: u64,
}

impl Mean {
    fn add(&mut self, x: f64) {
        self.count += 1;
        let k = if self.count < 20 {
            1.0 / self.count as f64
        } else {
            0.05
        };
        self.value += (x - self.value) * k;
    }
}

/// The window's state.
pub struct ViewApp {
    session: Session,
    renderer: RenderWorker,
    camera: OrbitCamera,
    head_sphere: HeadSphere,
    palette: PaletteItem,
    settings: [ToolSettings; 6],
    aim: Aim,
    mapper: GestureMapper,
    /// The tool's pose under the cursor (world), if it is over the view.
    pose: Option<Pose>,
    last_ray_pixel: Option<Pos2>,
    paused: bool,
    speed: f32,
    /// Simulated frames due on the wall clock and not yet taken.
    due: f64,
    last_paint: Instant,
    texture: Option<egui::TextureHandle>,
    last_image: Option<hair_render::RgbaImage>,
    rendered: Option<(u32, [u32; 2], OrbitCamera)>,
    render_ms: Mean,
    paint_ms: Mean,
    sim_frame_ms: Mean,
    paints: u64,
    started: Instant,
    opts: ExitOptions,
    phase: Phase,
    screenshot: Arc<Mutex<Option<Arc<egui::ColorImage>>>>,
    layout_printed: bool,
    message: Option<String>,
}

impl ViewApp {
    /// The app over a session, with the scene's first camera key as the starting view.
    pub fn new(session: Session, opts: ExitOptions) -> Self {
        let scene = session.sim().scene();
        let (eye, target) = hair::drivers::camera(&scene.camera, 0.0);
        let camera =
            OrbitCamera::from_eye_target(eye, target, scene.camera.fov_degrees.to_radians());
        let head_sphere = head_sphere(session.sim());
        let renderer = RenderWorker::start();
        eprintln!("hair view: rendering with {}", renderer.describe);
        Self {
            session,
            renderer,
            camera,
            head_sphere,
            palette: PaletteItem::Camera,
            settings: Tool::ALL.map(ToolSettings::default_for),
            aim: Aim::default(),
            mapper: GestureMapper::default(),
            pose: None,
            last_ray_pixel: None,
            paused: false,
            speed: 1.0,
            due: 0.0,
            last_paint: Instant::now(),
            texture: None,
            last_image: None,
            rendered: None,
            render_ms: Mean::default(),
            paint_ms: Mean::default(),
            sim_frame_ms: Mean::default(),
            paints: 0,
            started: Instant::now(),
            opts,
            phase: Phase::Running,
            screenshot: Arc::new(Mutex::new(None)),
            layout_printed: false,
            message: None,
        }
    }

    fn tool_settings(&mut self, tool: Tool) -> &mut ToolSettings {
        let i = Tool::ALL.iter().position(|&t| t == tool).unwrap_or(0);
        &mut self.settings[i]
    }

    fn report<T>(&mut self, what: &str, r: Result<T>) -> Option<T> {
        match r {
            Ok(v) => Some(v),
            Err(e) => {
                let text = format!("{what}: {e:#}");
                eprintln!("hair view: {text}");
                self.message = Some(text);
                None
            }
        }
    }

    /// Keys: palette 1-7, Space pause, Right/period one frame, R reset, Ctrl+Z undo, Q or
    /// Escape quit, [ and ] tool nearer/farther, - and + speed.
    fn keys(&mut self, ctx: &egui::Context) {
        let (events, ctrl) = ctx.input(|i| (i.events.clone(), i.modifiers.command));
        for e in events {
            match e {
                egui::Event::Text(t) => {
                    for c in t.chars() {
                        if let Some(item) = PaletteItem::from_shortcut(c) {
                            self.palette = item;
                        }
                        match c {
                            '[' => self.aim.nudge(-1.0),
                            ']' => self.aim.nudge(1.0),
                            '+' | '=' => self.speed = (self.speed * 2.0).min(8.0),
                            '-' => self.speed = (self.speed * 0.5).max(0.125),
                            _ => {}
                        }
                    }
                }
                egui::Event::Key {
                    key, pressed: true, ..
                } => match key {
                    egui::Key::Space => self.paused = !self.paused,
                    egui::Key::ArrowRight | egui::Key::Period => self.single_step(),
                    egui::Key::R if !ctrl => self.reset(),
                    egui::Key::Z if ctrl => self.undo(),
                    egui::Key::Q | egui::Key::Escape => self.begin_exit(ctx),
                    _ => {}
                },
                _ => {}
            }
        }
    }

    fn single_step(&mut self) {
        self.paused = true;
        let r = self.step_frame();
        self.report("step", r);
    }

    fn reset(&mut self) {
        self.mapper = GestureMapper::default();
        let r = self.session.reset();
        self.report("reset", r);
        self.due = 0.0;
    }

    fn undo(&mut self) {
        let r = self.session.undo_last_stroke();
        if let Some(done) = self.report("undo", r) {
            self.message = Some(if done {
                format!(
                    "undid the last stroke; replayed {} frames",
                    self.session.frames()
                )
            } else {
                "nothing to undo (or a tool is held)".into()
            });
        }
    }

    fn step_frame(&mut self) -> Result<()> {
        let t = Instant::now();
        self.session
            .queue_view(self.camera.eye(), self.camera.target);
        self.session.step_frame()?;
        self.sim_frame_ms.add(t.elapsed().as_secs_f64() * 1e3);
        Ok(())
    }

    /// Runs the frames due on the wall clock, and starts the exit at the frame limit.
    fn advance(&mut self, ctx: &egui::Context, wall: f64) {
        if !matches!(self.phase, Phase::Running) {
            return;
        }
        let limit = self.opts.frames;
        if limit.is_some_and(|n| self.session.frames() >= n) {
            self.begin_exit(ctx);
            return;
        }
        if self.paused {
            self.due = 0.0;
            return;
        }
        let rate = f64::from(self.session.sim().scene().frame_rate);
        self.due += wall * f64::from(self.speed) * rate;
        let started = Instant::now();
        let mut n = 0;
        while self.due >= 1.0
            && n < MAX_FRAMES_PER_PAINT
            && (n == 0 || started.elapsed() < SIMULATION_BUDGET)
            && limit.is_none_or(|l| self.session.frames() < l)
        {
            let r = self.step_frame();
            self.due -= 1.0;
            n += 1;
            if self.report("simulation", r).is_none() {
                self.paused = true;
                break;
            }
        }
        // What the caps leave is dropped: the simulation slows down instead of piling up.
        self.due = self.due.min(1.0);
    }

    fn begin_exit(&mut self, ctx: &egui::Context) {
        if !matches!(self.phase, Phase::Running) {
            return;
        }
        if self.opts.screenshot.is_some() {
            let slot = self.screenshot.clone();
            ctx.request_screenshot(move |image| {
                if let Ok(mut s) = slot.lock() {
                    *s = Some(image);
                }
            });
        }
        self.phase = Phase::Exiting(Instant::now());
    }

    /// Once the screenshot is in (or late), writes the outputs and closes the window.
    fn finish_exit(&mut self, ctx: &egui::Context) {
        let Phase::Exiting(since) = self.phase else {
            return;
        };
        let shot = self.screenshot.lock().ok().and_then(|mut s| s.take());
        let late = since.elapsed() > SCREENSHOT_TIMEOUT;
        if self.opts.screenshot.is_some() && shot.is_none() && !late {
            ctx.request_repaint();
            return;
        }
        let r = self.write_outputs(shot.as_deref());
        if let Err(e) = r {
            eprintln!("hair view: {e:#}");
            super::EXIT_FAILED.store(true, std::sync::atomic::Ordering::SeqCst);
        }
        self.phase = Phase::Closed;
        self.renderer.stop();
        ctx.send_viewport_cmd(egui::ViewportCommand::Close);
    }

    fn write_outputs(&self, shot: Option<&egui::ColorImage>) -> Result<()> {
        if let Some(path) = &self.opts.screenshot {
            let image = match shot {
                Some(s) => {
                    let [w, h] = s.size;
                    let bytes: Vec<u8> = s.pixels.iter().flat_map(|c| c.to_array()).collect();
                    hair_render::RgbaImage::from_raw(w as u32, h as u32, bytes)
                        .context("screenshot size")?
                }
                None => {
                    eprintln!(
                        "hair view: the window's screenshot did not arrive; saving the render alone"
                    );
                    self.last_image
                        .clone()
                        .context("nothing rendered to save")?
                }
            };
            hair_render::save_png(&image, path)?;
            eprintln!("hair view: wrote {}", path.display());
        }
        if let Some(path) = &self.opts.metrics {
            let m = self.metrics();
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            std::fs::write(path, serde_json::to_string_pretty(&m)?)
                .with_context(|| format!("writing {}", path.display()))?;
            eprintln!("hair view: wrote {}", path.display());
        }
        if let Some(path) = &self.opts.record {
            self.session.write_recording(path)?;
            eprintln!("hair view: wrote {}", path.display());
        }
        println!(
            "hair view: {} frames, {} events, state_hash {:016x}",
            self.session.frames(),
            self.session.event_count(),
            self.session.sim().state_hash()
        );
        Ok(())
    }

    fn metrics(&self) -> ViewMetrics {
        let sim = self.session.sim();
        let last = self.session.last_step();
        let wall = self.started.elapsed().as_secs_f64();
        ViewMetrics {
            scene: sim.scene().name.clone(),
            lod: self.session.policy().name().into(),
            renderer: self.renderer.describe.clone(),
            frames: self.session.frames(),
            substeps: sim.scene().substeps,
            sim_time_s: f64::from(sim.time()),
            state_hash: format!("{:016x}", sim.state_hash()),
            events: self.session.event_count(),
            ms_per_frame: self.session.mean_stage_ms().total * f64::from(sim.scene().substeps),
            ms_per_stage: self.session.mean_stage_ms(),
            ms_render: self.render_ms.value,
            window_frames: self.paints,
            window_fps: self.paints as f64 / wall.max(1e-9),
            skeletons: last.skeletons,
            active: last.active,
            dormant: last.dormant,
            lod_counts: lod_counts(sim),
            salon: last.salon,
        }
    }

    /// The left panel: palette, the tool's settings, the clock's controls.
    fn side_panel(&mut self, ui: &mut egui::Ui) {
        let ppp = ui.ctx().pixels_per_point();
        ui.spacing_mut().slider_width = 80.0;
        ui.heading("Tools");
        let mut rects = Vec::new();
        for item in PaletteItem::ALL {
            let text = format!("{}  {}", item.shortcut(), item.label());
            let r = ui.add(
                egui::Button::selectable(self.palette == item, text)
                    .min_size(Vec2::new(170.0, 28.0)),
            );
            // A press counts, not only a click: on a slow frame the press and the release can
            // arrive together.
            let pressed_here = ui.input(|i| {
                i.pointer.any_pressed()
                    && i.pointer.press_origin().is_some_and(|p| r.rect.contains(p))
            });
            if r.clicked() || pressed_here {
                self.palette = item;
            }
            rects.push((item.label(), r.rect));
        }
        if self.opts.print_layout && !self.layout_printed && self.paints >= 2 {
            for (label, r) in &rects {
                print_rect(&format!("palette {}", label.to_lowercase()), r, ppp);
            }
        }
        ui.separator();
        if let Some(tool) = self.palette.tool() {
            ui.label(format!("{} settings", PaletteItem::Tool(tool).label()));
            let s = self.tool_settings(tool);
            let reach_label = if tool == Tool::Scissors {
                "blade (m)"
            } else {
                "reach (m)"
            };
            ui.add(egui::Slider::new(&mut s.reach, 0.02..=0.6).text(reach_label));
            ui.add(egui::Slider::new(&mut s.angle, 0.05..=1.3).text("angle (rad)"));
            if tool != Tool::Scissors && tool != Tool::Grab {
                ui.add(egui::Slider::new(&mut s.strength, 0.0..=4.0).text("strength"));
            }
            ui.add(egui::Slider::new(&mut self.aim.standoff, 0.0..=0.5).text("standoff (m)"));
            if ui.button("Point at the head").clicked() {
                self.aim.yaw = 0.0;
                self.aim.pitch = 0.0;
            }
        } else {
            ui.label("Drag: orbit. Right/middle drag: pan. Wheel: zoom.");
        }
        ui.separator();
        ui.horizontal(|ui| {
            if ui
                .button(if self.paused { "Run" } else { "Pause" })
                .clicked()
            {
                self.paused = !self.paused;
            }
            if ui.button("Step").clicked() {
                self.single_step();
            }
        });
        ui.horizontal(|ui| {
            if ui.button("Reset").clicked() {
                self.reset();
            }
            if ui.button("Undo").clicked() {
                self.undo();
            }
        });
        ui.add(
            egui::Slider::new(&mut self.speed, 0.125..=8.0)
                .logarithmic(true)
                .text("speed"),
        );
        if ui.button("Quit").clicked() {
            self.begin_exit(ui.ctx());
        }
        ui.separator();
        ui.small(
            "Tools: move over the head, press to apply; Shift+move turns the tool, \
             [ ] nearer/farther, right drag orbits, wheel zooms. Space pause, Right arrow step, \
             R reset, Ctrl+Z undo, Q quit.",
        );
        if let Some(m) = &self.message {
            ui.separator();
            ui.colored_label(Color32::from_rgb(230, 190, 90), m);
        }
    }

    /// The view: camera and tool input, the rendered scene, the tool's area, the HUD.
    fn central(&mut self, ui: &mut egui::Ui) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, Sense::click_and_drag());
        let ctx = ui.ctx().clone();
        if self.opts.print_layout && !self.layout_printed && self.paints >= 2 {
            print_rect("view", &rect, ctx.pixels_per_point());
            self.layout_printed = true;
        }
        let (shift, scroll, delta, primary, secondary, middle) = ctx.input(|i| {
            (
                i.modifiers.shift,
                i.smooth_scroll_delta.y,
                i.pointer.delta(),
                i.pointer.primary_down(),
                i.pointer.secondary_down(),
                i.pointer.middle_down(),
            )
        });
        let tool = self.palette.tool();
        let hovered = response.hovered() || response.is_pointer_button_down_on();
        // Camera: orbit with the primary button in camera mode or the secondary in tool mode;
        // pan with the middle button (or the secondary in camera mode); zoom with the wheel
        // (tools: the wheel moves the tool nearer or farther).
        if response.is_pointer_button_down_on() {
            let orbit = if tool.is_none() { primary } else { secondary };
            let pan = middle || (tool.is_none() && secondary);
            if orbit {
                self.camera.orbit(delta.x, delta.y);
            } else if pan {
                self.camera.pan(delta.x, delta.y, rect.height());
            }
        }
        if hovered && scroll != 0.0 {
            if tool.is_some() {
                self.aim.nudge(-scroll / 50.0);
            } else {
                self.camera.zoom(scroll / 50.0);
            }
        }
        // The tool under the cursor; Shift turns it in place.
        let cursor = response
            .hover_pos()
            .or(ctx.pointer_latest_pos().filter(|p| rect.contains(*p)));
        self.pose = None;
        if let (Some(_), Some(mut at)) = (tool, cursor) {
            if shift {
                self.aim.turn(delta.x, delta.y);
                at = self.last_ray_pixel.unwrap_or(at);
            } else {
                self.last_ray_pixel = Some(at);
            }
            let local = at - rect.min;
            let ray = self
                .camera
                .ray(local.x, local.y, rect.width(), rect.height());
            let (_, right, up) = self.camera.basis();
            let sphere = self.head_sphere_now();
            self.pose = Some(tool_pose(&ray, &sphere, &self.aim, &up, &right));
        }
        let down = primary && response.is_pointer_button_down_on() && !shift;
        let held_down = primary && self.mapper.held().is_some();
        let settings = match self.palette.tool() {
            Some(t) => *self.tool_settings(t),
            None => ToolSettings::default_for(Tool::Water),
        };
        let gestures = self
            .mapper
            .update(self.palette, down || held_down, self.pose, settings);
        for g in gestures {
            self.session.queue(g);
        }

        // The scene: a new image is asked for when the last one is in and something changed.
        self.receive_image(&ctx);
        let size = render_size(rect.size());
        let key = (self.session.frames(), size, self.camera);
        if !self.renderer.busy && self.rendered.as_ref() != Some(&key) {
            self.request_render(size);
            self.rendered = Some(key);
        }
        let painter = ui.painter_at(rect);
        painter.rect_filled(rect, 0.0, Color32::from_rgb(82, 92, 107));
        if let Some(tex) = &self.texture {
            painter.image(
                tex.id(),
                rect,
                Rect::from_min_max(Pos2::ZERO, Pos2::new(1.0, 1.0)),
                Color32::WHITE,
            );
        }
        if let (Some(tool), Some(pose)) = (tool, self.pose) {
            let held = self.mapper.held() == Some(tool);
            let settings = *self.tool_settings(tool);
            self.draw_tool(&painter, rect, tool, &pose, &settings, held);
        }
        self.hud(&painter, rect);
    }

    fn head_sphere_now(&self) -> HeadSphere {
        let sim = self.session.sim();
        let head = sim.head_track().motion();
        let t = sim.teleport_offset();
        HeadSphere {
            centre: t * (head.position + head.rotation * self.head_sphere.centre.coords),
            radius: self.head_sphere.radius,
        }
    }

    fn request_render(&mut self, size: [u32; 2]) {
        let mut scene = crate::run::render_scene(self.session.sim());
        scene.camera = self.camera.render_camera();
        let settings = hair_render::RenderSettings {
            width: size[0],
            height: size[1],
            ..hair_render::RenderSettings::default()
        };
        let requests = self.renderer.requests.as_ref();
        if requests.is_some_and(|r| r.send((scene, settings)).is_ok()) {
            self.renderer.busy = true;
        }
    }

    /// Takes the worker's image, if one is done, into the view's texture.
    fn receive_image(&mut self, ctx: &egui::Context) {
        let Ok(done) = self.renderer.images.try_recv() else {
            return;
        };
        self.renderer.busy = false;
        let Some((image, ms)) = self.report("render", done) else {
            return;
        };
        let color = egui::ColorImage::from_rgba_unmultiplied(
            [image.width() as usize, image.height() as usize],
            image.as_raw(),
        );
        match &mut self.texture {
            Some(tex) => tex.set(color, egui::TextureOptions::LINEAR),
            None => {
                self.texture = Some(ctx.load_texture("scene", color, egui::TextureOptions::LINEAR))
            }
        }
        self.last_image = Some(image);
        self.render_ms.add(ms);
    }

    /// The tool's area: a translucent cone (its silhouette: the hull of apex and rim) or the
    /// scissors' triangle, brighter while pressed.
    fn draw_tool(
        &self,
        painter: &egui::Painter,
        rect: Rect,
        tool: Tool,
        pose: &Pose,
        s: &ToolSettings,
        held: bool,
    ) {
        let project = |p: &Point| {
            self.camera
                .project(p, rect.width(), rect.height())
                .map(|[x, y]| rect.min + Vec2::new(x, y))
        };
        let (r, g, b) = match tool {
            Tool::Water => (70, 150, 255),
            Tool::Spray => (230, 230, 120),
            Tool::Mousse => (240, 240, 240),
            Tool::Dryer => (255, 120, 60),
            Tool::Grab => (120, 230, 120),
            Tool::Scissors => (255, 80, 200),
        };
        let alpha = if held { 110 } else { 60 };
        let fill = Color32::from_rgba_unmultiplied(r, g, b, alpha);
        let line = Stroke::new(1.5, Color32::from_rgb(r, g, b));
        match influence_outline(tool, pose, s, 32) {
            Outline::Cone { apex, rim } => {
                let rim: Vec<Pos2> = rim.iter().filter_map(project).collect();
                let Some(a) = project(&apex) else { return };
                let mut pts = rim.clone();
                pts.push(a);
                let hull = convex_hull(pts);
                painter.add(egui::Shape::convex_polygon(hull, fill, line));
                painter.add(egui::Shape::closed_line(rim, line));
                painter.circle_filled(a, 4.0, Color32::from_rgb(r, g, b));
            }
            Outline::Triangle(t) => {
                let pts: Vec<Pos2> = t.iter().filter_map(project).collect();
                if pts.len() == 3 {
                    painter.add(egui::Shape::convex_polygon(pts, fill, line));
                }
            }
        }
    }

    fn hud(&self, painter: &egui::Painter, rect: Rect) {
        let sim = self.session.sim();
        let last = self.session.last_step();
        let st: StageMs = self.session.mean_stage_ms();
        let lod = lod_counts(sim);
        let salon = &last.salon;
        let fps = if self.paint_ms.value > 0.0 {
            1e3 / self.paint_ms.value
        } else {
            0.0
        };
        let text = format!(
            "{:.0} fps  render {:.1} ms  sim frame {:.1} ms{}\n\
             step ms: grid {:.2}  lod {:.2}  hair-hair {:.2}  dynamics {:.2} (salon {:.2})  body {:.2}  geometry {:.2}\n\
             frame {}  t = {:.2} s  speed x{}{}\n\
             skeletons {}: active {}  dormant {}   LOD strips {}  clusters {}  strand groups {}  hidden trees {}\n\
             water {:.2} g  bonds {}  cuts {}  fallen {}  grabbed {}  events {}",
            fps,
            self.render_ms.value,
            self.sim_frame_ms.value,
            if self.paused { "  PAUSED" } else { "" },
            st.grid,
            st.lod,
            st.hair_hair,
            st.dynamics,
            st.salon,
            st.hair_object,
            st.render_geometry,
            self.session.frames(),
            sim.time(),
            self.speed,
            match self.mapper.held() {
                Some(t) => format!("  [{} pressed]", t.name()),
                None => String::new(),
            },
            last.skeletons,
            last.active,
            last.dormant,
            lod.strips,
            lod.clusters,
            lod.strand_groups,
            last.lod_hidden_trees,
            salon.water_kg * 1e3,
            salon.bonds,
            salon.cuts,
            salon.fallen,
            salon.grabbed,
            self.session.event_count(),
        );
        let font = egui::FontId::monospace(12.0);
        let galley = painter.layout_no_wrap(text, font, Color32::WHITE);
        let at = rect.min + Vec2::new(8.0, 8.0);
        painter.rect_filled(
            Rect::from_min_size(at - Vec2::splat(4.0), galley.size() + Vec2::splat(8.0)),
            4.0,
            Color32::from_black_alpha(150),
        );
        painter.galley(at, galley, Color32::WHITE);
    }
}

impl eframe::App for ViewApp {
    fn raw_input_hook(&mut self, _ctx: &egui::Context, raw: &mut egui::RawInput) {
        // For scripts that drive the window: `HAIR_VIEW_TRACE_INPUT=1` logs every input event.
        if std::env::var_os("HAIR_VIEW_TRACE_INPUT").is_some() {
            for e in &raw.events {
                eprintln!("hair view input: {e:?}");
            }
        }
    }

    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = ui.ctx().clone();
        let now = Instant::now();
        let wall = (now - self.last_paint).as_secs_f64().min(0.25);
        if self.paints > 0 {
            self.paint_ms.add(wall * 1e3);
        }
        self.last_paint = now;
        self.paints += 1;
        if ctx.input(|i| i.viewport().close_requested()) && matches!(self.phase, Phase::Running) {
            // Write the outputs first; the exit closes the window itself.
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.begin_exit(&ctx);
        }
        self.keys(&ctx);
        self.advance(&ctx, wall);
        egui::Panel::left("palette")
            .exact_size(200.0)
            .resizable(false)
            .show(ui, |ui| self.side_panel(ui));
        egui::CentralPanel::default()
            .frame(egui::Frame::NONE)
            .show(ui, |ui| self.central(ui));
        self.finish_exit(&ctx);
        if !matches!(self.phase, Phase::Closed) {
            // About 60 window frames a second at most: the rest of the time is the renderer's.
            ctx.request_repaint_after(Duration::from_millis(15));
        }
    }
}

/// A scene and how to render it.
type RenderRequest = (hair_render::RenderScene, hair_render::RenderSettings);

/// `hair-render` on its own thread: on a software rasteriser an image takes longer than a
/// window frame, and the window must keep taking input meanwhile. One request at a time.
struct RenderWorker {
    /// `None` once stopped.
    requests: Option<mpsc::Sender<RenderRequest>>,
    images: mpsc::Receiver<Result<(hair_render::RgbaImage, f64)>>,
    busy: bool,
    describe: String,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl RenderWorker {
    fn start() -> Self {
        let (requests, inbox) = mpsc::channel::<RenderRequest>();
        let (outbox, images) = mpsc::channel();
        let renderer = hair_render::Renderer::new();
        let describe = renderer.describe();
        let thread = std::thread::spawn(move || {
            while let Ok((scene, settings)) = inbox.recv() {
                let t = Instant::now();
                let image = renderer
                    .render_to_image(&scene, &settings)
                    .context("rendering")
                    .map(|i| (i, t.elapsed().as_secs_f64() * 1e3));
                if outbox.send(image).is_err() {
                    break;
                }
            }
        });
        Self {
            requests: Some(requests),
            images,
            busy: false,
            describe,
            thread: Some(thread),
        }
    }

    /// Takes no more requests and waits for the render in flight, if any, and for the worker's
    /// renderer to be dropped on its thread. A process that ends while a render is still in the
    /// graphics driver can crash in the driver's teardown: one run of the `view_xvfb` test in
    /// about a dozen, on a loaded machine, ended in SIGSEGV after every output was written.
    fn stop(&mut self) {
        self.requests = None;
        if let Some(thread) = self.thread.take() {
            // A worker that panicked has nothing left in the driver either.
            let _ = thread.join();
        }
    }
}

impl Drop for RenderWorker {
    fn drop(&mut self) {
        self.stop();
    }
}

/// What `--metrics` writes when the window closes.
#[derive(Debug, Serialize)]
pub struct ViewMetrics {
    /// Scene name.
    pub scene: String,
    /// LOD policy.
    pub lod: String,
    /// Which renderer drew the scene.
    pub renderer: String,
    /// Frames simulated.
    pub frames: u32,
    /// Steps per frame.
    pub substeps: u32,
    /// Simulated time (s).
    pub sim_time_s: f64,
    /// Hash of the final state's float bits (hex), as `hair run` reports it.
    pub state_hash: String,
    /// Tool events recorded.
    pub events: usize,
    /// Mean milliseconds per simulated frame.
    pub ms_per_frame: f64,
    /// Mean milliseconds per step in each stage.
    pub ms_per_stage: StageMs,
    /// Mean milliseconds per rendered image.
    pub ms_render: f64,
    /// Window frames painted.
    pub window_frames: u64,
    /// Window frames per second over the session.
    pub window_fps: f64,
    /// Skeletons in the LOD front at the end.
    pub skeletons: usize,
    /// Of which integrated in the last step.
    pub active: usize,
    /// Of which frozen by localization in the last step.
    pub dormant: usize,
    /// The front by level.
    pub lod_counts: LodCounts,
    /// Salon counters at the end (water, bonds, cuts, fallen, grabbed).
    pub salon: SalonStats,
}

/// The LOD front by kind of node.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct LodCounts {
    /// Strips.
    pub strips: usize,
    /// Clusters.
    pub clusters: usize,
    /// Strand groups.
    pub strand_groups: usize,
}

fn lod_counts(sim: &hair::Simulation) -> LodCounts {
    let mut c = LodCounts::default();
    for &n in sim.front_nodes() {
        match sim.hierarchy().kind(n) {
            hair::lod::NodeKind::Strip => c.strips += 1,
            hair::lod::NodeKind::Cluster => c.clusters += 1,
            hair::lod::NodeKind::StrandGroup => c.strand_groups += 1,
        }
    }
    c
}

/// The sphere (head frame) the tools move around: the procedural head's ellipsoid, else the
/// bounds of the hair's roots.
fn head_sphere(sim: &hair::Simulation) -> HeadSphere {
    if let hair::scene::BodySpec::Head { .. } = sim.scene().body {
        let (c, axes) = hair::ssv::head::HEAD;
        return HeadSphere {
            centre: Point::from(c),
            radius: axes.iter().copied().fold(0.0, Real::max),
        };
    }
    let g = sim.render_geometry();
    let mut lo = Vector::repeat(Real::MAX);
    let mut hi = Vector::repeat(Real::MIN);
    for s in 0..g.strand_count() {
        if let Some(p) = g.strand(s).first() {
            lo = lo.inf(&p.coords);
            hi = hi.sup(&p.coords);
        }
    }
    if lo.x > hi.x {
        return HeadSphere {
            centre: Point::origin(),
            radius: 0.12,
        };
    }
    HeadSphere {
        centre: Point::from((lo + hi) * 0.5),
        radius: ((hi - lo) * 0.5).max().max(0.02),
    }
}

/// The rendered image's size for a view of `size` points: the view's aspect, within
/// [`MAX_RENDER`].
fn render_size(size: Vec2) -> [u32; 2] {
    let scale = (MAX_RENDER[0] / size.x.max(1.0))
        .min(MAX_RENDER[1] / size.y.max(1.0))
        .min(1.0);
    [
        ((size.x * scale).round() as u32).max(1),
        ((size.y * scale).round() as u32).max(1),
    ]
}

/// Prints a widget's rectangle in window pixels, for scripts that drive the window
/// (`--print-layout`).
fn print_rect(name: &str, r: &Rect, ppp: f32) {
    println!(
        "layout {name} {:.0} {:.0} {:.0} {:.0}",
        r.min.x * ppp,
        r.min.y * ppp,
        r.width() * ppp,
        r.height() * ppp
    );
}

/// The convex hull of points, counter-clockwise (monotone chain).
fn convex_hull(mut pts: Vec<Pos2>) -> Vec<Pos2> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: Pos2, a: Pos2, b: Pos2| (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    let mut hull: Vec<Pos2> = Vec::with_capacity(pts.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &Pos2>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hull_of_a_square_and_its_centre_is_the_square() {
        let pts = vec![
            Pos2::new(0.0, 0.0),
            Pos2::new(1.0, 0.0),
            Pos2::new(0.5, 0.5),
            Pos2::new(1.0, 1.0),
            Pos2::new(0.0, 1.0),
        ];
        let hull = convex_hull(pts);
        assert_eq!(hull.len(), 4);
        assert!(!hull.contains(&Pos2::new(0.5, 0.5)));
    }

    #[test]
    fn the_render_keeps_the_view_aspect_within_the_cap() {
        assert_eq!(render_size(Vec2::new(400.0, 300.0)), [400, 300]);
        assert_eq!(render_size(Vec2::new(1600.0, 800.0)), [800, 400]);
    }
}
