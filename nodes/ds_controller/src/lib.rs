//! The `ds_controller` node: a thin ROS 2 adapter around [`cowork_ds::DsController`].
//!
//! Two threads:
//! - the **real-time loop** ([`rt_loop`]) steps the controller every period (1 ms of wall time,
//!   or of `/clock` time with `use_sim_time`). It reads the latest inputs from a [`Mailbox`]
//!   of `Copy` data and sends `Copy` [`RtOutput`]s through a bounded channel; it never
//!   allocates, logs, serialises or publishes;
//! - the **ROS side** ([`run`]) converts and validates messages ([`Adapter`]) into the mailbox,
//!   and publishes what the loop produced: `/lwr/joint_velocity_command` (every output) and
//!   `/motion/status` (on every change and at `status_rate_hz`).
//!
//! Inputs carry their header stamps (when the data was measured): the watchdog ages them
//! against the node's clock, so a frame delivered late is as old as it is. Bad input never stops the node: a
//! bad command is aborted with its reason and the robot held; bad distances (NaN, infinite,
//! zero normal, unknown link) hold the robot with the reason until valid ones arrive.

pub mod human;
pub mod learned;
pub mod scene;

use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError, TrySendError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Result, bail};
use cowork_ds::goal::Reach;
use cowork_ds::primitive::{ConstantSpeed, Linear};
use cowork_ds::{
    ControlInput, ControlOutput, ControllerConfig, Distances, DsController, ExternalWrench, Fault,
    HoldReason, HumanInput, HumanMode, HumanState, LearnedField, LinkDistance, MotionCommand,
    Primitive, Status, Stream, WrenchIgnored,
};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{
    HumanState as HumanStateMsg, LinkDistances, MotionCommand as MotionCommandMsg, MotionStatus,
    WorldState,
};
use cowork_msgs::geometry_msgs::WrenchStamped;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::{Float64MultiArray, Header};
use cowork_robot::{DOF, JointVector, LinkPoses, MAX_LINKS, RobotModel};
use cowork_ros::{RosNode, qos};
use nalgebra::{Point3, Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::learned::Learned;
use crate::scene::{SceneObjects, SceneObjectsParams};

/// The `ds_controller: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Take time from `/clock`.
    pub use_sim_time: bool,
    /// Minimum rate of `/motion/status` (Hz); it is also published on every change.
    pub status_rate_hz: f64,
    /// Gain k (1/s) of a `KIND_LINEAR` command without parameters.
    pub default_linear_gain: f64,
    /// Directory `{"model_file": NAME}` commands may read models from (relative to the working
    /// directory); empty refuses every `model_file`.
    pub primitive_dir: String,
    /// Largest model file read (bytes).
    pub max_model_file_bytes: u64,
    /// The controller (period, watchdog bound, speeds, modulation, IK).
    pub controller: ControllerConfig,
    /// Which obstacle points are known scene objects (the link damper's shorter distances).
    pub scene_objects: SceneObjectsParams,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            use_sim_time: false,
            status_rate_hz: 50.0,
            default_linear_gain: 2.0,
            primitive_dir: "out/primitives".into(),
            max_model_file_bytes: 4 << 20,
            controller: ControllerConfig::default(),
            scene_objects: SceneObjectsParams::default(),
        }
    }
}

impl Params {
    /// Rejects NaN and out-of-range values; `place` names the file.
    pub fn validate(&self, place: &str) -> Result<()> {
        self.controller
            .validate()
            .map_err(|e| anyhow::anyhow!("{place}: controller: {e}"))?;
        for (field, v) in [
            ("status_rate_hz", self.status_rate_hz),
            ("default_linear_gain", self.default_linear_gain),
        ] {
            if !(v.is_finite() && v > 0.0) {
                bail!("{place}: `{field}` = {v} must be a positive number");
            }
        }
        self.scene_objects.validate(place)?;
        if !(1..=(256 << 20)).contains(&self.max_model_file_bytes) {
            bail!("{place}: `max_model_file_bytes` = {} must be in 1..=268435456", self.max_model_file_bytes);
        }
        Ok(())
    }
}

/// The push lwr_sim reports in execute mode (geometry_msgs/WrenchStamped, `header.frame_id` =
/// the contact link, force in that link's frame).
pub const TOPIC_EXTERNAL_WRENCH: &str = "/lwr/external_wrench";

/// A latest-value mailbox of `Copy` data between the ROS side and the real-time loop. The lock
/// is held only for a copy (no allocation, no I/O under it).
#[derive(Debug, Default)]
pub struct Mailbox<T: Copy>(Mutex<T>);

impl<T: Copy> Mailbox<T> {
    /// A mailbox holding `value`.
    pub fn new(value: T) -> Self {
        Self(Mutex::new(value))
    }

    /// A copy of the current value.
    pub fn read(&self) -> T {
        // A panic while holding the lock cannot leave a `Copy` value half-written.
        *self.0.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Changes the value in place.
    pub fn update(&self, f: impl FnOnce(&mut T)) {
        f(&mut self.0.lock().unwrap_or_else(|p| p.into_inner()));
    }
}

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

/// Everything the real-time loop reads, `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RtInputs {
    /// Latest joint positions (rad) and their arrival time (s); `None` before the first.
    pub joints: Option<(JointVector, f64)>,
    /// The motion to run.
    pub command: MotionCommand,
    /// Latest distances (stamp = arrival time).
    pub distances: Distances,
    /// Latest human state (stamp = arrival time).
    pub human: HumanInput,
    /// The newest distances message was rejected by the adapter (with this reason).
    pub distances_rejected: Option<&'static str>,
    /// The newest accepted `/lwr/external_wrench` (a person's push, base frame); `None` before
    /// the first and after a rejected one. It acts while younger than `ttc.max_wrench_age_s`.
    pub wrench: Option<ExternalWrench>,
}

impl Default for RtInputs {
    fn default() -> Self {
        Self {
            joints: None,
            command: MotionCommand {
                id: 0,
                primitive: Primitive::Hold,
                goal: Vector3::zeros(),
                orientation: None,
                end_effector_avoidance: true,
            },
            distances: Distances::NEVER,
            human: HumanInput { stamp: f64::NEG_INFINITY, state: HumanState::default() },
            distances_rejected: None,
            wrench: None,
        }
    }
}

/// One result of the real-time loop, `Copy`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RtOutput {
    /// Time of the step (s, node clock).
    pub time: f64,
    /// Joint velocity command (rad/s).
    pub qdot: JointVector,
    /// Motion status.
    pub status: Status,
    /// Command the step ran.
    pub command_id: u32,
    /// ‖x − g‖ (m); NaN when held without a joint reading.
    pub goal_error: f64,
    /// No `/joint_states` yet: nothing was computed.
    pub waiting_for_joints: bool,
    /// The link whose approach the link-distance damper limited this step (model index).
    pub approach_limited: Option<usize>,
    /// Task transition control is blending a push in: the contact link (model index, `None`
    /// once the touch is over) and the stack with the largest weight (0 T_ee, 1 [T_ee, T_ic],
    /// 2 [T_ic, T_ee]).
    pub guided: Option<(Option<usize>, u8)>,
    /// The step did not use the newest push, and why (a push that ended ages into
    /// [`WrenchIgnored::Stale`] with a positive age: the normal end of a touch).
    pub wrench_ignored: Option<WrenchIgnored>,
}

/// The node's clock, shared by both threads: wall time (s since the epoch) or `/clock` time
/// mirrored by the ROS side into an atomic.
#[derive(Debug, Clone)]
pub enum Clock {
    /// Wall clock.
    Wall,
    /// `/clock` time in ns (negative before the first tick).
    Sim(Arc<AtomicI64>),
}

impl Clock {
    /// Now (s); `None` while simulated time has not started.
    pub fn now(&self) -> Option<f64> {
        match self {
            Clock::Wall => Some(
                SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map(|d| d.as_secs_f64())
                    .unwrap_or(0.0),
            ),
            Clock::Sim(ns) => {
                let v = ns.load(Ordering::Acquire);
                (v >= 0).then_some(v as f64 * 1e-9)
            }
        }
    }
}

/// One control step on the latest inputs at time `t` (s); `field` is the learned primitive of
/// a [`Primitive::Learned`] command. Allocation-free (when the field is).
pub fn rt_step(
    ctl: &mut DsController,
    inputs: &RtInputs,
    t: f64,
    field: Option<&mut dyn LearnedField>,
    out: &mut ControlOutput,
) -> RtOutput {
    let stale_after = ctl.config().stale_after_s;
    let Some((q, q_stamp)) = inputs.joints else {
        return RtOutput {
            time: t,
            qdot: JointVector::zeros(),
            status: Status::Held(HoldReason::Command),
            command_id: inputs.command.id,
            goal_error: f64::NAN,
            waiting_for_joints: true,
            approach_limited: None,
            guided: None,
            wrench_ignored: None,
        };
    };
    let age = t - q_stamp;
    // A stamp from the future (clock stepped back, looped /clock) is as unusable as an old one.
    if !(age <= stale_after && age >= -ctl.config().future_tolerance_s) {
        let f = Fault::Stale { stream: Stream::JointStates, age_s: age, bound_s: stale_after };
        ctl.hold(&q, out, HoldReason::Fault(f));
    } else if let Some(reason) = inputs.distances_rejected {
        let f = Fault::Rejected { stream: Stream::Distances, reason };
        ctl.hold(&q, out, HoldReason::Fault(f));
    } else {
        let input = ControlInput {
            time: t,
            q,
            command: inputs.command,
            distances: inputs.distances,
            human: inputs.human,
        };
        // A fault is reported through `out.status` (Held with the fault).
        let _ = ctl.step_with_contact(&input, field, inputs.wrench.as_ref(), out);
    }
    let c = &out.diagnostics.contact;
    let guided = (c.weights[0] < 1.0 && !matches!(out.status, Status::Held(_))).then(|| {
        let top = if c.weights[2] >= c.weights[1] && c.weights[2] >= c.weights[0] {
            2
        } else if c.weights[1] >= c.weights[0] {
            1
        } else {
            0
        };
        (c.link, top)
    });
    RtOutput {
        time: t,
        qdot: out.qdot,
        status: out.status,
        command_id: inputs.command.id,
        goal_error: out.diagnostics.goal_error_m,
        waiting_for_joints: false,
        approach_limited: if out.diagnostics.safety.active { out.diagnostics.safety.link } else { None },
        guided,
        wrench_ignored: out.diagnostics.contact.ignored,
    }
}

/// Learned primitives handed between the ROS side and the real-time loop: the model of
/// command `id` goes in through `fields`; the loop returns replaced ones through `trash`, so
/// that it never frees memory either.
#[derive(Debug)]
pub struct FieldChannels {
    /// (command id, decoded model), ROS side → loop.
    pub fields: Receiver<(u32, Box<Learned>)>,
    /// Replaced models, loop → ROS side (dropped there).
    pub trash: SyncSender<Box<Learned>>,
}

/// The real-time loop: one [`rt_step`] per period of `clock` until `stop`. With the wall clock
/// it sleeps to absolute deadlines; with `/clock` it steps once per period of simulated time.
/// Outputs that do not fit the channel are dropped (the ROS side only needs the newest).
pub fn rt_loop(
    mut ctl: DsController,
    inputs: Arc<Mailbox<RtInputs>>,
    outputs: SyncSender<RtOutput>,
    clock: Clock,
    stop: Arc<AtomicBool>,
    channels: FieldChannels,
) {
    let mut field: Option<(u32, Box<Learned>)> = None;
    let period = ctl.config().period_s;
    let mut out = ControlOutput::default();
    let start = Instant::now();
    let mut k: u64 = 0;
    let mut last_t = f64::NEG_INFINITY;
    while !stop.load(Ordering::Relaxed) {
        match clock {
            Clock::Wall => {
                k += 1;
                let deadline = start + cowork_ros::duration_s(k as f64 * period);
                let now = Instant::now();
                if deadline > now {
                    std::thread::sleep(deadline - now);
                } else if now - deadline > cowork_ros::duration_s(10.0 * period) {
                    // Overrun (suspended process): resynchronise instead of bursting.
                    k = ((now - start).as_secs_f64() / period) as u64;
                }
            }
            Clock::Sim(_) => {
                // Time going back (lwr_sim restarted, a bag looped) is stepped at once: the
                // step then finds every input stamped in its future and holds the robot.
                let due = clock.now().is_some_and(|t| t < last_t || t - last_t >= period * (1.0 - 1e-6));
                if !due {
                    std::thread::sleep(Duration::from_micros(100));
                    continue;
                }
            }
        }
        let Some(t) = clock.now() else { continue };
        last_t = t;
        while let Ok(new) = channels.fields.try_recv() {
            if let Some((_, old)) = field.replace(new) {
                // Full trash (cannot happen: the ROS side drains it): keep the old one alive.
                if let Err(std::sync::mpsc::TrySendError::Full(old)) = channels.trash.try_send(old) {
                    std::mem::forget(old);
                }
            }
        }
        let snapshot = inputs.read();
        let f = match &mut field {
            Some((id, m)) if *id == snapshot.command.id => Some(&mut **m as &mut dyn LearnedField),
            _ => None,
        };
        let o = rt_step(&mut ctl, &snapshot, t, f, &mut out);
        let _ = outputs.try_send(o);
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
        if msg.name.is_empty() {
            if msg.position.len() != DOF {
                return Err(Rejection { reason: format!("{} positions without names, expected {DOF}", msg.position.len()) });
            }
            q.copy_from_slice(&msg.position);
        } else {
            if msg.name.len() != msg.position.len() {
                return Err(Rejection {
                    reason: format!("{} names but {} positions", msg.name.len(), msg.position.len()),
                });
            }
            for (j, want) in self.joint_names.iter().enumerate() {
                let Some(i) = msg.name.iter().position(|n| n == want) else {
                    return Err(Rejection { reason: format!("joint {want} missing") });
                };
                q[j] = msg.position[i];
            }
        }
        if let Some((j, v)) = q.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Rejection { reason: format!("position of {} is {v}", self.joint_names[j]) });
        }
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
        for (pos, l) in msg.links.iter().enumerate() {
            let i = if l.link_name.is_empty() {
                pos
            } else {
                self.link_names.iter().position(|n| *n == l.link_name).ok_or_else(|| Rejection {
                    reason: format!("unknown link name {:?} in entry {pos}", l.link_name),
                })?
            };
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
        let Some(link) = self.link_names.iter().position(|n| n == frame) else {
            return bad(format!("unknown contact frame {frame:?} (expected a link of the robot model)"));
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
        if !(age.abs() <= self.max_wrench_age_s) {
            return bad(format!("stale: stamped {age:.3} s before now (bound ±ttc.max_wrench_age_s = {} s)", self.max_wrench_age_s));
        }
        let Some(q) = q else {
            return bad("no /joint_states yet (the contact link's orientation is unknown)".into());
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

    /// `/motion/command` → the motion (with its decoded model for DMP / GMR / C-GMR), or why
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
            k @ (MotionCommandMsg::KIND_DMP | MotionCommandMsg::KIND_GMR | MotionCommandMsg::KIND_CGMR) => {
                let kind = match k {
                    MotionCommandMsg::KIND_DMP => "dmp",
                    MotionCommandMsg::KIND_GMR => "gmr",
                    _ => "cgmr",
                };
                match learned::decode(kind, &msg.parameters_json, &self.model_files) {
                    Ok(m) => model = Some(m),
                    Err(e) => return bad(format!("primitive kind {k} ({kind}): {e}")),
                }
                Primitive::Learned
            }
            k => return bad(format!("unknown primitive kind {k}")),
        };
        if let Some((what, value)) = primitive.invalid_parameter() {
            return bad(format!("primitive parameter {what} = {value} must be finite and > 0"));
        }
        let gp = &msg.goal.position;
        let goal = Vector3::new(gp.x, gp.y, gp.z);
        if !goal.iter().all(|v| v.is_finite()) {
            return bad(format!("goal position ({}, {}, {}) is not finite", gp.x, gp.y, gp.z));
        }
        let o = &msg.goal.orientation;
        let orientation = if msg.hold_orientation || matches!(primitive, Primitive::Hold) {
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
            return "waiting for /joint_states".into();
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
            Status::Held(HoldReason::Command) if o.command_id == 0 => "waiting for /motion/command".into(),
            Status::Held(HoldReason::Command) => "hold command".into(),
            Status::Held(HoldReason::SpeedZero) => "speed scale 0 (stop)".into(),
            Status::Held(HoldReason::Fault(f)) => match f {
                Fault::NonFinite { what, link } if link != usize::MAX => {
                    format!("non-finite {what} for link {} on /fded/distances", self.link_name(link))
                }
                Fault::ZeroNormal { link } => format!("zero obstacle normal for link {} on /fded/distances", self.link_name(link)),
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

/// How [`run`] ends.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Stop after this many wall seconds.
    pub duration_s: Option<f64>,
    /// Stop when raised (tests); Ctrl-C always stops.
    pub stop: Option<Arc<AtomicBool>>,
}

/// Runs the node: starts the real-time loop and serves the ROS side until stopped.
pub fn run(mut node: RosNode, model: RobotModel, params: &Params, options: &RunOptions) -> Result<()> {
    let adapter = Adapter::new(&model, params);
    let base_frame = model.link_names().first().cloned().unwrap_or_default();
    let mut scene = SceneObjects::from_params(&params.scene_objects, &base_frame)?;
    let ctl = DsController::new(model, params.controller)
        .map_err(|e| anyhow::anyhow!("controller: {e}"))?;
    // Best effort: a 1 kHz stream where only the newest sample counts. A reliable reader that
    // stalls (a frozen process) makes lwr_sim's writes fail for every reader and silenced
    // /joint_states graph-wide for ~20 s (tests/crosscheck/stranger.py chaos).
    let joint_sub = node.subscription::<JointState>("/joint_states", &qos::best_effort_depth(100))?;
    let dist_sub = node.subscription::<LinkDistances>("/fded/distances", &qos::reliable())?;
    let human_sub = node.subscription::<HumanStateMsg>("/human/state", &qos::reliable())?;
    let cmd_sub = node.subscription::<MotionCommandMsg>("/motion/command", &qos::reliable_depth(10))?;
    let world_sub = node.subscription::<WorldState>("/lwr/world", &qos::reliable_depth(10))?;
    // Task transition control: the push lwr_sim reports in execute mode (1 kHz while it lasts;
    // only the newest counts).
    let wrench_sub = if params.controller.ttc.enabled {
        Some(node.subscription::<WrenchStamped>(TOPIC_EXTERNAL_WRENCH, &qos::best_effort_depth(100))?)
    } else {
        None
    };
    let vel_pub = node.publisher::<Float64MultiArray>("/lwr/joint_velocity_command", &qos::reliable())?;
    let status_pub = node.publisher::<MotionStatus>("/motion/status", &qos::reliable_depth(10))?;

    let clock = if params.use_sim_time { Clock::Sim(Arc::new(AtomicI64::new(-1))) } else { Clock::Wall };
    let inputs = Arc::new(Mailbox::new(RtInputs::default()));
    let (tx, rx) = std::sync::mpsc::sync_channel::<RtOutput>(256);
    let (field_tx, field_rx) = std::sync::mpsc::sync_channel::<(u32, Box<Learned>)>(4);
    let (trash_tx, trash_rx) = std::sync::mpsc::sync_channel::<Box<Learned>>(16);
    let rt_stop = Arc::new(AtomicBool::new(false));
    let rt = {
        let (inputs, clock, stop) = (Arc::clone(&inputs), clock.clone(), Arc::clone(&rt_stop));
        let channels = FieldChannels { fields: field_rx, trash: trash_tx };
        std::thread::Builder::new()
            .name("ds_controller-rt".into())
            .spawn(move || rt_loop(ctl, inputs, tx, clock, stop, channels))?
    };
    tracing::info!(
        "ds_controller running at {:.0} Hz ({} time), watchdog {:.3} s",
        1.0 / params.controller.period_s,
        if params.use_sim_time { "/clock" } else { "wall" },
        params.controller.stale_after_s
    );
    tracing::info!(
        "link damper: {} scene objects known{} (their points get the scene distances, from /lwr/world poses)",
        scene.known(),
        if params.scene_objects.scene.is_empty() { String::new() } else { format!(" from {}", params.scene_objects.scene) }
    );
    let t = &params.controller.ttc;
    if t.enabled {
        tracing::info!(
            "task transition control on: pushes from {TOPIC_EXTERNAL_WRENCH}, f_i = {} N, f_s = {} N, c = {} m/(N s)",
            t.insert_force, t.switch_force, t.contact_gain
        );
    } else {
        tracing::info!("task transition control off (controller.ttc.enabled: false): pushes are not read");
    }
    let result = serve(&node, &adapter, params, options, &clock, &inputs, &rx, ServeIo {
        joint_sub: &joint_sub,
        dist_sub: &dist_sub,
        human_sub: &human_sub,
        cmd_sub: &cmd_sub,
        world_sub: &world_sub,
        wrench_sub: wrench_sub.as_ref(),
        scene: &mut scene,
        vel_pub: &vel_pub,
        status_pub: &status_pub,
        field_tx: &field_tx,
        trash_rx: &trash_rx,
    });
    rt_stop.store(true, Ordering::Relaxed);
    if rt.join().is_err() {
        tracing::error!("real-time loop panicked");
    }
    // Leave the robot still.
    let _ = vel_pub.publish(Float64MultiArray::from_vec(vec![0.0; DOF]));
    tracing::info!("ds_controller stopped");
    result
}

struct ServeIo<'a> {
    joint_sub: &'a cowork_ros::Subscription<JointState>,
    dist_sub: &'a cowork_ros::Subscription<LinkDistances>,
    human_sub: &'a cowork_ros::Subscription<HumanStateMsg>,
    cmd_sub: &'a cowork_ros::Subscription<MotionCommandMsg>,
    world_sub: &'a cowork_ros::Subscription<WorldState>,
    wrench_sub: Option<&'a cowork_ros::Subscription<WrenchStamped>>,
    scene: &'a mut SceneObjects,
    vel_pub: &'a cowork_ros::Publisher<Float64MultiArray>,
    status_pub: &'a cowork_ros::Publisher<MotionStatus>,
    field_tx: &'a SyncSender<(u32, Box<Learned>)>,
    trash_rx: &'a Receiver<Box<Learned>>,
}

#[allow(clippy::too_many_arguments)]
fn serve(
    node: &RosNode,
    adapter: &Adapter,
    params: &Params,
    options: &RunOptions,
    clock: &Clock,
    inputs: &Mailbox<RtInputs>,
    rx: &Receiver<RtOutput>,
    io: ServeIo<'_>,
) -> Result<()> {
    let started = Instant::now();
    let status_every = cowork_ros::duration_s(1.0 / params.status_rate_hz);
    let mut last_status: Option<(u32, u8, String)> = None;
    let mut last_status_at = Instant::now();
    let mut human = crate::human::CautiousHuman::new(params.controller.stale_after_s, params.controller.future_tolerance_s);
    // The command that was aborted (id, reason): its statuses read ABORTED while it is current.
    let mut aborted: Option<(u32, String)> = None;
    // The damper's last limited link and when (node clock, s): reported for 0.2 s after.
    let mut limited: Option<(usize, f64)> = None;
    // Scene-object warnings at most every 5 s (wall).
    let mut scene_warned: Option<Instant> = None;
    let mut scene_warn = |text: String| {
        if scene_warned.is_none_or(|t| t.elapsed() >= Duration::from_secs(5)) {
            tracing::warn!("{text}");
            scene_warned = Some(Instant::now());
        }
    };
    // Refused pushes: one warning at most every 2 s (wall), with the count since the last one.
    let mut wrench_warned: Option<Instant> = None;
    let mut wrench_refused: u64 = 0;
    loop {
        if cowork_ros::shutdown::requested()
            || options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst))
            || options.duration_s.is_some_and(|d| started.elapsed().as_secs_f64() >= d)
        {
            return Ok(());
        }
        if let Clock::Sim(ns) = clock
            && node.clock_started()
        {
            ns.store(node.now().to_nanos(), Ordering::Release);
        }
        // Ages are taken from the messages' header stamps (when the data was measured), not
        // from arrival: a frame delivered late is as old as it is.
        while let Some(m) = io.joint_sub.take() {
            match adapter.joint_state(&m) {
                Ok(q) => {
                    let t = m.header.stamp.to_secs_f64();
                    inputs.update(|i| i.joints = Some((q, t)));
                }
                Err(r) => tracing::warn!("/joint_states rejected: {}", r.reason),
            }
        }
        // Object poses before the distances they classify.
        while let Some(m) = io.world_sub.take() {
            if let Err(why) = io.scene.on_world(&m) {
                scene_warn(format!("/lwr/world refused: {why}; no scene object known until a good report (the damper treats every obstacle as a person)"));
            }
        }
        while let Some(m) = io.dist_sub.take() {
            match adapter.distances(&m, m.header.stamp.to_secs_f64()) {
                Ok(mut d) => {
                    if io.scene.known() > 0 && io.scene.mark(&mut d).is_none() {
                        scene_warn(format!(
                            "no /lwr/world report within {} s of /fded/distances at {:.3} s: no scene object known (the damper treats every obstacle as a person)",
                            params.scene_objects.max_age_s, d.stamp
                        ));
                    }
                    mark_handover_goal(&mut d, &inputs.read().command);
                    inputs.update(|i| {
                    i.distances = d;
                    i.distances_rejected = None;
                    })
                }
                Err(r) => {
                    tracing::warn!("/fded/distances rejected, robot held: {}", r.reason);
                    inputs.update(|i| i.distances_rejected = Some("malformed message (see the log)"));
                    publish_status(io.status_pub, node.now(), inputs.read().command.id, MotionStatus::STATE_HELD,
                        format!("rejected /fded/distances: {}", r.reason), f64::NAN)?;
                }
            }
        }
        while let Some(m) = io.wrench_sub.and_then(|s| s.take()) {
            let q = inputs.read().joints.map(|(q, _)| q);
            match adapter.wrench(&m, q.as_ref(), node.now().to_secs_f64()) {
                Ok(w) => inputs.update(|i| i.wrench = Some(w)),
                Err(r) => {
                    // Robot safe: the push is not used, the primitive runs on as without one.
                    inputs.update(|i| i.wrench = None);
                    wrench_refused += 1;
                    if wrench_warned.is_none_or(|t| t.elapsed() >= Duration::from_secs(2)) {
                        tracing::warn!(
                            "{TOPIC_EXTERNAL_WRENCH} ignored ({wrench_refused} refused since the last warning): {}; the primitive runs on without the push",
                            r.reason
                        );
                        wrench_warned = Some(Instant::now());
                        wrench_refused = 0;
                    }
                }
            }
        }
        while let Some(m) = io.human_sub.take() {
            match adapter.human(&m) {
                Ok(h) => {
                    let t = m.header.stamp.to_secs_f64();
                    // The most cautious live state, not the newest: another writer on the
                    // topic can slow the robot but not hurry it (`human.rs`).
                    let h = human.on_state(HumanInput { stamp: t, state: h }, node.now().to_secs_f64());
                    inputs.update(|i| i.human = h);
                }
                Err(r) => tracing::warn!("/human/state rejected: {}", r.reason),
            }
        }
        // Models the loop replaced are freed here, not on the real-time thread.
        while io.trash_rx.try_recv().is_ok() {}
        while let Some(m) = io.cmd_sub.take() {
            match adapter.command(&m) {
                Ok((c, model)) => {
                    tracing::info!("motion command {} {:?} → ({:.3}, {:.3}, {:.3}) {}", c.id, c.primitive, c.goal.x, c.goal.y, c.goal.z, m.label);
                    aborted = None;
                    // The model first: the loop finds it when it sees the command.
                    // Never block here: a stalled real-time loop must not stop the ROS side
                    // (or Ctrl-C). A model that does not fit is refused and the robot held.
                    let handed = match model {
                        None => Ok(()),
                        Some(model) => match io.field_tx.try_send((c.id, Box::new(model))) {
                            Ok(()) => Ok(()),
                            Err(TrySendError::Full(_)) => Err("the real-time loop is not taking models (stalled?)"),
                            Err(TrySendError::Disconnected(_)) => bail!("the real-time loop stopped"),
                        },
                    };
                    match handed {
                        Ok(()) => inputs.update(|i| i.command = c),
                        Err(reason) => {
                            tracing::warn!("motion command {} aborted, robot held: {reason}", c.id);
                            inputs.update(|i| i.command = MotionCommand { id: c.id, primitive: Primitive::Hold, ..i.command });
                            publish_status(io.status_pub, node.now(), c.id, MotionStatus::STATE_ABORTED, reason.into(), f64::NAN)?;
                            last_status = Some((c.id, MotionStatus::STATE_ABORTED, reason.into()));
                            last_status_at = Instant::now();
                            aborted = Some((c.id, reason.into()));
                        }
                    }
                }
                Err(r) => {
                    tracing::warn!("motion command {} aborted, robot held: {}", m.id, r.reason);
                    inputs.update(|i| {
                        i.command = MotionCommand { id: m.id, primitive: Primitive::Hold, ..i.command };
                    });
                    publish_status(io.status_pub, node.now(), m.id, MotionStatus::STATE_ABORTED, r.reason.clone(), f64::NAN)?;
                    last_status = Some((m.id, MotionStatus::STATE_ABORTED, r.reason.clone()));
                    last_status_at = Instant::now();
                    aborted = Some((m.id, r.reason));
                }
            }
        }
        // Outputs: wait briefly for the next one, then take all that are there; the newest
        // command wins.
        let mut newest = rx.recv_timeout(Duration::from_micros(500)).ok();
        loop {
            match rx.try_recv() {
                Ok(o) => newest = Some(o),
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => bail!("the real-time loop stopped"),
            }
        }
        let Some(o) = newest else { continue };
        // A push the loop refused although the adapter took it: stamped in the loop's future
        // (the clocks disagree), or one the loop judges otherwise. Ageing after the touch is not
        // news.
        if let Some(why) = o.wrench_ignored
            && !matches!(why, WrenchIgnored::Stale { age_s } if age_s >= 0.0)
        {
            wrench_refused += 1;
            if wrench_warned.is_none_or(|t| t.elapsed() >= Duration::from_secs(2)) {
                tracing::warn!("{TOPIC_EXTERNAL_WRENCH} not used by the control loop ({wrench_refused} since the last warning): {why}");
                wrench_warned = Some(Instant::now());
                wrench_refused = 0;
            }
        }
        if let Some(l) = o.approach_limited {
            limited = Some((l, o.time));
        } else if limited.is_some_and(|(_, t)| !(o.time - t <= 0.2 && o.time >= t)) {
            limited = None;
        }
        if !o.waiting_for_joints {
            io.vel_pub.publish(Float64MultiArray::from_vec(o.qdot.as_slice().to_vec()))?;
        }
        let (state, reason) = match &aborted {
            Some((id, reason)) if *id == o.command_id => (MotionStatus::STATE_ABORTED, reason.clone()),
            _ => (state_of(&o.status), adapter.reason(&o, limited.map(|l| l.0))),
        };
        let key = (o.command_id, state, reason);
        if last_status.as_ref() != Some(&key) || last_status_at.elapsed() >= status_every {
            publish_status(io.status_pub, node.now(), key.0, key.1, key.2.clone(), o.goal_error)?;
            if last_status.as_ref().is_none_or(|l| l.1 != key.1 || l.2 != key.2) {
                tracing::info!("status: command {} state {} {}", key.0, key.1, key.2);
            }
            last_status = Some(key);
            last_status_at = Instant::now();
        }
    }
}

fn publish_status(
    publisher: &cowork_ros::Publisher<MotionStatus>,
    stamp: Time,
    command_id: u32,
    state: u8,
    reason: String,
    goal_error: f64,
) -> Result<()> {
    publisher.publish(MotionStatus {
        header: Header { stamp, frame_id: String::new() },
        command_id,
        state,
        reason,
        goal_error,
    })
}
