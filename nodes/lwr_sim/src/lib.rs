//! The `lwr_sim` node: a thin ROS 2 adapter around [`cowork_sim::Simulator`].
//!
//! [`LwrSim`] turns messages into simulator inputs and simulator state into messages; it does no
//! I/O, so tests drive it directly. [`run`] wires it to DDS topics and paces simulated time.
//!
//! Inputs: `/lwr/joint_velocity_command` (std_msgs/Float64MultiArray, 7 values, rad/s),
//! `/lwr/gripper_command` (std_msgs/String `open` / `close`), `/external_wrench`
//! (geometry_msgs/WrenchStamped: expressed in `header.frame_id` and applied at its origin; an empty
//! frame or the base link means a base-frame wrench at the tool point). What a wrench does
//! depends on [`WrenchMode`]: in `teach` mode (the default) the arm yields to it by admittance
//! (zero-gravity kinesthetic teaching); in `execute` mode the arm does not move by itself: the
//! wrench is *reported* on `/lwr/external_wrench` (geometry_msgs/WrenchStamped, `header.frame_id`
//! = the contact link, force and torque in that link's frame, at `external_wrench.report_rate_hz`
//! while it acts) for the controller's task transition control (thesis Sec. 4.1.2), as the
//! LWR's joint torque sensors report a person's push while it runs a motion.
//! `/human/skeleton` (cowork_msgs/Skeleton, base frame): each person is drawn in the depth image
//! as a capsule body on the floor (see [`depth::People`]). `/lwr/place_object`
//! (cowork_msgs/WorldObject): a person moves a scene object (see [`person`]).
//! Outputs: `/clock`, `/joint_states`, `/tf` (link tree parent → child, objects), `/tf_static` (camera),
//! `/lwr/world` (cowork_msgs/WorldState: gripper, held object, tool pose, every object's pose,
//! tool distance and tilt, at `publish.world_rate_hz`; what the robot manager and the
//! experiments' success checks read),
//! `/camera/depth/image_raw` (sensor_msgs/Image, `32FC1` m or `16UC1` mm) and
//! `/camera/depth/camera_info` at the scene camera's `rate_hz` of simulated time (sensor-data
//! QoS), rendered by a worker thread from the newest state (see [`depth`]).

pub mod depth;
pub mod person;

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Transform, TransformStamped, Vector3, WrenchStamped};
use cowork_msgs::msg::{Skeleton, WorldObject, WorldState};
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::{Float64MultiArray, Header, String as RosString};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_ros::{RosNode, qos};
use cowork_sim::{GripperState, SimParams, Simulator, Wrench};
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

use crate::depth::{DepthCamera, DepthConfig, FrameClock, Mailbox, People};

/// Topic of [`LwrSim::world`].
pub const TOPIC_WORLD: &str = "/lwr/world";

/// Publication rates of the node, Hz of simulated time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PublishRates {
    /// `/clock`.
    pub clock_rate_hz: f64,
    /// `/joint_states`.
    pub joint_state_rate_hz: f64,
    /// `/tf` (links and objects).
    pub tf_rate_hz: f64,
    /// `/lwr/world` (grasp state and object poses).
    pub world_rate_hz: f64,
}

impl Default for PublishRates {
    fn default() -> Self {
        Self { clock_rate_hz: 1000.0, joint_state_rate_hz: 1000.0, tf_rate_hz: 50.0, world_rate_hz: 100.0 }
    }
}

/// Topic of [`LwrSim::reported_wrench`].
pub const TOPIC_EXTERNAL_WRENCH: &str = "/lwr/external_wrench";

/// What an `/external_wrench` does to the arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum WrenchMode {
    /// Kinesthetic teaching: the arm yields by admittance (ẋ = c f at the link), whatever
    /// the joint velocity command.
    #[default]
    Teach,
    /// Executing: the arm moves only as commanded; the wrench is reported on
    /// [`TOPIC_EXTERNAL_WRENCH`] for the controller.
    Execute,
}

/// The `external_wrench:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WrenchConfig {
    /// `teach` (admittance) or `execute` (reported).
    pub mode: WrenchMode,
    /// Rate of `/lwr/external_wrench` while a wrench acts (execute mode), Hz of simulated time.
    pub report_rate_hz: f64,
}

impl Default for WrenchConfig {
    fn default() -> Self {
        Self { mode: WrenchMode::Teach, report_rate_hz: 1000.0 }
    }
}

/// The `lwr_sim: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LwrSimConfig {
    /// Simulator parameters.
    pub simulation: SimParams,
    /// Topic rates.
    pub publish: PublishRates,
    /// The simulated depth camera.
    pub depth: DepthConfig,
    /// What an `/external_wrench` does (teach: admittance; execute: reported).
    pub external_wrench: WrenchConfig,
}

impl LwrSimConfig {
    /// Rejects NaN and out-of-range values; `place` names the file.
    pub fn validate(&self, place: &str) -> Result<()> {
        self.simulation.validate(place)?;
        let max = 1.0 / self.simulation.step_s;
        for (field, v) in [
            ("publish.clock_rate_hz", self.publish.clock_rate_hz),
            ("publish.joint_state_rate_hz", self.publish.joint_state_rate_hz),
            ("publish.tf_rate_hz", self.publish.tf_rate_hz),
            ("publish.world_rate_hz", self.publish.world_rate_hz),
            ("external_wrench.report_rate_hz", self.external_wrench.report_rate_hz),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                bail!("{place}: `{field}` = {v} must be in (0, {max}] Hz (one message per step at most)");
            }
        }
        self.depth.validate(place)?;
        Ok(())
    }
}

/// How simulated time relates to wall time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Pacing {
    /// Simulated seconds per wall second.
    Rate(f64),
    /// As fast as possible.
    Max,
}

impl Pacing {
    /// From `--rate R` / `--max`.
    pub fn from_args(rate: f64, max: bool) -> Result<Self> {
        if max {
            return Ok(Self::Max);
        }
        if !(rate.is_finite() && rate > 0.0) {
            bail!("--rate {rate}: must be a positive number (use --max for as fast as possible)");
        }
        Ok(Self::Rate(rate))
    }
}

/// What became due in one step.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Due {
    pub clock: bool,
    pub joint_states: bool,
    pub tf: bool,
    /// `/lwr/world`.
    pub world: bool,
    /// A depth camera frame (at the scene camera's rate).
    pub depth: bool,
    /// `/lwr/external_wrench` (execute mode, while a wrench acts).
    pub wrench: bool,
}

/// The simulator with its message conversions.
#[derive(Debug)]
pub struct LwrSim {
    sim: Simulator,
    every_clock: u64,
    every_joint_states: u64,
    every_tf: u64,
    every_world: u64,
    steps: u64,
    base_frame: String,
    joint_state: JointState,
    camera_clock: FrameClock,
    config_depth: DepthConfig,
    people: People,
    /// `Some` when wrenches are applied at their header stamps ([`follow_wrench_stamps`](Self::follow_wrench_stamps)).
    follow: Option<FollowWrench>,
    wrench_mode: WrenchMode,
    every_wrench: u64,
    wrench_timeout_ns: i64,
    /// Execute mode: the acting wrench (base frame), its link and when it arrived (ns).
    reported: Option<(Wrench, usize, i64)>,
}

/// Wrenches waiting for their stamp, and the newest stamp received (ns).
#[derive(Debug, Default)]
struct FollowWrench {
    pending: std::collections::VecDeque<WrenchStamped>,
    newest_ns: Option<i64>,
}

/// Wrenches waiting for their stamp at most (100 s of a 100 Hz teacher).
pub const MAX_PENDING_WRENCHES: usize = 10_000;

impl LwrSim {
    /// Wraps a simulator; `config.publish` sets the topic rates.
    pub fn new(sim: Simulator, config: LwrSimConfig) -> Self {
        let every = |hz: f64| ((1.0 / (hz * config.simulation.step_s)).round() as u64).max(1);
        let names = sim.model().joint_names().to_vec();
        let base_frame = sim.model().link_names()[0].clone();
        let n = names.len();
        let camera_clock = FrameClock::new(sim.scene().camera.rate_hz);
        Self {
            people: People::new(config.depth.floor_height_m, config.depth.person_timeout_s),
            config_depth: config.depth.clone(),
            camera_clock,
            every_clock: every(config.publish.clock_rate_hz),
            every_joint_states: every(config.publish.joint_state_rate_hz),
            every_tf: every(config.publish.tf_rate_hz),
            every_world: every(config.publish.world_rate_hz),
            steps: 0,
            base_frame,
            joint_state: JointState {
                name: names,
                position: vec![0.0; n],
                velocity: vec![0.0; n],
                ..Default::default()
            },
            follow: None,
            wrench_mode: config.external_wrench.mode,
            every_wrench: every(config.external_wrench.report_rate_hz),
            wrench_timeout_ns: (sim.params().wrench_timeout_s * 1e9) as i64,
            reported: None,
            sim,
        }
    }

    /// Teach (admittance) or execute (reported) mode for `/external_wrench` from now on; a
    /// reported wrench is dropped at a change (an applied one ends within `wrench_timeout_s`).
    pub fn set_wrench_mode(&mut self, mode: WrenchMode) {
        if mode != self.wrench_mode {
            self.reported = None;
        }
        self.wrench_mode = mode;
    }

    /// The current [`WrenchMode`].
    pub fn wrench_mode(&self) -> WrenchMode {
        self.wrench_mode
    }

    /// Execute mode: the acting wrench as `/lwr/external_wrench` reports it — stamped now,
    /// `header.frame_id` the contact link, force and torque in that link's frame at the
    /// current pose; `None` when no wrench acts (none received within `wrench_timeout_s`).
    pub fn reported_wrench(&self) -> Option<WrenchStamped> {
        let (w, link, t) = self.reported?;
        if self.sim.time_ns() - t > self.wrench_timeout_ns {
            return None;
        }
        let r = self.sim.link_poses().get(link).rotation;
        let f = r.inverse() * w.force;
        let m = r.inverse() * w.torque;
        Some(WrenchStamped {
            header: Header { stamp: self.now(), frame_id: self.sim.model().link_names()[link].clone() },
            wrench: cowork_msgs::geometry_msgs::Wrench {
                force: Vector3 { x: f.x, y: f.y, z: f.z },
                torque: Vector3 { x: m.x, y: m.y, z: m.z },
            },
        })
    }

    /// Replaying a recorded teacher: from now on every `/external_wrench` is applied when
    /// simulated time reaches its header stamp (at once when that is past), and once one has
    /// arrived [`run`] never lets simulated time pass the newest stamp received — the
    /// simulator waits for a teacher that falls behind, so a demonstration replays the same
    /// however loaded the machine is. Off by default (wrenches act on arrival).
    pub fn follow_wrench_stamps(&mut self) {
        self.follow.get_or_insert_with(FollowWrench::default);
    }

    /// Whether [`follow_wrench_stamps`](Self::follow_wrench_stamps) holds simulated time: it
    /// has reached the newest wrench stamp received.
    pub fn waiting_for_wrench(&self) -> bool {
        self.follow.as_ref().and_then(|f| f.newest_ns).is_some_and(|n| self.sim.time_ns() >= n)
    }

    /// The wrapped simulator.
    pub fn simulator(&self) -> &Simulator {
        &self.sim
    }

    /// Current simulated time.
    pub fn now(&self) -> Time {
        Time::from_nanos(self.sim.time_ns())
    }

    /// Applies a joint velocity command; a bad one is logged, and the robot is held.
    pub fn on_velocity_command(&mut self, msg: &Float64MultiArray) {
        if let Err(e) = self.sim.set_velocity_command(&msg.data) {
            tracing::warn!("/lwr/joint_velocity_command rejected, robot held: {e}");
        }
    }

    /// Opens or closes the gripper on `open` / `close`; anything else is logged and ignored.
    pub fn on_gripper_command(&mut self, msg: &RosString) {
        match msg.data.trim().to_ascii_lowercase().as_str() {
            "close" => match self.sim.command_gripper(true) {
                Some(name) => tracing::info!("gripper closed on {name}"),
                None => tracing::info!("gripper closed on nothing (no object within reach)"),
            },
            "open" => {
                self.sim.command_gripper(false);
                tracing::info!("gripper open");
            }
            other => tracing::warn!("/lwr/gripper_command: unknown command {other:?} (expected open or close)"),
        }
    }

    /// Applies an external wrench (see the module docs for its frame); when following wrench
    /// stamps, one stamped in the future waits for its time (the oldest dropped beyond
    /// [`MAX_PENDING_WRENCHES`]).
    pub fn on_wrench(&mut self, msg: &WrenchStamped) {
        let now = self.sim.time_ns();
        if let Some(f) = self.follow.as_mut() {
            let stamp = msg.header.stamp.to_nanos();
            f.newest_ns = Some(f.newest_ns.map_or(stamp, |n| n.max(stamp)));
            if stamp > now {
                if f.pending.len() >= MAX_PENDING_WRENCHES {
                    f.pending.pop_front();
                }
                f.pending.push_back(msg.clone());
                return;
            }
        }
        self.apply_wrench(msg);
    }

    fn apply_wrench(&mut self, msg: &WrenchStamped) {
        let frame = msg.header.frame_id.as_str();
        let f = &msg.wrench.force;
        let t = &msg.wrench.torque;
        let mut force = nalgebra::Vector3::new(f.x, f.y, f.z);
        let mut torque = nalgebra::Vector3::new(t.x, t.y, t.z);
        let link = if frame.is_empty() || frame == self.base_frame {
            None
        } else {
            match self.sim.model().link_index(frame) {
                Some(i) => {
                    let r = self.sim.link_poses().get(i).rotation;
                    force = r * force;
                    torque = r * torque;
                    Some(frame)
                }
                None => {
                    tracing::warn!("/external_wrench: unknown frame {frame:?}, wrench ignored");
                    return;
                }
            }
        };
        if self.wrench_mode == WrenchMode::Execute {
            // Reported, not applied: the arm moves only as the controller commands.
            if let Some((i, v)) = force.iter().chain(torque.iter()).enumerate().find(|(_, v)| !v.is_finite()) {
                self.reported = None;
                tracing::warn!("/external_wrench rejected: component {i} is {v}");
                return;
            }
            let index = link.and_then(|l| self.sim.model().link_index(l)).unwrap_or(self.sim.model().tip_link());
            self.reported = Some((Wrench { force, torque }, index, self.sim.time_ns()));
            return;
        }
        if let Err(e) = self.sim.set_wrench(Wrench { force, torque }, link) {
            tracing::warn!("/external_wrench rejected: {e}");
        }
    }

    /// Takes a person's skeleton for the depth camera; a malformed one is logged (the first
    /// time per person) and ignored.
    pub fn on_skeleton(&mut self, msg: &Skeleton) {
        let before = self.people.rejected();
        if let Err(e) = self.people.update(msg, self.sim.time_ns()) {
            if before == 0 || before.is_power_of_two() {
                tracing::warn!("{e} (ignored; {} refused so far)", before + 1);
            }
        }
    }

    /// The people the depth camera draws.
    pub fn people(&self) -> &People {
        &self.people
    }

    /// Advances one step and says which topics are due.
    pub fn step(&mut self) -> Due {
        let now = self.sim.time_ns();
        while let Some(w) = self
            .follow
            .as_mut()
            .and_then(|f| f.pending.front().is_some_and(|w| w.header.stamp.to_nanos() <= now).then(|| f.pending.pop_front()).flatten())
        {
            self.apply_wrench(&w);
        }
        self.sim.step();
        self.steps += 1;
        self.people.expire(self.sim.time_ns());
        Due {
            clock: self.steps % self.every_clock == 0,
            joint_states: self.steps % self.every_joint_states == 0,
            tf: self.steps % self.every_tf == 0,
            world: self.steps % self.every_world == 0,
            depth: self.camera_clock.due(self.sim.time_ns()),
            wrench: self.wrench_mode == WrenchMode::Execute
                && self.steps % self.every_wrench == 0
                && self.reported.is_some_and(|(_, _, t)| self.sim.time_ns() - t <= self.wrench_timeout_ns),
        }
    }

    /// `/clock` message at the current time.
    pub fn clock(&self) -> Clock {
        Clock { clock: self.now() }
    }

    /// `/joint_states` message at the current time.
    pub fn joint_states(&mut self) -> JointState {
        let stamp = self.now();
        let q = self.sim.joint_positions();
        let qd = self.sim.joint_velocities();
        self.joint_state.header.stamp = stamp;
        self.joint_state.position.copy_from_slice(q.as_slice());
        self.joint_state.velocity.copy_from_slice(qd.as_slice());
        self.joint_state.clone()
    }

    /// `/tf`: the frame tree as `robot_state_publisher` publishes it — each link in its parent
    /// link's frame (one transform per joint) — plus every object in the base frame.
    pub fn tf(&self) -> TFMessage {
        let stamp = self.now();
        let transforms = self
            .sim
            .frame_tree()
            .map(|e| transform(e.parent.unwrap_or(&self.base_frame), e.child, stamp, &e.pose))
            .collect();
        TFMessage { transforms }
    }

    /// `/lwr/world`: gripper state, held object, tool pose and every object (pose, distance
    /// from the tool point to its surface, tilt of its z axis from the vertical).
    pub fn world(&self) -> WorldState {
        let tool = self.sim.tool_pose();
        let tool_point = nalgebra::Point3::from(tool.translation.vector);
        let held = self.sim.held_object();
        let objects = self
            .sim
            .objects()
            .iter()
            .map(|o| {
                let z = o.pose.rotation * nalgebra::Vector3::z();
                WorldObject {
                    name: o.name.clone(),
                    pose: pose(&o.pose),
                    tool_distance: o.distance_to(&tool_point),
                    tilt: z.z.clamp(-1.0, 1.0).acos(),
                    held: held == Some(o.name.as_str()),
                }
            })
            .collect();
        WorldState {
            header: Header { stamp: self.now(), frame_id: self.base_frame.clone() },
            gripper_state: match self.sim.gripper() {
                GripperState::Open => WorldState::GRIPPER_OPEN,
                GripperState::Closed { .. } => WorldState::GRIPPER_CLOSED,
            },
            held_object: held.unwrap_or_default().to_owned(),
            tool_pose: pose(&tool),
            objects,
        }
    }

    /// `/robot_description`: the URDF the simulator runs, with each relative mesh path made an
    /// absolute `file://` URI so RViz's RobotModel and Foxglove's 3D panel on this machine find
    /// the meshes (`package://` and absolute URIs are left as they are).
    pub fn robot_description(&self) -> Result<RosString> {
        let source = self.sim.model().source();
        let text = std::fs::read_to_string(source)
            .with_context(|| format!("cannot read the robot description {}", source.display()))?;
        let dir = source.parent().unwrap_or(std::path::Path::new("."));
        let dir = std::fs::canonicalize(dir).with_context(|| format!("cannot resolve {}", dir.display()))?;
        Ok(RosString { data: absolute_mesh_uris(&text, &dir) })
    }

    /// `/tf_static`: the camera's optical frame.
    pub fn tf_static(&self) -> TFMessage {
        let camera = &self.sim.scene().camera;
        TFMessage {
            transforms: vec![transform(
                &self.base_frame,
                &camera.frame_id,
                self.now(),
                &camera.pose.isometry(),
            )],
        }
    }
}

fn pose(p: &Isometry3<f64>) -> Pose {
    let t = &p.translation.vector;
    let q = p.rotation.quaternion();
    Pose {
        position: Point { x: t.x, y: t.y, z: t.z },
        orientation: Quaternion { x: q.i, y: q.j, z: q.k, w: q.w },
    }
}

/// `filename="meshes/x.stl"` → `filename="file:///dir/meshes/x.stl"`; URIs with a scheme and
/// absolute paths are kept.
fn absolute_mesh_uris(urdf: &str, dir: &std::path::Path) -> String {
    const KEY: &str = "filename=\"";
    let mut out = String::with_capacity(urdf.len() + 64);
    let mut rest = urdf;
    while let Some(i) = rest.find(KEY) {
        let (head, tail) = rest.split_at(i + KEY.len());
        out.push_str(head);
        if !(tail.contains("://") && tail.find("://") < tail.find('"')) && !tail.starts_with('/') {
            out.push_str("file://");
            out.push_str(&dir.to_string_lossy());
            out.push('/');
        } else if tail.starts_with('/') {
            out.push_str("file://");
        }
        rest = tail;
    }
    out.push_str(rest);
    out
}

fn transform(parent: &str, child: &str, stamp: Time, pose: &Isometry3<f64>) -> TransformStamped {
    let t = &pose.translation.vector;
    let q = pose.rotation.quaternion();
    TransformStamped {
        header: Header { stamp, frame_id: parent.to_owned() },
        child_frame_id: child.to_owned(),
        transform: Transform {
            translation: Vector3 { x: t.x, y: t.y, z: t.z },
            rotation: Quaternion { x: q.i, y: q.j, z: q.k, w: q.w },
        },
    }
}

/// Renders and publishes every snapshot the loop posts, until the mailbox closes.
fn depth_worker(
    mut camera: DepthCamera,
    mailbox: &Mailbox,
    image_pub: &cowork_ros::Publisher<Image>,
    info_pub: &cowork_ros::Publisher<CameraInfo>,
) -> Result<()> {
    let mut image = Image::default();
    let mut info = CameraInfo::default();
    let mut done = None;
    while let Some(snap) = mailbox.take(done.take()) {
        match camera.render(&snap, &mut image, &mut info) {
            Ok(()) => {
                // The publisher takes ownership; the buffer is rebuilt next frame.
                image_pub.publish(std::mem::take(&mut image))?;
                info_pub.publish(info.clone())?;
            }
            Err(e) => tracing::warn!("depth frame at {:?} not rendered: {e:#}", snap.stamp),
        }
        done = Some(snap);
    }
    Ok(())
}

/// Runs the node until Ctrl-C or `duration` simulated seconds.
pub fn run(mut node: RosNode, mut lwr: LwrSim, pacing: Pacing, duration: Option<f64>) -> Result<()> {
    let commands = node.subscription::<Float64MultiArray>("/lwr/joint_velocity_command", &qos::reliable())?;
    let gripper = node.subscription::<RosString>("/lwr/gripper_command", &qos::reliable())?;
    // Deep: a replayed teacher may send its wrenches ahead of their stamps.
    let wrenches = node.subscription::<WrenchStamped>("/external_wrench", &qos::reliable_depth(1000))?;
    // Best effort matches every writer (reliable bags, best-effort trackers).
    let skeletons = node.subscription::<Skeleton>("/human/skeleton", &qos::best_effort_depth(20))?;
    let placements = node.subscription::<WorldObject>(person::TOPIC_PLACE_OBJECT, &qos::reliable_depth(100))?;
    let clock = node.publisher::<Clock>("/clock", &qos::clock())?;
    let joint_states = node.publisher::<JointState>("/joint_states", &qos::reliable())?;
    let tf = node.publisher::<TFMessage>("/tf", &qos::reliable_depth(100))?;
    let tf_static = node.publisher::<TFMessage>("/tf_static", &qos::latched())?;
    let world = node.publisher::<WorldState>(TOPIC_WORLD, &qos::reliable_depth(100))?;
    let wrench_report = node.publisher::<WrenchStamped>(TOPIC_EXTERNAL_WRENCH, &qos::reliable_depth(100))?;
    tf_static.publish(lwr.tf_static())?;
    // Latched, as robot_state_publisher's: a viewer that joins later still gets it.
    let description = node.publisher::<RosString>("/robot_description", &qos::latched())?;
    description.publish(lwr.robot_description()?)?;
    let camera = if lwr.config_depth.enabled {
        let image = node.publisher::<Image>("/camera/depth/image_raw", &qos::sensor_data())?;
        let info = node.publisher::<CameraInfo>("/camera/depth/camera_info", &qos::sensor_data())?;
        let camera = DepthCamera::new(&lwr.sim, &lwr.config_depth)?;
        let mailbox = Mailbox::new();
        let worker = {
            let mailbox = Arc::clone(&mailbox);
            std::thread::Builder::new()
                .name("lwr_sim_depth".into())
                .spawn(move || depth_worker(camera, &mailbox, &image, &info))?
        };
        Some((mailbox, worker))
    } else {
        None
    };
    tracing::info!(
        "lwr_sim running: {} joints, {} objects, pacing {pacing:?}, /external_wrench: {}",
        lwr.joint_state.name.len(),
        lwr.sim.objects().len(),
        match lwr.wrench_mode {
            WrenchMode::Teach => "teach (the arm yields by admittance)".to_owned(),
            WrenchMode::Execute => format!("execute (reported on {TOPIC_EXTERNAL_WRENCH}, the arm moves only as commanded)"),
        }
    );

    let end_ns = duration.map(|d| (d * 1e9) as i64);
    let mut start = Instant::now();
    let mut last_report = Instant::now();
    while !cowork_ros::shutdown::requested() {
        if end_ns.is_some_and(|end| lwr.sim.time_ns() >= end) {
            break;
        }
        while let Some(m) = commands.take() {
            lwr.on_velocity_command(&m);
        }
        while let Some(m) = gripper.take() {
            lwr.on_gripper_command(&m);
        }
        while let Some(m) = wrenches.take() {
            lwr.on_wrench(&m);
        }
        while let Some(m) = skeletons.take() {
            lwr.on_skeleton(&m);
        }
        while let Some(m) = placements.take() {
            lwr.on_place_object(&m);
        }
        if lwr.waiting_for_wrench() {
            // The replayed teacher is behind: wait for it, and keep the pace from here on.
            let held = Instant::now();
            std::thread::sleep(Duration::from_micros(200));
            start += held.elapsed();
            continue;
        }
        let due = lwr.step();
        if due.clock {
            clock.publish(lwr.clock())?;
        }
        if due.joint_states {
            joint_states.publish(lwr.joint_states())?;
        }
        if due.tf {
            tf.publish(lwr.tf())?;
        }
        if due.world {
            world.publish(lwr.world())?;
        }
        if due.wrench
            && let Some(w) = lwr.reported_wrench()
        {
            wrench_report.publish(w)?;
        }
        if due.depth {
            if let Some((mailbox, _)) = &camera {
                mailbox.post(&lwr.sim, &lwr.people);
            }
        }
        let sim_s = lwr.sim.time_ns() as f64 * 1e-9;
        if let Pacing::Rate(rate) = pacing {
            let target = start + cowork_ros::duration_s(sim_s / rate);
            let now = Instant::now();
            if target > now {
                std::thread::sleep(target - now);
            }
        }
        if last_report.elapsed() >= Duration::from_secs(10) {
            last_report = Instant::now();
            tracing::info!(
                "t_sim = {sim_s:.1} s, real-time factor {:.2}{}",
                sim_s / start.elapsed().as_secs_f64(),
                camera.as_ref().map_or(String::new(), |(m, _)| format!(
                    ", depth frames dropped (renderer busy): {}",
                    m.dropped()
                ))
            );
        }
    }
    if let Some((mailbox, worker)) = camera {
        mailbox.close();
        match worker.join() {
            Ok(result) => result?,
            Err(_) => bail!("the depth camera thread panicked"),
        }
    }
    tracing::info!("lwr_sim stopped at t_sim = {:.3} s", lwr.sim.time_ns() as f64 * 1e-9);
    Ok(())
}
