//! Golden-file test: a scripted stream through the node's own loop ([`robot_manager::run_loop`])
//! on a mock clock — world reports at 20 Hz, an action for a primitive that does not exist, a
//! malformed controller status, a spoken `teach`, a kinesthetic demonstration (tool to the
//! bottle, gripper closed, bottle lifted), `done`, and `done` again without `teach` — and every
//! output, summarised one JSON per line, compared with `tests/golden/manager.jsonl`
//! (`UPDATE_GOLDEN=1` rewrites it).

use std::path::PathBuf;

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{ActionCommand, Gesture, MotionStatus, WorldObject, WorldState};
use cowork_msgs::std_msgs::{Header, String as RosString};
use cowork_testkit::{ScriptedSource, assert_golden};
use robot_manager::{Input, Params, RobotManagerNode};
use serde_json::json;

fn pose(x: f64, y: f64, z: f64) -> Pose {
    Pose { position: Point { x, y, z }, orientation: Quaternion { x: 1.0, y: 0.0, z: 0.0, w: 0.0 } }
}

/// The world at `t`: the tool goes from above the table to the bottle (0.5–2 s), the gripper
/// closes at 2.2 s and the bottle is lifted 20 cm (2.5–3.5 s).
fn world(t: f64) -> WorldState {
    let bottle = [0.45, 0.35, 0.11];
    let start = [0.3, 0.0, 0.5];
    let s = ((t - 0.5) / 1.5).clamp(0.0, 1.0);
    let lift = ((t - 2.5) / 1.0).clamp(0.0, 1.0) * 0.2;
    let tool = [start[0] + s * (bottle[0] - start[0]), start[1] + s * (bottle[1] - start[1]), start[2] + s * (bottle[2] - start[2]) + lift];
    let held = t >= 2.2;
    WorldState {
        header: Header { stamp: Time::from_secs_f64(t), frame_id: "lwr_base_link".into() },
        gripper_state: if held { WorldState::GRIPPER_CLOSED } else { WorldState::GRIPPER_OPEN },
        held_object: if held { "bottle".into() } else { String::new() },
        tool_pose: pose(tool[0], tool[1], tool[2]),
        objects: vec![WorldObject {
            name: "bottle".into(),
            pose: if held { pose(tool[0], tool[1], tool[2]) } else { pose(bottle[0], bottle[1], bottle[2]) },
            tool_distance: if held { 0.0 } else { (0..3).map(|i| (tool[i] - bottle[i]).powi(2)).sum::<f64>().sqrt() },
            ..Default::default()
        }],
    }
}

fn r4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

#[test]
fn scripted_teaching_and_bad_input_give_the_golden_outputs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut params: Params = cowork_ros::params::load(&root.join("config/robot_manager.yaml"), "robot_manager").expect("params");
    params.database_dir = dir.path().display().to_string();
    let tick_rate_hz = params.tick_rate_hz;
    let (mut node, problem) = RobotManagerNode::new(params, 1);
    assert!(problem.is_none());

    let mut script: Vec<(f64, Input)> = (0..=90).map(|k| k as f64 * 0.05).map(|t| (t, Input::World(world(t)))).collect();
    script.push((0.12, Input::Action(ActionCommand { id: 4, label: "noa9(water)".into(), ..Default::default() })));
    script.push((0.14, Input::MotionStatus(MotionStatus { command_id: 77, state: 9, ..Default::default() })));
    script.push((0.16, Input::Gesture(Gesture { label: "wave".into(), ..Default::default() })));
    script.push((0.3, Input::Speech(RosString::new("teach"))));
    script.push((2.15, Input::Speech(RosString::new("gripper close"))));
    script.push((4.0, Input::Speech(RosString::new("done"))));
    script.push((4.2, Input::Speech(RosString::new("done"))));
    let mut source = ScriptedSource::new(script, 4.5);

    let mut lines = Vec::new();
    let mut last_objects: Option<String> = None;
    robot_manager::run_loop(&mut source, &mut node, tick_rate_hz, &|| 1, &mut |_, out| {
        for m in out.motion.drain(..) {
            lines.push(json!({ "motion": m.label, "kind": m.kind, "id": m.id }).to_string());
        }
        for m in out.gripper.drain(..) {
            lines.push(json!({ "gripper": m.data }).to_string());
        }
        for m in out.robot_stream.drain(..) {
            // Only what changes the supervisor's view: events, segments, mode.
            if !m.events.is_empty() || !m.segments.is_empty() {
                let events: Vec<_> = m.events.iter().map(|e| json!([e.label, e.done, e.failed, e.reason])).collect();
                let segments: Vec<_> = m.segments.iter().map(|s| json!([s.label, s.object_name, s.primitive_id])).collect();
                lines.push(json!({ "robot": r4(m.header.stamp.to_secs_f64()), "mode": m.mode, "events": events, "segments": segments }).to_string());
            }
        }
        for m in out.object_stream.drain(..) {
            // Only when what is visible changes.
            let seen: Vec<_> = m.objects.iter().map(|o| json!([o.name, o.visible])).collect();
            let line = json!({ "objects": seen }).to_string();
            if last_objects.as_ref() != Some(&line) {
                lines.push(line.clone());
                last_objects = Some(line);
            }
        }
        out.manipulated.clear();
        for w in out.warnings.drain(..) {
            lines.push(json!({ "warning": w.message }).to_string());
        }
        Ok(())
    })
    .expect("loop");
    let text = lines.join("\n");
    assert!(text.contains("no primitive `noa9`"), "an unknown primitive is refused by name:\n{text}");
    assert!(text.contains("speech `done`: not teaching"), "a second `done` is refused:\n{text}");
    assert!(text.contains("\"gripper\":\"close\""), "the spoken gripper command is passed on:\n{text}");
    assert!(text.contains("\"mode\":1"), "teaching mode is reported:\n{text}");
    assert_golden(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/manager.jsonl"), &lines);
}
