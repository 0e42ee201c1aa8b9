//! The ROS side of the node without I/O: [`Adapter`] (message conversion and validation),
//! [`StatusTracker`] (what `/motion/status` says: aborts, holds, resumes, de-duplication and the
//! status rate) and [`DsNode`], whose one handler per [`Input`] takes a message (or a result of
//! the real-time loop) and the node's clock and fills [`Outputs`]: the inputs the real-time loop
//! is to read, a model to hand it, the joint velocities and statuses to publish, warnings and
//! notes to log. Nothing here publishes, logs or reads a clock, so tests drive it message by
//! message with a mock clock (`tests/golden.rs`); `run.rs` wires it to DDS.

use cowork_ds::goal::Reach;
use cowork_ds::primitive::{ConstantSpeed, Linear};
use cowork_ds::{
    Distances, ExternalWrench, Fault, HoldReason, HumanInput, HumanMode, HumanState, JointMove, LinkDistance, MotionCommand,
    Primitive, Status, Stream, WrenchIgnored,
};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::WrenchStamped;
use cowork_msgs::msg::{
    HumanState as HumanStateMsg, LinkDistances, MotionCommand as MotionCommandMsg, MotionStatus, WorldState,
};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Header;
use cowork_robot::{DOF, JointVector, LinkPoses, MAX_LINKS, RobotModel};
use cowork_msgs::topics;
use cowork_ros::{Warning, quote};
use nalgebra::{Point3, Quaternion, UnitQuaternion, Vector3};

use crate::human::CautiousHuman;
use crate::learned::{self, Learned};
use crate::params::Params;
use crate::rt::{RtInputs, RtOutput};
use crate::scene::SceneObjects;

/// Obstacle points within this distance of a handover's goal are the hand the object is
/// handed to (m): the goal is the hand + 5 cm (Sec. 5.1.3), the hand about 10 cm long.
pub const HANDOVER_HAND_RADIUS_M: f64 = 0.15;

/// A command with end-effector avoidance off (the handover) goes to the person's hand: the
/// hand is the goal, not something to keep 10 cm from. Links whose closest obstacle point lies
/// within [`HANDOVER_HAND_RADIUS_M`] of the goal get the damper's known-object distances
/// (`Distances::scene_object`: it may come to a few cm, as to an object it grasps); every other
/// obstacle (the person's forearm, body, another person) keeps the full damping, and the links'
/// null-space avoidance is unchanged. Does nothing while end-effector avoidance is on.
pub fn mark_handover_goal(d: &mut Distances, command: &MotionCommand) {
    if command.end_effector_avoidance || matches!(command.primitive, Primitive::Hold) {
        return;
    }
    for (link, mark) in d.links.iter().zip(d.scene_object.iter_mut()).take(d.count) {
        if link.valid
            && link.obstacle_point.iter().all(|v| v.is_finite())
            && (link.obstacle_point.coords - command.goal).norm() <= HANDOVER_HAND_RADIUS_M
        {
            *mark = true;
        }
    }
}


/// Why the adapter rejected a message.
#[derive(Debug, Clone, PartialEq)]
pub struct Rejection {
    /// Human-readable reason, naming the field.
    pub reason: String,
}

/// Message conversions and validation (no I/O).
#[derive(Debug, Clone)]
pub struct Adapter {
    model: RobotModel,
    max_wrench_age_s: f64,
    max_force: f64,
    joint_names: Vec<String>,
    link_names: Vec<String>,
    /// Prefix of the robot's tf frames (`left/` in namespace `/left`), empty for none.
    frame_prefix: String,
    reach: Reach,
    far_speed: f64,
    default_linear_gain: f64,
    model_files: learned::ModelFiles,
}

impl Adapter {
    /// For `model` with `params`.
    pub fn new(model: &RobotModel, params: &Params) -> Self {
        Self {
            model: model.clone(),
            max_wrench_age_s: params.controller.ttc.max_wrench_age_s,
            max_force: params.controller.ttc.max_force,
            joint_names: model.joint_names().to_vec(),
            link_names: model.link_names().to_vec(),
            frame_prefix: String::new(),
            reach: Reach::of_model(model),
            far_speed: params.controller.scaling.far_speed,
            default_linear_gain: params.default_linear_gain,
            model_files: learned::ModelFiles {
                dir: (!params.primitive_dir.is_empty()).then(|| params.primitive_dir.clone().into()),
                max_bytes: params.max_model_file_bytes,
            },
        }
    }

    /// Name of link `i` (for reasons).
    pub fn link_name(&self, i: usize) -> &str {
        self.link_names.get(i).map(String::as_str).unwrap_or("?")
    }

    /// `/joint_states` → joint positions in model order (by name; by position when the
    /// message has no names).
    pub fn joint_state(&self, msg: &JointState) -> Result<JointVector, Rejection> {
        let mut q = JointVector::zeros();
        cowork_ros::joint_positions(&self.joint_names, msg, q.as_mut_slice()).map_err(|reason| Rejection { reason })?;
        Ok(q)
    }

    /// `/fded/distances` → per-link distances by URDF link (by name; by position for entries
    /// without a name). Non-finite values and zero normals are passed on for the controller's
    /// validation (it holds the robot, naming the link); structural errors are rejected here.
    pub fn distances(&self, msg: &LinkDistances, stamp: f64) -> Result<Distances, Rejection> {
        let mut d = Distances::clear(stamp);
        d.count = self.link_names.len().min(MAX_LINKS);
        // fDED sends one entry per link; an empty or partial message is no evidence that the
        // other links are free, so it is refused (and the robot held) rather than read as
        // "no obstacle".
        if msg.links.len() != d.count {
            return Err(Rejection {
                reason: format!(
                    "{} link entries, the robot has {} links (one entry per link is required)",
                    msg.links.len(),
                    d.count
                ),
            });
        }
        // Each link exactly once: a link named twice leaves another without an entry, which
        // would read as "no obstacle" (a fake all-clear).
        let mut seen = [false; MAX_LINKS];
        for (pos, l) in msg.links.iter().enumerate() {
            let i = if l.link_name.is_empty() {
                pos
            } else {
                self.link_names.iter().position(|n| *n == l.link_name).ok_or_else(|| Rejection {
                    reason: format!("unknown link name {:?} in entry {pos}", quote(&l.link_name)),
                })?
            };
            if std::mem::replace(&mut seen[i], true) {
                return Err(Rejection {
                    reason: format!("link {:?} has a second entry (entry {pos}); one entry per link is required", self.link_names[i]),
                });
            }
            let p = |p: &cowork_msgs::geometry_msgs::Point| Point3::new(p.x, p.y, p.z);
            let v = |v: &cowork_msgs::geometry_msgs::Vector3| Vector3::new(v.x, v.y, v.z);
            d.links[i] = LinkDistance {
                valid: l.valid,
                distance: l.distance,
                robot_point: p(&l.robot_point),
                obstacle_point: p(&l.obstacle_point),
                normal: v(&l.normal),
                obstacle_velocity: v(&l.obstacle_velocity),
            };
        }
        Ok(d)
    }

    /// `/lwr/external_wrench` → the push for task transition control: `header.frame_id` names
    /// the contact link (a link of the robot model), the force is expressed in that link's
    /// frame and turned into the base frame at the joint positions `q` (the newest
    /// `/joint_states`), `now` is the node's clock (s). Refused, naming the reason: no joint
    /// reading yet, an unknown or empty frame, a NaN / infinite force or stamp, a force above
    /// `ttc.max_force`, a stamp more than `ttc.max_wrench_age_s` away from `now` (either way).
    pub fn wrench(&self, msg: &WrenchStamped, q: Option<&JointVector>, now: f64) -> Result<ExternalWrench, Rejection> {
        let bad = |reason: String| Err(Rejection { reason });
        let frame = msg.header.frame_id.as_str();
        // The link's tf frame (`left/lwr_link_5` in namespace /left) or its model name.
        let link_name = frame.strip_prefix(self.frame_prefix.as_str()).unwrap_or(frame);
        let Some(link) = self.link_names.iter().position(|n| n == link_name) else {
            return bad(format!("unknown contact frame {:?} (expected a link of the robot model)", quote(frame)));
        };
        let f = &msg.wrench.force;
        let local = Vector3::new(f.x, f.y, f.z);
        let stamp = msg.header.stamp.to_secs_f64();
        if !(local.iter().all(|v| v.is_finite()) && stamp.is_finite()) {
            return bad(format!("non-finite force ({}, {}, {}) N on {frame}", f.x, f.y, f.z));
        }
        let norm = local.norm();
        if norm > self.max_force {
            return bad(format!("force {norm:.1} N on {frame} exceeds ttc.max_force {} N", self.max_force));
        }
        let age = now - stamp;
        if age.is_nan() || age.abs() > self.max_wrench_age_s {
            return bad(format!("stale: stamped {age:.3} s before now (bound ±ttc.max_wrench_age_s = {} s)", self.max_wrench_age_s));
        }
        let Some(q) = q else {
            return bad(format!("no {} yet (the contact link's orientation is unknown)", topics::JOINT_STATES.name));
        };
        let mut poses = LinkPoses::new();
        self.model.forward_kinematics(q, &mut poses);
        Ok(ExternalWrench { stamp, link, force: poses.get(link).rotation * local })
    }

    /// `/human/state` → what the controller needs.
    pub fn human(&self, msg: &HumanStateMsg) -> Result<HumanState, Rejection> {
        let mode = match msg.mode {
            HumanStateMsg::MODE_FAR => HumanMode::Far,
            HumanStateMsg::MODE_INTERACTION => HumanMode::Interaction,
            m => return Err(Rejection { reason: format!("unknown mode {m} (0 far, 1 interaction)") }),
        };
        Ok(HumanState { present: msg.present, mode, stopped: msg.stopped })
    }

    /// `/motion/command` → the motion (with its decoded model for DMP / GMR / C-GMR / HMM), or why
    /// it cannot run.
    pub fn command(&self, msg: &MotionCommandMsg) -> Result<(MotionCommand, Option<Learned>), Rejection> {
        let bad = |reason: String| Err(Rejection { reason });
        let mut model = None;
        let primitive = match msg.kind {
            MotionCommandMsg::KIND_LINEAR => {
                let gain = msg.parameters.first().copied().unwrap_or(self.default_linear_gain);
                Primitive::Linear(Linear { gain })
            }
            MotionCommandMsg::KIND_CONSTANT_SPEED => {
                let speed = if msg.nominal_speed == 0.0 { self.far_speed } else { msg.nominal_speed };
                let smoothing = msg.parameters.first().copied().unwrap_or(ConstantSpeed::DEFAULT_SMOOTHING);
                Primitive::ConstantSpeed(ConstantSpeed { speed, smoothing })
            }
            MotionCommandMsg::KIND_HOLD => Primitive::Hold,
            k @ (MotionCommandMsg::KIND_DMP
            | MotionCommandMsg::KIND_GMR
            | MotionCommandMsg::KIND_CGMR
            | MotionCommandMsg::KIND_HMM) => {
                let kind = match k {
                    MotionCommandMsg::KIND_DMP => "dmp",
                    MotionCommandMsg::KIND_GMR => "gmr",
                    MotionCommandMsg::KIND_HMM => "hmm",
                    _ => "cgmr",
                };
                match learned::decode(kind, &msg.parameters_json, &self.model_files, self.model.link_names()) {
                    Ok(m) => model = Some(m),
                    Err(e) => return bad(format!("primitive kind {k} ({kind}): {e}")),
                }
                Primitive::Learned
            }
            MotionCommandMsg::KIND_JOINTS => {
                let p = &msg.parameters;
                if p.len() != DOF + 2 {
                    return bad(format!(
                        "primitive kind {} (joints): parameters must be [7 joint positions (rad), gain (1/s), max_speed (rad/s)], got {} values",
                        msg.kind,
                        p.len()
                    ));
                }
                let mut joints = [0.0; DOF];
                joints.copy_from_slice(&p[..DOF]);
                for (i, (v, l)) in joints.iter().zip(self.model.joint_limits()).enumerate() {
                    if !l.contains(*v) {
                        return bad(format!(
                            "primitive kind {} (joints): joint {} goal {v} rad is outside its limits [{}, {}] rad",
                            msg.kind,
                            i + 1,
                            l.lower,
                            l.upper
                        ));
                    }
                }
                Primitive::Joints(JointMove { joints, gain: p[DOF], max_speed: p[DOF + 1] })
            }
            k => return bad(format!("unknown primitive kind {k}")),
        };
        if let Some((what, value)) = primitive.invalid_parameter() {
            return bad(format!("primitive parameter {what} = {value} must be finite and > 0"));
        }
        let gp = &msg.goal.position;
        let goal = match primitive {
            // The tool's position at the goal joints (the message's goal is not used).
            Primitive::Joints(m) => {
                let mut poses = LinkPoses::new();
                self.model.forward_kinematics(&JointVector::from_row_slice(&m.joints), &mut poses);
                poses.get(self.model.tip_link()).translation.vector
            }
            _ => Vector3::new(gp.x, gp.y, gp.z),
        };
        if !goal.iter().all(|v| v.is_finite()) {
            return bad(format!("goal position ({}, {}, {}) is not finite", gp.x, gp.y, gp.z));
        }
        let o = &msg.goal.orientation;
        let orientation = if msg.hold_orientation || matches!(primitive, Primitive::Hold | Primitive::Joints(_)) {
            None
        } else {
            let q = Quaternion::new(o.w, o.x, o.y, o.z);
            if !q.coords.iter().all(|v| v.is_finite()) || q.norm() < 0.5 {
                return bad(format!("goal orientation ({}, {}, {}, {}) is not a unit quaternion", o.x, o.y, o.z, o.w));
            }
            Some(UnitQuaternion::from_quaternion(q))
        };
        if !matches!(primitive, Primitive::Hold)
            && let Err(e) = self.reach.check(&goal)
        {
            return bad(e.to_string());
        }
        // A handover has to reach the person's hand: the command may turn the end effector's
        // avoidance off; null-space avoidance and the other links' damping stay on.
        let end_effector_avoidance = !msg.end_effector_avoidance_off;
        Ok((MotionCommand { id: msg.id, primitive, goal, orientation, end_effector_avoidance }, model))
    }

    /// A reason for a status message: the controller's fault with link names; while moving,
    /// `approach limited: LINK` when the link-distance damper held back link `limited` (the
    /// caller keeps it for a moment so a damper switching at 1 kHz does not flood the topic).
    pub fn reason(&self, o: &RtOutput, limited: Option<usize>) -> String {
        if o.waiting_for_joints {
            return format!("waiting for {}", topics::JOINT_STATES.name);
        }
        match o.status {
            Status::Running | Status::Converged => match (o.guided, limited) {
                (Some((link, stack)), _) => {
                    let stack = ["T_ee", "[T_ee, T_ic]", "[T_ic, T_ee]"][usize::from(stack.min(2))];
                    match link {
                        Some(l) => format!("guided: push on {}, {stack}", self.link_name(l)),
                        None => format!("guided: push released, {stack}"),
                    }
                }
                (None, Some(l)) => format!("approach limited: {}", self.link_name(l)),
                (None, None) => String::new(),
            },
            Status::Held(HoldReason::Command) if o.command_id == 0 => format!("waiting for {}", topics::MOTION_COMMAND.name),
            Status::Held(HoldReason::Command) => "hold command".into(),
            Status::Held(HoldReason::SpeedZero) => "speed scale 0 (stop)".into(),
            Status::Held(HoldReason::Fault(f)) => match f {
                Fault::NonFinite { what, link } if link != usize::MAX => {
                    format!("non-finite {what} for link {} on {}", self.link_name(link), topics::FDED_DISTANCES.name)
                }
                Fault::ZeroNormal { link } => {
                    format!("zero obstacle normal for link {} on {}", self.link_name(link), topics::FDED_DISTANCES.name)
                }
                other => other.to_string(),
            },
        }
    }
}

/// `/motion/status` state of an output.
pub fn state_of(status: &Status) -> u8 {
    match status {
        Status::Running => MotionStatus::STATE_RUNNING,
        Status::Converged => MotionStatus::STATE_CONVERGED,
        Status::Held(_) => MotionStatus::STATE_HELD,
    }
}


/// One input of the ROS side: a message from a subscription, or a result of the real-time loop.
#[derive(Debug, Clone)]
pub enum Input {
    /// `/joint_states`.
    JointState(JointState),
    /// `/fded/distances`.
    Distances(LinkDistances),
    /// `/human/state`.
    Human(HumanStateMsg),
    /// `/motion/command`.
    Command(MotionCommandMsg),
    /// `/lwr/world` (scene objects' poses).
    World(WorldState),
    /// `/<arm>/joint_states` of the scene's other arm number `.0` (`SceneObjects::other_arms`).
    OtherArm(usize, JointState),
    /// `/lwr/external_wrench` (only read with `controller.ttc.enabled`).
    Wrench(WrenchStamped),
    /// One step of the real-time loop.
    Step(RtOutput),
}

/// How long the damper's limited link stays in the status reason after it was last limited
/// (s, node clock): a damper switching at 1 kHz does not flood `/motion/status`.
pub const LIMITED_SHOWN_S: f64 = 0.2;

/// What `/motion/status` says, from the real-time loop's outputs and the ROS side's events:
/// - a status is published when (command id, state, reason) changes, and otherwise at most
///   once per `1 / status_rate_hz` of the node clock (at least that often while outputs come);
/// - an aborted command reads ABORTED with its reason for as long as it is the current command
///   (the loop holds the robot on it), until another command is accepted;
/// - a rejected `/fded/distances` reads HELD `rejected /fded/distances: REASON` at once and for
///   as long as the loop holds the robot on it; accepted distances end it;
/// - the link the damper limited stays in the reason for [`LIMITED_SHOWN_S`];
/// - a hold on stale data is one hold while it lasts, although its reason (with the data's
///   age) changes at every step: published once, then at the rate with the current age.
#[derive(Debug, Clone)]
pub struct StatusTracker {
    period_s: f64,
    last: Option<(u32, u8, String)>,
    last_at: f64,
    aborted: Option<(u32, String)>,
    distances_rejected: Option<String>,
    limited: Option<(usize, f64)>,
}

impl StatusTracker {
    /// At least one status per `1 / status_rate_hz` seconds while outputs come.
    pub fn new(status_rate_hz: f64) -> Self {
        Self {
            period_s: 1.0 / status_rate_hz,
            last: None,
            last_at: f64::NEG_INFINITY,
            aborted: None,
            distances_rejected: None,
            limited: None,
        }
    }

    /// A command was accepted: an earlier abort no longer applies.
    pub fn command_accepted(&mut self) {
        self.aborted = None;
    }

    /// Command `id` is aborted with `reason`: the ABORTED status to publish now (always: every
    /// command gets its answer, even a repeated one).
    pub fn abort(&mut self, id: u32, reason: &str, now: f64) -> MotionStatus {
        self.aborted = Some((id, reason.to_owned()));
        let key = (id, MotionStatus::STATE_ABORTED, reason.to_owned());
        self.publish(key, f64::NAN, now)
    }

    /// `/fded/distances` was rejected while command `id` is current: the HELD status to publish
    /// now, unless it says what the last one said within the status period (or `id` is aborted,
    /// which its status already says).
    pub fn distances_rejected(&mut self, id: u32, reason: &str, now: f64) -> Option<MotionStatus> {
        self.distances_rejected = Some(reason.to_owned());
        if self.aborted.as_ref().is_some_and(|(a, _)| *a == id) {
            return None;
        }
        let key = (id, MotionStatus::STATE_HELD, Self::rejected_reason(reason));
        self.due(&key, now).then(|| self.publish(key, f64::NAN, now))
    }

    /// Good `/fded/distances` arrived.
    pub fn distances_accepted(&mut self) {
        self.distances_rejected = None;
    }

    /// The status of a step of the real-time loop at node time `now`, when one is due, and
    /// whether its state or reason differ from the last one published (worth a log line).
    pub fn on_output(&mut self, o: &RtOutput, adapter: &Adapter, now: f64) -> Option<(MotionStatus, bool)> {
        if let Some(l) = o.approach_limited {
            self.limited = Some((l, o.time));
        } else if self.limited.is_some_and(|(_, t)| !(o.time - t <= LIMITED_SHOWN_S && o.time >= t)) {
            self.limited = None;
        }
        let (state, reason) = match (&self.aborted, &self.distances_rejected, o.status) {
            (Some((id, reason)), _, _) if *id == o.command_id => (MotionStatus::STATE_ABORTED, reason.clone()),
            (_, Some(why), Status::Held(HoldReason::Fault(Fault::Rejected { stream: Stream::Distances, .. }))) => {
                (MotionStatus::STATE_HELD, Self::rejected_reason(why))
            }
            _ => (state_of(&o.status), adapter.reason(o, self.limited.map(|l| l.0))),
        };
        // A stale input's reason carries its age, new at every step: the same hold for the
        // de-duplication (the status at the rate still says the current age).
        let same_as = match o.status {
            Status::Held(HoldReason::Fault(Fault::Stale { stream, age_s, .. })) if !matches!(self.aborted, Some((id, _)) if id == o.command_id) => {
                Some(format!("stale {stream}{}", if age_s < 0.0 { " (future)" } else { "" }))
            }
            _ => None,
        };
        let key = (o.command_id, state, same_as.unwrap_or_else(|| reason.clone()));
        if !self.due(&key, now) {
            return None;
        }
        let changed = self.last.as_ref().is_none_or(|l| l.1 != key.1 || l.2 != key.2);
        let mut status = self.publish(key, o.goal_error, now);
        status.reason = reason;
        Some((status, changed))
    }

    fn rejected_reason(reason: &str) -> String {
        format!("rejected {}: {reason}", topics::FDED_DISTANCES.name)
    }

    /// A status is due when it differs from the last one or the period has passed (or the
    /// clock went back: a restarted simulation).
    fn due(&self, key: &(u32, u8, String), now: f64) -> bool {
        self.last.as_ref() != Some(key) || !(now - self.last_at < self.period_s && now >= self.last_at)
    }

    fn publish(&mut self, key: (u32, u8, String), goal_error: f64, now: f64) -> MotionStatus {
        let (command_id, state, reason) = key.clone();
        self.last = Some(key);
        self.last_at = now;
        MotionStatus { header: Header { stamp: stamp(now), frame_id: String::new() }, command_id, state, reason, goal_error }
    }
}

/// A ROS time stamp of node time `t` (s).
pub fn stamp(t: f64) -> Time {
    if t.is_finite() { Time::from_nanos((t * 1e9).round() as i64) } else { Time::default() }
}

/// What one input asks of the run loop, in this order: hand `model` to the real-time loop
/// (and call [`DsNode::on_model_refused`] if it cannot take it), copy the node's
/// [`RtInputs`] into the loop's mailbox when `rt_changed`, publish `velocity` and `statuses`,
/// log `warnings` (rate-limited by kind) and `notes`. Cleared by the loop before each input.
#[derive(Debug, Default)]
pub struct Outputs {
    /// The inputs of the real-time loop changed.
    pub rt_changed: bool,
    /// A decoded learned model for command `id`, to hand to the real-time loop.
    pub model: Option<(u32, Box<Learned>)>,
    /// Joint velocity command (rad/s) to publish.
    pub velocity: Option<JointVector>,
    /// `/motion/status` messages to publish, in order.
    pub statuses: Vec<MotionStatus>,
    /// `/ds_controller/ttc` to publish: weights (T¹, T², T³) and the push (N).
    pub ttc: Option<[f64; 4]>,
    /// Warnings about inputs (the loop rate-limits them by kind).
    pub warnings: Vec<Warning>,
    /// Notes worth an info log line (a command accepted, a status change).
    pub notes: Vec<String>,
}

impl Outputs {
    /// Empties every field (keeps the buffers).
    pub fn clear(&mut self) {
        self.rt_changed = false;
        self.model = None;
        self.velocity = None;
        self.statuses.clear();
        self.ttc = None;
        self.warnings.clear();
        self.notes.clear();
    }
}

/// The ROS side's state: the adapter, the scene objects, the cautious choice of `/human/state`,
/// the status tracker and the inputs the real-time loop is to read. One handler per input;
/// `now` is the node's clock (s). Pure: no I/O, no logging, no clock reads.
#[derive(Debug)]
pub struct DsNode {
    adapter: Adapter,
    scene: SceneObjects,
    scene_max_age_s: f64,
    /// The damper's `hand_radius`, m: the hand is kept off the table below
    /// [`crate::scene::HAND_FLOOR_M`] only.
    hand_radius_m: f64,
    human: CautiousHuman,
    status: StatusTracker,
    rt: RtInputs,
    /// Node time `/ds_controller/ttc` was last published while blending; `None` at T¹.
    ttc_published: Option<f64>,
    /// The label of the last motion command logged, and how many commands with the same label
    /// (a streamed primitive's goals) came after it unlogged.
    logged_label: (String, u32),
}

impl DsNode {
    /// Names the robot's tf frames with `prefix` (`left/` for a node in namespace `/left`): a
    /// push reported on `left/lwr_link_5` is on link `lwr_link_5`.
    pub fn set_frame_prefix(&mut self, prefix: &str) {
        prefix.clone_into(&mut self.adapter.frame_prefix);
    }

    /// For `model` with `params` (validated) and the scene objects the damper knows.
    pub fn new(model: &RobotModel, params: &Params, scene: SceneObjects) -> Self {
        Self {
            adapter: Adapter::new(model, params),
            scene,
            scene_max_age_s: params.scene_objects.max_age_s,
            hand_radius_m: params.controller.safety.hand_radius,
            human: CautiousHuman::new(params.controller.stale_after_s, params.controller.future_tolerance_s),
            status: StatusTracker::new(params.status_rate_hz),
            rt: RtInputs::default(),
            ttc_published: None,
            logged_label: (String::new(), 0),
        }
    }

    /// What the real-time loop is to read now.
    pub fn rt_inputs(&self) -> &RtInputs {
        &self.rt
    }

    /// The message adapter.
    pub fn adapter(&self) -> &Adapter {
        &self.adapter
    }

    /// Number of scene objects whose shape is known.
    pub fn scene_objects_known(&self) -> usize {
        self.scene.known()
    }

    /// ` (0.087 m to an unknown obstacle at (x, y, z) m)`: link `l`'s newest distance, obstacle
    /// point (base frame) and whether it is a known scene object or another arm.
    fn limited_detail(&self, l: usize) -> String {
        let d = &self.rt.distances;
        match d.links.get(l).filter(|_| l < d.count) {
            Some(e) if e.valid => format!(
                " ({:.3} m to {} at ({:.2}, {:.2}, {:.2}) m)",
                e.distance,
                if d.scene_object[l] { "a known object" } else { "an unknown obstacle" },
                e.obstacle_point.x,
                e.obstacle_point.y,
                e.obstacle_point.z
            ),
            _ => String::new(),
        }
    }

    /// Handles one input at node time `now` (s), appending to `out`.
    pub fn on_input(&mut self, input: Input, now: f64, out: &mut Outputs) {
        match input {
            Input::JointState(m) => self.on_joint_state(&m, out),
            Input::Distances(m) => self.on_distances(&m, now, out),
            Input::Human(m) => self.on_human(&m, now, out),
            Input::Command(m) => self.on_command(&m, now, out),
            Input::World(m) => self.on_world(&m, out),
            Input::OtherArm(i, m) => self.on_other_arm(i, &m, out),
            Input::Wrench(m) => self.on_wrench(&m, now, out),
            Input::Step(o) => self.on_step(&o, now, out),
        }
    }

    /// `/joint_states`: the newest joint positions, stamped when measured (the watchdog ages
    /// them by the stamp, so a late delivery is as old as it is).
    pub fn on_joint_state(&mut self, m: &JointState, out: &mut Outputs) {
        match self.adapter.joint_state(m) {
            Ok(q) => {
                self.rt.joints = Some((q, m.header.stamp.to_secs_f64()));
                out.rt_changed = true;
            }
            Err(r) => out.warnings.push(Warning::new(
                format!("{}:rejected", topics::JOINT_STATES.name),
                format!("{} rejected: {}", topics::JOINT_STATES.name, r.reason),
            )),
        }
    }

    /// `/<arm>/joint_states` of another arm (`i` as in `SceneObjects::other_arms`): where its
    /// links are, for the damper. A rejected message is ignored with a warning (the arm's
    /// newest good state ages out, and then it is an unknown obstacle).
    pub fn on_other_arm(&mut self, i: usize, m: &JointState, out: &mut Outputs) {
        match self.adapter.joint_state(m) {
            Ok(q) => self.scene.on_other_arm(i, &q, m.header.stamp.to_secs_f64()),
            Err(r) => {
                let arm = self.scene.other_arms().get(i).cloned().unwrap_or_default();
                out.warnings.push(Warning::new(
                    format!("/{arm}/joint_states:rejected"),
                    format!("/{arm}/joint_states rejected (that arm is an unknown obstacle until good ones come): {}", r.reason),
                ));
            }
        }
    }

    /// `/fded/distances`: classified by the scene objects and the handover goal; a rejected
    /// message holds the robot (fail closed) with the reason in the status until good ones come.
    pub fn on_distances(&mut self, m: &LinkDistances, now: f64, out: &mut Outputs) {
        let topic = topics::FDED_DISTANCES.name;
        match self.adapter.distances(m, m.header.stamp.to_secs_f64()) {
            Ok(mut d) => {
                if self.scene.any() && self.scene.mark(&mut d).is_none() && self.scene.known() > 0 {
                    out.warnings.push(Warning::new(
                        format!("{topic}:no_world"),
                        format!(
                            "no {} report within {} s of {topic} at {:.3} s: no scene object known (the damper treats every obstacle as a person)",
                            topics::WORLD.name,
                            self.scene_max_age_s,
                            d.stamp
                        ),
                    ));
                }
                // The joints when the frame was taken (the newest, if that close to its stamp).
                if let Some((q, _)) = self.rt.joints.filter(|(_, t)| (t - d.stamp).abs() <= self.scene_max_age_s) {
                    self.scene.mark_table(&mut d, &q, self.hand_radius_m);
                }
                mark_handover_goal(&mut d, &self.rt.command);
                self.rt.distances = d;
                self.rt.distances_rejected = None;
                self.status.distances_accepted();
            }
            Err(r) => {
                out.warnings.push(Warning::new(
                    format!("{topic}:rejected"),
                    format!("{topic} rejected, robot held: {}", r.reason),
                ));
                self.rt.distances_rejected = Some("malformed message (see the log)");
                if let Some(s) = self.status.distances_rejected(self.rt.command.id, &r.reason, now) {
                    out.statuses.push(s);
                }
            }
        }
        out.rt_changed = true;
    }

    /// `/human/state`: the most cautious live state, not the newest (`human.rs`).
    pub fn on_human(&mut self, m: &HumanStateMsg, now: f64, out: &mut Outputs) {
        match self.adapter.human(m) {
            Ok(h) => {
                self.rt.human = self.human.on_state(HumanInput { stamp: m.header.stamp.to_secs_f64(), state: h }, now);
                out.rt_changed = true;
            }
            Err(r) => out.warnings.push(Warning::new(
                format!("{}:rejected", topics::HUMAN_STATE.name),
                format!("{} rejected: {}", topics::HUMAN_STATE.name, r.reason),
            )),
        }
    }

    /// `/motion/command`: the new motion (its model to be handed to the loop first), or
    /// ABORTED with the reason and the robot held.
    pub fn on_command(&mut self, m: &MotionCommandMsg, now: f64, out: &mut Outputs) {
        match self.adapter.command(m) {
            Ok((c, model)) => {
                // A streamed primitive sends a goal every few hundred ms under one label: the
                // first is logged, the rest counted in the next line logged.
                let (label, streamed) = &mut self.logged_label;
                if *label == m.label && !m.label.is_empty() {
                    *streamed += 1;
                } else {
                    let after = match *streamed {
                        0 => String::new(),
                        n => format!(" (after {n} more goal(s) streamed for {})", quote(label)),
                    };
                    out.notes.push(format!(
                        "motion command {}: {} → ({:.3}, {:.3}, {:.3}) m {}{after}",
                        c.id,
                        c.primitive,
                        c.goal.x,
                        c.goal.y,
                        c.goal.z,
                        quote(&m.label)
                    ));
                    m.label.clone_into(label);
                    *streamed = 0;
                }
                self.status.command_accepted();
                out.model = model.map(|model| (c.id, Box::new(model)));
                self.rt.command = c;
            }
            Err(r) => self.abort(m.id, &r.reason, now, out),
        }
        out.rt_changed = true;
    }

    /// The real-time loop could not take the model of command `id` (`reason`): the command is
    /// aborted and the robot held.
    pub fn on_model_refused(&mut self, id: u32, reason: &str, now: f64, out: &mut Outputs) {
        self.abort(id, reason, now, out);
        out.rt_changed = true;
    }

    fn abort(&mut self, id: u32, reason: &str, now: f64, out: &mut Outputs) {
        out.warnings.push(Warning::new(
            format!("{}:aborted", topics::MOTION_COMMAND.name),
            format!("motion command {id} aborted, robot held: {reason}"),
        ));
        self.rt.command = MotionCommand { id, primitive: Primitive::Hold, ..self.rt.command };
        out.statuses.push(self.status.abort(id, reason, now));
    }

    /// `/lwr/world`: poses of the scene objects (before the distances they classify).
    pub fn on_world(&mut self, m: &WorldState, out: &mut Outputs) {
        if let Err(why) = self.scene.on_world(m) {
            out.warnings.push(Warning::new(
                format!("{}:refused", topics::WORLD.name),
                format!(
                    "{} refused: {why}; no scene object known until a good report (the damper treats every obstacle as a person)",
                    topics::WORLD.name
                ),
            ));
        }
    }

    /// `/lwr/external_wrench`: a person's push in the base frame at the newest joint positions;
    /// a refused one is not used (the primitive runs on as without it).
    pub fn on_wrench(&mut self, m: &WrenchStamped, now: f64, out: &mut Outputs) {
        let q = self.rt.joints.map(|(q, _)| q);
        match self.adapter.wrench(m, q.as_ref(), now) {
            Ok(w) => self.rt.wrench = Some(w),
            Err(r) => {
                self.rt.wrench = None;
                let topic = topics::LWR_EXTERNAL_WRENCH.name;
                out.warnings.push(Warning::new(
                    format!("{topic}:refused"),
                    format!("{topic} ignored: {}; the primitive runs on without the push", r.reason),
                ));
            }
        }
        out.rt_changed = true;
    }

    /// A step of the real-time loop: its joint velocities (none while waiting for joint
    /// states) and, when due, its status.
    pub fn on_step(&mut self, o: &RtOutput, now: f64, out: &mut Outputs) {
        // A push the loop refused although the adapter took it (stamped in the loop's future:
        // the clocks disagree). Ageing after the touch is the normal end, not news.
        if let Some(why) = o.wrench_ignored
            && !matches!(why, WrenchIgnored::Stale { age_s } if age_s >= 0.0)
        {
            let topic = topics::LWR_EXTERNAL_WRENCH.name;
            out.warnings.push(Warning::new(format!("{topic}:unused"), format!("{topic} not used by the control loop: {why}")));
        }
        if !o.waiting_for_joints {
            out.velocity = Some(o.qdot);
        }
        // The TTC blend every 10 ms while it lasts, and once when it is back at T¹.
        let ([w1, w2, w3], force) = o.ttc;
        match self.ttc_published {
            _ if w1 < 1.0 && self.ttc_published.is_none_or(|t| now - t >= 0.01 || now < t) => {
                self.ttc_published = Some(now);
                out.ttc = Some([w1, w2, w3, force]);
            }
            Some(_) if w1 >= 1.0 => {
                self.ttc_published = None;
                out.ttc = Some([1.0, 0.0, 0.0, 0.0]);
            }
            _ => {}
        }
        if let Some((s, changed)) = self.status.on_output(o, &self.adapter, now) {
            if changed {
                // The log says what held the link back (the status only names the link).
                let detail = o.approach_limited.filter(|_| s.reason.starts_with("approach limited")).map(|l| self.limited_detail(l)).unwrap_or_default();
                let why = if s.reason.is_empty() { String::new() } else { format!(": {}", s.reason) };
                out.notes.push(format!("status: command {} {}{why}{detail}", s.command_id, MotionStatus::state_name(s.state)));
            }
            out.statuses.push(s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn adapter() -> Adapter {
        let model = RobotModel::from_urdf_file(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/robot/lwr4plus.urdf"),
        )
        .expect("URDF");
        Adapter::new(&model, &Params::default())
    }

    fn out(t: f64, id: u32, status: Status) -> RtOutput {
        RtOutput {
            time: t,
            qdot: JointVector::zeros(),
            status,
            command_id: id,
            goal_error: 0.1,
            waiting_for_joints: false,
            approach_limited: None,
            guided: None,
            ttc: ([1.0, 0.0, 0.0], 0.0),
            wrench_ignored: None,
        }
    }

    #[test]
    fn the_ttc_blend_is_published_every_10_ms_while_it_lasts_and_once_at_its_end() {
        let model = RobotModel::from_urdf_file(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/robot/lwr4plus.urdf"),
        )
        .expect("URDF");
        let mut node = DsNode::new(&model, &Params::default(), SceneObjects::new(Default::default(), 0.04, 0.2, "lwr_base_link"));
        let mut sent = Vec::new();
        for k in 0..40 {
            let t = 1.0 + k as f64 * 0.001;
            let blend = if (5..30).contains(&k) { ([0.5, 0.5, 0.0], 8.0) } else { ([1.0, 0.0, 0.0], 0.0) };
            let mut o = Outputs::default();
            node.on_step(&RtOutput { ttc: blend, ..out(t, 1, Status::Running) }, t, &mut o);
            if let Some(v) = o.ttc {
                sent.push((k, v));
            }
        }
        let ks: Vec<usize> = sent.iter().map(|(k, _)| *k).collect();
        assert_eq!(ks, vec![5, 15, 25, 30], "{sent:?}");
        assert_eq!(sent[0].1, [0.5, 0.5, 0.0, 8.0]);
        assert_eq!(sent[3].1, [1.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn the_same_status_is_repeated_at_the_rate_and_at_once_after_the_clock_went_back() {
        let a = adapter();
        let mut s = StatusTracker::new(10.0);
        assert!(s.on_output(&out(100.0, 1, Status::Running), &a, 100.0).is_some_and(|(_, changed)| changed));
        assert!(s.on_output(&out(100.05, 1, Status::Running), &a, 100.05).is_none());
        assert!(s.on_output(&out(100.11, 1, Status::Running), &a, 100.11).is_some_and(|(_, changed)| !changed));
        // A restarted simulation: its clock starts again from 0.
        assert!(s.on_output(&out(0.001, 1, Status::Running), &a, 0.001).is_some());
        assert!(s.on_output(&out(0.002, 1, Status::Running), &a, 0.002).is_none());
    }

    #[test]
    fn a_hold_on_stale_data_is_one_status_while_its_age_grows() {
        let a = adapter();
        let mut s = StatusTracker::new(50.0);
        let stale = |age_s| Status::Held(HoldReason::Fault(Fault::Stale { stream: Stream::Distances, age_s, bound_s: 0.3 }));
        let (first, changed) = s.on_output(&out(1.0, 1, stale(0.301)), &a, 1.0).expect("a new hold");
        assert!(changed && first.reason.contains("age 0.301 s exceeds 0.3 s"), "{}", first.reason);
        for k in 1..20 {
            let t = 1.0 + f64::from(k) * 1e-3;
            assert!(s.on_output(&out(t, 1, stale(0.301 + f64::from(k) * 1e-3)), &a, t).is_none(), "status at step {k}");
        }
        let (again, changed) = s.on_output(&out(1.021, 1, stale(0.322)), &a, 1.021).expect("at the rate");
        assert!(!changed && again.reason.contains("age 0.322 s"), "{}", again.reason);
        // Stamped in the future: another hold.
        assert!(s.on_output(&out(1.022, 1, stale(-0.5)), &a, 1.022).is_some_and(|(_, changed)| changed));
    }

    #[test]
    fn an_abort_holds_until_another_command_is_accepted() {
        let a = adapter();
        let mut s = StatusTracker::new(50.0);
        let st = s.abort(3, "goal position (NaN, 0, 0.5) is not finite", 1.0);
        assert_eq!((st.command_id, st.state), (3, MotionStatus::STATE_ABORTED));
        assert!(st.goal_error.is_nan());
        // The loop holds command 3: ABORTED, not HELD; a rejection does not overwrite it.
        assert!(s.distances_rejected(3, "0 link entries", 1.001).is_none());
        let (st, _) = s.on_output(&out(1.1, 3, Status::Held(HoldReason::Command)), &a, 1.1).expect("due");
        assert_eq!(st.state, MotionStatus::STATE_ABORTED);
        assert!(st.reason.contains("not finite"), "{}", st.reason);
        s.command_accepted();
        // The loop still holding on the rejected distances (the newest message was bad).
        let rejected = Fault::Rejected { stream: Stream::Distances, reason: "malformed message (see the log)" };
        let (st, changed) = s.on_output(&out(1.2, 4, Status::Held(HoldReason::Fault(rejected))), &a, 1.2).expect("due");
        assert!(changed);
        assert_eq!((st.command_id, st.state, st.reason.as_str()), (4, MotionStatus::STATE_HELD, "rejected /fded/distances: 0 link entries"));
        s.distances_accepted();
        let (st, _) = s.on_output(&out(1.3, 4, Status::Running), &a, 1.3).expect("due");
        assert_eq!((st.state, st.reason.as_str()), (MotionStatus::STATE_RUNNING, ""));
    }
}
