//! The `attentional_supervisor` node: a thin ROS 2 adapter around
//! [`cowork_supervisor::Supervisor`] (thesis Sec. 4.3.2–4.3.4, 5.2.2–5.2.4).
//!
//! [`SupervisorNode`] turns messages into library [`Event`]s and [`Decision`]s into messages; it
//! does no I/O, so tests drive it one tick at a time on a mock clock. [`run`] wires it to DDS
//! and paces the decision loop (`tick_rate_hz`, wall clock or `/clock`).
//!
//! Inputs:
//! * `/object_stream` (cowork_msgs/ObjectStream): one `objects` event per message
//!   (name, end-effector distance in m, visibility);
//! * `/robot_stream` (cowork_msgs/RobotStream): per message, in this order, the action events
//!   (`done` → `action_done`, `failed` → `action_failed` with the reason; "started" events
//!   carry nothing new), the teaching segments
//!   (→ `segment`), then the gripper state *when it changed* (→ `gripper`): the events and
//!   segments happened before the state the message reports;
//! * `/speech_command` (std_msgs/String): `speech`.
//!
//! Not used: `RobotStream.mode` (the supervisor switches mode on `/speech_command` itself),
//! `RobotStream.ee_pose` and `ObjectState.pose` (the distance stimulus is
//! `ObjectState.robot_distance`), `ActionEvent.command_id` (events are matched by label).
//! The messages carry no arm, per-arm distance or area, so over ROS the node drives a single
//! arm; dual-arm runs go through the library's event scripts.
//!
//! Outputs: `/supervisor/action` (cowork_msgs/ActionCommand), only when the decision changes —
//! a new action (`stop = false`) or an abort (`stop = true`, with the id and label of the
//! aborted command); `/supervisor/working_memory` (cowork_msgs/WorkingMemory) at
//! `snapshot_rate_hz`. Every other decision (learned action, mode, accomplished behaviour,
//! waiting for a demonstration, warning) is logged.
//!
//! Bad input (unknown object or speech word, NaN distance, an action event for an action that is
//! not running, an unknown action kind) is logged as a warning and the loop goes on; repeated
//! identical warnings are logged at most once every [`WARNING_REPEAT_S`] seconds.
//!
//! ```
//! use attentional_supervisor::{Params, SupervisorNode};
//! use cowork_msgs::builtin_interfaces::Time;
//! use cowork_msgs::msg::{ObjectState, ObjectStream};
//! use cowork_supervisor::{Ltm, Supervisor};
//!
//! let ltm = Ltm::parse(
//!     "objects([water]).\n\
//!      schema(add(Obj), [(subtask(take,Obj), hand.free)], Obj.taken).\n\
//!      schema(subtask(take,Obj), [(foa1(Obj), true)], Obj.taken).\n\
//!      schema(foa1(Obj), [], foa1.done, foa).\n",
//! ).unwrap();
//! let params = Params::default();
//! let sup = Supervisor::new(ltm, "add(water)", params.attention.clone()).unwrap();
//! let mut node = SupervisorNode::new(sup, &params);
//! node.on_object_stream(&ObjectStream {
//!     objects: vec![ObjectState { name: "water".into(), robot_distance: 0.5, visible: true, ..Default::default() }],
//!     ..Default::default()
//! });
//! let mut commands = Vec::new();
//! node.tick(Time::from_secs_f64(0.01), &mut commands);
//! assert_eq!(commands[0].label, "foa1(water)");
//! assert!(!commands[0].stop);
//! ```

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{ActionCommand, ActionEvent, ObjectStream, RobotStream, WmNode, WorkingMemory};
use cowork_msgs::std_msgs::{Header, String as RosString};
use cowork_ros::{RosNode, qos};
use cowork_supervisor::{
    ActionKind, Decision, Event, GripperState, ObjectObs, Supervisor, SupervisorConfig, WmSnapshot,
};
use serde::{Deserialize, Serialize};

/// Identical warnings are logged at most once per this many seconds (wall clock).
pub const WARNING_REPEAT_S: f64 = 10.0;

/// The `attentional_supervisor: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Decision loop rate (Hz): every tick re-decides the action, so a stimulus is answered
    /// within one period 1 / `tick_rate_hz` (plus transport).
    pub tick_rate_hz: f64,
    /// `/supervisor/working_memory` rate (Hz); 0 publishes no snapshots.
    pub snapshot_rate_hz: f64,
    /// Take time (tick pacing, stamps) from `/clock` instead of the wall clock.
    pub use_sim_time: bool,
    /// Decide nothing until the first `/object_stream` arrived: without object distances
    /// the activation periods (eq. 4.8) are all λ_max and the first command would be arbitrary.
    pub wait_for_object_stream: bool,
    /// Attentional system (thesis Table 5.3).
    pub attention: SupervisorConfig,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            tick_rate_hz: 100.0,
            snapshot_rate_hz: 10.0,
            use_sim_time: false,
            wait_for_object_stream: true,
            attention: SupervisorConfig::default(),
        }
    }
}

impl Params {
    /// Rejects NaN and out-of-range values; `place` names the parameter file.
    pub fn validate(&self, place: &str) -> Result<()> {
        let t = self.tick_rate_hz;
        if !(t.is_finite() && t > 0.0 && t <= 10_000.0) {
            bail!("{place}: `tick_rate_hz` = {t} must be in (0, 10000] Hz");
        }
        let s = self.snapshot_rate_hz;
        if !(s.is_finite() && s >= 0.0 && s <= t) {
            bail!("{place}: `snapshot_rate_hz` = {s} must be in [0, tick_rate_hz = {t}] Hz (0 = off)");
        }
        if let Err(e) = self.attention.validate() {
            bail!("{place}: `attention`: {e}");
        }
        Ok(())
    }

    /// Tick period (s).
    pub fn tick_period_s(&self) -> f64 {
        1.0 / self.tick_rate_hz
    }
}

/// `ObjectStream` → `objects` event. An object that is not visible and has no finite distance
/// keeps its last distance (an unseen object's distance is unknown, not bad input); a visible
/// one with a non-finite distance is passed on, and the library rejects it with a warning.
pub fn objects_event(msg: &ObjectStream) -> Event {
    let objects = msg
        .objects
        .iter()
        .map(|o| ObjectObs {
            name: o.name.clone(),
            distance: (o.visible || o.robot_distance.is_finite()).then_some(o.robot_distance),
            arm_distances: BTreeMap::new(),
            visible: o.visible,
            area: None,
        })
        .collect();
    Event::Objects { objects }
}

/// Longest speech command passed on whole (characters); no word of the vocabulary comes close.
pub const MAX_SPEECH_CHARS: usize = 200;

/// `/speech_command` → `speech` event (the library judges the vocabulary). A text longer than
/// [`MAX_SPEECH_CHARS`] is passed on as its prefix (it is not a command either way), so a
/// megabyte string is not copied into every warning about it.
pub fn speech_event(msg: &RosString) -> Event {
    Event::Speech { text: cowork_ros::text_prefix(&msg.data, MAX_SPEECH_CHARS).into_owned() }
}

/// `ActionEvent::KIND_*` / `ActionSegment::KIND_*` → action kind.
pub fn action_kind(kind: u8) -> Option<ActionKind> {
    match kind {
        ActionEvent::KIND_NOA => Some(ActionKind::Noa),
        ActionEvent::KIND_FOA => Some(ActionKind::Foa),
        ActionEvent::KIND_GRIPPER => Some(ActionKind::Gripper),
        _ => None,
    }
}

/// Action kind → `ActionEvent::KIND_*`.
pub fn kind_code(kind: ActionKind) -> u8 {
    match kind {
        ActionKind::Noa => ActionEvent::KIND_NOA,
        ActionKind::Foa => ActionEvent::KIND_FOA,
        ActionKind::Gripper => ActionEvent::KIND_GRIPPER,
    }
}

/// Turns the `RobotStream` state stream into edge events: the gripper is reported only when
/// its state or held object changes (grasp and release rewrite `<object>.taken`, so a
/// repeated report must not be replayed).
#[derive(Debug, Default, Clone)]
pub struct RobotStreamDecoder {
    gripper: Option<(u8, String)>,
}

impl RobotStreamDecoder {
    /// Appends the events of `msg` to `events` and what was wrong with it to `problems`.
    pub fn decode(&mut self, msg: &RobotStream, events: &mut Vec<Event>, problems: &mut Vec<String>) {
        for e in &msg.events {
            if e.failed {
                events.push(Event::ActionFailed { arm: None, label: e.label.clone(), reason: e.reason.clone() });
            } else if e.done {
                events.push(Event::ActionDone { arm: None, label: e.label.clone() });
            }
        }
        for s in &msg.segments {
            let Some(kind) = action_kind(s.kind) else {
                problems.push(format!(
                    "/robot_stream: segment '{}' has unknown kind {} (expected 0 NOA, 1 FOA, 2 gripper); dropped",
                    s.label, s.kind
                ));
                continue;
            };
            let object = (!s.object_name.is_empty()).then(|| s.object_name.clone());
            events.push(Event::Segment { arm: None, label: s.label.clone(), kind, object });
        }
        let state = match msg.gripper_state {
            RobotStream::GRIPPER_OPEN => GripperState::Open,
            RobotStream::GRIPPER_CLOSED => GripperState::Close,
            other => {
                problems.push(format!(
                    "/robot_stream: unknown gripper_state {other} (expected 0 open, 1 closed); gripper ignored"
                ));
                return;
            }
        };
        let held = if state == GripperState::Open { String::new() } else { msg.held_object.trim().to_owned() };
        let now = (msg.gripper_state, held);
        if self.gripper.as_ref() == Some(&now) {
            return;
        }
        let object = (!now.1.is_empty()).then(|| now.1.clone());
        self.gripper = Some(now);
        events.push(Event::Gripper { arm: None, state, object });
    }
}

/// Remembers the id of the command running on each arm, so an abort names what it aborts.
#[derive(Debug, Default, Clone)]
pub struct CommandTracker {
    running: BTreeMap<String, (u32, String)>,
}

impl CommandTracker {
    /// The `/supervisor/action` message for a decision, if it is one (`Action` or `Stop`).
    pub fn command(&mut self, decision: &Decision, stamp: Time) -> Option<ActionCommand> {
        let header = Header { stamp, frame_id: String::new() };
        match decision {
            Decision::Action { id, arm, label, .. } => {
                let arm = arm.clone().unwrap_or_default();
                self.running.insert(arm.clone(), (*id, label.clone()));
                Some(ActionCommand { header, id: *id, label: label.clone(), arm, stop: false })
            }
            Decision::Stop { arm, label, .. } => Some(self.stop(arm.as_deref().unwrap_or(""), label, header)),
            _ => None,
        }
    }

    fn stop(&mut self, arm: &str, label: &str, header: Header) -> ActionCommand {
        let id = match self.running.remove(arm) {
            Some((id, l)) if l == label => id,
            _ => 0,
        };
        ActionCommand { header, id, label: label.to_owned(), arm: arm.to_owned(), stop: true }
    }
}

/// A library snapshot as a `WorkingMemory` message.
pub fn working_memory(s: &WmSnapshot, stamp: Time) -> WorkingMemory {
    let nodes = s
        .nodes
        .iter()
        .map(|n| WmNode {
            id: n.id,
            parent: n.parent,
            name: n.name.clone(),
            releaser: n.releaser.clone(),
            releaser_value: n.releaser_value,
            postcondition: n.postcondition.clone(),
            concrete: n.concrete,
            emphasis: n.emphasis,
            magnitude: n.magnitude,
            period: n.period,
            done: n.done,
            enabled: n.enabled,
            assigned_to: match n.assigned_to {
                "robot" => WmNode::ASSIGNED_ROBOT,
                "human" => WmNode::ASSIGNED_HUMAN,
                _ => WmNode::ASSIGNED_NONE,
            },
            arm: n.arm.clone(),
        })
        .collect();
    WorkingMemory { header: Header { stamp, frame_id: String::new() }, nodes, true_variables: s.true_variables.clone() }
}

/// Fixed-rate pacing on any clock (s): due once per period, on a steady grid; a clock that
/// jumps ahead by more than a period (sim time faster than the loop) or back (a looped bag)
/// restarts the grid at the current time instead of bursting.
#[derive(Debug, Clone)]
pub struct Pacer {
    period_s: f64,
    next_s: Option<f64>,
}

impl Pacer {
    /// A pacer with this period (s).
    pub fn new(period_s: f64) -> Self {
        Self { period_s, next_s: None }
    }

    /// Whether a period started at `now_s`; advances the grid when it did.
    pub fn due(&mut self, now_s: f64) -> bool {
        match self.next_s {
            Some(next) if now_s < next && now_s >= next - 2.0 * self.period_s => false,
            Some(next) if now_s >= next && now_s < next + self.period_s => {
                self.next_s = Some(next + self.period_s);
                true
            }
            _ => {
                self.next_s = Some(now_s + self.period_s);
                true
            }
        }
    }

    /// Time (s, same clock) until the next period starts; zero when due.
    pub fn wait_s(&self, now_s: f64) -> f64 {
        self.next_s.map_or(0.0, |n| (n - now_s).clamp(0.0, self.period_s))
    }
}

/// Distinct warning texts remembered by [`WarnLimiter`].
const MAX_WARNING_KINDS: usize = 256;
/// Characters of a warning that are logged and that tell warnings apart.
const MAX_WARNING_CHARS: usize = 300;

/// Logs a warning unless the same text was logged less than [`WARNING_REPEAT_S`] ago. Bounded
/// whatever a peer sends: texts are cut to [`MAX_WARNING_CHARS`], and at most
/// [`MAX_WARNING_KINDS`] are remembered (the oldest is forgotten), so each call costs O(kinds).
#[derive(Debug, Default)]
struct WarnLimiter {
    last: HashMap<String, (Instant, u64)>,
}

impl WarnLimiter {
    fn warn(&mut self, text: &str) {
        let now = Instant::now();
        let text = cowork_ros::text_prefix(text, MAX_WARNING_CHARS);
        let text = text.as_ref();
        if self.last.len() >= MAX_WARNING_KINDS && !self.last.contains_key(text) {
            self.last.retain(|_, (t, _)| now.duration_since(*t).as_secs_f64() < WARNING_REPEAT_S);
            if self.last.len() >= MAX_WARNING_KINDS
                && let Some(oldest) = self.last.iter().min_by_key(|(_, (t, _))| *t).map(|(k, _)| k.clone())
            {
                self.last.remove(&oldest);
            }
        }
        match self.last.get_mut(text) {
            Some((t, suppressed)) if now.duration_since(*t).as_secs_f64() < WARNING_REPEAT_S => *suppressed += 1,
            Some((t, suppressed)) => {
                tracing::warn!("{text} (repeated {} more times)", *suppressed);
                *t = now;
                *suppressed = 0;
            }
            None => {
                tracing::warn!("{text}");
                self.last.insert(text.to_owned(), (now, 0));
            }
        }
    }
}

/// The supervisor with its message conversions; no I/O.
#[derive(Debug)]
pub struct SupervisorNode {
    sup: Supervisor,
    decoder: RobotStreamDecoder,
    tracker: CommandTracker,
    wait_for_objects: bool,
    objects_seen: bool,
    events: Vec<Event>,
    pending_problems: Vec<String>,
    problems: Vec<String>,
    decisions: Vec<Decision>,
    limiter: WarnLimiter,
    warnings: u64,
    last_tick_s: f64,
}

impl SupervisorNode {
    /// Wraps a supervisor; `params.wait_for_object_stream` gates the first decision.
    pub fn new(sup: Supervisor, params: &Params) -> Self {
        Self {
            sup,
            decoder: RobotStreamDecoder::default(),
            tracker: CommandTracker::default(),
            wait_for_objects: params.wait_for_object_stream,
            objects_seen: false,
            events: Vec::new(),
            pending_problems: Vec::new(),
            problems: Vec::new(),
            decisions: Vec::new(),
            limiter: WarnLimiter::default(),
            warnings: 0,
            last_tick_s: 0.0,
        }
    }

    /// The wrapped supervisor.
    pub fn supervisor(&self) -> &Supervisor {
        &self.sup
    }

    /// Gives the supervisor back (with what it learned).
    pub fn into_supervisor(self) -> Supervisor {
        self.sup
    }

    /// Whether the supervisor decides (the first `/object_stream` arrived, or no wait).
    pub fn ready(&self) -> bool {
        self.objects_seen || !self.wait_for_objects
    }

    /// Warnings logged so far (library warnings and malformed messages).
    pub fn warnings(&self) -> u64 {
        self.warnings
    }

    /// Decisions of the last tick.
    pub fn decisions(&self) -> &[Decision] {
        &self.decisions
    }

    /// Message problems reported by the last tick (malformed fields the library never saw).
    pub fn problems(&self) -> &[String] {
        &self.problems
    }

    /// `/object_stream`.
    pub fn on_object_stream(&mut self, msg: &ObjectStream) {
        self.objects_seen = true;
        self.sup.handle(&objects_event(msg), self.now_hint());
    }

    /// `/robot_stream`.
    pub fn on_robot_stream(&mut self, msg: &RobotStream) {
        self.events.clear();
        self.decoder.decode(msg, &mut self.events, &mut self.pending_problems);
        let t = self.now_hint();
        for e in &self.events {
            self.sup.handle(e, t);
        }
    }

    /// `/speech_command`.
    pub fn on_speech(&mut self, msg: &RosString) {
        self.sup.handle(&speech_event(msg), self.now_hint());
    }

    // Events take effect at the next tick; they carry the time of the last one.
    fn now_hint(&self) -> f64 {
        self.last_tick_s
    }

    /// One decision cycle at `now`: runs the supervisor (once ready), logs its decisions and
    /// appends the `/supervisor/action` messages to `out`.
    pub fn tick(&mut self, now: Time, out: &mut Vec<ActionCommand>) {
        self.problems.clear();
        std::mem::swap(&mut self.problems, &mut self.pending_problems);
        for p in &self.problems {
            self.warnings += 1;
            self.limiter.warn(p);
        }
        self.decisions.clear();
        self.last_tick_s = now.to_secs_f64();
        if !self.ready() {
            return;
        }
        self.sup.tick(now.to_secs_f64(), &mut self.decisions);
        for d in &self.decisions {
            if let Some(c) = self.tracker.command(d, now) {
                out.push(c);
            }
            match d {
                Decision::Warning { message, .. } => {
                    self.warnings += 1;
                    self.limiter.warn(message);
                }
                other => log_decision(other),
            }
        }
    }

    /// The working memory as a message.
    pub fn working_memory(&self, stamp: Time) -> WorkingMemory {
        working_memory(&self.sup.snapshot(), stamp)
    }

    /// Aborts for every action still running (sent when the node stops, so no arm goes on
    /// executing a command nobody supervises).
    pub fn shutdown_commands(&mut self, stamp: Time) -> Vec<ActionCommand> {
        let arms: Vec<String> = self.sup.state().arm_names().to_vec();
        let mut out = Vec::new();
        for (i, arm) in arms.iter().enumerate() {
            if let Some(label) = self.sup.running(i).map(str::to_owned) {
                out.push(self.tracker.stop(arm, &label, Header { stamp, frame_id: String::new() }));
            }
        }
        out
    }

    /// Saves the LTM to `path` (atomically) if something was learned since the last save.
    /// Returns whether it saved.
    pub fn save_ltm_if_changed(&mut self, path: &Path) -> cowork_supervisor::Result<bool> {
        if !self.sup.ltm_changed() {
            return Ok(false);
        }
        self.sup.ltm().save(path)?;
        self.sup.mark_ltm_saved();
        Ok(true)
    }
}

fn log_decision(d: &Decision) {
    match d {
        Decision::Action { id, arm, label, kind, subtask, releaser, emphasis } => tracing::info!(
            "action {id}: {label} ({}) of {subtask}{}, releaser {releaser}, emphasis {emphasis:.3} 1/s",
            kind.keyword(),
            arm.as_deref().map(|a| format!(" on arm {a}")).unwrap_or_default()
        ),
        Decision::Stop { arm, label, reason } => tracing::info!(
            "stop {label}{}: {reason}",
            arm.as_deref().map(|a| format!(" on arm {a}")).unwrap_or_default()
        ),
        Decision::AwaitDemonstration { subtask, .. } => {
            tracing::info!("subtask {subtask} is open: waiting for a demonstration (say `teach`)")
        }
        Decision::Attached { label, kind, subtask, releaser, .. } => {
            tracing::info!("learned {label} ({}) in {subtask}, releaser {releaser}", kind.keyword())
        }
        Decision::HumanAssigned { subtask } => tracing::info!("{subtask} assigned to the person"),
        Decision::Mode { mode } => tracing::info!("mode: {mode:?}"),
        Decision::Accomplished { behaviour } => tracing::info!("accomplished: {behaviour}"),
        Decision::TaskAccomplished { task } => tracing::info!("task accomplished: {task}"),
        Decision::Warning { message, .. } => tracing::warn!("{message}"),
    }
}

/// How [`run`] runs.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Node parameters.
    pub params: Params,
    /// Where learned LTMs are saved (atomically, after every change); `None` keeps them in
    /// memory only.
    pub save_ltm: Option<PathBuf>,
    /// Stop after this many wall-clock seconds.
    pub duration_s: Option<f64>,
    /// Stop when this flag is raised (besides Ctrl-C / SIGTERM).
    pub stop: Option<Arc<AtomicBool>>,
}

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`; returns the supervisor
/// with what it learned. `node` must have been created with `use_sim_time` =
/// `options.params.use_sim_time`.
pub fn run(mut node: RosNode, supervisor: Supervisor, options: &RunOptions) -> Result<Supervisor> {
    let params = &options.params;
    let robot = node.subscription::<RobotStream>("/robot_stream", &qos::reliable_depth(100))?;
    let objects = node.subscription::<ObjectStream>("/object_stream", &qos::reliable())?;
    let speech = node.subscription::<RosString>("/speech_command", &qos::reliable())?;
    let actions = node.publisher::<ActionCommand>("/supervisor/action", &qos::reliable())?;
    let wm = node.publisher::<WorkingMemory>("/supervisor/working_memory", &qos::reliable())?;

    let mut sn = SupervisorNode::new(supervisor, params);
    let mut ticks = Pacer::new(params.tick_period_s());
    let mut snapshots = (params.snapshot_rate_hz > 0.0).then(|| Pacer::new(1.0 / params.snapshot_rate_hz));
    let mut commands = Vec::new();
    let mut told_waiting = false;
    let mut told_clock = false;
    let mut told_unsaved = false;
    let mut save_retry: Option<Instant> = None;
    let started = Instant::now();
    let mut loop_ticks: u64 = 0;
    let stop_requested = || {
        cowork_ros::shutdown::requested()
            || options.stop.as_ref().is_some_and(|s| s.load(Ordering::SeqCst))
            || options.duration_s.is_some_and(|d| started.elapsed().as_secs_f64() >= d)
    };
    tracing::info!(
        "attentional_supervisor running: tick {} Hz, snapshots {} Hz, {} time, LTM saved to {}",
        params.tick_rate_hz,
        params.snapshot_rate_hz,
        if params.use_sim_time { "/clock" } else { "wall-clock" },
        options.save_ltm.as_deref().map_or("nowhere (no --save-ltm)".into(), |p| p.display().to_string())
    );

    while !stop_requested() {
        let now = node.now();
        let now_s = now.to_secs_f64();
        if !ticks.due(now_s) {
            let wait = if params.use_sim_time { 0.001f64.min(params.tick_period_s()) } else { ticks.wait_s(now_s) };
            std::thread::sleep(cowork_ros::duration_s(wait.max(50e-6)));
            continue;
        }
        // Stimuli are taken right before the tick that answers them.
        while let Some(m) = objects.take() {
            sn.on_object_stream(&m);
        }
        while let Some(m) = robot.take() {
            sn.on_robot_stream(&m);
        }
        while let Some(m) = speech.take() {
            sn.on_speech(&m);
        }
        if params.use_sim_time && !node.clock_started() && !told_clock {
            told_clock = true;
            tracing::info!("use_sim_time: waiting for /clock");
        }
        if !sn.ready() && !told_waiting {
            told_waiting = true;
            tracing::info!("waiting for the first /object_stream before deciding");
        }
        commands.clear();
        loop_ticks += 1;
        sn.tick(now, &mut commands);
        for c in commands.drain(..) {
            actions.publish(c)?;
        }
        if let Some(s) = snapshots.as_mut()
            && s.due(now_s)
        {
            wm.publish(sn.working_memory(now))?;
        }
        if sn.supervisor().ltm_changed() {
            match &options.save_ltm {
                Some(path) if save_retry.is_none_or(|t| t.elapsed() >= Duration::from_secs(1)) => {
                    match sn.save_ltm_if_changed(path) {
                        Ok(_) => {
                            save_retry = None;
                            tracing::info!("learned LTM saved to {}", path.display());
                        }
                        Err(e) => {
                            save_retry = Some(Instant::now());
                            tracing::error!("cannot save the learned LTM (retrying every second): {e}");
                        }
                    }
                }
                Some(_) => {}
                None if !told_unsaved => {
                    told_unsaved = true;
                    tracing::warn!("learned actions are kept in memory only; pass --save-ltm FILE to keep them");
                }
                None => {}
            }
        }
    }

    let now = node.now();
    for c in sn.shutdown_commands(now) {
        tracing::info!("stopping {} on shutdown", c.label);
        actions.publish(c)?;
    }
    if let Some(path) = &options.save_ltm {
        match sn.save_ltm_if_changed(path) {
            Ok(true) => tracing::info!("learned LTM saved to {}", path.display()),
            Ok(false) => {}
            Err(e) => bail!("cannot save the learned LTM to {}: {e}", path.display()),
        }
    }
    tracing::info!(
        "attentional_supervisor stopped after {loop_ticks} ticks ({} deciding, {} warnings)",
        sn.supervisor().ticks(),
        sn.warnings()
    );
    Ok(sn.into_supervisor())
}

#[cfg(test)]
mod bound_tests {
    use super::*;

    /// A flood of distinct (and huge) warnings keeps the limiter at its bound instead of
    /// growing (and rescanning) without end.
    #[test]
    fn the_warning_limiter_stays_bounded_under_a_flood() {
        let mut l = WarnLimiter::default();
        let big = "x".repeat(100_000);
        for i in 0..5_000 {
            l.warn(&format!("unknown speech word {i} {big}"));
        }
        assert!(l.last.len() <= MAX_WARNING_KINDS, "{}", l.last.len());
        assert!(l.last.keys().all(|k| k.len() < 2 * MAX_WARNING_CHARS), "keys are prefixes");
    }

    #[test]
    fn a_megabyte_speech_command_becomes_a_short_event() {
        let msg = RosString { data: "teach ".repeat(200_000) };
        let Event::Speech { text } = speech_event(&msg) else { panic!("a speech event") };
        assert!(text.len() < 4 * MAX_SPEECH_CHARS, "{}", text.len());
    }
}
