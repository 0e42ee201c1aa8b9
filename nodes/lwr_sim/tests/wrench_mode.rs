//! `/external_wrench` in teach mode (the arm yields by admittance) and execute mode (the arm
//! stays, the push is reported on `/lwr/external_wrench` with its link frame), step by step
//! without a network.

use cowork_msgs::geometry_msgs::{Vector3, Wrench as RosWrench, WrenchStamped};
use cowork_msgs::std_msgs::Header;
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use lwr_sim::{LwrSim, LwrSimConfig, WrenchMode};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn node(mode: Option<WrenchMode>) -> LwrSim {
    let config: LwrSimConfig =
        cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("bundled parameters load");
    config.validate("lwr_sim.yaml").expect("valid");
    assert_eq!(config.external_wrench.mode, WrenchMode::Teach, "teach is the bundled default");
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
    let mut n = LwrSim::new(Simulator::new(model, scene, config.simulation.clone()).expect("sim"), config);
    if let Some(m) = mode {
        n.set_wrench_mode(m);
    }
    n
}

fn push(frame: &str, f: [f64; 3]) -> WrenchStamped {
    WrenchStamped {
        header: Header { frame_id: frame.into(), ..Default::default() },
        wrench: RosWrench { force: Vector3 { x: f[0], y: f[1], z: f[2] }, torque: Vector3::default() },
    }
}

/// 0.5 s with a push renewed every 10 ms; returns the joint travel and the reports.
fn run(n: &mut LwrSim, w: &WrenchStamped) -> (f64, Vec<WrenchStamped>) {
    let q0 = *n.simulator().joint_positions();
    let mut reports = Vec::new();
    for k in 0..500 {
        if k % 10 == 0 {
            n.on_wrench(0, w);
        }
        if n.step().wrench {
            reports.extend(n.reported_wrench(0));
        }
    }
    ((n.simulator().joint_positions() - q0).norm(), reports)
}

#[test]
fn teach_mode_moves_the_arm_and_reports_nothing() {
    let mut n = node(None);
    let (moved, reports) = run(&mut n, &push("", [0.0, 0.0, 20.0]));
    assert!(moved > 0.01, "admittance moved the joints {moved} rad");
    assert!(reports.is_empty());
}

#[test]
fn execute_mode_keeps_the_arm_and_reports_the_push_in_the_link_frame() {
    let mut n = node(Some(WrenchMode::Execute));
    let model = n.simulator().model().clone();
    let elbow = model.joint_link(3);
    let name = model.link_names()[elbow].clone();
    // A base-frame push at the tool (empty frame): reported on the tool link.
    let (moved, reports) = run(&mut n, &push("", [0.0, 0.0, 20.0]));
    assert_eq!(moved, 0.0, "the arm moved by itself in execute mode");
    assert_eq!(reports.len(), 500, "one report per step at 1 kHz");
    let tool = &model.link_names()[model.tip_link()];
    assert!(reports.iter().all(|r| &r.header.frame_id == tool));
    let r = reports.last().expect("report");
    let rot = n.simulator().link_poses().get(model.tip_link()).rotation;
    let f = rot * nalgebra::Vector3::new(r.wrench.force.x, r.wrench.force.y, r.wrench.force.z);
    assert!((f - nalgebra::Vector3::new(0.0, 0.0, 20.0)).norm() < 1e-9, "base-frame force {f:?}");
    assert_eq!(r.header.stamp, n.now());
    // A push on the elbow in its own frame: reported on the elbow with the same components.
    let (_, reports) = run(&mut n, &push(&name, [3.0, -4.0, 12.0]));
    let r = reports.last().expect("report");
    assert_eq!(r.header.frame_id, name);
    let g = &r.wrench.force;
    assert!((g.x - 3.0).abs() < 1e-9 && (g.y + 4.0).abs() < 1e-9 && (g.z - 12.0).abs() < 1e-9, "{g:?}");
    // The push ends (its last message 10 steps ago): reports stop wrench_timeout_s (0.1 s)
    // after it.
    let mut after = 0;
    for _ in 0..300 {
        if n.step().wrench {
            after += 1;
        }
    }
    assert!((89..=92).contains(&after), "reports after the last push: {after}");
    // A NaN push is refused, nothing reported; an unknown frame too.
    let (_, reports) = run(&mut n, &push(&name, [f64::NAN, 0.0, 1.0]));
    assert!(reports.is_empty());
    let (_, reports) = run(&mut n, &push("elbow", [0.0, 0.0, 10.0]));
    assert!(reports.is_empty());
}
