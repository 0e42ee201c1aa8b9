//! `/lwr/external_wrench` in ds_controller without DDS: the adapter turns a push on a link
//! (force in the link's frame) into the controller's base-frame `ExternalWrench` and refuses
//! bad ones naming why; the real-time step with a push allocates nothing and blends it in.

use std::path::PathBuf;

use cowork_ds::primitive::ConstantSpeed;
use cowork_ds::{ControlOutput, DsController, ExternalWrench, HumanInput, HumanState, MotionCommand, Primitive, Distances};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Vector3, Wrench, WrenchStamped};
use cowork_msgs::std_msgs::Header;
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use ds_controller::{Adapter, Params, RtInputs, rt_step};
use std::hint::black_box;

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

fn model() -> RobotModel {
    RobotModel::from_urdf_file(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/robot/lwr4plus.urdf")).expect("URDF")
}

fn q() -> JointVector {
    JointVector::from_row_slice(&[0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0])
}

fn msg(frame: &str, stamp: f64, f: [f64; 3]) -> WrenchStamped {
    WrenchStamped {
        header: Header { stamp: Time::from_nanos((stamp * 1e9) as i64), frame_id: frame.into() },
        wrench: Wrench { force: Vector3 { x: f[0], y: f[1], z: f[2] }, torque: Vector3::default() },
    }
}

fn params() -> Params {
    let mut p = Params::default();
    p.controller.ttc.enabled = true;
    p
}

#[test]
fn a_push_in_a_link_frame_becomes_a_base_frame_force_on_that_link() {
    let model = model();
    let adapter = Adapter::new(&model, &params());
    let elbow = model.joint_link(3);
    let name = &model.link_names()[elbow];
    let w = adapter.wrench(&msg(name, 10.0, [1.0, 2.0, 3.0]), Some(&q()), 10.01).expect("accepted");
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q(), &mut poses);
    let want = poses.get(elbow).rotation * nalgebra::Vector3::new(1.0, 2.0, 3.0);
    assert_eq!(w.link, elbow);
    assert!((w.force - want).norm() < 1e-12, "{:?} vs {want:?}", w.force);
    assert!((w.stamp - 10.0).abs() < 1e-9);
}

#[test]
fn bad_pushes_are_refused_naming_why() {
    let model = model();
    let adapter = Adapter::new(&model, &params());
    let tool = model.link_names()[model.tip_link()].clone();
    for (m, q, now, has) in [
        (msg("elbow", 1.0, [0.0, 0.0, 10.0]), Some(q()), 1.0, "unknown contact frame \"elbow\""),
        (msg("", 1.0, [0.0, 0.0, 10.0]), Some(q()), 1.0, "unknown contact frame \"\""),
        (msg(&tool, 1.0, [f64::NAN, 0.0, 10.0]), Some(q()), 1.0, "non-finite force"),
        (msg(&tool, 1.0, [0.0, f64::INFINITY, 0.0]), Some(q()), 1.0, "non-finite force"),
        (msg(&tool, 1.0, [0.0, 0.0, 1e4]), Some(q()), 1.0, "exceeds ttc.max_force"),
        (msg(&tool, 1.0, [0.0, 0.0, 10.0]), Some(q()), 1.2, "stale"),
        (msg(&tool, 1.2, [0.0, 0.0, 10.0]), Some(q()), 1.0, "stale"),
        (msg(&tool, 1.0, [0.0, 0.0, 10.0]), None, 1.0, "no /joint_states yet"),
    ] {
        let e = adapter.wrench(&m, q.as_ref(), now).expect_err(has);
        assert!(e.reason.contains(has), "{has}: {}", e.reason);
    }
}

#[test]
fn real_time_steps_with_a_push_allocate_nothing_and_take_the_tool_along() {
    let model = model();
    let mut ctl = DsController::new(model.clone(), params().controller).expect("config");
    let tip = model.tip_link();
    let mut q = q();
    let x0 = model.link_pose(&q, tip).translation.vector;
    let mut inputs = RtInputs {
        command: MotionCommand {
            id: 1,
            primitive: Primitive::ConstantSpeed(ConstantSpeed::new(0.05)),
            goal: x0 + nalgebra::Vector3::new(0.0, 0.2, 0.0),
            orientation: None,
            end_effector_avoidance: true,
        },
        ..RtInputs::default()
    };
    let mut out = ControlOutput::default();
    let before = cowork_testkit::allocations();
    let mut guided = 0;
    for k in 0..2000 {
        let t = k as f64 * 1e-3;
        inputs.joints = Some((q, t));
        inputs.distances = Distances::clear(t);
        inputs.human = HumanInput { stamp: t, state: HumanState::default() };
        // 25 N towards −x on the tool from 0.2 s to 1.5 s.
        inputs.wrench = (200..1500).contains(&k).then_some(ExternalWrench { stamp: t, link: tip, force: nalgebra::Vector3::new(-25.0, 0.0, 0.0) });
        let o = rt_step(&mut ctl, &inputs, t, None, &mut out);
        guided += usize::from(o.guided.is_some());
        q += o.qdot * 1e-3;
        black_box(&o);
    }
    assert_eq!(cowork_testkit::allocations() - before, 0, "allocations in 2000 real-time steps with a push");
    let x = model.link_pose(&q, tip).translation.vector;
    assert!(x0.x - x.x > 0.1, "the tool went {} m along the push", x0.x - x.x);
    assert!(guided > 1000, "guided steps {guided}");
}
