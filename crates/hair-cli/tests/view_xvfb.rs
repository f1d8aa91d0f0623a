//! `hair view` in a real window under Xvfb, driven by real X events from `xdotool`: choose water
//! in the palette, drag across the hair, quit; then the metrics show water on the hair, the
//! screenshot has the window's content, and the recorded session replays to the same state hash.
//!
//! Skipped (loudly) where `xvfb-run` or `xdotool` is missing, unless `HAIR_REQUIRE_DISPLAY=1`
//! or `HAIR_REQUIRE_GPU=1` asks for it to fail instead (CI sets both).

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
}

fn required() -> bool {
    ["HAIR_REQUIRE_DISPLAY", "HAIR_REQUIRE_GPU"]
        .iter()
        .any(|v| std::env::var(v).is_ok_and(|s| s == "1"))
}

/// Kills a child still running when the test ends (a failed assertion included).
struct Reaper(Option<Child>);

impl Drop for Reaper {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// An Xvfb server for the test's lifetime: `xvfb-run` around a shell that prints the display
/// and its cookie file and waits for its standard input to close.
struct Xvfb {
    child: Reaper,
    display: String,
    xauthority: String,
}

impl Xvfb {
    fn start() -> Xvfb {
        let mut child = Command::new("xvfb-run")
            .args([
                "-a",
                "-s",
                "-screen 0 1024x720x24",
                "sh",
                "-c",
                "echo \"$DISPLAY $XAUTHORITY\"; read _",
            ])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .expect("starting xvfb-run");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("xvfb-run stdout"))
            .read_line(&mut line)
            .expect("reading the display");
        let mut parts = line.split_whitespace();
        let display = parts.next().expect("a display").to_string();
        let xauthority = parts.next().unwrap_or("").to_string();
        Xvfb {
            child: Reaper(Some(child)),
            display,
            xauthority,
        }
    }

    fn command(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("DISPLAY", &self.display);
        if !self.xauthority.is_empty() {
            c.env("XAUTHORITY", &self.xauthority);
        }
        c
    }

    fn xdotool(&self, args: &[&str]) -> String {
        let out = self
            .command("xdotool")
            .args(args)
            .output()
            .expect("running xdotool");
        assert!(
            out.status.success(),
            "xdotool {args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        String::from_utf8_lossy(&out.stdout).into_owned()
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        // Closing the shell's input ends it; xvfb-run then stops the server.
        if let Some(c) = self.child.0.as_mut() {
            if let Some(mut stdin) = c.stdin.take() {
                let _ = stdin.write_all(b"\n");
            }
            let deadline = Instant::now() + Duration::from_secs(5);
            while Instant::now() < deadline {
                if let Ok(Some(_)) = c.try_wait() {
                    self.child.0 = None;
                    return;
                }
                std::thread::sleep(Duration::from_millis(50));
            }
        }
    }
}

/// A rectangle `x y w h` from a `layout NAME x y w h` line.
fn rect(lines: &[String], name: &str) -> Option<[f32; 4]> {
    let prefix = format!("layout {name} ");
    let line = lines.iter().find(|l| l.starts_with(&prefix))?;
    let v: Vec<f32> = line[prefix.len()..]
        .split_whitespace()
        .filter_map(|t| t.parse().ok())
        .collect();
    (v.len() == 4).then(|| [v[0], v[1], v[2], v[3]])
}

fn replay_hash(scene: &Path) -> String {
    let loaded =
        hair::Scene::load(scene.to_str().expect("utf-8 path")).expect("the recording loads");
    let mut sim = hair::Simulation::new(&loaded, loaded.scene.lod).expect("the recording builds");
    for _ in 0..loaded.scene.frames * loaded.scene.substeps {
        sim.step().expect("a step");
    }
    format!("{:016x}", sim.state_hash())
}

#[test]
fn water_dragged_across_the_hair_in_a_real_window_is_recorded_and_replays() {
    if !(on_path("xvfb-run") && on_path("xdotool")) {
        let why = "xvfb-run or xdotool is missing (Debian: xvfb xauth xdotool)";
        if required() {
            panic!("{why}, and HAIR_REQUIRE_DISPLAY/HAIR_REQUIRE_GPU asks for this test");
        }
        eprintln!("SKIPPED view_xvfb: {why}");
        return;
    }
    let out: PathBuf = std::env::temp_dir().join(format!("hair-view-xvfb-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let (metrics, shot, record) = (
        out.join("view.json"),
        out.join("view.png"),
        out.join("session.ron"),
    );
    // The salon scene, lighter: the test profile simulates and renders slowly in software.
    let scene_path = out.join("small-salon.ron");
    let mut scene = hair::Scene::load("salon").expect("the salon scene").scene;
    if let hair::scene::HairstyleSpec::Procedural(p) = &mut scene.hairstyle {
        p.strands = 300;
    }
    scene.body = hair::scene::BodySpec::Head { resolution: 32 };
    std::fs::write(&scene_path, scene.to_ron()).unwrap();
    let x = Xvfb::start();
    let mut app = x
        .command(env!("CARGO_BIN_EXE_hair"))
        .arg("view")
        .arg(&scene_path)
        .args(["--size", "900", "600", "--print-layout"])
        // A backstop: the test quits with a key long before this.
        .args(["--frames", "5000"])
        .arg("--metrics")
        .arg(&metrics)
        .arg("--screenshot")
        .arg(&shot)
        .arg("--record")
        .arg(&record)
        .stdout(Stdio::piped())
        .spawn()
        .expect("starting hair view");
    let stdout = app.stdout.take().expect("stdout");
    let mut app = Reaper(Some(app));
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    // The layout arrives once the window has painted twice.
    let mut lines = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(180);
    while rect(&lines, "view").is_none() {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(l) => lines.push(l),
            Err(e) => panic!("no layout from hair view ({e:?}); got {lines:?}"),
        }
    }
    let water = rect(&lines, "palette water").expect("the water button");
    let view = rect(&lines, "view").expect("the view");
    let window = x.xdotool(&["search", "--sync", "--name", "hair view"]);
    let window = window
        .lines()
        .next()
        .expect("a window id")
        .trim()
        .to_string();
    let at = |x: f32, y: f32| [format!("{}", x.round()), format!("{}", y.round())];
    let click = at(water[0] + 0.5 * water[2], water[1] + 0.5 * water[3]);
    x.xdotool(&["mousemove", "--window", &window, &click[0], &click[1]]);
    std::thread::sleep(Duration::from_millis(500));
    // Held long enough for a slow window frame to see the button down.
    x.xdotool(&["mousedown", "1"]);
    std::thread::sleep(Duration::from_millis(1500));
    x.xdotool(&["mouseup", "1"]);
    std::thread::sleep(Duration::from_millis(1500));
    // Drag across the head, in the middle of the view.
    let (cx, cy) = (view[0] + 0.5 * view[2], view[1] + 0.45 * view[3]);
    let start = at(cx - 0.12 * view[2], cy);
    x.xdotool(&["mousemove", "--window", &window, &start[0], &start[1]]);
    std::thread::sleep(Duration::from_millis(500));
    x.xdotool(&["mousedown", "1"]);
    for k in 1..=12 {
        std::thread::sleep(Duration::from_millis(400));
        let p = at(cx - 0.12 * view[2] + k as f32 * 0.02 * view[2], cy);
        x.xdotool(&["mousemove", "--window", &window, &p[0], &p[1]]);
    }
    std::thread::sleep(Duration::from_millis(1500));
    x.xdotool(&["mouseup", "1"]);
    std::thread::sleep(Duration::from_millis(1500));
    // Keys go to the focused window; with no window manager, focus it by hand.
    x.xdotool(&["windowfocus", "--sync", &window]);
    x.xdotool(&["key", "q"]);
    let deadline = Instant::now() + Duration::from_secs(120);
    let status = loop {
        let child = app.0.as_mut().expect("the app");
        if let Some(s) = child.try_wait().expect("waiting for hair view") {
            app.0 = None;
            break s;
        }
        assert!(
            Instant::now() < deadline,
            "hair view did not exit after `q`"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    while let Ok(l) = rx.try_recv() {
        lines.push(l);
    }
    assert!(
        status.success(),
        "hair view failed: {status}; stdout {lines:?}"
    );

    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&metrics).expect("metrics written"))
            .expect("metrics are JSON");
    let water_kg = m["salon"]["water_kg"].as_f64().expect("salon.water_kg");
    assert!(water_kg > 0.0, "no water on the hair: {m}");
    assert!(
        m["events"].as_u64().unwrap_or(0) >= 2,
        "press and release recorded: {m}"
    );
    let frames = m["frames"].as_u64().unwrap_or(0);
    assert!(frames > 0, "{m}");

    let image = hair_render::image::open(&shot)
        .expect("screenshot written")
        .to_rgba8();
    assert!(
        image.width() >= 800 && image.height() >= 500,
        "{:?}",
        image.dimensions()
    );
    let mut colours = std::collections::HashSet::new();
    for p in image.pixels() {
        colours.insert(p.0);
    }
    assert!(
        colours.len() > 200,
        "a screenshot of {} colours is blank",
        colours.len()
    );

    let hash = m["state_hash"].as_str().expect("state_hash").to_string();
    assert_eq!(
        replay_hash(&record),
        hash,
        "the recorded session replays to the view's state"
    );
    let _ = std::fs::remove_dir_all(&out);
}
