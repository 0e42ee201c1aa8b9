//! Stream fuzzing of the nodes' message handlers: one node instance per target lives across
//! all inputs, so its state (clocks, filters, mode, teaching, the last world) accumulates as it
//! would over a long run with a misbehaving peer. An input is one message: its first byte picks
//! the subscription, the rest is the CDR payload; what decodes goes to the node's handler
//! exactly as its run loop hands it over, then the node's clock advances and it ticks.
//!
//! Besides "no panic", each target asserts what a message must never do to the robot (the
//! assertion failing counts as a panic, a finding): `lwr_sim`'s joints stay finite and inside
//! their limits, `human_observer`'s speed scale stays finite and non-negative, `robot_manager`
//! never sends ds_controller a motion with a non-finite goal or speed, `fded_distance` never
//! reports a NaN distance.

use std::path::Path;

use anyhow::{Context, Result};
use cowork_msgs::RosMessage;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::{from_cdr, to_cdr};
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{
    ActionCommand, Gesture, MotionStatus, ObjectStream, RobotStream, Skeleton, WorldObject, WorldState,
};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::{Float64MultiArray, Header, String as RosString};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::geometry_msgs::WrenchStamped;
use cowork_robot::RobotModel;

use crate::{Target, Verdict};

/// Family of these targets in the table.
const FAMILY: &str = "node handlers (message streams)";

/// `[kind, CDR...]` seeds: each seed payload prefixed with the index of its subscription.
fn seeds(kinds: &[Vec<Vec<u8>>]) -> Vec<Vec<u8>> {
    kinds
        .iter()
        .enumerate()
        .flat_map(|(k, payloads)| {
            payloads.iter().map(move |p| {
                let mut s = Vec::with_capacity(p.len() + 1);
                s.push(k as u8);
                s.extend_from_slice(p);
                s
            })
        })
        .collect()
}

/// Payloads of `T` from the seed bags (at most 4 per topic) plus `extra`.
fn payloads<T: RosMessage>(bag: &[(String, Vec<u8>)], extra: &[T]) -> Vec<Vec<u8>> {
    let name = T::type_name();
    let mut out: Vec<Vec<u8>> = bag.iter().filter(|(t, _)| *t == name).map(|(_, d)| d.clone()).collect();
    out.extend(extra.iter().map(to_cdr));
    out
}

fn split(b: &[u8], kinds: usize) -> Option<(usize, &[u8])> {
    let (&k, rest) = b.split_first()?;
    Some((usize::from(k) % kinds, rest))
}

fn pose(x: f64, y: f64, z: f64) -> Pose {
    Pose { position: Point { x, y, z }, orientation: Quaternion { x: 1.0, y: 0.0, z: 0.0, w: 0.0 } }
}

fn world() -> WorldState {
    WorldState {
        header: Header { stamp: Time::from_secs_f64(1.0), frame_id: "lwr_base_link".into() },
        gripper_state: WorldState::GRIPPER_OPEN,
        held_object: String::new(),
        tool_pose: pose(0.45, 0.35, 0.25),
        objects: vec![
            WorldObject { name: "bottle".into(), pose: pose(0.45, 0.35, 0.11), tool_distance: 0.1, ..Default::default() },
            WorldObject { name: "cup".into(), pose: pose(0.6, 0.0, 0.05), tool_distance: 0.4, ..Default::default() },
        ],
    }
}

fn words(ws: &[&str]) -> Vec<RosString> {
    ws.iter().map(|w| RosString { data: (*w).to_owned() }).collect()
}

/// Every stream target.
pub(crate) fn targets(root: &Path, bag: &[(String, Vec<u8>)]) -> Result<Vec<Target>> {
    let model = RobotModel::from_urdf_file(root.join("config/robot/lwr4plus.urdf")).context("URDF")?;
    Ok(vec![
        lwr_sim_target(root, bag, model.clone())?,
        human_observer_target(root, bag, model.clone())?,
        robot_manager_target(root)?,
        supervisor_target(root, bag)?,
        fded_target(root, bag, model)?,
    ])
}

fn lwr_sim_target(root: &Path, bag: &[(String, Vec<u8>)], model: RobotModel) -> Result<Target> {
    let config: lwr_sim::LwrSimConfig = cowork_ros::params::load(&root.join("config/lwr_sim.yaml"), "lwr_sim")?;
    let scene = cowork_sim::Scene::from_file(&root.join("config/scenes/kitchen.yaml"))?;
    let limits = *model.joint_limits();
    let sim = cowork_sim::Simulator::new(model, scene, config.simulation.clone())?;
    let mut node = lwr_sim::LwrSim::new(sim, config);
    let kinds = vec![
        payloads::<Float64MultiArray>(bag, &[Float64MultiArray { data: vec![0.3, -0.2, 0.2, 0.4, -0.3, 0.2, 0.5], ..Default::default() }]),
        payloads::<RosString>(bag, &words(&["close", "open"])),
        payloads::<WrenchStamped>(bag, &[]),
        payloads::<Skeleton>(bag, &[]),
    ];
    Ok(Target {
        name: "stream lwr_sim".into(),
        family: FAMILY,
        seeds: seeds(&kinds),
        dictionary: &[],
        max_len: 1 << 16,
        cost: 4,
        check: Box::new(move |b| {
            let Some((k, cdr)) = split(b, 4) else { return Verdict::Refused };
            let decoded = match k {
                0 => from_cdr::<Float64MultiArray>(cdr).map(|m| node.on_velocity_command(0, &m)),
                1 => from_cdr::<RosString>(cdr).map(|m| node.on_gripper_command(0, &m)),
                2 => from_cdr::<WrenchStamped>(cdr).map(|m| node.on_wrench(0, &m)),
                _ => from_cdr::<Skeleton>(cdr).map(|m| node.on_skeleton(&m)),
            };
            for _ in 0..10 {
                node.step();
            }
            let q = node.simulator().joint_positions();
            for (i, l) in limits.iter().enumerate() {
                assert!(
                    q[i].is_finite() && q[i] >= l.lower - 1e-9 && q[i] <= l.upper + 1e-9,
                    "joint {i} at {} outside [{}, {}] after a message",
                    q[i],
                    l.lower,
                    l.upper
                );
            }
            assert!(node.simulator().joint_velocities().iter().all(|v| v.is_finite()), "non-finite joint velocity");
            if decoded.is_ok() { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}

fn human_observer_target(root: &Path, bag: &[(String, Vec<u8>)], model: RobotModel) -> Result<Target> {
    let mut params: human_observer::Params =
        cowork_ros::params::load(&root.join("config/human_observer.yaml"), "human_observer")?;
    params.urdf = root.join("config/robot/lwr4plus.urdf").display().to_string();
    let gestures = cowork_observer::GestureModel::from_file(&root.join("config/gestures.json"))?;
    let mut node = human_observer::ObserverNode::new(model, params, Some(gestures))?;
    let kinds = vec![
        payloads::<JointState>(bag, &[]),
        payloads::<RosString>(bag, &words(&["stop", "come", "handover right"])),
        payloads::<Skeleton>(bag, &[]),
    ];
    let mut now = 0.0;
    Ok(Target {
        name: "stream human_observer".into(),
        family: FAMILY,
        seeds: seeds(&kinds),
        dictionary: &[],
        max_len: 1 << 16,
        cost: 4,
        check: Box::new(move |b| {
            let Some((k, cdr)) = split(b, 3) else { return Verdict::Refused };
            now += 1.0 / 30.0;
            let ok = match k {
                0 => from_cdr::<JointState>(cdr).map(|m| drop(node.on_joint_state(&m))).is_ok(),
                1 => from_cdr::<RosString>(cdr).map(|m| node.on_speech(&m)).is_ok(),
                _ => match from_cdr::<Skeleton>(cdr) {
                    Ok(m) => {
                        let out = node.on_skeleton(&m);
                        assert!(out.state.speed_scale.is_finite() && out.state.speed_scale >= 0.0, "speed {}", out.state.speed_scale);
                        true
                    }
                    Err(_) => false,
                },
            };
            if let Some(s) = node.on_tick(now) {
                assert!(s.speed_scale.is_finite() && s.speed_scale >= 0.0, "speed scale {} on /human/state", s.speed_scale);
            }
            if ok { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}

fn robot_manager_target(root: &Path) -> Result<Target> {
    let dir = tempfile::tempdir().context("database directory")?;
    let mut params: robot_manager::Params =
        cowork_ros::params::load(&root.join("config/robot_manager.yaml"), "robot_manager")?;
    params.database_dir = dir.path().display().to_string();
    let (mut node, _problem) = robot_manager::RobotManagerNode::new(params, 1);
    let mut out = robot_manager::Outbox::default();
    let kinds = vec![
        vec![to_cdr(&world())],
        words(&["teach", "done", "gripper close", "gripper open", "stop", "repeat"]).iter().map(to_cdr).collect(),
        vec![to_cdr(&ActionCommand { id: 3, label: "foa1(water)".into(), ..Default::default() })],
        vec![to_cdr(&MotionStatus { command_id: 1, state: MotionStatus::STATE_CONVERGED, ..Default::default() })],
        vec![to_cdr(&Gesture { label: "stop".into(), confidence: 0.9, ..Default::default() })],
    ];
    let mut t = 0.0;
    Ok(Target {
        name: "stream robot_manager".into(),
        family: FAMILY,
        seeds: seeds(&kinds),
        dictionary: &[],
        max_len: 1 << 14,
        cost: 4,
        check: Box::new(move |b| {
            let _keep = &dir;
            let Some((k, cdr)) = split(b, 5) else { return Verdict::Refused };
            t += 0.02;
            let now = cowork_manager::Stamp { t, unix_s: 1 };
            out.clear();
            let ok = match k {
                0 => from_cdr::<WorldState>(cdr).map(|m| node.on_world(&m, now, &mut out)).is_ok(),
                1 => from_cdr::<RosString>(cdr).map(|m| node.on_speech(&m, now, &mut out)).is_ok(),
                2 => from_cdr::<ActionCommand>(cdr).map(|m| node.on_action(&m, now, &mut out)).is_ok(),
                3 => from_cdr::<MotionStatus>(cdr).map(|m| node.on_motion_status(&m, now, &mut out)).is_ok(),
                _ => from_cdr::<Gesture>(cdr).map(|m| node.on_gesture(&m, now, &mut out)).is_ok(),
            };
            node.tick(now, &mut out);
            for m in &out.motion {
                let p = &m.goal.position;
                assert!(
                    [p.x, p.y, p.z, m.nominal_speed].iter().all(|v| v.is_finite()),
                    "motion command {} with a non-finite goal or speed: {m:?}",
                    m.id
                );
            }
            if ok { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}

fn supervisor_target(root: &Path, bag: &[(String, Vec<u8>)]) -> Result<Target> {
    let params: attentional_supervisor::Params =
        cowork_ros::params::load(&root.join("config/attentional_supervisor.yaml"), "attentional_supervisor")?;
    let ltm = cowork_supervisor::Ltm::load(&root.join("config/learned/kitchen.learned.schema"))?;
    let sup = cowork_supervisor::Supervisor::new(ltm, "pourDrink", params.attention.clone())?;
    let mut node = attentional_supervisor::SupervisorNode::new(sup, &params);
    let kinds = vec![
        vec![to_cdr(&ObjectStream::default())],
        vec![to_cdr(&RobotStream::default())],
        payloads::<RosString>(bag, &words(&["stop", "repeat", "human add(water)", "teach", "done"])),
    ];
    let mut t = 0.0;
    let mut actions = Vec::new();
    Ok(Target {
        name: "stream attentional_supervisor".into(),
        family: FAMILY,
        seeds: seeds(&kinds),
        dictionary: &[],
        max_len: 1 << 14,
        cost: 4,
        check: Box::new(move |b| {
            let Some((k, cdr)) = split(b, 3) else { return Verdict::Refused };
            t += 0.02;
            let ok = match k {
                0 => from_cdr::<ObjectStream>(cdr).map(|m| node.on_object_stream(&m)).is_ok(),
                1 => from_cdr::<RobotStream>(cdr).map(|m| node.on_robot_stream(&m)).is_ok(),
                _ => from_cdr::<RosString>(cdr).map(|m| node.on_speech(&m)).is_ok(),
            };
            actions.clear();
            node.tick(Time::from_secs_f64(t), &mut actions);
            if ok { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}

fn fded_target(root: &Path, bag: &[(String, Vec<u8>)], model: RobotModel) -> Result<Target> {
    let mut params: fded_distance::Params =
        cowork_ros::params::load(&root.join("config/fded_distance.yaml"), "fded_distance")?;
    params.backend = "cpu".into();
    params.manipulated.scene = root.join("config/scenes/kitchen.yaml").display().to_string();
    let mut node = fded_distance::FdedNode::new(model, params)?;
    let kinds = vec![
        payloads::<CameraInfo>(bag, &[]),
        payloads::<JointState>(bag, &[]),
        payloads::<TFMessage>(bag, &[]),
        vec![to_cdr(&ObjectStream::default())],
        payloads::<Image>(bag, &[]),
    ];
    Ok(Target {
        name: "stream fded_distance".into(),
        family: FAMILY,
        seeds: seeds(&kinds),
        dictionary: &[],
        max_len: 4 << 20,
        cost: 40,
        check: Box::new(move |b| {
            let Some((k, cdr)) = split(b, 5) else { return Verdict::Refused };
            let ok = match k {
                0 => from_cdr::<CameraInfo>(cdr).is_ok_and(|m| node.on_camera_info(&m).is_ok()),
                1 => from_cdr::<JointState>(cdr).is_ok_and(|m| node.on_joint_state(&m).is_ok()),
                2 => from_cdr::<TFMessage>(cdr).is_ok_and(|m| node.on_tf_static(&m).is_ok()),
                3 => from_cdr::<ObjectStream>(cdr).is_ok_and(|m| node.on_manipulated(&m).is_ok()),
                _ => match from_cdr::<Image>(cdr) {
                    Ok(m) => match node.on_depth(&m) {
                        Ok(d) => {
                            assert!(d.links.iter().all(|l| !l.distance.is_nan()), "NaN distance reported");
                            true
                        }
                        Err(_) => false,
                    },
                    Err(_) => false,
                },
            };
            if ok { Verdict::Accepted } else { Verdict::Refused }
        }),
    })
}
