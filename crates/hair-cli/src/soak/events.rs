//! The soak's random events: a seeded generator of tool events and camera keys around the hair.

use hair::scene::CameraKey;
use hair::{Pose, PoseKey, Tool, ToolAction, ToolEvent};

/// SplitMix64 (Steele, Lea & Flood 2014): a tiny, well-mixed, seedable generator; the soak
/// needs reproducible streams, not cryptographic ones.
pub(super) struct SplitMix64(pub(super) u64);

impl SplitMix64 {
    pub(super) fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub(super) fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub(super) fn range(&mut self, lo: f64, hi: f64) -> f32 {
        (lo + (hi - lo) * self.unit()) as f32
    }
    pub(super) fn below(&mut self, n: usize) -> usize {
        (self.unit() * n as f64) as usize % n
    }
    pub(super) fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }
    /// Uniform on the unit sphere.
    pub(super) fn direction(&mut self) -> [f32; 3] {
        let z = 2.0 * self.unit() - 1.0;
        let a = std::f64::consts::TAU * self.unit();
        let r = (1.0 - z * z).max(0.0).sqrt();
        [(r * a.cos()) as f32, (r * a.sin()) as f32, z as f32]
    }
}

/// The hair's axis-aligned box at the start (world frame): where the tools aim.
#[derive(Clone, Copy, Debug)]
pub(super) struct HairBox {
    center: [f32; 3],
    half: [f32; 3],
    radius: f32,
}

impl HairBox {
    pub(super) fn of(points: &[hair::ssv::Point]) -> Option<Self> {
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let half: [f32; 3] = std::array::from_fn(|k| 0.5 * (hi[k] - lo[k]));
        let radius = half.iter().map(|h| h * h).sum::<f32>().sqrt();
        (radius.is_finite() && radius > 0.0).then(|| Self {
            center: std::array::from_fn(|k| 0.5 * (lo[k] + hi[k])),
            half,
            radius,
        })
    }
}

/// Kinds of events the soak fires: each tool's press, move and release, and camera keys.
pub(super) const KINDS: usize = Tool::ALL.len() + 1;

/// Draws the random events and keeps which tools are pressed, so that every event it makes is
/// one the script accepts (a move or release only of a pressed tool).
pub(super) struct EventMaker {
    pub(super) rng: SplitMix64,
    hair: HairBox,
    pressed: [bool; 6],
    /// Per tool, events fired by action (press, move, release).
    pub(super) counts: [[u64; 3]; 6],
    /// Camera keys fired.
    pub(super) camera_keys: u64,
    /// Tool events fired with a path.
    pub(super) paths: u64,
}

impl EventMaker {
    /// A generator of seed `seed` aiming at `hair`, no tool pressed.
    pub(super) fn new(seed: u64, hair: HairBox) -> Self {
        Self {
            rng: SplitMix64(seed),
            hair,
            pressed: [false; 6],
            counts: [[0; 3]; 6],
            camera_keys: 0,
            paths: 0,
        }
    }

    pub(super) fn pose(&mut self, tool: Tool) -> Pose {
        let (c, h, r) = (self.hair.center, self.hair.half, self.hair.radius);
        let out = self.rng.direction();
        let dist = self.rng.range(0.5, 1.4) * r;
        let position = std::array::from_fn(|k| c[k] + out[k] * dist);
        // Mostly aimed at a point of the hair's box, now and then anywhere.
        let direction = if self.rng.chance(0.85) {
            let aim: [f32; 3] = std::array::from_fn(|k| c[k] + h[k] * self.rng.range(-1.0, 1.0));
            let d: [f32; 3] = std::array::from_fn(|k| aim[k] - position[k]);
            if d.iter().any(|x| x.abs() > 1e-6) {
                d
            } else {
                self.rng.direction()
            }
        } else {
            self.rng.direction()
        };
        let mut up = self.rng.direction();
        if tool == Tool::Scissors {
            // The blades' plane needs `up` away from the direction.
            let n = |v: &[f32; 3]| v.iter().map(|x| x * x).sum::<f32>().sqrt();
            let cross = [
                up[1] * direction[2] - up[2] * direction[1],
                up[2] * direction[0] - up[0] * direction[2],
                up[0] * direction[1] - up[1] * direction[0],
            ];
            if n(&cross) <= 0.1 * n(&direction) {
                up = [-direction[1], direction[0], 0.0];
                if n(&up) <= 0.1 * n(&direction) {
                    up = [0.0, -direction[2], direction[1]];
                }
            }
        }
        Pose {
            position,
            direction,
            up,
        }
    }

    /// A random event of a random kind at `time`: `Ok` a tool event, `Err` a camera key.
    pub(super) fn event(&mut self, time: f32) -> Result<ToolEvent, CameraKey> {
        let kind = self.rng.below(KINDS);
        let Some(&tool) = Tool::ALL.get(kind) else {
            let c = self.hair.center;
            let out = self.rng.direction();
            let dist = self.rng.range(2.0, 5.0) * self.hair.radius;
            let jitter = 0.3 * self.hair.radius;
            return Err(CameraKey {
                time,
                eye: std::array::from_fn(|k| c[k] + out[k] * dist),
                target: std::array::from_fn(|k| c[k] + jitter * self.rng.range(-1.0, 1.0)),
            });
        };
        let i = tool as usize;
        let action = match (self.pressed[i], self.rng.chance(0.6)) {
            (false, _) => ToolAction::Press,
            (true, true) => ToolAction::Move,
            (true, false) => ToolAction::Release,
        };
        let pose = self.pose(tool);
        let mut path = Vec::new();
        if action != ToolAction::Release && self.rng.chance(0.3) {
            let mut t = time;
            for _ in 0..1 + self.rng.below(3) {
                t += self.rng.range(0.05, 1.0);
                path.push(PoseKey {
                    time: t,
                    pose: self.pose(tool),
                });
            }
        }
        Ok(ToolEvent {
            time,
            tool,
            action,
            pose,
            path,
            strength: self.rng.range(0.2, 2.0),
            reach: self.rng.range(0.05, 0.5),
            angle: self.rng.range(0.05, 0.7),
        })
    }

    /// Notes an event the simulation took.
    pub(super) fn took(&mut self, event: &ToolEvent) {
        let i = event.tool as usize;
        let a = match event.action {
            ToolAction::Press => 0,
            ToolAction::Move => 1,
            ToolAction::Release => 2,
        };
        self.pressed[i] = event.action != ToolAction::Release;
        self.counts[i][a] += 1;
        self.paths += u64::from(!event.path.is_empty());
    }
}

/// An event fired, without its path (a copy that takes no memory).
#[derive(Clone, Copy, Debug)]
#[expect(dead_code, reason = "read only through Debug, in error messages")]
pub(super) enum Fired {
    /// A tool event.
    Tool {
        time: f32,
        tool: Tool,
        action: ToolAction,
        pose: Pose,
        path_keys: usize,
        strength: f32,
        reach: f32,
        angle: f32,
    },
    /// A camera key.
    Camera(CameraKey),
}

impl Fired {
    pub(super) fn of(e: &ToolEvent) -> Self {
        Fired::Tool {
            time: e.time,
            tool: e.tool,
            action: e.action,
            pose: e.pose,
            path_keys: e.path.len(),
            strength: e.strength,
            reach: e.reach,
            angle: e.angle,
        }
    }
}
