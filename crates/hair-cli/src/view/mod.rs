//! `hair view SCENE`: the interactive salon window (Ward, Galoppo & Lin, *Interactive Virtual
//! Hair Salon*, §3.1). The simulation runs at its fixed step; a palette picks a tool, the mouse
//! moves it over the head and applies it; every gesture becomes a tool event of the same
//! script `hair run` replays, so a session is recorded (`--record`), undone and replayed to the
//! same state hash. See `docs/view.md`.
//!
//! | module | what it holds |
//! |---|---|
//! | `input` | cursor to ray to tool pose, the orbit camera, palette, gestures (no window) |
//! | `session` | the simulation with the live events stamped at step boundaries, record, undo |
//! | `app` | the eframe window: palette, settings, rendered scene, tool overlay, HUD |

mod app;
mod input;
mod session;

use anyhow::{Context, Result, bail};
use hair::{LodPolicy, Scene};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

/// Arguments of `hair view`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// A built-in scene name (`hair scenes` lists them) or a scene file (.ron).
    #[arg(default_value = "salon")]
    pub scene: String,
    /// Simulate this many frames, then write the outputs and exit (default: run until closed).
    #[arg(long)]
    pub frames: Option<u32>,
    /// On exit, save a screenshot of the window (PNG).
    #[arg(long)]
    pub screenshot: Option<PathBuf>,
    /// On exit, write the counters and the state hash (JSON).
    #[arg(long)]
    pub metrics: Option<PathBuf>,
    /// On exit, write the session as a scene file whose tool script is the recorded events:
    /// `hair run FILE` replays it. An existing file is kept unless `--force` is given, and the
    /// scene file the session loaded is never written over.
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Let `--record` replace an existing file (never the loaded scene's).
    #[arg(long)]
    pub force: bool,
    /// LOD policy: fine, adaptive, coarse-strands, clusters, strips (default: the scene's own).
    #[arg(long)]
    pub lod: Option<String>,
    /// Worker threads of the simulation (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Window width and height (pixels).
    #[arg(long, num_args = 2, value_names = ["WIDTH", "HEIGHT"], default_values_t = [1280, 800])]
    pub size: Vec<u32>,
    /// Print the palette buttons' and the view's rectangles (window pixels) once laid out, for
    /// scripts that drive the window.
    #[arg(long)]
    pub print_layout: bool,
}

/// What the window writes when it closes.
#[derive(Clone, Debug, Default)]
pub struct ExitOptions {
    /// Frame limit.
    pub frames: Option<u32>,
    /// Screenshot path.
    pub screenshot: Option<PathBuf>,
    /// Metrics path.
    pub metrics: Option<PathBuf>,
    /// Recording path.
    pub record: Option<PathBuf>,
    /// Whether to print the layout.
    pub print_layout: bool,
}

/// Set when writing the outputs failed inside the window, so the command exits non-zero.
static EXIT_FAILED: AtomicBool = AtomicBool::new(false);

/// Why there is no window to open, if there is none: the view needs an X11 display (XWayland
/// provides one under Wayland), and winit panics rather than failing without one.
fn missing_display() -> Option<String> {
    let set = |name: &str| std::env::var_os(name).is_some_and(|v| !v.is_empty());
    if set("DISPLAY") {
        return None;
    }
    Some(if set("WAYLAND_DISPLAY") {
        "hair view needs an X11 display: WAYLAND_DISPLAY is set but DISPLAY is not (start XWayland)"
            .into()
    } else {
        "hair view needs a display and DISPLAY is not set; without one, run it under Xvfb: \
         xvfb-run -a -s \"-screen 0 1280x800x24\" hair view ..."
            .into()
    })
}

/// Refuses a `--record` file that would lose what the user made, before the window opens (not
/// at its close, after the styling): the scene file the session loaded (the recording drops
/// the scene's own tool script, so it would be gone), or any existing file unless `force`.
fn check_record_target(scene: &str, record: &Path, force: bool) -> Result<()> {
    let same = |a: &Path, b: &Path| matches!((a.canonicalize(), b.canonicalize()), (Ok(a), Ok(b)) if a == b);
    if same(Path::new(scene), record) {
        bail!(
            "--record {}: that is the scene being loaded; record the session to another file",
            record.display()
        );
    }
    if !force && record.exists() {
        bail!(
            "--record {}: exists; pass --force to replace it",
            record.display()
        );
    }
    Ok(())
}

/// Runs the command.
pub fn run(args: Args) -> Result<()> {
    let loaded = Scene::load(&args.scene)?;
    let policy = match &args.lod {
        Some(name) => LodPolicy::from_name(name).with_context(|| {
            format!(
                "unknown LOD policy `{name}` (fine, adaptive, coarse-strands, clusters, strips)"
            )
        })?,
        None => loaded.scene.lod,
    };
    if args.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    let [width, height] = [args.size[0], args.size[1]];
    if !(200..=8192).contains(&width) || !(150..=8192).contains(&height) {
        bail!("--size {width} {height}: the window must be 200x150 to 8192x8192 pixels");
    }
    if let Some(record) = &args.record {
        check_record_target(&args.scene, record, args.force)?;
    }
    if let Some(why) = missing_display() {
        bail!(why);
    }
    if let Some(threads) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build_global()
            .context("setting the worker threads")?;
    }
    let mut session = session::Session::new(loaded, policy)?;
    // Interactive: the body's distance field is computed before the first frame, so that the
    // first seconds do not stutter while the hair first reaches each part of the body.
    session.prefill_body_field();
    let opts = ExitOptions {
        frames: args.frames,
        screenshot: args.screenshot,
        metrics: args.metrics,
        record: args.record,
        print_layout: args.print_layout,
    };
    let native = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_title("hair view")
            .with_inner_size([width as f32, height as f32]),
        ..eframe::NativeOptions::default()
    };
    eframe::run_native(
        "hair view",
        native,
        Box::new(move |_cc| Ok(Box::new(app::ViewApp::new(session, opts)))),
    )
    .map_err(|e| anyhow::anyhow!("hair view: the window failed: {e}"))?;
    if EXIT_FAILED.load(Ordering::SeqCst) {
        bail!("hair view: writing the outputs failed (see above)");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_recording_never_replaces_the_scene_and_replaces_others_only_when_forced() {
        let dir = std::env::temp_dir().join(format!("hair-view-record-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let scene = dir.join("mine.ron");
        std::fs::write(&scene, "Scene()").unwrap();
        let scene_name = scene.to_str().unwrap();
        // The loaded scene, by its own path or another spelling of it: never, even forced.
        let other_spelling = dir.join(".").join("mine.ron");
        for target in [&scene, &other_spelling] {
            for force in [false, true] {
                let err = check_record_target(scene_name, target, force).unwrap_err();
                assert!(err.to_string().contains("scene being loaded"), "{err}");
            }
        }
        // Another existing file: only with --force.
        let old = dir.join("old.ron");
        std::fs::write(&old, "kept").unwrap();
        let err = check_record_target(scene_name, &old, false).unwrap_err();
        assert!(err.to_string().contains("--force"), "{err}");
        check_record_target(scene_name, &old, true).unwrap();
        // A new file, and a built-in scene's name (no file of that name here).
        check_record_target(scene_name, &dir.join("new.ron"), false).unwrap();
        check_record_target("salon", &dir.join("new.ron"), false).unwrap();
        assert_eq!(std::fs::read_to_string(&old).unwrap(), "kept");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
