//! `/motion/command` of kind `KIND_JOINTS` (a move in joint space): decoded into
//! `Primitive::Joints` with the tool's position at the goal joints as the goal, or refused with a
//! reason naming what is wrong.

use std::path::PathBuf;

use cowork_ds::{JointMove, Primitive};
use cowork_msgs::msg::MotionCommand as MotionCommandMsg;
use cowork_robot::{JointVector, RobotModel};
use ds_controller::{Adapter, Params};

fn lwr() -> RobotModel {
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(urdf).expect("URDF")
}

fn command(parameters: Vec<f64>) -> MotionCommandMsg {
    MotionCommandMsg { id: 3, kind: MotionCommandMsg::KIND_JOINTS, label: "foa1(water)".into(), parameters, ..Default::default() }
}

/// The kitchen's ready pose (rad).
fn ready() -> Vec<f64> {
    [0.0f64, 30.0, 0.0, 90.0, 0.0, 60.0, 0.0].iter().map(|d| d.to_radians()).collect()
}

#[test]
fn a_joint_move_is_decoded_with_the_tools_position_at_its_goal() {
    let model = lwr();
    let adapter = Adapter::new(&model, &Params::default());
    let (cmd, learned) = adapter.command(&command(ready().into_iter().chain([2.0, 0.6]).collect())).expect("accepted");
    assert!(learned.is_none());
    let Primitive::Joints(JointMove { joints, gain, max_speed }) = cmd.primitive else { panic!("{cmd:?}") };
    assert_eq!(joints.to_vec(), ready());
    assert_eq!((gain, max_speed), (2.0, 0.6));
    let tool = model.link_pose(&JointVector::from_row_slice(&joints), model.tip_link()).translation.vector;
    assert!((cmd.goal - tool).norm() < 1e-12, "goal {} vs tool {}", cmd.goal, tool);
    assert!(cmd.orientation.is_none(), "the orientation follows the joints");
}

#[test]
fn a_bad_joint_move_is_refused_with_the_reason() {
    let model = lwr();
    let adapter = Adapter::new(&model, &Params::default());
    let with = |edit: &dyn Fn(&mut Vec<f64>)| {
        let mut p: Vec<f64> = ready().into_iter().chain([2.0, 0.6]).collect();
        edit(&mut p);
        adapter.command(&command(p)).expect_err("refused").reason
    };
    let cases: [(&dyn Fn(&mut Vec<f64>), &str); 5] = [
        (&|p| p.truncate(8), "got 8 values"),
        (&|p| p[6] = 3.0, "joint 7 goal 3 rad is outside its limits"),
        (&|p| p[2] = f64::NAN, "joint 3 goal NaN rad is outside its limits"),
        (&|p| p[7] = f64::INFINITY, "gain = inf"),
        (&|p| p[8] = 0.0, "max_speed = 0"),
    ];
    for (edit, expected) in cases {
        let reason = with(edit);
        assert!(reason.contains(expected), "{reason:?} does not contain {expected:?}");
        assert!(reason.len() < 300, "short: {reason}");
    }
}
