//! The robot manager's state machine (thesis Sec. 4.3.1, 5.2.1, Fig. 4.10): typed inputs in,
//! typed outputs out, time given by the caller — no I/O, so tests run it on a mock clock.

use std::collections::BTreeMap;

use cowork_robot::JointVector;
use nalgebra::Isometry3;

use crate::config::{ManagerConfig, NoaExecution, WORLD};
use crate::database::Database;
use crate::label::Label;
use crate::primitive::{MotionPlan, Primitive};
use crate::segment::{ActionKind, GripperCommand, Note, Segment, Segmenter};
use crate::turn::{PreviewPath, Previewer, VIA_PASS_M, lifted_via, turned};
use crate::world::{World, WorldReport};

/// Teaching or executing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Executing the supervisor's actions (or holding).
    Execute,
    /// Kinesthetic teaching: the arm is let go (zero-gravity admittance) and segmented.
    Teach,
}

/// State of a motion as the controller reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MotionState {
    /// Running.
    Running,
    /// Goal reached.
    Converged,
    /// Refused or faulted.
    Aborted,
    /// Held (stale inputs, speed 0, hold command); resumes by itself.
    Held,
}

/// An action command of the supervisor.
#[derive(Debug, Clone, PartialEq)]
pub struct ActionRequest {
    /// Command id.
    pub id: u32,
    /// Label, e.g. `noa2(water)`.
    pub label: String,
    /// Abort the current action.
    pub stop: bool,
}

/// A controller status.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionReport {
    /// Id of the motion command it belongs to.
    pub command_id: u32,
    /// State.
    pub state: MotionState,
    /// Why (aborted / held).
    pub reason: String,
}

/// An input, at the time given to [`Manager::handle`].
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// The simulator's world report.
    World(WorldReport),
    /// A speech command.
    Speech(String),
    /// A supervisor command.
    Action(ActionRequest),
    /// A controller status.
    Motion(MotionReport),
    /// Time passes (timeouts).
    Tick,
    /// The arm's joint positions (rad, model order) at time `t` (s): where a motion preview
    /// starts from (`crate::turn`).
    Joints {
        /// s.
        t: f64,
        /// rad.
        q: JointVector,
    },
}

/// A motion for the controller.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionOrder {
    /// Motion command id (increasing).
    pub id: u32,
    /// Action label (empty for a hold).
    pub label: String,
    /// What to run; `None` holds the arm.
    pub plan: Option<MotionPlan>,
    /// Nominal speed, m/s.
    pub nominal_speed: f64,
}

/// An action started, done or failed.
#[derive(Debug, Clone, PartialEq)]
pub struct ActionReport {
    /// Label.
    pub label: String,
    /// Kind.
    pub kind: ActionKind,
    /// Supervisor command id (0 while teaching).
    pub command_id: u32,
    /// Accomplished (a.done).
    pub done: bool,
    /// Could not be accomplished.
    pub failed: bool,
    /// Why it failed.
    pub reason: String,
}

/// A segment learned while teaching.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentReport {
    /// Label.
    pub label: String,
    /// Kind.
    pub kind: ActionKind,
    /// Object whose frame holds the goal (`world` for the base).
    pub object: String,
    /// Start, s.
    pub t_start: f64,
    /// End, s.
    pub t_end: f64,
    /// Goal (end pose), base frame.
    pub goal: Isometry3<f64>,
    /// Database key (empty for a segment that was not learned).
    pub primitive_id: String,
}

/// An output.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    /// To the controller (`/motion/command`).
    Motion(MotionOrder),
    /// To the gripper (`/lwr/gripper_command`).
    Gripper(GripperCommand),
    /// Action event (`/robot_stream`).
    Action(ActionReport),
    /// Segment (`/robot_stream`).
    Segment(SegmentReport),
    /// The database changed (save it).
    DatabaseChanged,
    /// Mode switched.
    Mode(Mode),
    /// Something worth an info log line.
    Info(String),
    /// Bad input or a failure, with what was done about it.
    Warn(String),
}

/// The time of an input: simulated (s) and wall clock (Unix s, stamped into primitives).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stamp {
    /// Simulated (or ROS) time, s.
    pub t: f64,
    /// Wall clock, s since the Unix epoch.
    pub unix_s: u64,
}

#[derive(Debug, Clone, PartialEq)]
struct Running {
    command_id: u32,
    label: String,
    kind: ActionKind,
    primitive: Option<Primitive>,
    gripper: Option<GripperCommand>,
    object: String,
    started: f64,
    motion_id: Option<u32>,
    stream: Option<Stream>,
    /// The object's frame the action runs in (turned), base frame: a stalled FOA is lifted in it.
    frame: Option<Isometry3<f64>>,
    /// A linear FOA's own plan (its goal): what a lifted motion ends with.
    linear: Option<MotionPlan>,
    /// Progress and when it was last made (s): the closest the tool came to a linear FOA's
    /// goal (m, a centimetre counts), a streamed NOA's reference time (s); none for
    /// `turn.stall_s` is a stall ([`Manager::watch_progress`]).
    progress: (f64, f64),
    /// Rescued once already (a stalled action is lifted or turned at most once).
    rescued: bool,
    /// The legs of a lifted motion still to send after the one running, next first.
    legs: Vec<MotionPlan>,
    /// The goal of the leg running while more follow: passing it within [`VIA_PASS_M`] starts
    /// the next.
    leg_goal: Option<Isometry3<f64>>,
    /// A linear FOA whose reach is still to be previewed ([`Manager::way_round`]).
    check_reach: bool,
}

/// A NOA being streamed: the rolled-out poses and how far the reference is.
#[derive(Debug, Clone, PartialEq)]
struct Stream {
    poses: Vec<(f64, Isometry3<f64>)>,
    /// Reference time along the rollout, s.
    t_ref: f64,
    /// Index of the last goal sent.
    sent: usize,
    /// Time of the last world report used to advance, s.
    last_t: f64,
}

/// Spoken words the manager understands.
pub const VOCABULARY: &str = "teach, done, stop, repeat, gripper open, gripper close, human <subtask>";

/// The robot manager.
#[derive(Debug)]
pub struct Manager {
    cfg: ManagerConfig,
    db: Database,
    mode: Mode,
    world: Option<World>,
    segmenter: Option<Segmenter>,
    demonstration: String,
    motion_id: u32,
    current: Option<Running>,
    interrupted: Option<Running>,
    segments: Vec<Segment>,
    notes: Vec<Note>,
    learned: Vec<(Segment, Primitive)>,
    /// Object (task name) of the last near-object action started: the one a following
    /// `gripper(close)` closes on.
    last_noa_object: Option<String>,
    /// The object the last executed `close` took and where it stood then (base frame): the
    /// frame of a FOA that puts it back ([`crate::Primitive::home`]).
    grasped_at: Option<(String, Isometry3<f64>)>,
    /// Time of the input being handled, s.
    now_t: f64,
    /// The last motion command, until the controller reports on it (or a newer one).
    unacked: Option<Unacked>,
    /// The last motion command sent: what a controller that started over is sent again.
    last_order: Option<MotionOrder>,
    /// Some `/motion/status` arrived: a controller is there to send to again.
    controller_heard: bool,
    /// Previews motions to choose a round object's turn (`crate::turn`); `None`: never turned.
    previewer: Option<Previewer>,
    /// Newest joint positions (time s, rad).
    joints: Option<(f64, JointVector)>,
    /// Every object of the last world report: scene name, pose (base frame), and whether it
    /// rests upright (a preview avoids only those: a bottle a person is pouring moves on).
    scene_objects: Vec<(String, Isometry3<f64>, bool)>,
    /// Per object (scene name): where it last came to rest and since when (s).
    rest: BTreeMap<String, (Isometry3<f64>, f64)>,
    /// The turn (rad) each object's frame was last used with, until the hand opens or closes.
    turns: BTreeMap<String, f64>,
    /// When an empty closed gripper was last opened (world time, s).
    reopened_t: Option<f64>,
}

/// A linear FOA whose tool has not come this much closer to its goal (m) for
/// `turn.stall_s` is held short of it (the damper holding the arm off a bottle in the way).
const STALL_PROGRESS_M: f64 = 0.01;
/// Within [`VIA_PASS_M`] of its goal an approach that has not come this much closer (m) for
/// `turn.stall_s` is held short.
const STALL_NEAR_PROGRESS_M: f64 = 0.002;

/// The move back to the ready pose that unwinds an arm ([`Manager::way_round`]): gain, 1/s,
/// and the fastest joint, rad/s (the tool keeps ds_controller's allowed speed besides).
const UNWIND_GAIN: f64 = 2.0;
const UNWIND_MAX_SPEED: f64 = 0.6;

/// What [`Manager::shape_motion`] chooses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Shaping {
    /// An action starting: the turn of a round object's frame.
    Start,
    /// A linear FOA held short of its goal: a lift from where the tool is.
    StalledLift,
    /// A streamed NOA, or a linear FOA that is not lifted, held short: another turn, from
    /// where the arm is.
    StalledTurn,
}

/// An object that has not moved for this long rests (s).
const REST_S: f64 = 1.0;

/// How often an unanswered motion command is sent again before the manager stops trying (the
/// action's own timeout then fails it).
const MAX_MOTION_RESENDS: u32 = 5;

/// A motion command the controller has not reported on yet.
#[derive(Debug, Clone)]
struct Unacked {
    order: MotionOrder,
    /// When it was (last) sent, s.
    sent_t: f64,
    /// How often it was sent again.
    resends: u32,
}

impl Manager {
    /// A manager in execute mode with `db` (which must belong to `cfg.robot`).
    pub fn new(cfg: ManagerConfig, db: Database) -> Self {
        Self {
            cfg,
            db,
            mode: Mode::Execute,
            world: None,
            segmenter: None,
            demonstration: String::new(),
            motion_id: 0,
            current: None,
            interrupted: None,
            segments: Vec::new(),
            notes: Vec::new(),
            learned: Vec::new(),
            last_noa_object: None,
            grasped_at: None,
            now_t: 0.0,
            unacked: None,
            last_order: None,
            controller_heard: false,
            previewer: None,
            joints: None,
            scene_objects: Vec::new(),
            rest: BTreeMap::new(),
            turns: BTreeMap::new(),
            reopened_t: None,
        }
    }

    /// Lets the manager preview motions and turn round objects' frames (`crate::turn`).
    pub fn set_previewer(&mut self, previewer: Previewer) {
        self.previewer = Some(previewer);
    }

    /// The database.
    pub fn database(&self) -> &Database {
        &self.db
    }

    /// The configuration.
    pub fn config(&self) -> &ManagerConfig {
        &self.cfg
    }

    /// Mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Latest world (task names).
    pub fn world(&self) -> Option<&World> {
        self.world.as_ref()
    }

    /// Label of the action running now.
    pub fn running(&self) -> Option<&str> {
        self.current.as_ref().map(|r| r.label.as_str())
    }

    /// The object (task name) the running action goes to, which must not repel the arm: the
    /// object in whose frame the running motion's goal lies — a near-object action (approach,
    /// grasp, pour over it) or a far-object action towards it (its goal is 12 cm from the
    /// object, well inside the obstacle modulation's reach: as an obstacle the bottle slowed
    /// the approach `foa1(water)` from 5 s to over 60 s) — and, during a `gripper(close)`, the
    /// object of the near-object action before it. `None` for actions in the world frame,
    /// holds, teaching and when nothing runs. The held object is the world's
    /// ([`World::held`]), not this.
    pub fn target_object(&self) -> Option<&str> {
        let cur = self.current.as_ref()?;
        match (cur.kind, cur.gripper) {
            (ActionKind::Noa | ActionKind::Foa, _) if cur.object != WORLD => Some(cur.object.as_str()),
            (ActionKind::Gripper, Some(GripperCommand::Close)) => self.last_noa_object.as_deref(),
            _ => None,
        }
    }

    /// Every (segment, primitive) learned so far, in order (for offline evaluation).
    pub fn learned(&self) -> &[(Segment, Primitive)] {
        &self.learned
    }

    /// Names the demonstration stored in the next primitives' `source` (bag file or session).
    pub fn set_demonstration(&mut self, name: &str) {
        name.clone_into(&mut self.demonstration);
    }

    /// Handles one input at `now`, appending what it causes to `out`.
    pub fn handle(&mut self, input: &Input, now: Stamp, out: &mut Vec<Output>) {
        self.now_t = now.t;
        match input {
            Input::World(r) => self.on_world(r, now, out),
            Input::Speech(text) => self.on_speech(text, now, out),
            Input::Action(a) => self.on_action(a, now, out),
            Input::Motion(m) => self.on_motion(m, out),
            Input::Tick => self.on_tick(now, out),
            Input::Joints { t, q } => {
                if t.is_finite() && q.iter().all(|v| v.is_finite()) {
                    self.joints = Some((*t, *q));
                }
            }
        }
    }

    fn hold(&mut self, label: &str, out: &mut Vec<Output>) {
        self.send(label.to_owned(), None, out);
    }

    fn report(out: &mut Vec<Output>, r: &Running, done: bool, failed: bool, reason: String) {
        out.push(Output::Action(ActionReport {
            label: r.label.clone(),
            kind: r.kind,
            command_id: r.command_id,
            done,
            failed,
            reason,
        }));
    }

    fn fail(&mut self, r: &Running, reason: String, out: &mut Vec<Output>) {
        out.push(Output::Warn(format!("action {} (command {}) failed: {reason}; robot held", r.label, r.command_id)));
        Self::report(out, r, false, true, reason);
        self.hold(&r.label, out);
    }

    fn on_world(&mut self, r: &WorldReport, now: Stamp, out: &mut Vec<Output>) {
        let world = match World::from_report(r, &self.cfg) {
            Ok(w) => w,
            Err(e) => return out.push(Output::Warn(format!("/lwr/world: {e}; report ignored"))),
        };
        self.note_rest(r);
        if let Some(s) = self.segmenter.as_mut() {
            if !s.started() {
                s.start(&world);
            } else {
                s.observe(&world, &mut self.segments, &mut self.notes);
            }
        }
        self.world = Some(world);
        self.flush_teaching(now, out);
        self.stream_step(out);
        if let (Some(cur), Some(w)) = (&self.current, &self.world)
            && cur.leg_goal.is_some_and(|g| (w.tool.translation.vector - g.translation.vector).norm() <= VIA_PASS_M)
        {
            self.next_leg(out);
        }
        self.way_round(out);
        self.watch_progress(out);
        self.reopen_empty_gripper(out);
        // A gripper action is done when the simulator reports it.
        let Some(cur) = self.current.clone() else { return };
        let (Some(cmd), Some(w)) = (cur.gripper, self.world.as_ref()) else { return };
        let done = match cmd {
            GripperCommand::Close => w.gripper_closed && w.held.is_some(),
            GripperCommand::Open => !w.gripper_closed && w.held.is_none(),
        };
        if done {
            if cmd == GripperCommand::Close && cur.object != WORLD && w.held.as_deref() != Some(cur.object.as_str()) {
                out.push(Output::Warn(format!(
                    "{}: the gripper holds {} instead of {}",
                    cur.label,
                    w.held.as_deref().unwrap_or("nothing"),
                    cur.object
                )));
            }
            self.current = None;
            out.push(Output::Info(format!("{} done: {}", cur.label, w.held.as_deref().map_or("hand free".to_owned(), |h| format!("holding {h}")))));
            Self::report(out, &cur, true, false, String::new());
        }
    }

    /// Keeps [`Self::scene_objects`]: an object rests when it has moved less than 5 mm and 3°
    /// for [`REST_S`] and stands within 15° of upright (one never seen moving rests). Upright is
    /// the world's up ([`Previewer::up`]): the base's z of a shoulder-mounted arm is horizontal,
    /// and judged by it no pizza bottle ever stood, so no preview saw one.
    fn note_rest(&mut self, r: &WorldReport) {
        self.scene_objects.clear();
        let up = self.previewer.as_ref().map_or_else(nalgebra::Vector3::z, Previewer::up);
        for o in &r.objects {
            let anchor = self.rest.entry(o.name.clone()).or_insert((o.pose, f64::NEG_INFINITY));
            let moved = (o.pose.translation.vector - anchor.0.translation.vector).norm() > 0.005
                || o.pose.rotation.angle_to(&anchor.0.rotation) > 3f64.to_radians();
            if moved || r.t < anchor.1 {
                *anchor = (o.pose, r.t);
            }
            let upright = (o.pose.rotation * nalgebra::Vector3::z()).dot(&up) >= 15f64.to_radians().cos();
            self.scene_objects.push((o.name.clone(), o.pose, upright && r.t - anchor.1 >= REST_S));
        }
    }

    /// In execute mode a gripper closed on nothing, with no gripper action under way, is opened
    /// again (at most once per `gripper_timeout_s`): it holds nothing, and closed it is not free
    /// for the next grasp — the supervisor's `hand.free` follows the gripper. A grasp stopped as
    /// the person took the bottle away (coffee-cooperative seed 1) closed on nothing and left
    /// the task waiting for a free hand until the time limit.
    fn reopen_empty_gripper(&mut self, out: &mut Vec<Output>) {
        let Some(w) = &self.world else { return };
        if self.mode != Mode::Execute || !w.gripper_closed || w.held.is_some() {
            self.reopened_t = None;
            return;
        }
        if self.current.as_ref().is_some_and(|c| c.gripper.is_some())
            || self.reopened_t.is_some_and(|t| w.t - t < self.cfg.gripper_timeout_s)
        {
            return;
        }
        self.reopened_t = Some(w.t);
        out.push(Output::Info("the gripper is closed on nothing and no gripper action is under way: opened again".into()));
        out.push(Output::Gripper(GripperCommand::Open));
    }

    fn flush_teaching(&mut self, now: Stamp, out: &mut Vec<Output>) {
        for n in self.notes.drain(..) {
            out.push(Output::Warn(format!("teaching at {:.2} s: {}", n.t, n.text)));
        }
        let mut changed = false;
        for seg in std::mem::take(&mut self.segments) {
            match Primitive::learn(&seg, &self.cfg.dmp, self.cfg.foa_gain, &self.demonstration, now.unix_s) {
                Ok(p) => {
                    out.push(Output::Info(format!(
                        "segment {} ({:?}) {:.2}–{:.2} s, {} samples, goal in the frame of {}",
                        seg.label,
                        seg.kind,
                        seg.t_start,
                        seg.t_end,
                        seg.samples.len(),
                        seg.object
                    )));
                    out.push(Output::Segment(SegmentReport {
                        label: seg.label.clone(),
                        kind: seg.kind,
                        object: seg.object.clone(),
                        t_start: seg.t_start,
                        t_end: seg.t_end,
                        goal: seg.end_pose(),
                        primitive_id: p.id.clone(),
                    }));
                    self.db.insert(p.clone());
                    self.learned.push((seg, p));
                    changed = true;
                }
                Err(e) => out.push(Output::Warn(format!("{e}: the segment is not learned and not sent to the supervisor"))),
            }
        }
        if let Some(s) = &self.segmenter {
            self.db.next_index = self.db.next_index.max(s.next_index());
        }
        if changed {
            out.push(Output::DatabaseChanged);
        }
    }

    fn on_speech(&mut self, raw: &str, now: Stamp, out: &mut Vec<Output>) {
        let text = raw.trim().to_lowercase();
        let words: Vec<&str> = text.split_whitespace().collect();
        match words.as_slice() {
            ["teach"] => {
                if self.mode == Mode::Teach {
                    return out.push(Output::Warn("speech `teach`: already teaching; ignored".into()));
                }
                if let Some(cur) = self.current.take() {
                    out.push(Output::Info(format!("{} interrupted by teaching", cur.label)));
                }
                self.interrupted = None;
                self.mode = Mode::Teach;
                let mut s = Segmenter::new(&self.cfg, self.db.next_index);
                match &self.world {
                    Some(w) => s.start(w),
                    None => out.push(Output::Warn("teaching without a /lwr/world report yet: segmentation starts with the first one".into())),
                }
                self.segmenter = Some(s);
                self.hold("", out);
                out.push(Output::Mode(Mode::Teach));
                out.push(Output::Info("teach mode: the arm is let go (zero-gravity admittance); guide it".into()));
            }
            ["done"] => {
                if self.mode != Mode::Teach {
                    return out.push(Output::Warn("speech `done`: not teaching; ignored".into()));
                }
                if let (Some(s), Some(w)) = (self.segmenter.as_mut(), self.world.as_ref()) {
                    s.finish(w, &mut self.segments, &mut self.notes);
                }
                self.flush_teaching(now, out);
                self.segmenter = None;
                self.mode = Mode::Execute;
                self.hold("", out);
                out.push(Output::Mode(Mode::Execute));
            }
            ["stop"] => {
                if self.mode == Mode::Teach {
                    return out.push(Output::Warn("speech `stop` while teaching: the arm is already let go; ignored".into()));
                }
                match self.current.take() {
                    Some(cur) => {
                        out.push(Output::Info(format!("stop: {} interrupted, arm held (say `repeat` to resume)", cur.label)));
                        self.hold(&cur.label, out);
                        self.interrupted = Some(cur);
                    }
                    None => {
                        self.hold("", out);
                        out.push(Output::Info("stop: nothing running, arm held".into()));
                    }
                }
            }
            ["repeat"] => match self.interrupted.take() {
                Some(r) if self.mode == Mode::Execute => {
                    out.push(Output::Info(format!("repeat: resuming {}", r.label)));
                    let req = ActionRequest { id: r.command_id, label: r.label.clone(), stop: false };
                    self.start(&req, now, out);
                }
                Some(r) => {
                    self.interrupted = Some(r);
                    out.push(Output::Warn("speech `repeat` while teaching; ignored".into()));
                }
                None => out.push(Output::Warn("speech `repeat`: nothing was interrupted; ignored".into())),
            },
            ["gripper", w @ ("open" | "close")] => {
                let cmd = if *w == "open" { GripperCommand::Open } else { GripperCommand::Close };
                let held = self.world.as_ref().and_then(|w| w.held.clone());
                let closed = self.world.as_ref().is_some_and(|w| w.gripper_closed);
                if cmd == GripperCommand::Open && held.is_none() && !closed {
                    out.push(Output::Warn("speech `gripper open` while the hand holds nothing and is open: sent anyway".into()));
                }
                out.push(Output::Gripper(cmd));
                if self.mode == Mode::Teach {
                    match (self.segmenter.as_mut(), self.world.as_ref()) {
                        (Some(s), Some(w)) => s.gripper(w, cmd, None, &mut self.segments, &mut self.notes),
                        _ => out.push(Output::Warn(format!("speech `gripper {w}` before any /lwr/world report: no segment"))),
                    }
                    self.flush_teaching(now, out);
                }
            }
            ["human", rest @ ..] if !rest.is_empty() => {
                out.push(Output::Info(format!("speech `{text}`: the supervisor gives that subtask to the person")));
            }
            _ => out.push(Output::Warn(format!("speech {raw:?} is not in the vocabulary ({VOCABULARY}); ignored"))),
        }
    }

    fn on_action(&mut self, a: &ActionRequest, now: Stamp, out: &mut Vec<Output>) {
        if self.mode == Mode::Teach {
            return out.push(Output::Warn(format!(
                "/supervisor/action {} (id {}) while teaching: ignored (say `done` first)",
                if a.stop { "stop" } else { a.label.as_str() },
                a.id
            )));
        }
        if a.stop {
            match self.current.take() {
                Some(cur) => {
                    out.push(Output::Info(format!("supervisor stop: {} interrupted, arm held", cur.label)));
                    self.hold(&cur.label, out);
                    self.interrupted = Some(cur);
                }
                None => self.hold("", out),
            }
            return;
        }
        if let Some(cur) = self.current.as_mut()
            && cur.label == a.label
        {
            // The same action again (e.g. after `repeat`): adopt the new id, keep running.
            cur.command_id = a.id;
            return;
        }
        self.start(a, now, out);
    }

    fn start(&mut self, a: &ActionRequest, now: Stamp, out: &mut Vec<Output>) {
        if let Some(prev) = self.current.take() {
            out.push(Output::Info(format!("{} replaced by {}", prev.label, a.label)));
        }
        self.interrupted = None;
        let mut run = Running {
            command_id: a.id,
            label: a.label.clone(),
            kind: ActionKind::Foa,
            primitive: None,
            gripper: None,
            object: WORLD.to_owned(),
            started: now.t,
            motion_id: None,
            stream: None,
            frame: None,
            linear: None,
            progress: (f64::INFINITY, now.t),
            rescued: false,
            legs: Vec::new(),
            leg_goal: None,
            check_reach: false,
        };
        let label = match Label::parse(&a.label) {
            Ok(l) => l,
            Err(e) => return self.fail(&run, e, out),
        };
        if let Some(p) = self.db.get(&label.functor).cloned() {
            run.kind = p.kind;
            run.gripper = p.gripper;
            run.object = p.object.clone();
            // Reuse on another object: `foa1(coffee)` runs foa1 learned on water in coffee's frame.
            if let Some(arg) = label.args.first()
                && p.relative_to_object()
                && *arg != p.object
            {
                if self.cfg.objects.values().any(|t| t == arg) {
                    run.object = arg.clone();
                } else {
                    return self.fail(
                        &run,
                        format!("label argument `{arg}` is not a known object (primitive {} was learned on {})", p.id, p.object),
                        out,
                    );
                }
            }
            run.primitive = Some(p);
        } else if label.functor == "gripper" && matches!(label.args.as_slice(), [w] if w == "close" || w == "open") {
            run.kind = ActionKind::Gripper;
            run.gripper = Some(if label.args[0] == "close" { GripperCommand::Close } else { GripperCommand::Open });
        } else {
            let known: Vec<&str> = self.db.primitives.keys().map(String::as_str).collect();
            return self.fail(
                &run,
                format!(
                    "no primitive `{}` for action `{}` in the database of robot `{}` (known: {})",
                    label.functor,
                    a.label,
                    self.db.robot,
                    if known.is_empty() { "none".to_owned() } else { known.join(", ") }
                ),
                out,
            );
        }
        let world = match &self.world {
            Some(w) if now.t - w.t <= self.cfg.world_stale_s => w,
            Some(w) => {
                let age = now.t - w.t;
                return self.fail(&run, format!("the last /lwr/world report is {age:.2} s old (limit {} s)", self.cfg.world_stale_s), out);
            }
            None => return self.fail(&run, "no /lwr/world report yet: object poses unknown".into(), out),
        };
        if run.kind == ActionKind::Noa && run.object != WORLD {
            self.last_noa_object = Some(run.object.clone());
        } else if run.kind != ActionKind::Gripper {
            self.last_noa_object = None;
        }
        if let Some(cmd) = run.gripper {
            if cmd == GripperCommand::Close
                && let Some(h) = &world.held
            {
                if *h != run.object && self.cfg.objects.get(h).is_none_or(|task| *task != run.object) {
                    return self.fail(&run, format!("the hand already holds {h}"), out);
                }
                // Already done (commanded again after a restart of this node or of the
                // supervisor, or by a second `repeat`).
                out.push(Output::Warn(format!("{}: the hand already holds {h}; done at once", run.label)));
                Self::report(out, &run, false, false, String::new());
                Self::report(out, &run, true, false, String::new());
                return;
            }
            if cmd == GripperCommand::Open && world.held.is_none() && !world.gripper_closed {
                out.push(Output::Warn(format!("{}: the hand holds nothing and is open; done at once", run.label)));
                Self::report(out, &run, false, false, String::new());
                Self::report(out, &run, true, false, String::new());
                return;
            }
            if cmd == GripperCommand::Close
                && let Some(o) = world.object(&run.object)
            {
                self.grasped_at = Some((run.object.clone(), o.pose));
            }
            self.turns.clear();
            out.push(Output::Gripper(cmd));
            Self::report(out, &run, false, false, String::new());
            self.current = Some(run);
            return;
        }
        let home = run.primitive.as_ref().and_then(|p| p.home.clone().map(|h| (h, p.taught_object_pose.to_isometry())));
        let pose = if let Some((home, taught)) = home {
            match self.grasped_at.as_ref().filter(|(n, _)| *n == home) {
                Some((_, stood)) => *stood,
                None => {
                    out.push(Output::Warn(format!(
                        "{}: puts {home} back where it stood when grasped, but no grasp of {home} was executed: where it stood when taught",
                        run.label
                    )));
                    match taught {
                        Some(t) => t,
                        None => return self.fail(&run, format!("the taught pose of {home} is not a rotation"), out),
                    }
                }
            }
        } else if run.object == WORLD {
            Isometry3::identity()
        } else {
            match world.object(&run.object) {
                Some(o) if o.visible => o.pose,
                Some(_) => return self.fail(&run, format!("object `{}` is not visible", run.object), out),
                None => {
                    let names: Vec<&str> = world.objects.iter().map(|o| o.name.as_str()).collect();
                    return self.fail(
                        &run,
                        format!("object `{}` is not in the scene (objects: {})", run.object, names.join(", ")),
                        out,
                    );
                }
            }
        };
        let (tool, world_t) = (world.tool, world.t);
        let pose = self.shape_motion(&run, pose, Shaping::Start, out).0;
        run.frame = Some(pose);
        if self.cfg.noa_execution == NoaExecution::Stream
            && run.kind == ActionKind::Noa
            && let Some(p) = run.primitive.as_ref()
        {
            let poses = match p.rollout_poses(&pose, &tool, 0.01) {
                Ok(Some(poses)) if !poses.is_empty() => poses,
                Ok(_) => return self.fail(&run, "the NOA has no DMP to roll out".into(), out),
                Err(e) => return self.fail(&run, e.to_string(), out),
            };
            run.stream = Some(Stream { poses, t_ref: 0.0, sent: 0, last_t: world_t });
            Self::report(out, &run, false, false, String::new());
            self.current = Some(run);
            self.stream_step(out);
            return;
        }
        let plan = match run.primitive.as_ref().map(|p| p.plan(&pose)) {
            Some(Ok(p)) => p,
            Some(Err(e)) => return self.fail(&run, e.to_string(), out),
            None => return self.fail(&run, "no primitive".into(), out),
        };
        if run.kind == ActionKind::Foa && matches!(plan, MotionPlan::Linear { .. }) {
            run.linear = Some(plan.clone());
            run.check_reach = self.cfg.turn.way_round && !self.cfg.turn.objects.contains(&run.object);
        }
        run.motion_id = Some(self.send(run.label.clone(), Some(plan), out));
        Self::report(out, &run, false, false, String::new());
        self.current = Some(run);
    }

    /// The frame `object_pose` of `run`'s object, turned about its axis when the object is
    /// round (`turn.objects`) and the taught yaw's preview does not reach the goal with the
    /// clearance; `stalled` (a linear FOA held short of its goal, `turn.lift_m` given): the frame
    /// as it is and the via points of the best lifted motion from where the tool is, none if
    /// none reaches (`crate::turn`; a previewer and fresh joints needed). Says why.
    fn shape_motion(&mut self, run: &Running, object_pose: Isometry3<f64>, shaping: Shaping, out: &mut Vec<Output>) -> (Isometry3<f64>, Vec<Isometry3<f64>>) {
        let (Some(previewer), Some(world), Some(p)) = (&self.previewer, &self.world, &run.primitive) else {
            return (object_pose, Vec::new());
        };
        let cfg = &self.cfg.turn;
        // Lifted: the frame in use (`object_pose`) is kept.
        let stalled = shaping == Shaping::StalledLift;
        let turnable = !stalled && run.kind != ActionKind::Gripper && run.object != WORLD && cfg.objects.contains(&run.object);
        let liftable = stalled && run.kind == ActionKind::Foa && p.linear_gain.is_some() && !cfg.lift_m.is_empty();
        if !turnable && !liftable {
            return (object_pose, Vec::new());
        }
        let last = if turnable { self.turns.get(&run.object).copied().unwrap_or(0.0) } else { 0.0 };
        let q0 = match self.joints {
            Some((t, q)) if (world.t - t).abs() <= cfg.max_joint_age_s => q,
            other => {
                out.push(Output::Warn(format!(
                    "{}: no joint positions within {} s of the world report ({}): not previewed, {} kept at its last turn, not lifted",
                    run.label,
                    cfg.max_joint_age_s,
                    other.map_or("none yet".to_owned(), |(t, _)| format!("{:.3} s apart", world.t - t)),
                    run.object
                )));
                return (turned(&object_pose, last), Vec::new());
            }
        };
        let others = self.in_the_way(run, world);
        let chain = self.db.chain_after(p);
        let up = previewer.up();
        let tol = cfg.reach_tolerance_m;
        // The action (turned by `turn`, lifted by `lift` m) and the chain taught after it.
        let preview = |turn: f64, lift: f64| -> Option<(crate::turn::PreviewRun, String, Vec<Isometry3<f64>>)> {
            let frame = turned(&object_pose, turn);
            let (mut q, mut tool) = (q0, world.tool);
            let mut all: Option<(crate::turn::PreviewRun, String)> = None;
            let mut vias = Vec::new();
            for (i, step) in std::iter::once(p).chain(chain.iter().copied()).enumerate() {
                let r = match step.kind {
                    ActionKind::Noa => {
                        let poses = step.rollout_poses(&frame, &tool, 0.01).ok().flatten()?;
                        let path = PreviewPath::Stream {
                            poses: &poses,
                            period: self.cfg.stream_period_s,
                            gain: self.cfg.stream_gain,
                            tracking: self.cfg.stream_tracking_m,
                        };
                        previewer.run(&q, &path, &others, tol)
                    }
                    _ if i == 0 && lift > 0.0 => {
                        let (goal, gain) = (step.goal_at(&frame)?, step.linear_gain?);
                        vias = lifted_via(&tool, &goal, up * lift).to_vec();
                        let mut r: Option<crate::turn::PreviewRun> = None;
                        for v in &vias {
                            let leg = previewer.run(r.as_ref().map_or(&q, |r| &r.q_end), &PreviewPath::Via { goal: *v, gain, pass_m: VIA_PASS_M }, &others, tol);
                            r = Some(match r {
                                None => leg,
                                Some(r) => r.then(leg),
                            });
                        }
                        let r = r?;
                        let last_leg = previewer.run(&r.q_end, &PreviewPath::Linear { goal, gain }, &others, tol);
                        r.then(last_leg)
                    }
                    _ => {
                        let path = PreviewPath::Linear { goal: step.goal_at(&frame)?, gain: step.linear_gain? };
                        previewer.run(&q, &path, &others, tol)
                    }
                };
                (q, tool) = (r.q_end, r.tool_end);
                // The chain's figures: reached if every step did, the smallest clearance; named by
                // the step that failed or came closest.
                let failed = !r.reached;
                all = Some(match all {
                    None => (r, step.label.clone()),
                    Some((a, l)) => {
                        let label = if failed || r.clearance_m < a.clearance_m { step.label.clone() } else { l };
                        (a.then(r), label)
                    }
                });
                if all.as_ref().is_some_and(|(a, _)| !a.reached) {
                    break;
                }
            }
            all.map(|(r, label)| (r, label, vias))
        };
        type Previewed = (crate::turn::PreviewRun, String, Vec<Isometry3<f64>>);
        // The yaw in use is kept when it reaches with the clearance; a turn must also keep the
        // joints off their limits and the wrist off its singularity.
        let clear = |r: &Previewed| r.0.reached && r.0.clearance_m >= cfg.clearance_m;
        let good = |r: &Previewed| clear(r) && r.0.joint_margin_rad >= cfg.joint_margin_deg.to_radians();
        // Failing that, ranked by `TurnConfig::rank`.
        let rank = |r: &Previewed| cfg.rank(&r.0);
        // Of (height or turn, preview) pairs, the best ranked that reaches (the first of equals).
        let best_reaching = |candidates: &mut dyn Iterator<Item = (f64, Previewed)>| {
            candidates.filter(|(_, r)| r.0.reached).fold(None::<(f64, Previewed)>, |b, (k, r)| match b {
                Some((bk, br)) if rank(&br) >= rank(&r) => Some((bk, br)),
                _ => Some((k, r)),
            })
        };
        let describe = |(r, label, _): &Previewed| {
            let near = r.closest.as_ref().map_or(String::new(), |(l, o)| format!(" ({l} at {o})"));
            format!(
                "{label} {}, clearance {:.3} m{near}, joint margin {:.0}°",
                if r.reached { "reaches".to_owned() } else { format!("{:.3} m short", r.tool_error_m) },
                r.clearance_m,
                r.joint_margin_rad.to_degrees()
            )
        };
        let Some(first) = preview(last, 0.0) else {
            out.push(Output::Warn(format!("{}: {} not previewed (no rollout or goal for its chain): kept at {:+.0}°", run.label, run.object, last.to_degrees())));
            return (turned(&object_pose, last), Vec::new());
        };
        if stalled {
            // The straight motion is held where it stands: the lift that reaches, ranked as
            // the turns are; none reaching: none.
            let Some((h, r)) = best_reaching(&mut cfg.lift_m.iter().filter_map(|&h| preview(last, h).map(|r| (h, r)))) else {
                out.push(Output::Warn(format!("{}: held short of its goal; no lift reaches it ({})", run.label, describe(&first))));
                return (object_pose, Vec::new());
            };
            out.push(Output::Info(format!(
                "{}: held short of its goal: lifted {h:.2} m from here (straight on: {}; lifted: {})",
                run.label,
                describe(&first),
                describe(&r)
            )));
            return (object_pose, r.2);
        }
        if shaping == Shaping::StalledTurn {
            // The turn in use is held short: the best other turn that reaches, from here.
            let Some((turn, r)) = best_reaching(&mut cfg.candidates(last).into_iter().skip(1).filter_map(|turn| preview(turn, 0.0).map(|r| (turn, r))))
            else {
                out.push(Output::Warn(format!("{}: held short; no other turn of {} reaches ({})", run.label, run.object, describe(&first))));
                return (turned(&object_pose, last), Vec::new());
            };
            out.push(Output::Info(format!(
                "{}: held short: {} turned {:+.0}° about its axis from here (at {:+.0}°: {}; now: {})",
                run.label,
                run.object,
                turn.to_degrees(),
                last.to_degrees(),
                describe(&first),
                describe(&r)
            )));
            self.turns.insert(run.object.clone(), turn);
            return (turned(&object_pose, turn), Vec::new());
        }
        if clear(&first) {
            out.push(Output::Info(format!("{}: {} kept at {:+.0}° ({})", run.label, run.object, last.to_degrees(), describe(&first))));
            if turnable {
                self.turns.insert(run.object.clone(), last);
            }
            return (turned(&object_pose, last), Vec::new());
        }
        let mut best = (last, first.clone());
        for turn in cfg.candidates(last).into_iter().skip(1) {
            let Some(r) = preview(turn, 0.0) else { continue };
            if good(&r) || rank(&r) > rank(&best.1) {
                best = (turn, r);
            }
            if good(&best.1) {
                break;
            }
        }
        let (turn, chosen) = best;
        if (turn - last).abs() > 1e-9 {
            out.push(Output::Info(format!(
                "{}: {} turned {:+.0}° about its axis (at {:+.0}°: {}; now: {})",
                run.label,
                run.object,
                turn.to_degrees(),
                last.to_degrees(),
                describe(&first),
                describe(&chosen)
            )));
        } else {
            out.push(Output::Warn(format!("{}: no turn of {} does better than {:+.0}° ({})", run.label, run.object, last.to_degrees(), describe(&first))));
        }
        self.turns.insert(run.object.clone(), turn);
        (turned(&object_pose, turn), Vec::new())
    }

    /// The objects a preview of `run` keeps the arm off (scene name, pose, base frame): every
    /// object at rest but the action's own and the held one (one that moves or is tilted — a
    /// bottle a person is pouring — will be elsewhere).
    fn in_the_way(&self, run: &Running, world: &World) -> Vec<(&str, Isometry3<f64>)> {
        let own = [self.cfg.scene_name(&run.object), world.held.as_deref().and_then(|h| self.cfg.scene_name(h).or(Some(h)))];
        self.scene_objects
            .iter()
            .filter(|(n, _, resting)| *resting && !own.contains(&Some(n.as_str())))
            .map(|(n, pose, _)| (n.as_str(), *pose))
            .collect()
    }

    /// Once a linear FOA outside the turnable frames has started: previewed from where the arm
    /// is; when it does not reach its goal, previewed after a move in joint space back to the
    /// arm's ready pose, and when that reaches, the move is sent first (`crate::turn`, *The
    /// way round*).
    fn way_round(&mut self, out: &mut Vec<Output>) {
        let Some(cur) = self.current.as_mut().filter(|c| c.check_reach) else { return };
        cur.check_reach = false;
        self.unwind(false, out);
    }

    /// The running linear FOA, unless `stalled` (held short for `turn.stall_s`: then from
    /// where it stands) only when its preview from here stops short: previewed after a move in
    /// joint space back to the ready pose, and when it reaches from there, the move is sent
    /// first and the FOA after it.
    fn unwind(&mut self, stalled: bool, out: &mut Vec<Output>) {
        let Some(cur) = self.current.clone() else { return };
        let (Some(previewer), Some(world), Some(MotionPlan::Linear { goal, gain })) = (&self.previewer, &self.world, &cur.linear) else {
            return;
        };
        let (goal, gain) = (*goal, *gain);
        // A held object would swing with the wrist: only an empty hand is unwound.
        if world.held.is_some() {
            return;
        }
        let cfg = &self.cfg.turn;
        let (Some(q0), Some(ready)) = (self.joints.filter(|(t, _)| (world.t - t).abs() <= cfg.max_joint_age_s).map(|(_, q)| q), previewer.ready())
        else {
            return;
        };
        let others = self.in_the_way(&cur, world);
        let tol = cfg.reach_tolerance_m;
        let direct = previewer.run(&q0, &PreviewPath::Linear { goal, gain }, &others, tol);
        if direct.reached && !stalled {
            return;
        }
        let unwind = PreviewPath::Joints { joints: ready, gain: UNWIND_GAIN, max_speed: UNWIND_MAX_SPEED };
        let back = previewer.run(&q0, &unwind, &others, tol);
        let on = previewer.run(&back.q_end, &PreviewPath::Linear { goal, gain }, &others, tol);
        let r = back.then(on);
        let short = if stalled {
            format!(
                "held short of its goal {:.3} m away (straight on from here: {})",
                (world.tool.translation.vector - goal.translation.vector).norm(),
                if direct.reached { "reaches".to_owned() } else { format!("{:.3} m short", direct.tool_error_m) }
            )
        } else {
            format!("straight on it stops {:.3} m short (joint margin {:.0}°)", direct.tool_error_m, direct.joint_margin_rad.to_degrees())
        };
        if !r.reached {
            return out.push(Output::Warn(format!(
                "{}: {short}, and from the ready pose too ({:.3} m short): runs on as it was",
                cur.label, r.tool_error_m
            )));
        }
        out.push(Output::Info(format!(
            "{}: {short}: back to the ready pose in joint space first, then on to the goal (reaches, clearance {:.3} m, joint margin {:.0}°)",
            cur.label,
            r.clearance_m,
            r.joint_margin_rad.to_degrees()
        )));
        let plan = MotionPlan::Joints { joints: ready, gain: UNWIND_GAIN, max_speed: UNWIND_MAX_SPEED, tool: previewer.tool_at(&ready) };
        let id = self.send(cur.label.clone(), Some(plan), out);
        if let Some(c) = self.current.as_mut() {
            // The joint move ends when the controller reports it converged.
            c.legs = vec![MotionPlan::Linear { goal, gain }];
            c.leg_goal = None;
            c.motion_id = Some(id);
            c.rescued = true;
        }
    }

    /// Advances a streamed NOA: the reference time moves with time while the tool tracks the
    /// last goal; the goal sent is the rollout pose one `stream_period_s` ahead of the
    /// reference, renewed whenever the reference reaches it; the last one is the goal.
    fn stream_step(&mut self, out: &mut Vec<Output>) {
        let (Some(cur), Some(w)) = (self.current.as_mut(), self.world.as_ref()) else { return };
        let Some(st) = cur.stream.as_mut() else { return };
        let last = st.poses.len() - 1;
        let dt = (w.t - st.last_t).max(0.0);
        st.last_t = w.t;
        let reference = st.poses[st.sent].1;
        let tracking = (w.tool.translation.vector - reference.translation.vector).norm();
        if cur.motion_id.is_some() && tracking <= self.cfg.stream_tracking_m {
            st.t_ref += dt;
        }
        let period = self.cfg.stream_period_s;
        let due = cur.motion_id.is_none()
            || (st.sent < last && st.t_ref >= st.poses[st.sent].0 - 1e-9);
        if !due {
            return;
        }
        let k = if cur.motion_id.is_none() {
            st.poses.partition_point(|p| p.0 < period).min(last)
        } else {
            st.poses.partition_point(|p| p.0 < st.t_ref + period).min(last)
        };
        st.sent = k.max(st.sent);
        let goal = st.poses[st.sent].1;
        let (label, gain) = (cur.label.clone(), self.cfg.stream_gain);
        let id = self.send(label, Some(MotionPlan::Linear { goal, gain }), out);
        if let Some(cur) = self.current.as_mut() {
            cur.motion_id = Some(id);
        }
    }

    /// Follows an action's progress (`turn.stall_s` > 0, a previewer there): a linear FOA held
    /// short of its goal for `stall_s` is lifted ([`Self::lift_stalled`], with `turn.lift_m`),
    /// else in a round object's frame turned another way, else (`turn.way_round`, the hand
    /// empty) unwound back to the ready pose ([`Self::unwind`]); a streamed NOA in a round
    /// object's frame whose reference has not moved for `stall_s` is turned another way from
    /// where the arm is ([`Self::turn_stalled`]); once per action.
    fn watch_progress(&mut self, out: &mut Vec<Output>) {
        let stall_s = self.cfg.turn.stall_s;
        if self.mode != Mode::Execute || stall_s <= 0.0 || self.previewer.is_none() {
            return;
        }
        let (Some(cur), Some(w)) = (self.current.as_mut(), self.world.as_ref()) else { return };
        if cur.rescued || cur.motion_id.is_none() {
            return;
        }
        let turnable = self.cfg.turn.objects.contains(&cur.object);
        let liftable = !self.cfg.turn.lift_m.is_empty();
        let unwindable = self.cfg.turn.way_round;
        let (measure, moved) = match (&cur.linear, &cur.stream) {
            (Some(MotionPlan::Linear { goal, .. }), _) if liftable || turnable || unwindable => {
                let d = (w.tool.translation.vector - goal.translation.vector).norm();
                // Within a via point's reach of the goal a lifted or turned motion is converging,
                // not held. An approach to unwind must gain millimetres there: seed 9's spoon
                // approach stood 1.5 cm short for 120 s.
                let near = if liftable || turnable { d <= VIA_PASS_M } else { d < cur.progress.0 - STALL_NEAR_PROGRESS_M };
                (d, d < cur.progress.0 - STALL_PROGRESS_M || near)
            }
            (_, Some(st)) if turnable => {
                // The reference moves while the tool tracks it; at the last goal it converges.
                let at_last = st.sent + 1 >= st.poses.len()
                    && (w.tool.translation.vector - st.poses[st.sent].1.translation.vector).norm() <= VIA_PASS_M;
                (-st.t_ref, -st.t_ref < cur.progress.0 || at_last)
            }
            _ => return,
        };
        if moved || w.t < cur.progress.1 {
            cur.progress = (measure, w.t);
        } else if w.t - cur.progress.1 >= stall_s {
            cur.rescued = true;
            // A linear FOA is lifted where heights are given (the pizza), else turned in a
            // turnable frame, else unwound.
            if cur.stream.is_none() && liftable {
                self.lift_stalled(out);
            } else if turnable {
                self.turn_stalled(out);
            } else {
                self.unwind(true, out);
            }
        }
    }

    /// A streamed NOA, or a linear FOA with no lift heights, held short in a turnable frame:
    /// the best other turn of its object's frame that reaches, previewed from where the arm
    /// is; the rollout restarts from the tool in that frame, the FOA is sent to its goal there.
    fn turn_stalled(&mut self, out: &mut Vec<Output>) {
        let Some(cur) = self.current.clone() else { return };
        let (Some(frame), Some(p), Some((tool, t))) = (cur.frame, cur.primitive.as_ref(), self.world.as_ref().map(|w| (w.tool, w.t))) else {
            return;
        };
        let last = self.turns.get(&cur.object).copied().unwrap_or(0.0);
        // The object's own pose: the frame in use turned back.
        let object_pose = turned(&frame, -last);
        let (pose, _) = self.shape_motion(&cur, object_pose, Shaping::StalledTurn, out);
        if (pose.rotation.angle_to(&frame.rotation)) < 1e-9 {
            return;
        }
        if cur.stream.is_none() {
            let plan = match p.plan(&pose) {
                Ok(plan @ MotionPlan::Linear { .. }) => plan,
                other => {
                    let why = other.map_or_else(|e| e.to_string(), |_| "not a linear motion".to_owned());
                    return out.push(Output::Warn(format!("{}: held short; the turned goal could not be planned ({why}): runs on as it was", cur.label)));
                }
            };
            let id = self.send(cur.label.clone(), Some(plan.clone()), out);
            if let Some(c) = self.current.as_mut() {
                c.frame = Some(pose);
                c.linear = Some(plan);
                c.motion_id = Some(id);
            }
            return;
        }
        let poses = match p.rollout_poses(&pose, &tool, 0.01) {
            Ok(Some(poses)) if !poses.is_empty() => poses,
            _ => return,
        };
        if let Some(c) = self.current.as_mut() {
            c.frame = Some(pose);
            c.stream = Some(Stream { poses, t_ref: 0.0, sent: 0, last_t: t });
            c.motion_id = None;
        }
        self.stream_step(out);
    }

    /// A linear FOA held short of its goal: previewed lifted from where the tool is (up by
    /// each of `turn.lift_m`, across to that height above the goal, down onto it), the best
    /// that reaches is sent leg by leg; none reaching: it runs on as it was.
    fn lift_stalled(&mut self, out: &mut Vec<Output>) {
        let Some(cur) = self.current.clone() else { return };
        let (Some(frame), Some(MotionPlan::Linear { goal, gain })) = (cur.frame, cur.linear.clone()) else { return };
        let (_, vias) = self.shape_motion(&cur, frame, Shaping::StalledLift, out);
        let Some(first) = vias.first().copied() else { return };
        let legs: Vec<MotionPlan> = vias[1..].iter().map(|v| MotionPlan::Linear { goal: *v, gain }).chain([MotionPlan::Linear { goal, gain }]).collect();
        let id = self.send(cur.label.clone(), Some(MotionPlan::Linear { goal: first, gain }), out);
        if let Some(c) = self.current.as_mut() {
            c.legs = legs;
            c.leg_goal = Some(first);
            c.motion_id = Some(id);
        }
    }

    /// Sends the next leg of a lifted motion (the via point passed or converged on).
    fn next_leg(&mut self, out: &mut Vec<Output>) {
        let Some(cur) = self.current.as_mut() else { return };
        if cur.legs.is_empty() {
            return;
        }
        let plan = cur.legs.remove(0);
        cur.leg_goal = match &plan {
            MotionPlan::Linear { goal, .. } if !cur.legs.is_empty() => Some(*goal),
            _ => None,
        };
        let label = cur.label.clone();
        let id = self.send(label, Some(plan), out);
        if let Some(cur) = self.current.as_mut() {
            cur.motion_id = Some(id);
        }
    }

    /// Sends the next motion command (`plan` `None` holds the arm) to the controller, keeps it
    /// until the controller reports on it (see `resend_unacked`), and returns its id.
    fn send(&mut self, label: String, plan: Option<MotionPlan>, out: &mut Vec<Output>) -> u32 {
        self.motion_id += 1;
        let order = MotionOrder { id: self.motion_id, label, plan, nominal_speed: self.cfg.nominal_speed_m_s };
        self.unacked = Some(Unacked { order: order.clone(), sent_t: self.now_t, resends: 0 });
        self.last_order = Some(order.clone());
        out.push(Output::Motion(order));
        self.motion_id
    }

    /// Sends the last motion command again when the controller has not reported on it for
    /// `motion_resend_s` (lost before the controller's reader matched the manager's writer).
    fn resend_unacked(&mut self, now: f64, out: &mut Vec<Output>) {
        let period = self.cfg.motion_resend_s;
        // While teaching the person moves the arm; and without any controller status there is
        // no controller to send to (the teaching graph runs none).
        if self.mode == Mode::Teach || !self.controller_heard {
            return;
        }
        let Some(u) = self.unacked.as_mut() else { return };
        // A clock that went back (restarted simulation) restarts the wait.
        if now < u.sent_t {
            u.sent_t = now;
        }
        if now - u.sent_t < period || u.resends >= MAX_MOTION_RESENDS {
            return;
        }
        u.sent_t = now;
        u.resends += 1;
        out.push(Output::Warn(format!(
            "no /motion/status for motion command {} ({}) {period} s after it was sent: sent again ({} of {MAX_MOTION_RESENDS})",
            u.order.id,
            if u.order.label.is_empty() { "hold" } else { &u.order.label },
            u.resends
        )));
        out.push(Output::Motion(u.order.clone()));
    }

    fn on_motion(&mut self, m: &MotionReport, out: &mut Vec<Output>) {
        self.controller_heard = true;
        if m.command_id == 0 {
            // The controller's "waiting for a command". After it had reported on the running
            // action's motion, it has started over (killed and started again, or stopped and
            // continued) and lost it: sent again, then tracked as unacknowledged.
            if self.unacked.is_none()
                && let Some(order) = self.last_order.clone()
                && self.current.as_ref().is_some_and(|c| c.motion_id == Some(order.id))
            {
                out.push(Output::Warn(format!(
                    "/motion/status: the controller waits for a command while motion command {} ({}) runs (it started over?): sent again",
                    order.id, order.label
                )));
                self.unacked = Some(Unacked { order: order.clone(), sent_t: self.now_t, resends: 0 });
                out.push(Output::Motion(order));
            }
            return;
        }
        if m.command_id > self.motion_id {
            return out.push(Output::Warn(format!(
                "/motion/status for unknown command id {} (last sent {}): ignored",
                m.command_id, self.motion_id
            )));
        }
        if self.unacked.as_ref().is_some_and(|u| m.command_id >= u.order.id) {
            self.unacked = None;
        }
        let Some(cur) = self.current.clone() else { return };
        if cur.motion_id != Some(m.command_id) {
            return; // a status of an older command (or of a hold)
        }
        // A streamed NOA is done when the goal of its last reference has converged.
        let streaming_not_last = cur.stream.as_ref().is_some_and(|s| s.sent + 1 < s.poses.len());
        match m.state {
            MotionState::Converged if streaming_not_last => {}
            MotionState::Converged if !cur.legs.is_empty() => self.next_leg(out),
            MotionState::Converged => {
                self.current = None;
                out.push(Output::Info(format!("{} done", cur.label)));
                Self::report(out, &cur, true, false, String::new());
            }
            MotionState::Aborted => {
                self.current = None;
                let reason = if m.reason.is_empty() { "aborted by the controller".to_owned() } else { m.reason.clone() };
                self.fail(&cur, reason, out);
            }
            MotionState::Running | MotionState::Held => {}
        }
    }

    fn on_tick(&mut self, now: Stamp, out: &mut Vec<Output>) {
        self.resend_unacked(now.t, out);
        let Some(cur) = self.current.clone() else { return };
        let elapsed = now.t - cur.started;
        let limit = if cur.gripper.is_some() { self.cfg.gripper_timeout_s } else { self.cfg.action_timeout_s };
        if elapsed > limit {
            self.current = None;
            let why = match (cur.gripper, self.world.as_ref()) {
                (Some(GripperCommand::Close), Some(w)) if w.gripper_closed && w.held.is_none() => {
                    "the gripper closed on nothing (no object within reach)".to_owned()
                }
                (Some(_), _) => "the simulator did not report the gripper state".to_owned(),
                _ => "the motion did not converge".to_owned(),
            };
            self.fail(&cur, format!("timed out after {elapsed:.1} s (limit {limit} s): {why}"), out);
        }
    }
}
