//! Input mapping of `hair view`, free of any window: the orbit camera, the ray from the cursor,
//! the tool's pose over the head, the palette and the button gestures that become
//! [`hair::ToolEvent`]s (Ward, Galoppo & Lin, *Interactive Virtual Hair Salon*, §3.1: a 2D menu
//! picks the tool, the tool moves in 3D over the head, the button applies it).
//!
//! Everything here is plain maths over plain data so it is unit-tested without a display.

use hair::ssv::{Point, Real, Vector};
use hair::{Pose, Tool, ToolAction, ToolEvent};
use nalgebra::{Matrix4, Rotation3, Unit};

/// One entry of the tool palette.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PaletteItem {
    /// The mouse moves the camera; no tool acts.
    Camera,
    /// A salon tool: the mouse moves it over the head and the button applies it.
    Tool(Tool),
}

impl PaletteItem {
    /// The palette, in the order it is drawn.
    pub const ALL: [PaletteItem; 7] = [
        PaletteItem::Camera,
        PaletteItem::Tool(Tool::Scissors),
        PaletteItem::Tool(Tool::Water),
        PaletteItem::Tool(Tool::Spray),
        PaletteItem::Tool(Tool::Mousse),
        PaletteItem::Tool(Tool::Dryer),
        PaletteItem::Tool(Tool::Grab),
    ];

    /// The button's label.
    pub fn label(self) -> &'static str {
        match self {
            PaletteItem::Camera => "Camera",
            PaletteItem::Tool(Tool::Scissors) => "Scissors",
            PaletteItem::Tool(Tool::Water) => "Water",
            PaletteItem::Tool(Tool::Spray) => "Hairspray",
            PaletteItem::Tool(Tool::Mousse) => "Mousse",
            PaletteItem::Tool(Tool::Dryer) => "Dryer",
            PaletteItem::Tool(Tool::Grab) => "Grab",
        }
    }

    /// The key that picks it (1-7, in palette order).
    pub fn shortcut(self) -> char {
        let i = Self::ALL.iter().position(|&p| p == self).unwrap_or(0);
        char::from(b'1' + i as u8)
    }

    /// The item whose shortcut is `c`, if any.
    pub fn from_shortcut(c: char) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.shortcut() == c)
    }

    /// The salon tool, if this is one.
    pub fn tool(self) -> Option<Tool> {
        match self {
            PaletteItem::Camera => None,
            PaletteItem::Tool(t) => Some(t),
        }
    }
}

/// A tool's side-panel settings: what its events carry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToolSettings {
    /// Reach of the cone, or blade length of the scissors (m).
    pub reach: Real,
    /// Cut-off half angle of the cone, or half the blades' opening (rad).
    pub angle: Real,
    /// Multiple of the tool's nominal effect.
    pub strength: Real,
}

impl ToolSettings {
    /// Defaults that reach the hair from the tool's standoff over the head.
    pub fn default_for(tool: Tool) -> Self {
        let (reach, angle, strength) = match tool {
            Tool::Water => (0.3, 0.45, 1.5),
            Tool::Spray => (0.35, 0.35, 1.0),
            Tool::Mousse => (0.3, 0.3, 1.0),
            Tool::Dryer => (0.4, 0.35, 1.5),
            Tool::Grab => (0.25, 0.3, 1.0),
            Tool::Scissors => (0.3, 0.35, 1.0),
        };
        Self {
            reach,
            angle,
            strength,
        }
    }
}

/// A ray (unit direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where it starts.
    pub origin: Point,
    /// Unit direction.
    pub direction: Vector,
}

impl Ray {
    /// The point at parameter `t` (m along the ray).
    pub fn at(&self, t: Real) -> Point {
        self.origin + self.direction * t
    }
}

/// A camera orbiting a target: yaw about +y, pitch above the horizon, distance, and a
/// vertical field of view; the same projection as `hair-render`'s (right-handed look-at,
/// depth in `[0, 1]`, pixel rows from the top).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// The point orbited and looked at (m, world).
    pub target: Point,
    /// Angle about +y from +z towards +x (rad).
    pub yaw: Real,
    /// Angle above the horizontal plane (rad, within +-1.5).
    pub pitch: Real,
    /// Eye to target (m).
    pub distance: Real,
    /// Vertical field of view (rad).
    pub fov_y: Real,
}

/// Pitch limit of the orbit: short of the poles, where the look-at frame flips.
const MAX_PITCH: Real = 1.5;

impl OrbitCamera {
    /// The orbit that sees `target` from `eye`.
    pub fn from_eye_target(eye: Point, target: Point, fov_y: Real) -> Self {
        let d = eye - target;
        let distance = d.norm().max(1e-3);
        let pitch = (d.y / distance)
            .clamp(-1.0, 1.0)
            .asin()
            .clamp(-MAX_PITCH, MAX_PITCH);
        let yaw = d.x.atan2(d.z);
        Self {
            target,
            yaw,
            pitch,
            distance,
            fov_y,
        }
    }

    /// The eye position.
    pub fn eye(&self) -> Point {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + Vector::new(cp * sy, sp, cp * cy) * self.distance
    }

    /// Unit forward, right and up of the view.
    pub fn basis(&self) -> (Vector, Vector, Vector) {
        let f = (self.target - self.eye()).normalize();
        let r = f
            .cross(&Vector::y())
            .try_normalize(1e-9)
            .unwrap_or_else(Vector::x);
        let u = r.cross(&f);
        (f, r, u)
    }

    /// Orbits by pixel deltas of the mouse (0.01 rad per pixel).
    pub fn orbit(&mut self, dx: Real, dy: Real) {
        self.yaw -= dx * 0.01;
        self.pitch = (self.pitch + dy * 0.01).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Zooms by `steps` wheel notches (positive: nearer), 10 % a notch, within 5 cm to 20 m.
    pub fn zoom(&mut self, steps: Real) {
        self.distance = (self.distance * 0.9f32.powf(steps)).clamp(0.05, 20.0);
    }

    /// Pans by pixel deltas in a viewport `height` pixels tall: the point under the cursor at
    /// the target's depth stays under it.
    pub fn pan(&mut self, dx: Real, dy: Real, height: Real) {
        let (_, r, u) = self.basis();
        let metres_per_pixel = 2.0 * self.distance * (0.5 * self.fov_y).tan() / height.max(1.0);
        self.target += (-r * dx + u * dy) * metres_per_pixel;
    }

    /// View-projection for an image of `width` x `height` pixels (wgpu clip space).
    pub fn view_proj(&self, width: Real, height: Real) -> Matrix4<Real> {
        let aspect = width / height.max(1.0);
        let view = Matrix4::look_at_rh(&self.eye(), &self.target, &Vector::y());
        hair_render::perspective_zero_to_one(self.fov_y, aspect, NEAR, FAR) * view
    }

    /// Pixel position (from the top left) of `p` in a `width` x `height` image, or `None`
    /// behind the eye.
    pub fn project(&self, p: &Point, width: Real, height: Real) -> Option<[Real; 2]> {
        let c = self.view_proj(width, height) * p.to_homogeneous();
        if c.w <= 1e-6 {
            return None;
        }
        let (x, y) = (c.x / c.w, c.y / c.w);
        Some([(0.5 * x + 0.5) * width, (0.5 - 0.5 * y) * height])
    }

    /// The ray from the eye through pixel `(x, y)` (from the top left) of a `width` x
    /// `height` image.
    pub fn ray(&self, x: Real, y: Real, width: Real, height: Real) -> Ray {
        let (f, r, u) = self.basis();
        let t = (0.5 * self.fov_y).tan();
        let aspect = width / height.max(1.0);
        let nx = 2.0 * x / width.max(1.0) - 1.0;
        let ny = 1.0 - 2.0 * y / height.max(1.0);
        let d = f + r * (nx * t * aspect) + u * (ny * t);
        Ray {
            origin: self.eye(),
            direction: d.normalize(),
        }
    }

    /// The renderer's camera.
    pub fn render_camera(&self) -> hair_render::Camera {
        hair_render::Camera {
            eye: self.eye(),
            target: self.target,
            up: Vector::y(),
            fov_y: self.fov_y,
            near: NEAR,
            far: FAR,
        }
    }
}

/// Near and far clip distances of the view (m): `hair-render`'s defaults.
const NEAR: Real = 0.05;
const FAR: Real = 20.0;

/// Where the tool is held: on a sphere around the head `standoff` metres outside it, pointing
/// at the head turned by `yaw` and `pitch`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aim {
    /// Distance outside the head's bounding sphere (m; the wheel changes it).
    pub standoff: Real,
    /// Turn of the direction about the view's up axis (rad; Shift + drag).
    pub yaw: Real,
    /// Turn of the direction about the view's right axis (rad; Shift + drag).
    pub pitch: Real,
}

impl Default for Aim {
    fn default() -> Self {
        Self {
            standoff: 0.08,
            yaw: 0.0,
            pitch: 0.0,
        }
    }
}

impl Aim {
    /// Moves the tool nearer (negative) or farther by `steps` wheel notches, 1 cm each, kept
    /// between 0 and 1 m outside the head.
    pub fn nudge(&mut self, steps: Real) {
        self.standoff = (self.standoff + 0.01 * steps).clamp(0.0, 1.0);
    }

    /// Turns the direction by pixel deltas of the mouse (0.01 rad per pixel, within +-1.4).
    pub fn turn(&mut self, dx: Real, dy: Real) {
        self.yaw = (self.yaw - dx * 0.01).clamp(-1.4, 1.4);
        self.pitch = (self.pitch - dy * 0.01).clamp(-1.4, 1.4);
    }
}

/// The head the tools move around: a bounding sphere (world).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadSphere {
    /// Centre (m).
    pub centre: Point,
    /// Radius (m).
    pub radius: Real,
}

/// Where the ray meets the sphere first from its origin, or, if it passes by, the sphere's
/// point nearest the ray, so the tool slides along the silhouette instead of jumping.
pub fn point_on_sphere(ray: &Ray, centre: &Point, radius: Real) -> Point {
    let oc = ray.origin - centre;
    let b = oc.dot(&ray.direction);
    let c = oc.norm_squared() - radius * radius;
    let disc = b * b - c;
    if disc >= 0.0 {
        let t = -b - disc.sqrt();
        if t >= 0.0 {
            return ray.at(t);
        }
    }
    let closest = ray.at((-b).max(0.0));
    let out = (closest - centre)
        .try_normalize(1e-9)
        .unwrap_or(-ray.direction);
    centre + out * radius
}

/// The tool's pose for a cursor ray: on the sphere `aim.standoff` outside the head, pointing
/// at the head's centre turned by the aim's angles about the camera's `up` and `right`; `up`
/// of the pose (the scissors' blade plane) is the camera's up made normal to the direction.
pub fn tool_pose(ray: &Ray, head: &HeadSphere, aim: &Aim, up: &Vector, right: &Vector) -> Pose {
    let position = point_on_sphere(ray, &head.centre, head.radius + aim.standoff);
    let toward = (head.centre - position)
        .try_normalize(1e-9)
        .unwrap_or(ray.direction);
    let turn = Rotation3::from_axis_angle(&Unit::new_normalize(*up), aim.yaw)
        * Rotation3::from_axis_angle(&Unit::new_normalize(*right), aim.pitch);
    let direction = turn * toward;
    let pose_up = (up - direction * up.dot(&direction))
        .try_normalize(1e-6)
        .unwrap_or_else(|| direction.cross(right).normalize());
    Pose {
        position: position.coords.into(),
        direction: direction.into(),
        up: pose_up.into(),
    }
}

/// What the user did with a tool, before it is stamped with a simulation time.
#[derive(Clone, Debug, PartialEq)]
pub struct Gesture {
    /// The tool.
    pub tool: Tool,
    /// Press, move or release.
    pub action: ToolAction,
    /// Pose (the release keeps the last one; the salon ignores it).
    pub pose: Pose,
    /// The tool's settings at the time.
    pub settings: ToolSettings,
}

impl Gesture {
    /// The event at simulated time `time`.
    pub fn event(&self, time: Real) -> ToolEvent {
        ToolEvent {
            time,
            tool: self.tool,
            action: self.action,
            pose: self.pose,
            path: Vec::new(),
            strength: self.settings.strength,
            reach: self.settings.reach,
            angle: self.settings.angle,
        }
    }
}

/// Turns the button and the tool's pose, frame after frame, into gestures: button down over
/// the view presses the chosen tool, movement while held moves it (scissors snip only on the
/// press), button up or a change of tool releases it.
#[derive(Clone, Debug, Default)]
pub struct GestureMapper {
    held: Option<(Tool, Pose)>,
}

impl GestureMapper {
    /// The tool held down, if any.
    pub fn held(&self) -> Option<Tool> {
        self.held.map(|(t, _)| t)
    }

    /// One frame of input: the palette's choice, whether the button is down (a press counts
    /// only when it starts over the view, which the caller tells by `pose` being `Some`), and
    /// the tool's pose under the cursor. Returns the gestures in order.
    pub fn update(
        &mut self,
        item: PaletteItem,
        button_down: bool,
        pose: Option<Pose>,
        settings: ToolSettings,
    ) -> Vec<Gesture> {
        let mut out = Vec::new();
        if let Some((tool, last)) = self.held {
            let keep = button_down && item.tool() == Some(tool);
            if !keep {
                out.push(Gesture {
                    tool,
                    action: ToolAction::Release,
                    pose: last,
                    settings,
                });
                self.held = None;
            } else if let Some(p) = pose
                && p != last
            {
                if tool != Tool::Scissors {
                    out.push(Gesture {
                        tool,
                        action: ToolAction::Move,
                        pose: p,
                        settings,
                    });
                }
                self.held = Some((tool, p));
            }
            return out;
        }
        if button_down && let (Some(tool), Some(p)) = (item.tool(), pose) {
            out.push(Gesture {
                tool,
                action: ToolAction::Press,
                pose: p,
                settings,
            });
            self.held = Some((tool, p));
        }
        out
    }
}

/// The outline of a tool's area of influence (world): the cone's apex and rim (`segments`
/// points), or the scissors' triangle, exactly as the salon builds them.
pub fn influence_outline(tool: Tool, pose: &Pose, s: &ToolSettings, segments: usize) -> Outline {
    let apex = Point::from(Vector::from(pose.position));
    let dir = Vector::from(pose.direction)
        .try_normalize(1e-12)
        .unwrap_or_else(|| -Vector::z());
    let up = Vector::from(pose.up);
    if tool == Tool::Scissors {
        let side = up
            .cross(&dir)
            .try_normalize(1e-12)
            .unwrap_or_else(Vector::x);
        let (sn, c) = s.angle.sin_cos();
        return Outline::Triangle([
            apex,
            apex + (dir * c + side * sn) * s.reach,
            apex + (dir * c - side * sn) * s.reach,
        ]);
    }
    let a = up.cross(&dir).try_normalize(1e-9).unwrap_or_else(|| {
        dir.cross(&Vector::x())
            .try_normalize(1e-9)
            .unwrap_or_else(Vector::y)
    });
    let b = dir.cross(&a);
    let centre = apex + dir * s.reach;
    let r = s.reach * s.angle.tan();
    let rim = (0..segments.max(3))
        .map(|k| {
            let phi = std::f32::consts::TAU * k as Real / segments.max(3) as Real;
            let (sp, cp) = phi.sin_cos();
            centre + (a * cp + b * sp) * r
        })
        .collect();
    Outline::Cone { apex, rim }
}

/// A tool's area of influence to draw.
#[derive(Clone, Debug, PartialEq)]
pub enum Outline {
    /// A cone: apex and the rim at its reach.
    Cone {
        /// The tool's tip.
        apex: Point,
        /// Points around the rim.
        rim: Vec<Point>,
    },
    /// The scissors' blades: apex and the two blade tips.
    Triangle([Point; 3]),
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera() -> OrbitCamera {
        OrbitCamera::from_eye_target(
            Point::new(0.55, 0.1, -0.75),
            Point::new(0.0, -0.05, 0.0),
            40f32.to_radians(),
        )
    }

    fn close(a: &Point, b: &Point, tol: Real) -> bool {
        (a - b).norm() <= tol
    }

    #[test]
    fn an_orbit_from_an_eye_and_target_gives_back_the_eye() {
        let c = camera();
        assert!(close(&c.eye(), &Point::new(0.55, 0.1, -0.75), 1e-5));
    }

    #[test]
    fn the_ray_through_a_projected_point_passes_through_it() {
        let c = camera();
        let (w, h) = (800.0, 600.0);
        for p in [
            Point::new(0.0, 0.0, 0.0),
            Point::new(0.1, -0.2, 0.05),
            Point::new(-0.05, 0.1, 0.1),
        ] {
            let [x, y] = c.project(&p, w, h).unwrap();
            let ray = c.ray(x, y, w, h);
            let t = (p - ray.origin).dot(&ray.direction);
            assert!(close(&ray.at(t), &p, 1e-4), "{p:?}");
        }
        // The image centre looks at the target.
        let ray = c.ray(400.0, 300.0, w, h);
        let (f, _, _) = c.basis();
        assert!((ray.direction - f).norm() < 1e-6);
    }

    #[test]
    fn a_ray_at_the_head_puts_the_tool_on_the_near_side_pointing_at_it() {
        let c = camera();
        let head = HeadSphere {
            centre: Point::origin(),
            radius: 0.12,
        };
        let [x, y] = c.project(&head.centre, 800.0, 600.0).unwrap();
        let ray = c.ray(x, y, 800.0, 600.0);
        let (_, r, u) = c.basis();
        let aim = Aim::default();
        let pose = tool_pose(&ray, &head, &aim, &u, &r);
        let p = Point::from(Vector::from(pose.position));
        assert!((p.coords.norm() - 0.2).abs() < 1e-4);
        // Between the eye and the head.
        assert!((c.eye() - p).norm() < (c.eye() - head.centre).norm());
        let d = Vector::from(pose.direction);
        assert!(
            (d + p.coords.normalize()).norm() < 1e-4,
            "points at the centre"
        );
        // `up` is normal to the direction (the scissors need a blade plane).
        assert!(Vector::from(pose.up).dot(&d).abs() < 1e-5);
    }

    #[test]
    fn a_ray_past_the_head_slides_the_tool_along_the_silhouette() {
        let ray = Ray {
            origin: Point::new(-1.0, 0.5, 0.0),
            direction: Vector::x(),
        };
        let p = point_on_sphere(&ray, &Point::origin(), 0.2);
        assert!(close(&p, &Point::new(0.0, 0.2, 0.0), 1e-6));
    }

    #[test]
    fn turning_the_aim_turns_the_direction_away_from_the_centre() {
        // A level camera: the direction at the head is normal to the turning axis (up).
        let c = OrbitCamera::from_eye_target(
            Point::new(0.5, 0.0, -0.6),
            Point::origin(),
            40f32.to_radians(),
        );
        let head = HeadSphere {
            centre: Point::origin(),
            radius: 0.12,
        };
        let ray = c.ray(400.0, 300.0, 800.0, 600.0);
        let (_, r, u) = c.basis();
        let straight = tool_pose(&ray, &head, &Aim::default(), &u, &r);
        let mut aim = Aim::default();
        aim.turn(30.0, 0.0);
        let turned = tool_pose(&ray, &head, &aim, &u, &r);
        assert_eq!(straight.position, turned.position);
        let cos = Vector::from(straight.direction).dot(&Vector::from(turned.direction));
        assert!((cos - 0.3f32.cos()).abs() < 1e-4);
        aim.nudge(-100.0);
        assert_eq!(aim.standoff, 0.0);
    }

    #[test]
    fn palette_shortcuts_pick_each_item() {
        for item in PaletteItem::ALL {
            assert_eq!(PaletteItem::from_shortcut(item.shortcut()), Some(item));
        }
        assert_eq!(
            PaletteItem::from_shortcut('3'),
            Some(PaletteItem::Tool(Tool::Water))
        );
        assert_eq!(PaletteItem::from_shortcut('9'), None);
    }

    fn pose_at(x: f32) -> Pose {
        Pose {
            position: [x, 0.0, 0.2],
            ..Pose::default()
        }
    }

    #[test]
    fn press_drag_release_become_press_moves_release() {
        let water = PaletteItem::Tool(Tool::Water);
        let s = ToolSettings::default_for(Tool::Water);
        let mut m = GestureMapper::default();
        let actions = |g: Vec<Gesture>| g.into_iter().map(|g| g.action).collect::<Vec<_>>();
        assert!(m.update(water, false, Some(pose_at(0.0)), s).is_empty());
        assert_eq!(
            actions(m.update(water, true, Some(pose_at(0.0)), s)),
            [ToolAction::Press]
        );
        assert_eq!(m.held(), Some(Tool::Water));
        // Held still: nothing; moved: a move.
        assert!(m.update(water, true, Some(pose_at(0.0)), s).is_empty());
        let g = m.update(water, true, Some(pose_at(0.1)), s);
        assert_eq!(g.len(), 1);
        assert_eq!(g[0].action, ToolAction::Move);
        assert_eq!(g[0].pose, pose_at(0.1));
        assert_eq!(g[0].event(1.5).time, 1.5);
        assert_eq!(g[0].event(1.5).reach, s.reach);
        assert_eq!(
            actions(m.update(water, false, Some(pose_at(0.1)), s)),
            [ToolAction::Release]
        );
        assert_eq!(m.held(), None);
    }

    #[test]
    fn the_camera_never_makes_events_and_a_press_off_the_view_does_nothing() {
        let s = ToolSettings::default_for(Tool::Water);
        let mut m = GestureMapper::default();
        assert!(
            m.update(PaletteItem::Camera, true, Some(pose_at(0.0)), s)
                .is_empty()
        );
        assert!(
            m.update(PaletteItem::Tool(Tool::Water), true, None, s)
                .is_empty()
        );
    }

    #[test]
    fn changing_tool_while_held_releases_it_and_scissors_only_snip_on_press() {
        let s = ToolSettings::default_for(Tool::Scissors);
        let mut m = GestureMapper::default();
        let sc = PaletteItem::Tool(Tool::Scissors);
        assert_eq!(m.update(sc, true, Some(pose_at(0.0)), s).len(), 1);
        assert!(m.update(sc, true, Some(pose_at(0.2)), s).is_empty());
        let g = m.update(PaletteItem::Tool(Tool::Water), true, Some(pose_at(0.2)), s);
        assert_eq!(g.len(), 1);
        assert_eq!(
            (g[0].tool, g[0].action),
            (Tool::Scissors, ToolAction::Release)
        );
    }

    #[test]
    fn outlines_match_the_salon_areas() {
        let pose = Pose {
            position: [0.0, 0.0, 0.3],
            direction: [0.0, 0.0, -1.0],
            up: [0.0, 1.0, 0.0],
        };
        let s = ToolSettings {
            reach: 0.2,
            angle: 0.4,
            strength: 1.0,
        };
        let Outline::Cone { apex, rim } = influence_outline(Tool::Water, &pose, &s, 16) else {
            panic!("water has a cone");
        };
        assert_eq!(apex, Point::new(0.0, 0.0, 0.3));
        for p in &rim {
            assert!((p.z - 0.1).abs() < 1e-6);
            let r = (p.x * p.x + p.y * p.y).sqrt();
            assert!((r - 0.2 * 0.4f32.tan()).abs() < 1e-5);
        }
        let Outline::Triangle(t) = influence_outline(Tool::Scissors, &pose, &s, 16) else {
            panic!("scissors have a triangle");
        };
        assert!((t[1] - t[0]).norm() - 0.2 < 1e-6);
        assert!(
            t.iter().all(|p| p.y.abs() < 1e-6),
            "blades open in the plane normal to up"
        );
    }
}
