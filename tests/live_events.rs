//! Live tool events (`Simulation::push_tool_event`, `push_camera_key`): what an interactive
//! session feeds a running simulation, checked as a script's events are.

use hair::scene::{BodySpec, CameraKey, HairstyleSpec};
use hair::{LodPolicy, Pose, Scene, Simulation, Tool, ToolAction, ToolEvent};

fn small_salon() -> Simulation {
    let mut loaded = Scene::load("salon").expect("built-in salon");
    loaded.scene.tools.events.clear();
    if let HairstyleSpec::Procedural(p) = &mut loaded.scene.hairstyle {
        p.strands = 60;
    }
    loaded.scene.body = BodySpec::Head { resolution: 16 };
    Simulation::new(&loaded, LodPolicy::Fine).expect("the scene builds")
}

fn event(time: f32, tool: Tool, action: ToolAction) -> ToolEvent {
    ToolEvent {
        time,
        tool,
        action,
        pose: Pose {
            position: [0.0, 0.0, -0.35],
            direction: [0.0, 0.0, 1.0],
            up: [0.0, 1.0, 0.0],
        },
        path: Vec::new(),
        strength: 1.0,
        reach: 0.3,
        angle: 0.4,
    }
}

#[test]
fn a_live_event_acts_at_the_next_step_and_joins_the_scene_script() {
    let mut sim = small_salon();
    for _ in 0..3 {
        sim.step().unwrap();
    }
    let t = sim.next_event_time();
    assert!(t > sim.time() && t < sim.time() + sim.dt());
    sim.push_tool_event(event(t, Tool::Water, ToolAction::Press))
        .unwrap();
    assert_eq!(sim.scene().tools.events.len(), 1);
    let s = sim.step().unwrap();
    assert_eq!(s.salon.tools_pressed, 1);
    assert!(s.salon.water_kg > 0.0);
}

#[test]
fn live_events_in_the_past_or_of_unpressed_tools_are_refused() {
    let mut sim = small_salon();
    for _ in 0..3 {
        sim.step().unwrap();
    }
    let past = sim.time() - sim.dt();
    assert!(
        sim.push_tool_event(event(past, Tool::Water, ToolAction::Press))
            .is_err()
    );
    let t = sim.next_event_time();
    assert!(
        sim.push_tool_event(event(t, Tool::Grab, ToolAction::Release))
            .is_err()
    );
    assert!(
        sim.push_tool_event(event(f32::NAN, Tool::Water, ToolAction::Press))
            .is_err()
    );
    // Refused events leave the script as it was.
    assert!(sim.scene().tools.events.is_empty());
    assert!(sim.salon().script().events.is_empty());
    let key = CameraKey {
        time: past,
        eye: [0.0, 0.0, 1.0],
        target: [0.0; 3],
    };
    assert!(sim.push_camera_key(key).is_err());
    assert!(sim.push_camera_key(CameraKey { time: t, ..key }).is_ok());
}
