//! [`LwrSim`]: the simulator with its message conversions and one handler per input
//! (command, gripper, wrench, skeleton, placement); pure: messages in, [`Output`]s and
//! [`Warning`]s out, no I/O and no logging.

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Transform, TransformStamped, Vector3, WrenchStamped};
use cowork_msgs::msg::{Skeleton, WorldObject, WorldState};
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::{Float64MultiArray, Header, String as RosString};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::topics;
use cowork_ros::Warning;
use cowork_sim::{GripperState, Simulator, Wrench};
use nalgebra::Isometry3;
use serde::Serialize;

use crate::depth::{DepthConfig, DepthSnapshot, FrameClock, People};
use crate::params::{LwrSimConfig, WrenchMode};

/// What the node takes in. Per-arm inputs carry the arm's index ([`Simulator::arms`]; 0 for
/// the one arm of a single-arm scene), from the topic in that arm's namespace.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// `/lwr/joint_velocity_command`: 7 joint velocities, rad/s.
    VelocityCommand(usize, Float64MultiArray),
    /// `/lwr/gripper_command`: `open` / `close`.
    GripperCommand(usize, RosString),
    /// `/external_wrench`: a push on the arm.
    Wrench(usize, WrenchStamped),
    /// `/lwr/follow_joints`: joint targets the arm follows (imitation teaching).
    FollowJoints(usize, JointState),
    /// `/human/skeleton`: a person for the depth camera.
    Skeleton(Skeleton),
    /// `/lwr/place_object`: a person moved a scene object.
    PlaceObject(WorldObject),
}

/// What the node puts out, in the order it happened. Per-arm outputs carry the arm's index:
/// they go to the topic in that arm's namespace.
#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Output {
    /// `/clock`.
    Clock(Clock),
    /// `/joint_states`.
    JointStates(usize, JointState),
    /// `/tf`.
    Tf(TFMessage),
    /// `/lwr/world`.
    World(usize, WorldState),
    /// `/lwr/external_wrench` (execute mode).
    ExternalWrench(usize, WrenchStamped),
    /// The state a depth frame shows, for the renderer (serialised as its stamp and counts).
    Depth(#[serde(serialize_with = "depth_summary")] Box<DepthSnapshot>),
    /// The gripper was commanded: closed (on `object`, if one was within reach) or opened.
    Gripper {
        /// The arm.
        arm: usize,
        /// Closed (true) or open.
        closed: bool,
        /// The object grasped.
        object: Option<String>,
    },
    /// A warning for the log (rate-limited by the caller).
    Warning(Warning),
}

fn depth_summary<S: serde::Serializer>(snap: &DepthSnapshot, s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeStruct;
    let mut st = s.serialize_struct("DepthSnapshot", 4)?;
    st.serialize_field("stamp", &snap.stamp)?;
    st.serialize_field("q", snap.arms.first().map_or(&[][..], |a| a.1.as_slice()))?;
    st.serialize_field("objects", &snap.objects.len())?;
    st.serialize_field("people_capsules", &snap.people.len())?;
    st.end()
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
    /// The scene's root frame (`lwr_base_link`, or `world` with named arms).
    root_frame: String,
    /// `/joint_states` of each arm, reused.
    joint_states: Vec<JointState>,
    /// Each arm's input topic names, for warnings.
    arm_topics: Vec<ArmTopics>,
    camera_clock: FrameClock,
    config_depth: DepthConfig,
    people: People,
    /// `Some` when wrenches are applied at their header stamps ([`follow_wrench_stamps`](Self::follow_wrench_stamps)).
    follow: Option<FollowWrench>,
    wrench_mode: WrenchMode,
    every_wrench: u64,
    wrench_timeout_ns: i64,
    /// Execute mode: per arm, the acting wrench (the arm's base frame), its link and when it
    /// arrived (ns).
    reported: Vec<Option<(Wrench, usize, i64)>>,
    /// Refusals of wrenches applied at their stamps during [`step`](Self::step), until
    /// [`on_step`](Self::on_step) puts them out.
    step_warnings: Vec<Warning>,
}

/// An arm's input topics, named in its namespace (`/left/lwr/joint_velocity_command`).
#[derive(Debug)]
struct ArmTopics {
    command: String,
    follow: String,
    gripper: String,
    wrench: String,
}

/// Refusals kept between two [`LwrSim::on_step`]s at most (the rest are dropped).
pub const MAX_STEP_WARNINGS: usize = 64;

/// A teacher's input that acts at its header stamp.
#[derive(Debug)]
enum Timed {
    Wrench(WrenchStamped),
    Joints(JointState),
}

impl Timed {
    fn stamp_ns(&self) -> i64 {
        match self {
            Timed::Wrench(m) => m.header.stamp.to_nanos(),
            Timed::Joints(m) => m.header.stamp.to_nanos(),
        }
    }
}

/// Teacher inputs (wrenches, followed joint targets) waiting for their stamp, and the newest
/// stamp received (ns).
#[derive(Debug, Default)]
struct FollowWrench {
    /// (arm, input), stamps as received.
    pending: std::collections::VecDeque<(usize, Timed)>,
    newest_ns: Option<i64>,
}

/// Teacher inputs waiting for their stamp at most (100 s of a 100 Hz teacher).
pub const MAX_PENDING_WRENCHES: usize = 10_000;

impl LwrSim {
    /// Wraps a simulator; `config.publish` sets the topic rates.
    pub fn new(sim: Simulator, config: LwrSimConfig) -> Self {
        let every = |hz: f64| ((1.0 / (hz * config.simulation.step_s)).round() as u64).max(1);
        let names = sim.model().joint_names().to_vec();
        let n = names.len();
        let arms = sim.arms();
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
            root_frame: sim.root_frame().to_owned(),
            joint_states: arms
                .iter()
                .map(|_| JointState {
                    name: names.clone(),
                    position: vec![0.0; n],
                    velocity: vec![0.0; n],
                    ..Default::default()
                })
                .collect(),
            follow: None,
            wrench_mode: config.external_wrench.mode,
            every_wrench: every(config.external_wrench.report_rate_hz),
            wrench_timeout_ns: (sim.params().wrench_timeout_s * 1e9) as i64,
            arm_topics: arms
                .iter()
                .map(|a| {
                    let ns = format!("/{}", a.name());
                    ArmTopics {
                        follow: topics::FOLLOW_JOINTS.name_in(&ns).into_owned(),
                        command: topics::JOINT_VELOCITY_COMMAND.name_in(&ns).into_owned(),
                        gripper: topics::GRIPPER_COMMAND.name_in(&ns).into_owned(),
                        wrench: topics::EXTERNAL_WRENCH.name_in(&ns).into_owned(),
                    }
                })
                .collect(),
            reported: vec![None; arms.len()],
            step_warnings: Vec::new(),
            sim,
        }
    }

    /// Teach (admittance) or execute (reported) mode for `/external_wrench` from now on; a
    /// reported wrench is dropped at a change (an applied one ends within `wrench_timeout_s`).
    pub fn set_wrench_mode(&mut self, mode: WrenchMode) {
        if mode != self.wrench_mode {
            self.reported.fill(None);
        }
        self.wrench_mode = mode;
    }

    /// The current [`WrenchMode`].
    pub fn wrench_mode(&self) -> WrenchMode {
        self.wrench_mode
    }

    /// Execute mode: the wrench acting on arm `arm` as `/lwr/external_wrench` reports it —
    /// stamped now, `header.frame_id` the contact link's frame, force and torque in that
    /// link's frame at the current pose; `None` when no wrench acts (none received within
    /// `wrench_timeout_s`).
    pub fn reported_wrench(&self, arm: usize) -> Option<WrenchStamped> {
        let (w, link, t) = self.reported[arm]?;
        if self.sim.time_ns() - t > self.wrench_timeout_ns {
            return None;
        }
        let r = self.sim.arm(arm).link_poses().get(link).rotation;
        let f = r.inverse() * w.force;
        let m = r.inverse() * w.torque;
        Some(WrenchStamped {
            header: Header { stamp: self.now(), frame_id: self.sim.arm(arm).frames()[link].clone() },
            wrench: cowork_msgs::geometry_msgs::Wrench {
                force: Vector3 { x: f.x, y: f.y, z: f.z },
                torque: Vector3 { x: m.x, y: m.y, z: m.z },
            },
        })
    }

    /// Replaying a recorded teacher: from now on every `/external_wrench` and `/lwr/follow_joints`
    /// is applied when simulated time reaches its header stamp (at once when that is past), and
    /// once one has arrived [`run`](crate::run) never lets simulated time pass the newest stamp
    /// received — the simulator waits for a teacher that falls behind, so a demonstration
    /// replays the same however loaded the machine is. Off by default (they act on arrival).
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

    /// Any input; what it gave to put out (a warning, the gripper's new state), if anything.
    pub fn on_input(&mut self, input: &Input) -> Option<Output> {
        match input {
            Input::VelocityCommand(arm, m) => self.on_velocity_command(*arm, m).map(Output::Warning),
            Input::GripperCommand(arm, m) => Some(self.gripper_command(*arm, m)),
            Input::Wrench(arm, m) => self.on_wrench(*arm, m).map(Output::Warning),
            Input::FollowJoints(arm, m) => self.on_follow_joints(*arm, m).map(Output::Warning),
            Input::Skeleton(m) => self.on_skeleton(m).map(Output::Warning),
            Input::PlaceObject(m) => self.on_place_object(m).err().map(Output::Warning),
        }
    }

    /// The ROS namespace of arm `arm`'s topics: `/` for the one arm of a single-arm scene,
    /// `/<name>` for a named arm.
    pub fn namespace(&self, arm: usize) -> String {
        format!("/{}", self.sim.arm(arm).name())
    }

    /// Applies a joint velocity command to arm `arm`; a bad one is refused (the warning says
    /// why), and that arm is held.
    pub fn on_velocity_command(&mut self, arm: usize, msg: &Float64MultiArray) -> Option<Warning> {
        let topic = &self.arm_topics[arm].command;
        self.sim
            .set_arm_velocity_command(arm, &msg.data)
            .err()
            .map(|e| Warning::new(format!("{topic}:data"), format!("{topic} rejected, robot held: {e}")))
    }

    /// Opens or closes the gripper on `open` / `close`; anything else is refused (the
    /// warning says why) and changes nothing. ([`on_input`](Self::on_input) also reports
    /// what the gripper closed on.)
    pub fn on_gripper_command(&mut self, arm: usize, msg: &RosString) -> Option<Warning> {
        match self.gripper_command(arm, msg) {
            Output::Warning(w) => Some(w),
            _ => None,
        }
    }

    /// `/lwr/gripper_command`: [`Output::Gripper`], or the warning.
    fn gripper_command(&mut self, arm: usize, msg: &RosString) -> Output {
        match msg.data.trim().to_ascii_lowercase().as_str() {
            "close" => Output::Gripper { arm, closed: true, object: self.sim.command_arm_gripper(arm, true).map(str::to_owned) },
            "open" => {
                self.sim.command_arm_gripper(arm, false);
                Output::Gripper { arm, closed: false, object: None }
            }
            _ => {
                let topic = &self.arm_topics[arm].gripper;
                Output::Warning(Warning::new(
                    format!("{topic}:data"),
                    format!("{topic}: unknown command {:?} (expected open or close)", cowork_ros::quote(msg.data.trim())),
                ))
            }
        }
    }

    /// Applies an external wrench (see the module docs for its frame); when following wrench
    /// stamps, one stamped in the future waits for its time (the oldest dropped beyond
    /// [`MAX_PENDING_WRENCHES`]). A refused one is a warning.
    pub fn on_wrench(&mut self, arm: usize, msg: &WrenchStamped) -> Option<Warning> {
        if self.defer(arm, msg.header.stamp.to_nanos(), || Timed::Wrench(msg.clone())) {
            return None;
        }
        self.apply_wrench(arm, msg)
    }

    /// Makes arm `arm` follow the joint targets of `msg` (`/lwr/follow_joints`: `position` in
    /// the model's joint order; `name`, when given, must be the arm's joint names in that
    /// order) for `command_timeout_s`; when following teacher stamps, one stamped in the future
    /// waits for its time like a wrench. A refused one holds the arm; the warning says why.
    pub fn on_follow_joints(&mut self, arm: usize, msg: &JointState) -> Option<Warning> {
        if self.defer(arm, msg.header.stamp.to_nanos(), || Timed::Joints(msg.clone())) {
            return None;
        }
        self.apply_follow_joints(arm, msg)
    }

    /// When following teacher stamps, notes `stamp_ns` and queues an input stamped in the
    /// future (true: deferred).
    fn defer(&mut self, arm: usize, stamp_ns: i64, input: impl FnOnce() -> Timed) -> bool {
        let now = self.sim.time_ns();
        let Some(f) = self.follow.as_mut() else {
            return false;
        };
        f.newest_ns = Some(f.newest_ns.map_or(stamp_ns, |n| n.max(stamp_ns)));
        if stamp_ns <= now {
            return false;
        }
        if f.pending.len() >= MAX_PENDING_WRENCHES {
            f.pending.pop_front();
        }
        f.pending.push_back((arm, input()));
        true
    }

    fn apply_follow_joints(&mut self, arm: usize, msg: &JointState) -> Option<Warning> {
        let topic = &self.arm_topics[arm].follow;
        let names = self.sim.model().joint_names();
        if !msg.name.is_empty() && msg.name.as_slice() != names {
            let got = cowork_ros::text_prefix(&msg.name.join(", "), 200).into_owned();
            let warning = Warning::new(
                format!("{topic}:name"),
                format!("{topic}: joint names [{got}] are not the arm's [{}] in order; arm held", names.join(", ")),
            );
            self.sim.hold_arm(arm);
            return Some(warning);
        }
        self.sim
            .set_arm_joint_target(arm, &msg.position)
            .err()
            .map(|e| Warning::new(format!("{topic}:position"), format!("{topic} rejected, arm held: {e}")))
    }

    fn apply_wrench(&mut self, arm: usize, msg: &WrenchStamped) -> Option<Warning> {
        let topic = &self.arm_topics[arm].wrench;
        let frames = self.sim.arm(arm).frames();
        // A link's frame, as tf names it (`left/lwr_link_3`) or by its model name.
        let frame = msg.header.frame_id.as_str();
        let index = frames.iter().position(|f| f == frame).or_else(|| self.sim.model().link_index(frame));
        let f = &msg.wrench.force;
        let t = &msg.wrench.torque;
        let mut force = nalgebra::Vector3::new(f.x, f.y, f.z);
        let mut torque = nalgebra::Vector3::new(t.x, t.y, t.z);
        let link = if frame.is_empty() || index == Some(0) {
            None
        } else {
            match index {
                Some(i) => {
                    let r = self.sim.arm(arm).link_poses().get(i).rotation;
                    force = r * force;
                    torque = r * torque;
                    Some(i)
                }
                None => {
                    return Some(Warning::new(
                        format!("{topic}:header.frame_id"),
                        format!("{topic}: unknown frame {:?}, wrench ignored", cowork_ros::quote(frame)),
                    ));
                }
            }
        };
        if self.wrench_mode == WrenchMode::Execute {
            // Reported, not applied: the arm moves only as the controller commands.
            if let Some((i, v)) = force.iter().chain(torque.iter()).enumerate().find(|(_, v)| !v.is_finite()) {
                self.reported[arm] = None;
                return Some(Warning::new(format!("{topic}:wrench"), format!("{topic} rejected: component {i} is {v}")));
            }
            let index = link.unwrap_or(self.sim.model().tip_link());
            self.reported[arm] = Some((Wrench { force, torque }, index, self.sim.time_ns()));
            return None;
        }
        let link = link.unwrap_or(self.sim.model().tip_link());
        self.sim
            .set_arm_wrench_on_link(arm, Wrench { force, torque }, link)
            .err()
            .map(|e| Warning::new(format!("{topic}:wrench"), format!("{topic} rejected: {e}")))
    }

    /// Takes a person's skeleton for the depth camera; a malformed one is refused (the
    /// warning names the problem and counts the refusals) and changes nothing.
    pub fn on_skeleton(&mut self, msg: &Skeleton) -> Option<Warning> {
        self.people.update(msg, self.sim.time_ns()).err().map(|e| {
            Warning::new(
                format!("{}:frame", topics::SKELETON.name),
                format!("{e} (ignored; {} refused so far)", self.people.rejected()),
            )
        })
    }

    /// A person moved `msg.name` to `msg.pose` (`/lwr/place_object`, base frame) — takes the
    /// bottle, pours, puts it back — as a scripted experiment's person does. Only `name` and
    /// `pose` are read; the object goes exactly there (no settling). Refused, with a warning,
    /// for an object the scene does not have, the one the gripper holds, or a bad pose; the
    /// world is then unchanged. This is a simulator control input, like Gazebo's
    /// `set_entity_state`: on a real cell the person just does it.
    pub fn on_place_object(&mut self, msg: &WorldObject) -> Result<(), Warning> {
        let topic = topics::PLACE_OBJECT.name;
        let (p, q) = (&msg.pose.position, &msg.pose.orientation);
        let quat = nalgebra::Quaternion::new(q.w, q.x, q.y, q.z);
        let name = cowork_ros::quote(&msg.name);
        if !(quat.norm().is_finite() && quat.norm() > 1e-6) {
            return Err(Warning::new(
                format!("{topic}:pose.orientation"),
                format!("{topic}: object {name:?}: orientation is not a rotation; ignored"),
            ));
        }
        let pose = Isometry3::from_parts(
            nalgebra::Translation3::new(p.x, p.y, p.z),
            nalgebra::UnitQuaternion::from_quaternion(quat),
        );
        self.sim.place_object(&msg.name, pose).map_err(|e| {
            let e = cowork_ros::text_prefix(&e.to_string(), 300).into_owned();
            Warning::new(format!("{topic}:object"), format!("{topic}: {e}; ignored"))
        })
    }

    /// Advances one step (see [`step`](Self::step)) and appends what became due to `out`:
    /// refusals of wrenches applied at their stamps, `/clock`, `/joint_states`, `/tf`,
    /// `/lwr/world`, `/lwr/external_wrench`, a depth snapshot (when the camera is enabled).
    pub fn on_step(&mut self, out: &mut Vec<Output>) -> Due {
        let due = self.step();
        out.extend(self.step_warnings.drain(..).map(Output::Warning));
        if due.clock {
            out.push(Output::Clock(self.clock()));
        }
        let arms = self.sim.arms().len();
        if due.joint_states {
            out.extend((0..arms).map(|arm| Output::JointStates(arm, self.joint_states(arm))));
        }
        if due.tf {
            out.push(Output::Tf(self.tf()));
        }
        if due.world {
            out.extend((0..arms).map(|arm| Output::World(arm, self.world(arm))));
        }
        if due.wrench {
            out.extend((0..arms).filter_map(|arm| Some(Output::ExternalWrench(arm, self.reported_wrench(arm)?))));
        }
        if due.depth && self.config_depth.enabled {
            let mut snap = DepthSnapshot::default();
            snap.capture(&self.sim, &self.people);
            out.push(Output::Depth(Box::new(snap)));
        }
        due
    }

    /// The depth camera's parameters.
    pub fn depth_config(&self) -> &DepthConfig {
        &self.config_depth
    }

    /// Simulated time, s.
    pub fn time_s(&self) -> f64 {
        self.sim.time_ns() as f64 * 1e-9
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
            .and_then(|f| f.pending.front().is_some_and(|(_, w)| w.stamp_ns() <= now).then(|| f.pending.pop_front()).flatten())
        {
            let refused = match &w.1 {
                Timed::Wrench(m) => self.apply_wrench(w.0, m),
                Timed::Joints(m) => self.apply_follow_joints(w.0, m),
            };
            if let Some(warning) = refused
                && self.step_warnings.len() < MAX_STEP_WARNINGS
            {
                self.step_warnings.push(warning);
            }
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
                && self.reported.iter().flatten().any(|(_, _, t)| self.sim.time_ns() - t <= self.wrench_timeout_ns),
        }
    }

    /// `/clock` message at the current time.
    pub fn clock(&self) -> Clock {
        Clock { clock: self.now() }
    }

    /// `/joint_states` of arm `arm` at the current time (joint names unprefixed).
    pub fn joint_states(&mut self, arm: usize) -> JointState {
        let stamp = self.now();
        let a = self.sim.arm(arm);
        let msg = &mut self.joint_states[arm];
        msg.header.stamp = stamp;
        msg.position.copy_from_slice(a.joint_positions().as_slice());
        msg.velocity.copy_from_slice(a.joint_velocities().as_slice());
        msg.clone()
    }

    /// Whether `frame` is the base of a named arm: fixed in the world, so on `/tf_static`.
    fn is_arm_base(&self, frame: &str) -> bool {
        self.sim.scene().has_named_arms() && self.sim.arms().iter().any(|a| a.frames()[0] == frame)
    }

    /// `/tf`: the frame tree as `robot_state_publisher` publishes it — each link in its parent
    /// link's frame (one transform per joint) — plus every object in the root frame (the arm
    /// bases of a scene with named arms are on `/tf_static`).
    pub fn tf(&self) -> TFMessage {
        let stamp = self.now();
        let transforms = self
            .sim
            .frame_tree()
            .filter(|e| !self.is_arm_base(e.child))
            .map(|e| transform(e.parent.unwrap_or(&self.root_frame), e.child, stamp, &e.pose))
            .collect();
        TFMessage { transforms }
    }

    /// `/lwr/world` of arm `arm`, in the arm's base frame: its gripper state, held object, tool
    /// pose and every object (pose, distance from its tool point to the object's surface, tilt
    /// of the object's z axis from the world's vertical).
    pub fn world(&self, arm: usize) -> WorldState {
        let a = self.sim.arm(arm);
        let to_base = a.base().inverse();
        let tool = self.sim.arm_tool_pose(arm);
        let tool_point = nalgebra::Point3::from(self.sim.world_tool_pose(arm).translation.vector);
        let held = self.sim.arm_held_object(arm);
        let objects = self
            .sim
            .objects()
            .iter()
            .map(|o| {
                let z = o.pose.rotation * nalgebra::Vector3::z();
                WorldObject {
                    name: o.name.clone(),
                    pose: pose(&(to_base * o.pose)),
                    tool_distance: o.distance_to(&tool_point),
                    tilt: z.z.clamp(-1.0, 1.0).acos(),
                    held: held == Some(o.name.as_str()),
                }
            })
            .collect();
        WorldState {
            header: Header { stamp: self.now(), frame_id: a.frames()[0].clone() },
            gripper_state: match a.gripper() {
                GripperState::Open => WorldState::GRIPPER_OPEN,
                GripperState::Closed { .. } => WorldState::GRIPPER_CLOSED,
            },
            held_object: held.unwrap_or_default().to_owned(),
            tool_pose: pose(&tool),
            objects,
        }
    }

    /// `/tf_static`: the camera's optical frame, and the base of every named arm, in the root
    /// frame.
    pub fn tf_static(&self) -> TFMessage {
        let camera = &self.sim.scene().camera;
        let mut transforms = vec![transform(&self.root_frame, &camera.frame_id, self.now(), &camera.pose.isometry())];
        transforms.extend(
            self.sim
                .frame_tree()
                .filter(|e| self.is_arm_base(e.child))
                .map(|e| transform(&self.root_frame, e.child, self.now(), &e.pose)),
        );
        TFMessage { transforms }
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
pub(crate) fn absolute_mesh_uris(urdf: &str, dir: &std::path::Path) -> String {
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

/// The URDF `urdf` with every link of `links` renamed `<prefix><link>` (its `<link name=…>`
/// and the joints' `parent`/`child` references), as robot_state_publisher's `frame_prefix`.
pub(crate) fn prefix_link_names(urdf: &str, links: &[String], prefix: &str) -> String {
    let mut out = urdf.to_owned();
    for link in links {
        for (from, to) in [
            (format!("<link name=\"{link}\""), format!("<link name=\"{prefix}{link}\"")),
            (format!("link=\"{link}\""), format!("link=\"{prefix}{link}\"")),
        ] {
            out = out.replace(&from, &to);
        }
    }
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


#[cfg(test)]
mod tests {
    use super::*;
    use cowork_robot::RobotModel;
    use cowork_sim::Scene;

    fn kitchen() -> LwrSim {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let config: LwrSimConfig = cowork_ros::params::load(&root.join("config/lwr_sim.yaml"), "lwr_sim").expect("bundled parameters");
        let model = RobotModel::from_urdf_file(&root.join("config/robot/lwr4plus.urdf")).expect("URDF");
        let scene = Scene::from_file(&root.join("config/scenes/kitchen.yaml")).expect("scene");
        LwrSim::new(Simulator::new(model, scene, config.simulation.clone()).expect("simulator"), config)
    }

    #[test]
    fn placements_move_known_objects_and_refuse_the_rest() {
        let mut lwr = kitchen();
        let mut m = WorldObject { name: "bottle".into(), ..Default::default() };
        m.pose.position.x = 0.9;
        m.pose.position.z = 0.4;
        m.pose.orientation.w = 1.0;
        assert_eq!(lwr.on_place_object(&m), Ok(()));
        let bottle = lwr.sim.objects().iter().find(|o| o.name == "bottle").map(|o| o.pose.translation.vector);
        assert_eq!(bottle.map(|v| (v.x, v.z)), Some((0.9, 0.4)));
        let mut bad = m.clone();
        bad.pose.orientation.w = 0.0;
        bad.pose.position.x = 0.1;
        assert_eq!(lwr.on_place_object(&bad).map_err(|w| w.kind), Err("/lwr/place_object:pose.orientation".to_owned()));
        bad = m.clone();
        bad.pose.position.y = f64::INFINITY;
        assert!(lwr.on_place_object(&bad).is_err());
        bad = m.clone();
        bad.name = "x".repeat(100_000);
        let w = lwr.on_place_object(&bad).expect_err("unknown object");
        assert!(w.message.len() < 1000, "the warning quotes a prefix of the name: {} bytes", w.message.len());
        let bottle = lwr.sim.objects().iter().find(|o| o.name == "bottle").map(|o| o.pose.translation.vector);
        assert_eq!(bottle.map(|v| (v.x, v.y, v.z)), Some((0.9, 0.0, 0.4)), "refused placements change nothing");
    }
}
