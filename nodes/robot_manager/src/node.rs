//! The node's state and one handler per message: messages in, messages out, no I/O (logging
//! aside). Tests drive it with messages and a mock clock.

use std::path::{Path, PathBuf};

use cowork_manager::{
    ActionKind, ActionRequest, Database, GripperCommand, Input, Manager, MotionPlan, MotionReport, MotionState, Mode,
    ObjectReport, Output, Stamp, WorldReport,
};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{
    ActionCommand, ActionEvent, ActionSegment, Gesture, MotionCommand, MotionStatus, ObjectState, ObjectStream,
    RobotStream, WorldState,
};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::{Header, String as RosString};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};

use crate::params::Params;

/// What one handler call produced, to be published.
#[derive(Debug, Default, Clone, PartialEq)]
pub struct Outbox {
    /// `/motion/command`.
    pub motion: Vec<MotionCommand>,
    /// `/lwr/gripper_command`.
    pub gripper: Vec<RosString>,
    /// `/robot_stream`.
    pub robot_stream: Vec<RobotStream>,
    /// `/object_stream`.
    pub object_stream: Vec<ObjectStream>,
    /// `/manipulated_objects`.
    pub manipulated: Vec<ObjectStream>,
    /// Warnings for the log (the run loop rate-limits them).
    pub warnings: Vec<cowork_ros::Warning>,
}

impl Outbox {
    /// Empties every list.
    pub fn clear(&mut self) {
        self.motion.clear();
        self.gripper.clear();
        self.robot_stream.clear();
        self.object_stream.clear();
        self.manipulated.clear();
        self.warnings.clear();
    }
}

/// Rounds a ROS time to seconds.
pub fn seconds(t: &Time) -> f64 {
    t.to_secs_f64()
}

fn isometry(p: &Pose) -> Isometry3<f64> {
    let q = &p.orientation;
    let quat = nalgebra::Quaternion::new(q.w, q.x, q.y, q.z);
    let rot = if quat.norm() > 1e-9 && quat.coords.iter().all(|v| v.is_finite()) {
        UnitQuaternion::new_normalize(quat)
    } else {
        // Left non-finite on purpose: the library refuses the report, naming the field.
        UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(f64::NAN, 0.0, 0.0, 0.0))
    };
    Isometry3::from_parts(Translation3::new(p.position.x, p.position.y, p.position.z), rot)
}

/// An isometry as a `geometry_msgs/Pose`.
pub fn pose(p: &Isometry3<f64>) -> Pose {
    let t = p.translation.vector;
    let q = p.rotation.coords;
    Pose { position: Point { x: t.x, y: t.y, z: t.z }, orientation: Quaternion { x: q.x, y: q.y, z: q.z, w: q.w } }
}

/// `/lwr/world` → the library's world report.
pub fn world_report(msg: &WorldState) -> WorldReport {
    WorldReport {
        t: seconds(&msg.header.stamp),
        tool: isometry(&msg.tool_pose),
        gripper_closed: msg.gripper_state == WorldState::GRIPPER_CLOSED,
        held: (!msg.held_object.is_empty()).then(|| msg.held_object.clone()),
        objects: msg
            .objects
            .iter()
            .map(|o| ObjectReport {
                name: o.name.clone(),
                pose: isometry(&o.pose),
                distance: o.tool_distance,
                tilt: o.tilt,
                visible: true,
            })
            .collect(),
    }
}

/// Action kind → `ActionEvent::KIND_*` (the same codes as `ActionSegment`).
pub fn kind_code(k: ActionKind) -> u8 {
    match k {
        ActionKind::Noa => ActionEvent::KIND_NOA,
        ActionKind::Foa => ActionEvent::KIND_FOA,
        ActionKind::Gripper => ActionEvent::KIND_GRIPPER,
    }
}

/// The robot manager with its message conversions.
#[derive(Debug)]
pub struct RobotManagerNode {
    manager: Manager,
    params: Params,
    db_path: PathBuf,
    db_dirty: bool,
    events: Vec<ActionEvent>,
    segments: Vec<ActionSegment>,
    last_stream_s: Option<f64>,
    out: Vec<Output>,
    /// Warnings not yet handed to the run loop ([`Self::take_warnings`]).
    pending_warnings: Vec<cowork_ros::Warning>,
    warnings: u64,
    last_warning: Option<String>,
    last_world: Option<WorldState>,
    /// Joint names of the previewer's model (empty: no previewer).
    joint_names: Vec<String>,
    /// The arm this manager serves (`left`, from its namespace `/left`); empty for the one arm
    /// of a single-arm robot.
    arm: String,
}

impl RobotManagerNode {
    /// Loads the database of `params.manager.robot` from `params.database_dir` (removing the
    /// temporary files of saves that were killed). A database file
    /// that does not load is moved aside to `<file>.corrupt-<unix s>` (so nothing learned is
    /// lost) and the node starts empty; the error says why, naming the file and field.
    pub fn new(params: Params, unix_s: u64) -> (Self, Option<String>) {
        let db_path = Database::path(Path::new(&params.database_dir), &params.manager.robot);
        // A save killed half-way (kill -9) leaves its temporary file; the database is intact.
        match cowork_store::remove_orphan_temporaries(&db_path) {
            Ok(removed) => {
                removed.iter().for_each(|p| tracing::info!("removed {} (left by a save that was killed)", p.display()))
            }
            Err(e) => tracing::warn!("{e}"),
        }
        let mut problem = None;
        let db = match Database::load_or_new(&db_path, &params.manager.robot) {
            Ok(db) if db.robot == params.manager.robot => db,
            Ok(db) => {
                problem = Some(format!(
                    "primitive database {} belongs to robot `{}`, not `{}`: not used",
                    db_path.display(),
                    db.robot,
                    params.manager.robot
                ));
                Database::new(&params.manager.robot)
            }
            Err(e) => {
                let aside = PathBuf::from(format!("{}.corrupt-{unix_s}", db_path.display()));
                let moved = match std::fs::rename(&db_path, &aside) {
                    Ok(()) => format!("moved to {}", aside.display()),
                    Err(m) => format!("could not be moved aside ({m}); it is left as it is and new primitives are not saved over it"),
                };
                problem = Some(format!("{e}; the file is {moved}; starting with an empty database"));
                Database::new(&params.manager.robot)
            }
        };
        let node = Self {
            manager: Manager::new(params.manager.clone(), db),
            params,
            db_path,
            db_dirty: false,
            events: Vec::new(),
            segments: Vec::new(),
            last_stream_s: None,
            out: Vec::new(),
            pending_warnings: Vec::new(),
            warnings: 0,
            last_warning: None,
            last_world: None,
            joint_names: Vec::new(),
            arm: String::new(),
        };
        (node, problem)
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The library object.
    pub fn manager(&self) -> &Manager {
        &self.manager
    }

    /// Database file.
    pub fn database_path(&self) -> &Path {
        &self.db_path
    }

    /// Warnings so far.
    pub fn warnings(&self) -> u64 {
        self.warnings
    }

    /// Whether something learned is not saved yet.
    pub fn database_dirty(&self) -> bool {
        self.db_dirty
    }

    /// Saves the database (atomically) if it changed; true when it saved.
    pub fn save_if_changed(&mut self) -> cowork_manager::Result<bool> {
        let Some(db) = self.take_changes() else { return Ok(false) };
        if let Err(e) = write_database(&self.db_path, &db) {
            self.save_failed();
            return Err(e);
        }
        Ok(true)
    }

    /// A copy of the database when it changed since the last call (the change is then counted
    /// as handed over: call [`save_failed`](Self::save_failed) if writing it fails), for a saver
    /// that writes it with [`write_database`] off the message loop.
    pub fn take_changes(&mut self) -> Option<Database> {
        if !self.db_dirty {
            return None;
        }
        self.db_dirty = false;
        Some(self.manager.database().clone())
    }

    /// Writing what [`take_changes`](Self::take_changes) gave failed: the database counts as
    /// changed again (the next save writes it whole).
    pub fn save_failed(&mut self) {
        self.db_dirty = true;
    }

    /// The newest warning (also logged, rate-limited), for tests and diagnostics.
    pub fn last_warning(&self) -> Option<&str> {
        self.last_warning.as_deref()
    }

    fn warn(&mut self, text: &str) {
        self.warnings += 1;
        self.last_warning = Some(text.to_owned());
        // The kind is the text itself, cut short: identical warnings are rate-limited together.
        let kind = cowork_ros::quote(text).into_owned();
        self.pending_warnings.push(cowork_ros::Warning::new(kind, text));
    }

    /// The warnings made since the last call, for the run loop's rate-limited log.
    pub fn take_warnings(&mut self, into: &mut Vec<cowork_ros::Warning>) {
        into.append(&mut self.pending_warnings);
    }

    fn run(&mut self, input: Input, now: Stamp, outbox: &mut Outbox) {
        self.out.clear();
        self.manager.handle(&input, now, &mut self.out);
        let outs = std::mem::take(&mut self.out);
        let mut urgent = false;
        let stamp = Time::from_secs_f64(now.t.max(0.0));
        for o in &outs {
            match o {
                Output::Motion(m) => {
                    let mut c = MotionCommand {
                        header: Header { stamp, frame_id: String::new() },
                        id: m.id,
                        label: m.label.clone(),
                        nominal_speed: m.nominal_speed,
                        ..Default::default()
                    };
                    match &m.plan {
                        None => c.kind = MotionCommand::KIND_HOLD,
                        Some(MotionPlan::Linear { goal, gain }) => {
                            c.kind = MotionCommand::KIND_LINEAR;
                            c.parameters = vec![*gain];
                            c.goal = pose(goal);
                        }
                        Some(MotionPlan::Dmp { goal, model_json }) => {
                            c.kind = MotionCommand::KIND_DMP;
                            c.parameters_json.clone_from(model_json);
                            c.goal = pose(goal);
                        }
                        Some(MotionPlan::Joints { joints, gain, max_speed, tool }) => {
                            c.kind = MotionCommand::KIND_JOINTS;
                            c.parameters = joints.iter().copied().chain([*gain, *max_speed]).collect();
                            c.goal = pose(tool);
                        }
                        Some(MotionPlan::Gripper(_)) => continue,
                    }
                    if c.kind == MotionCommand::KIND_HOLD {
                        // Ignored by the controller, but a valid pose for any reader.
                        c.goal = self.last_world.as_ref().map_or_else(|| pose(&Isometry3::identity()), |w| w.tool_pose);
                    }
                    outbox.motion.push(c);
                }
                Output::Gripper(g) => outbox.gripper.push(RosString {
                    data: match g {
                        GripperCommand::Close => "close".into(),
                        GripperCommand::Open => "open".into(),
                    },
                }),
                Output::Action(a) => self.events.push(ActionEvent {
                    label: a.label.clone(),
                    kind: kind_code(a.kind),
                    command_id: a.command_id,
                    done: a.done,
                    failed: a.failed,
                    reason: a.reason.clone(),
                }),
                Output::Segment(s) => self.segments.push(ActionSegment {
                    label: s.label.clone(),
                    kind: kind_code(s.kind),
                    object_name: s.object.clone(),
                    start_time: Time::from_secs_f64(s.t_start.max(0.0)),
                    end_time: Time::from_secs_f64(s.t_end.max(0.0)),
                    goal: pose(&s.goal),
                    primitive_id: s.primitive_id.clone(),
                }),
                Output::DatabaseChanged => self.db_dirty = true,
                Output::Mode(m) => {
                    urgent = true;
                    tracing::info!("mode: {m:?}");
                }
                Output::Info(t) => tracing::info!("{t}"),
                Output::Warn(t) => self.warn(t),
            }
        }
        self.out = outs;
        let urgent = urgent || !self.events.is_empty() || !self.segments.is_empty();
        let due = self.last_stream_s.is_none_or(|l| now.t - l >= 1.0 / self.params.stream_rate_hz || now.t < l);
        if (urgent || due) && self.last_world.is_some() {
            self.streams(stamp, outbox);
            self.last_stream_s = Some(now.t);
        }
    }

    fn streams(&mut self, stamp: Time, outbox: &mut Outbox) {
        let Some(w) = self.manager.world() else { return };
        let header = Header { stamp, frame_id: self.last_world.as_ref().map(|w| w.header.frame_id.clone()).unwrap_or_default() };
        outbox.robot_stream.push(RobotStream {
            header: header.clone(),
            ee_pose: pose(&w.tool),
            gripper_state: if w.gripper_closed { RobotStream::GRIPPER_CLOSED } else { RobotStream::GRIPPER_OPEN },
            held_object: w.held.clone().unwrap_or_default(),
            mode: match self.manager.mode() {
                Mode::Execute => RobotStream::MODE_EXECUTE,
                Mode::Teach => RobotStream::MODE_TEACH,
            },
            events: std::mem::take(&mut self.events),
            segments: std::mem::take(&mut self.segments),
        });
        outbox.object_stream.push(ObjectStream {
            header,
            objects: w
                .objects
                .iter()
                .map(|o| ObjectState { name: o.name.clone(), pose: pose(&o.pose), robot_distance: o.distance, visible: o.visible })
                .collect(),
        });
    }

    /// `/lwr/world`. Besides the streams, every report gives one `/manipulated_objects` list
    /// ([`manipulated`](Self::manipulated)).
    pub fn on_world(&mut self, msg: &WorldState, now: Stamp, outbox: &mut Outbox) {
        self.last_world = Some(msg.clone());
        self.run(Input::World(world_report(msg)), now, outbox);
        outbox.manipulated.push(self.manipulated(msg));
    }

    /// The objects of `world` the robot manipulates now, which fded_distance must not see as
    /// obstacles: the held object and the object the running action goes to
    /// ([`cowork_manager::Manager::target_object`]) — scene names, poses of `world`, stamped with `world`'s stamp
    /// and frame (the pose's time). Empty when there is none; every other object, the table
    /// and people stay obstacles.
    pub fn manipulated(&self, world: &WorldState) -> ObjectStream {
        let cfg = self.manager.config();
        let target = self.manager.target_object();
        ObjectStream {
            header: world.header.clone(),
            objects: world
                .objects
                .iter()
                .filter(|o| {
                    let held = o.held || (!world.held_object.is_empty() && world.held_object == o.name);
                    held || target.is_some_and(|t| cfg.task_name(&o.name) == Some(t))
                })
                .map(|o| ObjectState { name: o.name.clone(), pose: o.pose, robot_distance: o.tool_distance, visible: true })
                .collect(),
        }
    }

    /// Lets the manager preview motions (`manager.turn`); `joint_names` in the previewer's model
    /// order, for `/joint_states`.
    pub fn set_previewer(&mut self, previewer: cowork_manager::Previewer, joint_names: Vec<String>) {
        self.manager.set_previewer(previewer);
        self.joint_names = joint_names;
    }

    /// Whether the manager previews motions (and so wants `/joint_states`).
    pub fn previews(&self) -> bool {
        !self.joint_names.is_empty()
    }

    /// `/joint_states` (only with a previewer): the joints a preview starts from, at their
    /// header stamp. A message that does not give every joint is warned about and dropped.
    pub fn on_joint_state(&mut self, msg: &JointState, now: Stamp, outbox: &mut Outbox) {
        if self.joint_names.is_empty() {
            return;
        }
        let mut q = cowork_robot::JointVector::zeros();
        if let Err(e) = cowork_ros::joint_positions(&self.joint_names, msg, q.as_mut_slice()) {
            return self.warn(&format!("/joint_states: {e}; message dropped"));
        }
        self.run(Input::Joints { t: seconds(&msg.header.stamp), q }, now, outbox);
    }

    /// `/speech_command`. Words for every arm (`teach`), or addressed to one arm of a robot
    /// with named arms (`left: teach`, `left: gripper close`): another arm's words are not this
    /// manager's business; addressed words on a single-arm robot are refused with a warning.
    pub fn on_speech(&mut self, msg: &RosString, now: Stamp, outbox: &mut Outbox) {
        let Some((arm, words)) = addressed(&msg.data) else {
            return self.run(Input::Speech(msg.data.clone()), now, outbox);
        };
        if arm == self.arm {
            self.run(Input::Speech(words.to_owned()), now, outbox);
        } else if self.arm.is_empty() {
            let text = cowork_ros::text_prefix(msg.data.trim(), 80);
            self.warn(&format!("/speech_command {text:?} is for arm `{arm}`: this robot_manager serves a single-arm robot; ignored"));
        }
    }

    /// Serves arm `arm` of a robot with named arms (the last token of the node's namespace:
    /// `left` for `/left`): only `/supervisor/action` commands for that arm are executed.
    pub fn set_arm(&mut self, arm: &str) {
        arm.clone_into(&mut self.arm);
    }

    /// Teaching or executing.
    pub fn mode(&self) -> Mode {
        self.manager.mode()
    }

    /// The arm served ([`set_arm`](Self::set_arm)); empty for a single-arm robot.
    pub fn arm(&self) -> &str {
        &self.arm
    }

    /// `/supervisor/action`: executed when it is for this manager's arm. Another arm's command
    /// is not this manager's business (ignored); a command naming an arm on a single-arm
    /// robot, or naming none on a robot with named arms, is refused with a warning: nothing
    /// moves on a command meant for another robot.
    pub fn on_action(&mut self, msg: &ActionCommand, now: Stamp, outbox: &mut Outbox) {
        if msg.arm != self.arm {
            let label = cowork_ros::text_prefix(&msg.label, 80);
            let arm = cowork_ros::text_prefix(&msg.arm, 40);
            if self.arm.is_empty() {
                return self.warn(&format!(
                    "/supervisor/action {} `{label}` is for arm `{arm}`: this robot_manager serves a single-arm robot (start one per arm in its namespace, --ros-args -r __ns:=/{arm}); ignored",
                    msg.id
                ));
            }
            if msg.arm.is_empty() {
                return self.warn(&format!(
                    "/supervisor/action {} `{label}` names no arm: this robot_manager serves arm `{}` of a robot with named arms; ignored",
                    msg.id, self.arm
                ));
            }
            return;
        }
        self.run(Input::Action(ActionRequest { id: msg.id, label: msg.label.clone(), stop: msg.stop }), now, outbox);
    }

    /// `/motion/status`.
    pub fn on_motion_status(&mut self, msg: &MotionStatus, now: Stamp, outbox: &mut Outbox) {
        let state = match msg.state {
            MotionStatus::STATE_RUNNING => MotionState::Running,
            MotionStatus::STATE_CONVERGED => MotionState::Converged,
            MotionStatus::STATE_ABORTED => MotionState::Aborted,
            MotionStatus::STATE_HELD => MotionState::Held,
            other => {
                return self.warn(&format!(
                    "/motion/status: unknown state {other} for command {} (expected 0..3); ignored",
                    msg.command_id
                ));
            }
        };
        self.run(Input::Motion(MotionReport { command_id: msg.command_id, state, reason: msg.reason.clone() }), now, outbox);
    }

    /// `/human/gesture`: `stop` stops like the spoken word, `come` resumes like `repeat`;
    /// other gestures are the observer's business.
    pub fn on_gesture(&mut self, msg: &Gesture, now: Stamp, outbox: &mut Outbox) {
        let word = match msg.label.as_str() {
            Gesture::LABEL_STOP => "stop",
            Gesture::LABEL_COME if self.manager.mode() == Mode::Execute => "repeat",
            Gesture::LABEL_COME | Gesture::LABEL_HANDOVER_RIGHT => return,
            other => return self.warn(&format!("/human/gesture: unknown label {other:?}; ignored")),
        };
        self.run(Input::Speech(word.into()), now, outbox);
    }

    /// Timeouts.
    pub fn tick(&mut self, now: Stamp, outbox: &mut Outbox) {
        self.run(Input::Tick, now, outbox);
    }
}

/// Splits speech addressed to an arm, `left: teach` → (`left`, `teach`); `None` when the words
/// name no arm (no `:` after a first word that is a ROS name).
pub fn addressed(text: &str) -> Option<(&str, &str)> {
    let (arm, words) = text.trim().split_once(':')?;
    let arm = arm.trim();
    cowork_ros::is_name_token(arm).then_some((arm, words.trim()))
}

/// Writes `db` to `path` atomically and durably ([`Database::save`]: temporary file, fsync,
/// rename, directory fsync), creating its directory first.
pub fn write_database(path: &Path, db: &Database) -> cowork_manager::Result<()> {
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(|source| cowork_manager::ManagerError::Io {
            op: "creating the directory of",
            path: path.to_owned(),
            source,
        })?;
    }
    db.save(path)
}
