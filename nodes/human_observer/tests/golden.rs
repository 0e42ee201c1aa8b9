//! Golden-file test: a scripted input stream (joint states, a person at the robot's side, a
//! corrupt frame, spoken stop / repeat, then silence) through the node's own loop
//! ([`human_observer::run_loop`]) on a mock clock; every output, summarised one JSON per line,
//! is compared with `tests/golden/observer.jsonl` (`UPDATE_GOLDEN=1` rewrites it).

mod common;

use std::path::PathBuf;

use common::{joint_state, root, skeleton};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::String as RosString;
use cowork_people::{BodySize, Performer, Stance};
use cowork_robot::RobotModel;
use cowork_testkit::{ScriptedSource, assert_golden};
use human_observer::{Input, ObserverNode, Output, Params};
use serde_json::json;

fn r4(x: f64) -> f64 {
    (x * 1e4).round() / 1e4
}

#[test]
fn scripted_person_stop_repeat_and_bad_frames_give_the_golden_outputs() {
    let mut params: Params = cowork_ros::params::load(&root().join("config/human_observer.yaml"), "human_observer").expect("params");
    params.urdf = root().join("config/robot/lwr4plus.urdf").display().to_string();
    params.gestures = String::new();
    let model = RobotModel::from_urdf_file(&params.urdf).expect("URDF");
    let mut node = ObserverNode::new(model, params, None).expect("node");

    let person = Performer::new(4, BodySize::MEDIUM, Stance::new(0.1, -0.75, 1.57), 1).expect("performer");
    let mut script: Vec<(f64, Input)> = (0..40).map(|k| (k as f64 * 0.05, Input::JointState(joint_state(k as f64 * 0.05)))).collect();
    for k in 0..36 {
        let t = 0.2 + k as f64 / 30.0;
        let mut m = skeleton(&person, t);
        if k == 20 {
            m.poses[5].position.z = f64::NAN;
        }
        script.push((t, Input::Skeleton(m)));
    }
    // An incomplete joint state, a 10 kB speech string, stop and repeat.
    script.push((0.5, Input::JointState(JointState { name: vec!["x".into()], position: vec![1.0], ..Default::default() })));
    script.push((0.6, Input::Speech(RosString::new(&"blah ".repeat(2000)))));
    script.push((0.9, Input::Speech(RosString::new("stop"))));
    script.push((1.1, Input::Speech(RosString::new("repeat"))));
    let mut source = ScriptedSource::new(script, 3.0);

    let mut lines = Vec::new();
    let summary = human_observer::run_loop(&mut source, &mut node, &mut |out| {
        lines.push(
            match out {
                Output::State(s) => json!({
                    "state": r4(s.header.stamp.to_secs_f64()), "present": s.present, "mode": s.mode,
                    "distance": r4(s.distance), "speed_scale": r4(s.speed_scale), "stopped": s.stopped,
                }),
                Output::Gesture(g) => json!({ "gesture": g.label }),
                Output::Markers(m) => json!({ "markers": m.markers.len() }),
                Output::FollowJoints(i, m) => json!({ "follow": i, "position": m.position }),
                Output::Warning(w) => json!({ "warning": w.kind, "message": w.message }),
            }
            .to_string(),
        );
    });
    assert_eq!(summary.skeletons, 36);
    // What the golden file must show, checked here so a rewrite cannot bless a regression.
    let text = lines.join("\n");
    assert!(text.contains("\"warning\":\"/human/skeleton:poses[5].position\""), "the NaN frame is reported by field");
    assert!(text.contains("\"warning\":\"/joint_states\""), "the incomplete joint state is reported");
    assert!(text.contains("\"stopped\":true") && text.contains("\"speed_scale\":0.0"), "spoken stop holds the robot");
    let last_state = lines.iter().rev().find(|l| l.contains("\"state\""));
    assert!(last_state.is_some_and(|l| l.contains("\"present\":false")), "silence drops the person: {last_state:?}");
    assert_golden(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/observer.jsonl"), &lines);
}
