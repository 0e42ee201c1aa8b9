//! Task transition control over DDS (thesis Sec. 4.1.2): `lwr_sim` in execute mode (a push on
//! `/external_wrench` is reported on `/lwr/external_wrench`, the arm moves only as commanded)
//! + `ds_controller` (TTC enabled by `config/ds_controller.yaml`), on `/clock` time, a private
//! domain. A client plays fDED and the human observer, runs a constant-speed primitive and
//! pushes the tool: a light push (< f_i) leaves the end effector on its path, a firm one
//! (> f_s) takes it along. Judged from `/joint_states` (forward kinematics), not from commands.
//!
//! `cargo test -p ds_controller --test ttc_over_dds -- --nocapture` prints the figures.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3, Wrench, WrenchStamped};
use cowork_msgs::msg::{HumanState, LinkDistance, LinkDistances, MotionCommand, MotionStatus};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Header;
use cowork_robot::{JointVector, RobotModel};
use cowork_ros::{NodeConfig, RosNode, qos};
use cowork_sim::{Scene, Simulator};
use ds_controller::{Params, RunOptions};
use lwr_sim::{LwrSim, LwrSimConfig, Pacing, WrenchMode};
use nalgebra::Vector3 as V3;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Distance of `p` from the line through `a` along unit `u`, and the offset vector.
fn off_line(p: &V3<f64>, a: &V3<f64>, u: &V3<f64>) -> V3<f64> {
    let d = p - a;
    d - u * u.dot(&d)
}

#[test]
fn a_light_push_is_absorbed_and_a_firm_push_takes_the_end_effector_along() {
    cowork_ros::init_logging();
    let domain = cowork_ros::domain::test_domain("ds_controller ttc test");
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let mut sim_config: LwrSimConfig =
        cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("lwr_sim params");
    sim_config.depth.enabled = false;
    sim_config.external_wrench.mode = WrenchMode::Execute;
    let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
    let sim = Simulator::new(model.clone(), scene, sim_config.simulation.clone()).expect("simulator");
    let sim_node =
        RosNode::new("lwr_sim", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("sim node");
    let lwr = LwrSim::new(sim, sim_config);
    let _sim = std::thread::spawn(move || lwr_sim::run(sim_node, lwr, Pacing::Rate(1.0), Some(50.0)));

    let mut params: Params =
        cowork_ros::params::load(&root().join("config/ds_controller.yaml"), "ds_controller").expect("params");
    assert!(params.controller.ttc.enabled, "config/ds_controller.yaml enables TTC");
    params.use_sim_time = true;
    params.scene_objects.scene = root().join(&params.scene_objects.scene).display().to_string();
    params.validate("ds_controller.yaml").expect("valid params");
    let (f_i, f_s) = (params.controller.ttc.insert_force, params.controller.ttc.switch_force);
    let stop = Arc::new(AtomicBool::new(false));
    let ctl_node = RosNode::new(
        "ds_controller",
        &NodeConfig { domain_id: Some(domain), use_sim_time: true, ..Default::default() },
    )
    .expect("controller node");
    let options = RunOptions { duration_s: Some(60.0), stop: Some(Arc::clone(&stop)) };
    let ctl_model = model.clone();
    let controller = std::thread::spawn(move || ds_controller::run(ctl_node, ctl_model, &params, &options));

    let mut node =
        RosNode::new("test_client", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("client");
    let distances = node.publisher::<LinkDistances>("/fded/distances", &qos::reliable()).expect("pub");
    let human = node.publisher::<HumanState>("/human/state", &qos::reliable()).expect("pub");
    let command = node.publisher::<MotionCommand>("/motion/command", &qos::reliable_depth(10)).expect("pub");
    let push = node.publisher::<WrenchStamped>("/external_wrench", &qos::reliable_depth(100)).expect("pub");
    let status = node.subscription::<MotionStatus>("/motion/status", &qos::reliable_depth(100)).expect("sub");
    let joints = node.subscription::<JointState>("/joint_states", &qos::reliable()).expect("sub");
    let reports = node.subscription::<WrenchStamped>("/lwr/external_wrench", &qos::reliable_depth(1000)).expect("sub");
    let link_names = model.link_names().to_vec();

    // Newest (sim time, q); every TCP sample with its sim time.
    let mut last: Option<(f64, JointVector)> = None;
    let mut reasons: Vec<String> = Vec::new();
    let mut report_frames: Vec<String> = Vec::new();
    let tcp = |q: &JointVector| model.link_pose(q, model.tip_link()).translation.vector;
    let pump = |last: &mut Option<(f64, JointVector)>, reasons: &mut Vec<String>, frames: &mut Vec<String>| {
        while let Some(js) = joints.take() {
            *last = Some((js.header.stamp.to_secs_f64(), JointVector::from_column_slice(&js.position)));
        }
        while let Some(s) = status.take() {
            if reasons.last() != Some(&s.reason) {
                reasons.push(s.reason);
            }
        }
        while let Some(w) = reports.take() {
            if frames.last() != Some(&w.header.frame_id) {
                frames.push(w.header.frame_id);
            }
        }
    };
    let header = |t: f64, frame: &str| Header { stamp: Time::from_nanos((t * 1e9) as i64), frame_id: frame.into() };
    let feed = |t: f64| {
        let links = link_names.iter().map(|n| LinkDistance { link_name: n.clone(), ..Default::default() }).collect();
        distances
            .publish(LinkDistances { header: header(t, "lwr_base_link"), links, min_index: -1, backend: "test".into(), ..Default::default() })
            .expect("pub");
        human
            .publish(HumanState { header: header(t, "lwr_base_link"), mode: HumanState::MODE_FAR, speed_scale: 0.3, ..Default::default() })
            .expect("pub");
    };

    let deadline = Instant::now() + Duration::from_secs(30);
    while !(command.subscription_count(&node) > 0
        && push.subscription_count(&node) > 0
        && status.publisher_count(&node) > 0
        && reports.publisher_count(&node) > 0
        && last.is_some())
    {
        assert!(Instant::now() < deadline, "graph not discovered within 30 s");
        pump(&mut last, &mut reasons, &mut report_frames);
        std::thread::sleep(Duration::from_millis(5));
    }
    let (t_start, q0) = last.expect("joint states");
    let x0 = tcp(&q0);
    // 0.05 m/s towards a goal 30 cm away along +y (6 s).
    let goal = x0 + V3::new(0.0, 0.30, 0.0);
    let dir = (goal - x0).normalize();
    command
        .publish(MotionCommand {
            id: 1,
            kind: MotionCommand::KIND_CONSTANT_SPEED,
            label: "ttc test".into(),
            goal: Pose {
                position: Point { x: goal.x, y: goal.y, z: goal.z },
                orientation: Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 },
            },
            nominal_speed: 0.05,
            hold_orientation: true,
            ..Default::default()
        })
        .expect("pub");

    // Phases in simulated seconds after the command: light push on the tool 1.0–2.5 s,
    // nothing 2.5–3.0 s, firm push 3.0–4.0 s, both towards −x (across the path).
    let light = 0.6 * f_i;
    let firm = f_s + 10.0;
    let push_dir = V3::new(-1.0, 0.0, 0.0);
    let mut light_dev: f64 = 0.0;
    let mut firm_end = V3::zeros();
    let mut firm_dev: f64 = 0.0;
    let wall_end = Instant::now() + Duration::from_secs(40);
    let mut next_feed = Instant::now();
    loop {
        pump(&mut last, &mut reasons, &mut report_frames);
        let (t, q) = last.expect("joint states");
        let s = t - t_start;
        if s >= 4.2 {
            break;
        }
        assert!(Instant::now() < wall_end, "simulated time too slow: {s:.2} s in 40 s");
        if Instant::now() >= next_feed {
            feed(t);
            let f = if (1.0..2.5).contains(&s) {
                Some(light)
            } else if (3.0..4.0).contains(&s) {
                Some(firm)
            } else {
                None
            };
            if let Some(f) = f {
                let v = push_dir * f;
                push.publish(WrenchStamped {
                    header: header(t, ""),
                    wrench: Wrench { force: Vector3 { x: v.x, y: v.y, z: v.z }, torque: Vector3::default() },
                })
                .expect("pub");
            }
            next_feed += Duration::from_millis(5);
        }
        let off = off_line(&tcp(&q), &x0, &dir);
        if (1.0..2.6).contains(&s) {
            light_dev = light_dev.max(off.norm());
        }
        if (3.0..4.1).contains(&s) {
            firm_dev = firm_dev.max(off.norm());
            firm_end = off;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let along = firm_end.dot(&push_dir);
    eprintln!(
        "light push {light:.1} N (< f_i = {f_i} N) for 1.5 s: end effector off its path by at most {:.2} mm; \
         firm push {firm:.1} N (> f_s = {f_s} N) for 1 s: {:.1} mm off the path, {:.1} mm along the push",
        light_dev * 1e3,
        firm_dev * 1e3,
        along * 1e3
    );
    eprintln!("statuses: {reasons:?}; /lwr/external_wrench frames: {report_frames:?}");
    stop.store(true, Ordering::SeqCst);
    controller.join().expect("controller thread").expect("ds_controller run");

    let tool = model.link_names()[model.tip_link()].clone();
    assert_eq!(report_frames, vec![tool], "lwr_sim reported the pushes on the tool link");
    // Admittance (teach mode) would have moved the tool c f t = 0.005 × 3 × 1.5 = 22 mm.
    assert!(light_dev < 0.003, "a light push moved the end effector {light_dev} m off its path");
    // c f = 0.125 m/s once [T_ic, T_ee] is in (≈ 0.5 s to blend): ≥ 5 cm along the push.
    assert!(along > 0.05, "a firm push moved the end effector only {along} m along it");
    assert!(along > 0.8 * firm_end.norm(), "the end effector left along the push: {firm_end:?}");
    assert!(reasons.iter().any(|r| r.contains("guided") && r.contains("[T_ic, T_ee]")), "statuses: {reasons:?}");
}
