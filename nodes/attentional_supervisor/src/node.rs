//! [`SupervisorNode`]: the supervisor with its message conversions and one handler per input;
//! pure: messages and the clock in, [`Output`]s out, no I/O and no logging (the run loop logs
//! the [`Output::Decision`]s and [`Output::Warning`]s).

use std::collections::BTreeMap;

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{ActionCommand, ActionEvent, ObjectStream, RobotStream, WmNode, WorkingMemory};
use cowork_msgs::std_msgs::{Header, String as RosString};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::topics;
use cowork_ros::Warning;
use cowork_supervisor::{ActionKind, Decision, Event, GripperState, ObjectObs, Supervisor, WmSnapshot};
use serde::Serialize;

use crate::areas::Areas;
use crate::params::{MAX_ACTION_RESENDS, Params};

/// Identical warnings are logged at most once per this many seconds.
pub const WARNING_REPEAT_S: f64 = 10.0;

/// Longest speech command passed on whole (characters); no word of the vocabulary comes close.
pub const MAX_SPEECH_CHARS: usize = 200;

/// Characters of a library warning that are logged (it may quote a speech command).
pub const MAX_WARNING_CHARS: usize = 300;

/// What the node takes in. A single-arm LTM reads the root topics (`ObjectStream`,
/// `RobotStream`); one that declares arms reads each arm's (`ArmObjectStream`,
/// `ArmRobotStream`) and `/tf_static`.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// `/object_stream`: object distances and visibility.
    ObjectStream(ObjectStream),
    /// `/robot_stream`: action events, teaching segments, gripper state.
    RobotStream(RobotStream),
    /// `/speech_command`.
    Speech(RosString),
    /// `/<arm>/object_stream` of an arm the LTM declares (poses in that arm's base frame).
    ArmObjectStream {
        /// The arm, as the LTM names it (`left`).
        arm: String,
        /// The message.
        msg: ObjectStream,
    },
    /// `/<arm>/robot_stream` of an arm the LTM declares.
    ArmRobotStream {
        /// The arm, as the LTM names it (`left`).
        arm: String,
        /// The message.
        msg: RobotStream,
    },
    /// `/tf_static`: the arm bases in the world frame (dual-arm).
    TfStatic(TFMessage),
}

/// What the node puts out, in the order it happened.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Output {
    /// `/supervisor/action`: a new action or an abort.
    Action(ActionCommand),
    /// `/supervisor/working_memory`.
    WorkingMemory(WorkingMemory),
    /// A decision of the supervisor, for the log (actions and stops come as
    /// [`Output::Action`] too).
    Decision(Decision),
    /// The LTM changed (teaching attached actions): its new text, to save.
    Learned {
        /// The whole LTM in schema notation (what `Ltm::save` writes).
        ltm: String,
    },
    /// A warning for the log (rate-limited by the caller).
    Warning(Warning),
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
/// repeated report must not be replayed). [`Default`]: the one arm of a single-arm robot
/// (`/robot_stream`, events with no arm); [`for_arm`](Self::for_arm): one arm of a dual-arm
/// robot, each with its own decoder (its own last gripper state).
#[derive(Debug, Default, Clone)]
pub struct RobotStreamDecoder {
    gripper: Option<(u8, String)>,
    /// `(arm, /<arm>/robot_stream)`; `None`: the single arm on `/robot_stream`.
    arm: Option<(String, String)>,
}

impl RobotStreamDecoder {
    /// The decoder of arm `arm`'s `/<arm>/robot_stream`: every event it yields names `arm`.
    pub fn for_arm(arm: &str) -> Self {
        Self { gripper: None, arm: Some((arm.to_owned(), topics::ROBOT_STREAM.name_in(&format!("/{arm}")).into_owned())) }
    }

    /// The topic decoded: `/robot_stream` or `/<arm>/robot_stream`.
    pub fn topic(&self) -> &str {
        self.arm.as_ref().map_or(topics::ROBOT_STREAM.name, |(_, t)| t.as_str())
    }

    /// Appends the events of `msg` to `events` and what was wrong with it to `problems`.
    pub fn decode(&mut self, msg: &RobotStream, events: &mut Vec<Event>, problems: &mut Vec<String>) {
        let mut warnings = Vec::new();
        self.decode_warnings(msg, events, &mut warnings);
        problems.extend(warnings.into_iter().map(|w| w.message));
    }

    /// [`decode`](Self::decode) with the problems as [`Warning`]s (kind
    /// `/robot_stream:<field>`, `/left/robot_stream:<field>`).
    pub fn decode_warnings(&mut self, msg: &RobotStream, events: &mut Vec<Event>, problems: &mut Vec<Warning>) {
        let (arm, topic) = match &self.arm {
            Some((a, t)) => (Some(a), t.as_str()),
            None => (None, topics::ROBOT_STREAM.name),
        };
        for e in &msg.events {
            if e.failed {
                events.push(Event::ActionFailed { arm: arm.cloned(), label: e.label.clone(), reason: e.reason.clone() });
            } else if e.done {
                events.push(Event::ActionDone { arm: arm.cloned(), label: e.label.clone() });
            }
        }
        for s in &msg.segments {
            let Some(kind) = action_kind(s.kind) else {
                problems.push(Warning::new(
                    format!("{topic}:segments.kind"),
                    format!(
                        "{topic}: segment '{}' has unknown kind {} (expected 0 NOA, 1 FOA, 2 gripper); dropped",
                        cowork_ros::quote(&s.label),
                        s.kind
                    ),
                ));
                continue;
            };
            let object = (!s.object_name.is_empty()).then(|| s.object_name.clone());
            events.push(Event::Segment { arm: arm.cloned(), label: s.label.clone(), kind, object });
        }
        let state = match msg.gripper_state {
            RobotStream::GRIPPER_OPEN => GripperState::Open,
            RobotStream::GRIPPER_CLOSED => GripperState::Close,
            other => {
                problems.push(Warning::new(
                    format!("{topic}:gripper_state"),
                    format!("{topic}: unknown gripper_state {other} (expected 0 open, 1 closed); gripper ignored"),
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
        events.push(Event::Gripper { arm: arm.cloned(), state, object });
    }
}

/// Remembers the id of the command running on each arm, so an abort names what it aborts.
/// [`Default`] passes commands for any arm; [`for_arms`](Self::for_arms) only for the arms
/// given (what the node uses: a command for an arm the LTM does not declare is never sent).
#[derive(Debug, Default, Clone)]
pub struct CommandTracker {
    running: BTreeMap<String, (u32, String)>,
    /// The arms commands may name (`""`: the single arm); `None`: any.
    arms: Option<Vec<String>>,
}

impl CommandTracker {
    /// A tracker that turns only decisions for `arms` into commands (the library's
    /// `State::arm_names`: one empty name for a single arm).
    pub fn for_arms(arms: &[String]) -> Self {
        Self { running: BTreeMap::new(), arms: Some(arms.to_vec()) }
    }

    /// Whether a command may name `arm` (`""`: none).
    pub fn declares(&self, arm: &str) -> bool {
        self.arms.as_ref().is_none_or(|a| a.iter().any(|x| x == arm))
    }

    /// The `/supervisor/action` message for a decision, if it is one (`Action` or `Stop`) and
    /// its arm is [declared](Self::declares).
    pub fn command(&mut self, decision: &Decision, stamp: Time) -> Option<ActionCommand> {
        let header = Header { stamp, frame_id: String::new() };
        match decision {
            Decision::Action { id, arm, label, .. } => {
                let arm = arm.clone().unwrap_or_default();
                if !self.declares(&arm) {
                    return None;
                }
                self.running.insert(arm.clone(), (*id, label.clone()));
                Some(ActionCommand { header, id: *id, label: label.clone(), arm, stop: false })
            }
            Decision::Stop { arm, label, .. } => {
                let arm = arm.as_deref().unwrap_or("");
                self.declares(arm).then(|| self.stop(arm, label, header))
            }
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

/// Rate-limit key of a library warning: its variant, never its (peer-supplied) text, so a
/// flood of distinct bad words is one kind.
pub fn warning_kind(w: &cowork_supervisor::Warning) -> &'static str {
    use cowork_supervisor::Warning as W;
    match w {
        W::UnknownSpeech { .. } => "supervisor:unknown_speech",
        W::UnknownObject { .. } => "supervisor:unknown_object",
        W::UnknownArm { .. } => "supervisor:unknown_arm",
        W::UnknownSubtask { .. } => "supervisor:unknown_subtask",
        W::UnexpectedActionEvent { .. } => "supervisor:unexpected_action_event",
        W::ActionFailed { .. } => "supervisor:action_failed",
        W::NoOpenSubtask { .. } => "supervisor:no_open_subtask",
        W::SegmentOutsideTeaching { .. } => "supervisor:segment_outside_teaching",
        W::BadLabel { .. } => "supervisor:bad_label",
        W::NonFinite { .. } => "supervisor:non_finite",
        W::IgnoredSpeech { .. } => "supervisor:ignored_speech",
        W::UnfinishedDemonstration { .. } => "supervisor:unfinished_demonstration",
    }
}

/// What the node keeps per arm: one with an empty name on the root topics for a single-arm
/// LTM, one per declared arm on its namespace's topics otherwise.
#[derive(Debug, Clone)]
struct ArmIo {
    /// As the LTM names it (`""`: the single arm).
    name: String,
    /// Its own last gripper state.
    decoder: RobotStreamDecoder,
    /// The arm's last action command until an event of its id arrives on the arm's
    /// robot stream: (command, when it was last sent s, how often it was sent again).
    unacked: Option<(ActionCommand, f64, u32)>,
    /// The arm's last action command, with when it was sent (s), until a done or failed
    /// event of it: what a robot manager that restarted in the middle of it is sent again.
    running: Option<(ActionCommand, f64)>,
    /// The supervisor's time (s) at the arm's last robot stream message.
    stream_s: Option<f64>,
    /// The robot stream came back after this silence (s) while `running`: the command goes
    /// out again at the next tick.
    silence_s: Option<f64>,
}

/// The supervisor with its message conversions; no I/O.
#[derive(Debug)]
pub struct SupervisorNode {
    sup: Supervisor,
    params: Params,
    tracker: CommandTracker,
    /// Indexed like the library's arms (`State::arm_names`).
    arms: Vec<ArmIo>,
    /// Dual-arm: the per-arm object streams, arm bases and areas; `None` for a single arm.
    areas: Option<Areas>,
    objects_seen: bool,
    events: Vec<Event>,
    pending_problems: Vec<Warning>,
    problems: Vec<Warning>,
    decisions: Vec<Decision>,
    scratch: Vec<Output>,
    warnings: u64,
    last_tick_s: f64,
}

impl SupervisorNode {
    /// Wraps a supervisor; `params.wait_for_object_stream` gates the first decision, and
    /// the run loop ticks at `params.tick_rate_hz`. When the LTM declares arms the node reads
    /// each arm's streams and `/tf_static` (see the crate docs); `params.areas` is used then.
    pub fn new(sup: Supervisor, params: &Params) -> Self {
        let state = sup.state();
        let dual = state.is_dual();
        let arms = state
            .arm_names()
            .iter()
            .map(|a| ArmIo {
                name: a.clone(),
                decoder: if dual { RobotStreamDecoder::for_arm(a) } else { RobotStreamDecoder::default() },
                unacked: None,
                running: None,
                stream_s: None,
                silence_s: None,
            })
            .collect();
        let areas = dual.then(|| Areas::new(state.arm_names(), &params.areas, &params.attention.central_area));
        Self {
            tracker: CommandTracker::for_arms(state.arm_names()),
            sup,
            params: params.clone(),
            arms,
            areas,
            objects_seen: false,
            events: Vec::new(),
            pending_problems: Vec::new(),
            problems: Vec::new(),
            decisions: Vec::new(),
            scratch: Vec::new(),
            warnings: 0,
            last_tick_s: 0.0,
        }
    }

    /// The node's parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// The wrapped supervisor.
    pub fn supervisor(&self) -> &Supervisor {
        &self.sup
    }

    /// Gives the supervisor back (with what it learned).
    pub fn into_supervisor(self) -> Supervisor {
        self.sup
    }

    /// The arms the node reads per-arm topics for (the LTM's `arms([...])`); empty for a
    /// single-arm LTM, which reads the root topics.
    pub fn dual_arms(&self) -> Vec<String> {
        if self.areas.is_some() { self.arms.iter().map(|a| a.name.clone()).collect() } else { Vec::new() }
    }

    /// Dual-arm: the object merge with the arm bases known so far; `None` for a single arm.
    pub fn areas(&self) -> Option<&Areas> {
        self.areas.as_ref()
    }

    /// Whether the supervisor decides: no wait, or the first `/object_stream` arrived (with
    /// arms: the first `/<arm>/object_stream` of every arm, so no arm's first decision lacks
    /// its distances).
    pub fn ready(&self) -> bool {
        !self.params.wait_for_object_stream
            || match &self.areas {
                Some(a) => a.all_seen(),
                None => self.objects_seen,
            }
    }

    /// Warnings so far (library warnings and malformed messages).
    pub fn warnings(&self) -> u64 {
        self.warnings
    }

    /// Decisions of the last tick.
    pub fn decisions(&self) -> &[Decision] {
        &self.decisions
    }

    /// Message problems reported by the last tick (malformed fields the library never saw).
    pub fn problems(&self) -> &[Warning] {
        &self.problems
    }

    /// Any input.
    pub fn on_input(&mut self, input: &Input) {
        match input {
            Input::ObjectStream(m) => self.on_object_stream(m),
            Input::RobotStream(m) => self.on_robot_stream(m),
            Input::Speech(m) => self.on_speech(m),
            Input::ArmObjectStream { arm, msg } => self.on_arm_object_stream(arm, msg),
            Input::ArmRobotStream { arm, msg } => self.on_arm_robot_stream(arm, msg),
            Input::TfStatic(m) => self.on_tf_static(m),
        }
    }

    /// `/object_stream` (single arm; with arms it carries no arm and is dropped with a warning).
    pub fn on_object_stream(&mut self, msg: &ObjectStream) {
        if self.areas.is_some() {
            return self.root_topic_with_arms(topics::OBJECT_STREAM.name);
        }
        self.objects_seen = true;
        self.sup.handle(&objects_event(msg), self.now_hint());
    }

    /// `/robot_stream` (single arm; with arms it carries no arm and is dropped with a warning).
    pub fn on_robot_stream(&mut self, msg: &RobotStream) {
        if self.areas.is_some() {
            return self.root_topic_with_arms(topics::ROBOT_STREAM.name);
        }
        self.robot_stream(0, msg);
    }

    /// `/<arm>/object_stream`: merged with the other arms' newest into one `objects` event
    /// with per-arm distances and areas ([`Areas::event`]).
    pub fn on_arm_object_stream(&mut self, arm: &str, msg: &ObjectStream) {
        let Some(i) = self.declared_arm(arm, topics::OBJECT_STREAM.name) else { return };
        let Some(areas) = self.areas.as_mut() else { return };
        areas.on_object_stream(i, msg);
        let event = areas.event(&mut self.pending_problems);
        self.sup.handle(&event, self.now_hint());
    }

    /// `/<arm>/robot_stream`: events tagged with `arm`.
    pub fn on_arm_robot_stream(&mut self, arm: &str, msg: &RobotStream) {
        if let Some(i) = self.declared_arm(arm, topics::ROBOT_STREAM.name) {
            self.robot_stream(i, msg);
        }
    }

    /// `/tf_static` (dual-arm; ignored for a single arm): the arm bases. Objects already
    /// reported are placed again at once, so their areas do not wait for the next stream.
    pub fn on_tf_static(&mut self, msg: &TFMessage) {
        let Some(areas) = self.areas.as_mut() else { return };
        let before: Vec<_> = (0..self.arms.len()).map(|i| areas.bases().get(i).copied()).collect();
        areas.on_tf_static(msg, &mut self.pending_problems);
        let changed = (0..self.arms.len()).any(|i| areas.bases().get(i).copied() != before[i]);
        if changed {
            let event = areas.event(&mut self.pending_problems);
            self.sup.handle(&event, self.now_hint());
        }
    }

    /// `/speech_command`.
    pub fn on_speech(&mut self, msg: &RosString) {
        self.sup.handle(&speech_event(msg), self.now_hint());
    }

    fn robot_stream(&mut self, i: usize, msg: &RobotStream) {
        let Some(io) = self.arms.get_mut(i) else { return };
        if io.unacked.as_ref().is_some_and(|(c, _, _)| msg.events.iter().any(|e| e.command_id == c.id || e.label == c.label)) {
            io.unacked = None;
        }
        // A stream silent for longer than `action_resend_s` while an action ran: its robot
        // manager stopped (killed, or stopped and continued) and may have started over without
        // it. Sent again at the next tick; a manager still running it ignores it (same label).
        // The silence counts from the later of the last stream and the command; a message that
        // answers the command itself (the manager has it) ends no silence.
        let now = self.last_tick_s;
        let answers = |c: &ActionCommand| msg.events.iter().any(|e| e.command_id == c.id || e.label == c.label);
        if let Some((c, sent_s)) = &io.running
            && let Some(last) = io.stream_s
            && now - last.max(*sent_s) > self.params.action_resend_s
            && !answers(c)
        {
            io.silence_s = Some(now - last.max(*sent_s));
        }
        io.stream_s = Some(now);
        if io.running.as_ref().is_some_and(|(c, _)| msg.events.iter().any(|e| (e.done || e.failed) && (e.command_id == c.id || e.label == c.label))) {
            io.running = None;
            io.silence_s = None;
        }
        self.events.clear();
        io.decoder.decode_warnings(msg, &mut self.events, &mut self.pending_problems);
        let t = self.now_hint();
        for e in &self.events {
            self.sup.handle(e, t);
        }
    }

    /// The index of `arm` when the LTM declares it; else a warning naming the topic.
    fn declared_arm(&mut self, arm: &str, topic: &str) -> Option<usize> {
        let i = self.areas.as_ref().and_then(|_| self.arms.iter().position(|a| a.name == arm));
        if i.is_none() {
            let arms = self.dual_arms();
            let what = if arms.is_empty() { "the LTM declares no arms (a single arm reads the root topics)".to_owned() } else { format!("not an arm of the LTM ({})", arms.join(", ")) };
            self.pending_problems.push(Warning::new(
                "supervisor:undeclared_arm",
                format!("/{}{topic}: {what}; dropped", cowork_ros::quote(arm)),
            ));
        }
        i
    }

    fn root_topic_with_arms(&mut self, topic: &str) {
        self.pending_problems.push(Warning::new(
            format!("{topic}:arms"),
            format!("{topic} carries no arm and the LTM declares arms ({}): each arm's /<arm>{topic} is read instead; dropped", self.dual_arms().join(", ")),
        ));
    }

    // Events take effect at the next tick; they carry the time of the last one.
    fn now_hint(&self) -> f64 {
        self.last_tick_s
    }

    /// One decision cycle at `now`: reports the problems of the messages since the last tick,
    /// runs the supervisor (once ready) and appends, per decision, the `/supervisor/action`
    /// message it implies, the decision itself (or its warning) to `out`. A command for an arm
    /// the LTM does not declare is not sent (a warning instead; the library never decides one).
    pub fn on_tick(&mut self, now: Time, out: &mut Vec<Output>) {
        self.problems.clear();
        std::mem::swap(&mut self.problems, &mut self.pending_problems);
        self.warnings += self.problems.len() as u64;
        out.extend(self.problems.iter().cloned().map(Output::Warning));
        self.decisions.clear();
        self.last_tick_s = now.to_secs_f64();
        if !self.ready() {
            return;
        }
        self.resend_unacked(now, out);
        self.resend_after_silence(now, out);
        self.sup.tick(now.to_secs_f64(), &mut self.decisions);
        for d in &self.decisions {
            match self.tracker.command(d, now) {
                Some(c) => {
                    if let Some(io) = self.arms.iter_mut().find(|a| a.name == c.arm) {
                        io.unacked = (!c.stop).then(|| (c.clone(), now.to_secs_f64(), 0));
                        io.running = (!c.stop).then(|| (c.clone(), now.to_secs_f64()));
                        io.silence_s = None;
                    }
                    out.push(Output::Action(c));
                }
                None => {
                    if let Decision::Action { arm, label, .. } | Decision::Stop { arm, label, .. } = d {
                        self.warnings += 1;
                        out.push(Output::Warning(Warning::new(
                            "supervisor:undeclared_arm",
                            format!(
                                "command `{}` for arm `{}`, which the LTM does not declare: not sent",
                                cowork_ros::text_prefix(label, MAX_WARNING_CHARS),
                                arm.as_deref().unwrap_or("")
                            ),
                        )));
                    }
                }
            }
            match d {
                Decision::Warning { message, warning } => {
                    self.warnings += 1;
                    out.push(Output::Warning(Warning::new(
                        warning_kind(warning),
                        cowork_ros::text_prefix(message, MAX_WARNING_CHARS).into_owned(),
                    )));
                }
                other => out.push(Output::Decision(other.clone())),
            }
        }
    }

    /// Sends an arm's last action command again when no event of its id came on that arm's
    /// robot stream within `action_resend_s` (at most [`MAX_ACTION_RESENDS`] times, each with
    /// a warning). The manager starts a command it missed and ignores one it runs (same label).
    fn resend_unacked(&mut self, now: Time, out: &mut Vec<Output>) {
        let now_s = now.to_secs_f64();
        for io in &mut self.arms {
            let topic = io.decoder.topic();
            let Some((cmd, sent_s, resends)) = io.unacked.as_mut() else { continue };
            if now_s < *sent_s {
                // The clock went back (a new simulation): count from now.
                *sent_s = now_s;
                continue;
            }
            if now_s - *sent_s < self.params.action_resend_s {
                continue;
            }
            let what = format!("action {} `{}`", cmd.id, cowork_ros::text_prefix(&cmd.label, MAX_WARNING_CHARS));
            let message = if *resends >= MAX_ACTION_RESENDS {
                let m = format!("no {topic} event for {what} after {MAX_ACTION_RESENDS} resends: not sent again (is robot_manager running?)");
                io.unacked = None;
                m
            } else {
                *resends += 1;
                *sent_s = now_s;
                cmd.header.stamp = now;
                out.push(Output::Action(cmd.clone()));
                format!("no {topic} event for {what} within {} s: sent again ({}/{MAX_ACTION_RESENDS})", self.params.action_resend_s, *resends)
            };
            self.warnings += 1;
            out.push(Output::Warning(Warning::new("supervisor:action_resent", message)));
        }
    }

    /// Sends an arm's running action again when its robot stream came back after a silence
    /// (see [`robot_stream`](Self::robot_stream)), with a warning; it is then tracked as
    /// unanswered, as a new command is.
    fn resend_after_silence(&mut self, now: Time, out: &mut Vec<Output>) {
        for io in &mut self.arms {
            let Some(silence) = io.silence_s.take() else { continue };
            let Some((cmd, _)) = io.running.as_mut() else { continue };
            cmd.header.stamp = now;
            out.push(Output::Action(cmd.clone()));
            io.unacked = Some((cmd.clone(), now.to_secs_f64(), 0));
            let message = format!(
                "{} silent for {silence:.1} s while action {} `{}` ran (robot_manager stopped or restarted?): sent again",
                io.decoder.topic(),
                cmd.id,
                cowork_ros::text_prefix(&cmd.label, MAX_WARNING_CHARS)
            );
            self.warnings += 1;
            out.push(Output::Warning(Warning::new("supervisor:action_resent", message)));
        }
    }

    /// [`on_tick`](Self::on_tick) keeping only the `/supervisor/action` messages (appended to
    /// `out`); the decisions stay readable through [`decisions`](Self::decisions).
    pub fn tick(&mut self, now: Time, out: &mut Vec<ActionCommand>) {
        let mut all = std::mem::take(&mut self.scratch);
        all.clear();
        self.on_tick(now, &mut all);
        out.extend(all.drain(..).filter_map(|o| match o {
            Output::Action(c) => Some(c),
            _ => None,
        }));
        self.scratch = all;
    }

    /// The LTM's text when it changed since the last call (or the last save): what a run
    /// saves. Clears the change flag.
    pub fn take_learned(&mut self) -> Option<String> {
        if !self.sup.ltm_changed() {
            return None;
        }
        self.sup.mark_ltm_saved();
        Some(self.sup.ltm().to_text())
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

    pub(crate) fn supervisor_mut(&mut self) -> &mut Supervisor {
        &mut self.sup
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_megabyte_speech_command_becomes_a_short_event() {
        let msg = RosString { data: "teach ".repeat(200_000) };
        let Event::Speech { text } = speech_event(&msg) else { panic!("a speech event") };
        assert!(text.len() < 4 * MAX_SPEECH_CHARS, "{}", text.len());
    }
}
