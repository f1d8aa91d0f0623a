//! Rest on the first frame: with a still head, no wind and no tools, every built-in groom is
//! its own static equilibrium.

use hair::dynamics::SkeletonId;
use hair::{LodPolicy, Scene, Simulation};

/// The built-in scenes' names.
const SCENES: [&str; 8] = [
    "wind", "shake", "torus", "zoom", "bristles", "wardlin", "sintel", "salon",
];

/// The largest, over the steps of the first second, of the mean distance (mm) of the front's
/// nodes from where they were built, for `scene` made still.
fn still_drift_mm(scene: &str, policy: Option<LodPolicy>) -> f64 {
    let mut loaded = Scene::load(scene).expect("scene loads");
    let s = &mut loaded.scene;
    if std::env::var("NOBODY").is_ok() { s.body = hair::scene::BodySpec::None; }
    if std::env::var("NOHH").is_ok() { s.collision.hair_hair = hair::collide::HairHairModel::Off; }
    s.head_motion = hair::scene::HeadMotionSpec::Still;
    s.wind.speed = 0.0;
    s.tools.events.clear();
    let policy = policy.unwrap_or(s.lod);
    let steps = (s.frame_rate * s.substeps as f32).round() as u64;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("pool");
    pool.install(|| {
        let mut sim = Simulation::new(&loaded, policy).expect("scene builds");
        let start = sim.state().positions().to_vec();
        let mut worst: f64 = 0.0;
        for _ in 0..steps {
            sim.step().expect("step");
            let (mut sum, mut n) = (0.0f64, 0usize);
            for &node in sim.front_nodes() {
                for i in sim.state().nodes(SkeletonId(node)) {
                    sum += f64::from((sim.state().positions()[i] - start[i]).norm());
                    n += 1;
                }
            }
            worst = worst.max(sum / n.max(1) as f64 * 1e3);
        }
        worst
    })
}

#[test]
#[ignore]
fn print_drift() {
    for scene in SCENES {
        let t = std::time::Instant::now();
        let d = still_drift_mm(scene, None);
        eprintln!("{scene}: {d:.3} mm ({:.1} s)", t.elapsed().as_secs_f64());
    }
}
