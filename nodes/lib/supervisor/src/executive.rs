//! The tick-driven attentional executive (thesis Sec. 5.2.2–5.2.4): events update the state
//! variables; every tick `alive` maintains the WM, attention recomputes emphases, and each
//! arm is given the most emphasised enabled action (winner-takes-all, eq. 4.9) subject to the
//! exclusive resources: one action per arm (its gripper included), one arm per behaviour, and
//! the shared central area granted first-come-first-served.

use serde::Serialize;

use crate::attention::{self, SupervisorConfig};
use crate::error::{Error, Result, Warning};
use crate::events::{Event, GripperState, ObjectObs};
use crate::ltm::Ltm;
use crate::schema::{ActionKind, Term};
use crate::state::{GroundCond, State};
use crate::teaching::{self, TeachSession};
use crate::wm::{NodeId, NodeKind, Wm, status};

/// Supervisor mode (speech `teach` / `done`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Commanding learned actions.
    Execute,
    /// Attaching demonstrated actions.
    Teach,
}

/// What the supervisor decided; the ROS node maps `Action`/`Stop` to `/supervisor/action`.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum Decision {
    /// Execute this action (replaces whatever the arm was doing).
    Action {
        id: u32,
        #[serde(skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        label: String,
        kind: ActionKind,
        subtask: String,
        releaser: String,
        emphasis: f64,
    },
    /// Abort the arm's current action.
    Stop {
        #[serde(skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        label: String,
        reason: String,
    },
    /// The most emphasised subtask is open: wait for (or ask for) a demonstration.
    AwaitDemonstration {
        #[serde(skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        subtask: String,
    },
    /// A segmented action was learned (Algorithm 4).
    Attached {
        #[serde(skip_serializing_if = "Option::is_none")]
        arm: Option<String>,
        label: String,
        kind: ActionKind,
        subtask: String,
        releaser: String,
    },
    /// A subtask was assigned to the person.
    HumanAssigned { subtask: String },
    /// Mode switched.
    Mode { mode: Mode },
    /// A behaviour's post-condition was reached.
    Accomplished { behaviour: String },
    /// The whole task is accomplished.
    TaskAccomplished { task: String },
    /// Bad or inapplicable input; nothing else happened.
    Warning { message: String, warning: Warning },
}

#[derive(Debug, Clone, PartialEq)]
enum Current {
    Idle,
    Running { node: NodeId, label: String },
    Waiting { node: NodeId },
}

#[derive(Debug, Clone)]
struct ArmSlot {
    current: Current,
    central_request_s: Option<f64>,
}

/// A resource grant, for checks and displays.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Grant {
    /// Resource name: `arm:<name>`, `gripper:<name>` or the central area.
    pub resource: String,
    /// Holder (arm name, empty for a single-arm robot).
    pub arm: String,
    /// Behaviour holding it.
    pub behaviour: String,
}

/// One node of a WM snapshot (field meanings as in `cowork_msgs/WmNode`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WmNodeView {
    pub id: u32,
    pub parent: i32,
    pub name: String,
    pub kind: NodeKind,
    pub releaser: String,
    pub releaser_value: bool,
    pub postcondition: String,
    pub concrete: bool,
    pub emphasis: f64,
    pub magnitude: f64,
    pub period: f64,
    pub done: bool,
    pub enabled: bool,
    pub status: &'static str,
    pub assigned_to: &'static str,
    pub arm: String,
}

/// A WM snapshot: nodes in pre-order (index 0 is `alive`) and the true state variables.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct WmSnapshot {
    pub nodes: Vec<WmNodeView>,
    pub true_variables: Vec<String>,
}

/// The attentional supervisor.
#[derive(Debug)]
pub struct Supervisor {
    cfg: SupervisorConfig,
    ltm: Ltm,
    state: State,
    wm: Wm,
    task: Term,
    mode: Mode,
    halted: bool,
    slots: Vec<ArmSlot>,
    central: Option<usize>,
    session: TeachSession,
    pending: Vec<Decision>,
    next_id: u32,
    task_reported: bool,
    ltm_changed: bool,
    ticks: u64,
}

impl Supervisor {
    /// Allocates `task` (e.g. `prepareCoffee`, `add(water)`) from the LTM in execute mode.
    pub fn new(ltm: Ltm, task: &str, cfg: SupervisorConfig) -> Result<Self> {
        cfg.validate()?;
        let unknown = |reason: String| Error::UnknownTask { task: task.to_owned(), reason };
        let t = Term::parse(task).map_err(|e| unknown(e.to_string()))?;
        if !t.is_ground() {
            return Err(unknown("the task must not contain variables".into()));
        }
        for c in t.constant_args() {
            if !ltm.is_object(c) && !ltm.arms().iter().any(|a| a == c) {
                return Err(unknown(format!("unknown object '{c}'")));
            }
        }
        if ltm.retrieve(&t).is_none() {
            return Err(unknown("no schema in the LTM matches it".into()));
        }
        let mut state = State::new(ltm.arms());
        let wm = Wm::new(&t, &ltm, &mut state);
        let n = state.n_arms();
        Ok(Self {
            cfg,
            ltm,
            state,
            wm,
            task: t,
            mode: Mode::Execute,
            halted: false,
            slots: vec![ArmSlot { current: Current::Idle, central_request_s: None }; n],
            central: None,
            session: TeachSession::default(),
            pending: Vec::new(),
            next_id: 1,
            task_reported: false,
            ltm_changed: false,
            ticks: 0,
        })
    }

    /// The long-term memory (with everything learned so far).
    pub fn ltm(&self) -> &Ltm {
        &self.ltm
    }

    /// True once something was learned since the last call of `mark_ltm_saved`.
    pub fn ltm_changed(&self) -> bool {
        self.ltm_changed
    }

    /// Clears the `ltm_changed` flag (after saving).
    pub fn mark_ltm_saved(&mut self) {
        self.ltm_changed = false;
    }

    /// State variables and objects.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The working memory.
    pub fn wm(&self) -> &Wm {
        &self.wm
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Ticks run so far.
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// True when the task's post-condition has been reached.
    pub fn task_accomplished(&self) -> bool {
        self.wm.get(self.wm.task()).is_none_or(|n| n.accomplished)
    }

    /// Label of the action commanded to `arm` (index; 0 for a single arm), if running.
    pub fn running(&self, arm: usize) -> Option<&str> {
        match &self.slots.get(arm)?.current {
            Current::Running { label, .. } => Some(label),
            _ => None,
        }
    }

    /// The arm holding the central area, if any.
    pub fn central_holder(&self) -> Option<&str> {
        self.central.map(|a| self.state.arm_names()[a].as_str())
    }

    /// Current resource grants.
    pub fn grants(&self) -> Vec<Grant> {
        let mut out = Vec::new();
        for (a, s) in self.slots.iter().enumerate() {
            if let Current::Running { node, label, .. } = &s.current {
                let arm = self.state.arm_names()[a].clone();
                out.push(Grant { resource: format!("arm:{arm}"), arm: arm.clone(), behaviour: label.clone() });
                if matches!(self.wm.get(*node).map(|n| n.kind), Some(NodeKind::Action(ActionKind::Gripper))) {
                    out.push(Grant { resource: format!("gripper:{arm}"), arm: arm.clone(), behaviour: label.clone() });
                }
            }
        }
        if let Some(a) = self.central {
            let arm = self.state.arm_names()[a].clone();
            let behaviour = self.running(a).unwrap_or("").to_owned();
            out.push(Grant { resource: self.cfg.central_area.clone(), arm, behaviour });
        }
        out
    }

    fn arm_name(&self, a: usize) -> Option<String> {
        if self.state.is_dual() { Some(self.state.arm_names()[a].clone()) } else { None }
    }

    fn warn(&mut self, w: Warning) {
        self.pending.push(Decision::Warning { message: w.to_string(), warning: w });
    }

    fn resolve_arm(&mut self, arm: Option<&str>) -> Option<usize> {
        match arm {
            None => Some(0),
            Some(name) => match self.state.arm_index(name) {
                Some(i) => Some(i),
                None if !self.state.is_dual() && name.is_empty() => Some(0),
                None => {
                    self.warn(Warning::UnknownArm { arm: name.to_owned() });
                    None
                }
            },
        }
    }

    /// Applies one stimulus. Never fails: bad input becomes a `Warning` decision, returned by
    /// the next `tick` together with everything else this event caused.
    pub fn handle(&mut self, event: &Event, now_s: f64) {
        let _ = now_s;
        match event {
            Event::Objects { objects } => {
                for o in objects {
                    self.observe(o);
                }
            }
            Event::Gripper { arm, state, object } => {
                let Some(a) = self.resolve_arm(arm.as_deref()) else { return };
                match state {
                    GripperState::Open => self.state.release(a),
                    GripperState::Close => {
                        let obj = object.as_deref().filter(|o| !o.is_empty());
                        if let Some(o) = obj
                            && !self.ltm.is_object(o)
                        {
                            self.warn(Warning::UnknownObject { name: o.to_owned() });
                            self.state.grasp(a, None);
                        } else {
                            self.state.grasp(a, obj);
                        }
                    }
                }
            }
            Event::ActionDone { arm, label } => self.action_finished(arm.as_deref(), label, None),
            Event::ActionFailed { arm, label, reason } => self.action_finished(arm.as_deref(), label, Some(reason)),
            Event::Segment { arm, label, kind, object } => {
                if self.mode != Mode::Teach {
                    self.warn(Warning::SegmentOutsideTeaching { label: label.clone() });
                    return;
                }
                let a = match arm {
                    Some(_) => match self.resolve_arm(arm.as_deref()) {
                        Some(a) => Some(a),
                        None => return,
                    },
                    None => None,
                };
                if let Some(o) = object.as_deref().filter(|o| !o.is_empty())
                    && !self.ltm.is_object(o)
                {
                    self.warn(Warning::UnknownObject { name: o.to_owned() });
                    return;
                }
                let term = match teaching::action_term(label, object.as_deref()) {
                    Ok(t) => t,
                    Err(w) => return self.warn(w),
                };
                attention::update(&mut self.wm, &self.state, &self.cfg);
                match teaching::attach(&mut self.wm, &mut self.ltm, &mut self.state, &mut self.session, term, *kind, a) {
                    Ok(at) => {
                        self.ltm_changed = true;
                        let arm = at.arm.and_then(|a| self.arm_name(a));
                        self.pending.push(Decision::Attached {
                            arm,
                            label: at.label,
                            kind: at.kind,
                            subtask: at.subtask,
                            releaser: at.releaser,
                        });
                    }
                    Err(w) => self.warn(w),
                }
            }
            Event::Speech { text } => self.speech(text),
            Event::State { var, value } => {
                if var.is_empty() || var.split('.').any(str::is_empty) {
                    self.warn(Warning::BadLabel { label: var.clone(), reason: "empty state variable segment".into() });
                } else {
                    self.state.set(var, *value);
                }
            }
        }
    }

    fn observe(&mut self, o: &ObjectObs) {
        if !self.ltm.is_object(&o.name) {
            return self.warn(Warning::UnknownObject { name: o.name.clone() });
        }
        if o.distance.is_some_and(|d| !d.is_finite()) || o.arm_distances.values().any(|d| !d.is_finite()) {
            return self.warn(Warning::NonFinite { field: format!("distance of {}", o.name) });
        }
        let mut per_arm = Vec::new();
        for (arm, d) in &o.arm_distances {
            match self.state.arm_index(arm).filter(|_| self.state.is_dual()) {
                Some(i) => per_arm.push((i, *d)),
                None => self.warn(Warning::UnknownArm { arm: arm.clone() }),
            }
        }
        let info = self.state.object_mut(&o.name);
        if o.distance.is_some() {
            info.distance_m = o.distance;
        }
        for (i, d) in per_arm {
            info.arm_distance_m[i] = Some(d);
        }
        let returned = !info.visible && o.visible;
        info.visible = o.visible;
        if o.area.is_some() {
            info.area.clone_from(&o.area);
        }
        if returned {
            self.human_returned(&o.name);
        }
    }

    /// The object a person carried away is back in view: every unfinished behaviour about it
    /// that the person took over (`human add(water)`) is done — its post-condition is asserted
    /// and the `alive` pass accomplishes it (Fig. 5.21: the robot then goes on with what needed
    /// it, e.g. use(spoon) after both adds).
    fn human_returned(&mut self, object: &str) {
        let posts: Vec<GroundCond> = self
            .wm
            .iter()
            .filter(|n| n.human && !n.accomplished && n.object.as_deref() == Some(object))
            .map(|n| n.post.clone())
            .collect();
        for p in posts {
            self.state.assert_cond(&p);
        }
    }

    fn action_finished(&mut self, arm: Option<&str>, label: &str, failure: Option<&String>) {
        let arms: Vec<usize> = match arm {
            Some(_) => match self.resolve_arm(arm) {
                Some(a) => vec![a],
                None => return,
            },
            None => (0..self.slots.len()).collect(),
        };
        let hit = arms.into_iter().find_map(|a| match &self.slots[a].current {
            Current::Running { node, label: l, .. } if l == label => Some((a, *node)),
            _ => None,
        });
        let Some((a, node)) = hit else {
            return self.warn(Warning::UnexpectedActionEvent { label: label.to_owned() });
        };
        self.slots[a].current = Current::Idle;
        match failure {
            None => {
                let (post, obj) = match self.wm.get(node) {
                    Some(n) => (n.post.clone(), n.action_object.clone()),
                    None => return,
                };
                self.state.assert_cond(&post);
                let left_central = obj.as_deref().and_then(|o| self.state.area(o)) != Some(self.cfg.central_area.as_str());
                if self.central == Some(a) && left_central {
                    self.central = None;
                }
            }
            Some(reason) => {
                self.warn(Warning::ActionFailed { label: label.to_owned(), reason: reason.clone() });
                let max = self.cfg.max_retries;
                let parent = self.wm.get_mut(node).and_then(|n| {
                    n.failures += 1;
                    (n.failures >= max).then_some(n.parent).flatten()
                });
                if let Some(p) = parent.and_then(|p| self.wm.get_mut(p)) {
                    p.blocked = true;
                }
            }
        }
    }

    fn stop_all(&mut self, reason: &str) {
        for a in 0..self.slots.len() {
            if let Current::Running { label, .. } = &self.slots[a].current {
                let d = Decision::Stop { arm: self.arm_name(a), label: label.clone(), reason: reason.to_owned() };
                self.pending.push(d);
            }
            self.slots[a].current = Current::Idle;
        }
    }

    fn speech(&mut self, raw: &str) {
        let mut text = raw.trim();
        // Words addressed to one arm (`left: teach`) are taken as the same words: one teaching
        // session learns from whichever arm acts; `gripper …` is that arm's manager's business.
        if let Some((arm, rest)) = text.split_once(':')
            && !arm.trim().is_empty()
            && arm.trim().chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            if !self.state.arm_names().iter().any(|a| a == arm.trim()) {
                let reason = format!("no arm `{}` in the LTM (arms: {})", arm.trim(), self.state.arm_names().join(", "));
                return self.warn(Warning::IgnoredSpeech { text: text.to_owned(), reason });
            }
            text = rest.trim();
        }
        let lower = text.to_lowercase();
        let words: Vec<&str> = lower.split_whitespace().collect();
        let ignored = |reason: &str| Warning::IgnoredSpeech { text: text.to_owned(), reason: reason.to_owned() };
        match words.as_slice() {
            ["teach"] => {
                if self.mode == Mode::Teach {
                    return self.warn(ignored("already teaching"));
                }
                self.stop_all("teaching");
                self.mode = Mode::Teach;
                self.session = TeachSession::default();
                self.pending.push(Decision::Mode { mode: Mode::Teach });
            }
            ["done"] => {
                if self.mode != Mode::Teach {
                    return self.warn(ignored("not teaching"));
                }
                self.mode = Mode::Execute;
                // A release in the same tick as `done` still ends its subtask; what stays
                // unfinished is reported by `forget_unfinished` below.
                teaching::finish_demonstrated(&self.wm, &mut self.state, &mut self.session, &mut Vec::new());
                let forgotten = teaching::forget_unfinished(&mut self.wm, &mut self.ltm, &self.state);
                self.ltm_changed |= !forgotten.is_empty();
                for w in forgotten {
                    self.warn(w);
                }
                let ids: Vec<NodeId> = self.wm.iter().filter(|n| n.taught).map(|n| n.id).collect();
                for id in ids {
                    if let Some(n) = self.wm.get_mut(id) {
                        n.taught = false;
                    }
                }
                self.pending.push(Decision::Mode { mode: Mode::Execute });
            }
            ["stop"] => {
                self.stop_all("stop");
                self.halted = true;
            }
            ["repeat"] => {
                if self.halted {
                    self.halted = false;
                } else if self.task_accomplished() {
                    self.warn(ignored("the task is already accomplished"));
                } else {
                    self.warn(ignored("not stopped"));
                }
            }
            ["gripper", "open" | "close"] => {} // robot manager's vocabulary
            ["human", ..] => {
                let rest = text.split_once(char::is_whitespace).map(|(_, r)| r.trim()).unwrap_or("");
                let target = Term::parse(rest).map(|t| t.to_string()).unwrap_or_else(|_| rest.to_owned());
                let found: Vec<NodeId> = self
                    .wm
                    .iter()
                    .filter(|n| !n.accomplished && n.kind != NodeKind::Root && n.label == target)
                    .map(|n| n.id)
                    .collect();
                if found.is_empty() {
                    return self.warn(Warning::UnknownSubtask { text: rest.to_owned() });
                }
                for id in found {
                    if let Some(n) = self.wm.get_mut(id) {
                        n.human = true;
                    }
                }
                self.pending.push(Decision::HumanAssigned { subtask: target });
            }
            _ => self.warn(Warning::UnknownSpeech { text: text.to_owned() }),
        }
    }

    /// One supervisor cycle: flushes what events caused, runs `alive` and the attentional
    /// update, and (executing, not stopped) re-decides every arm's action. Decisions are
    /// appended to `out` (which is not cleared).
    pub fn tick(&mut self, now_s: f64, out: &mut Vec<Decision>) {
        self.ticks += 1;
        out.append(&mut self.pending);
        let teaching = self.mode == Mode::Teach;
        if teaching {
            attention::update(&mut self.wm, &self.state, &self.cfg);
            let mut unfinished = Vec::new();
            teaching::finish_demonstrated(&self.wm, &mut self.state, &mut self.session, &mut unfinished);
            for w in unfinished {
                out.push(Decision::Warning { message: w.to_string(), warning: w });
            }
        }
        let report = self.wm.alive(&self.ltm, &mut self.state, self.cfg.max_depth, teaching);
        out.extend(report.accomplished.into_iter().map(|b| Decision::Accomplished { behaviour: b }));
        attention::update(&mut self.wm, &self.state, &self.cfg);
        if self.task_accomplished() {
            if !self.task_reported {
                self.task_reported = true;
                self.central = None;
                for a in 0..self.slots.len() {
                    if let Current::Running { label, .. } = &self.slots[a].current {
                        out.push(Decision::Stop { arm: self.arm_name(a), label: label.clone(), reason: "task accomplished".into() });
                    }
                }
                for s in &mut self.slots {
                    s.current = Current::Idle;
                }
                out.push(Decision::TaskAccomplished { task: self.task.to_string() });
            }
            return;
        }
        if self.mode == Mode::Execute && !self.halted {
            self.decide(now_s, out);
        }
    }

    /// Convenience: `tick` into a new vector.
    pub fn tick_vec(&mut self, now_s: f64) -> Vec<Decision> {
        let mut v = Vec::new();
        self.tick(now_s, &mut v);
        v
    }

    fn needs_central(&self, id: NodeId) -> bool {
        self.wm
            .get(id)
            .and_then(|n| n.action_object.as_deref())
            .and_then(|o| self.state.area(o))
            .is_some_and(|a| a == self.cfg.central_area)
    }

    fn decide(&mut self, now_s: f64, out: &mut Vec<Decision>) {
        struct Cand {
            node: NodeId,
            arm: Option<usize>,
            e: f64,
            central: bool,
            open: bool,
        }
        let mut cands: Vec<Cand> = Vec::new();
        for n in self.wm.iter() {
            if n.accomplished || !n.enabled || !n.accessible {
                continue;
            }
            let open = n.is_open();
            if matches!(n.kind, NodeKind::Action(_)) || open {
                cands.push(Cand { node: n.id, arm: n.arm, e: n.emphasis, central: false, open });
            }
        }
        for c in &mut cands {
            c.central = !c.open && self.needs_central(c.node);
        }
        cands.sort_by(|a, b| b.e.total_cmp(&a.e).then(a.node.cmp(&b.node)));

        let mut order: Vec<usize> = (0..self.slots.len()).collect();
        order.sort_by(|&a, &b| {
            let ra = self.slots[a].central_request_s.unwrap_or(f64::INFINITY);
            let rb = self.slots[b].central_request_s.unwrap_or(f64::INFINITY);
            ra.total_cmp(&rb).then(a.cmp(&b))
        });
        let mut taken: Vec<NodeId> = Vec::new();
        for a in order {
            let running = match &self.slots[a].current {
                Current::Running { node, .. } => Some(*node),
                _ => None,
            };
            let mut best: Option<&Cand> = None;
            let mut best_score = f64::NEG_INFINITY;
            let mut wants_central = false;
            for c in cands
                .iter()
                .filter(|c| c.arm.is_none_or(|x| x == a) && !taken.contains(&c.node) && self.wm.get(c.node).is_some())
            {
                if c.central && self.central.is_some_and(|h| h != a) {
                    wants_central = true;
                    continue;
                }
                let score = if Some(c.node) == running { c.e * (1.0 + self.cfg.hysteresis) } else { c.e };
                if score > best_score {
                    best_score = score;
                    best = Some(c);
                }
            }
            if wants_central {
                self.slots[a].central_request_s.get_or_insert(now_s);
            } else {
                self.slots[a].central_request_s = None;
            }
            let choice = best.map(|c| (c.node, c.open, c.central));
            if let Some((node, _, _)) = choice {
                taken.push(node);
            }
            self.apply(a, choice, out);
        }
    }

    fn apply(&mut self, a: usize, choice: Option<(NodeId, bool, bool)>, out: &mut Vec<Decision>) {
        let arm = self.arm_name(a);
        match choice {
            Some((node, false, central)) => {
                if central {
                    // Granted (or kept) here; `decide` never offers a central action to an arm
                    // while another arm holds the area.
                    self.central = Some(a);
                    self.slots[a].central_request_s = None;
                }
                if let Current::Running { node: r, .. } = self.slots[a].current
                    && r == node
                {
                    return;
                }
                let Some(n) = self.wm.get(node) else { return };
                let kind = match n.kind {
                    NodeKind::Action(k) => k,
                    _ => return,
                };
                let label = n.label.clone();
                let releaser = n.releaser.to_string();
                let emphasis = n.emphasis;
                let subtask = n.parent.and_then(|p| self.wm.get(p)).map(|p| p.label.clone()).unwrap_or_default();
                for anc in self.wm.ancestors(node) {
                    if let Some(p) = self.wm.get_mut(anc) {
                        p.started = true;
                    }
                }
                self.wm.commit_groups(node);
                let id = self.next_id;
                self.next_id = self.next_id.wrapping_add(1).max(1);
                self.slots[a].current = Current::Running { node, label: label.clone() };
                out.push(Decision::Action { id, arm, label, kind, subtask, releaser, emphasis });
            }
            Some((node, true, _)) => {
                if self.slots[a].current == (Current::Waiting { node }) {
                    return;
                }
                if let Current::Running { label, .. } = &self.slots[a].current {
                    out.push(Decision::Stop { arm: arm.clone(), label: label.clone(), reason: "waiting for a demonstration".into() });
                }
                let subtask = self.wm.get(node).map(|n| n.label.clone()).unwrap_or_default();
                self.slots[a].current = Current::Waiting { node };
                out.push(Decision::AwaitDemonstration { arm, subtask });
            }
            None => {
                if let Current::Running { label, .. } = &self.slots[a].current {
                    out.push(Decision::Stop { arm, label: label.clone(), reason: "no enabled action".into() });
                }
                self.slots[a].current = Current::Idle;
            }
        }
    }

    /// The WM as data (field meanings as in `cowork_msgs/WmNode`).
    pub fn snapshot(&self) -> WmSnapshot {
        let order = self.wm.preorder();
        let index = |id: NodeId| order.iter().position(|&x| x == id).map_or(-1, |i| i as i32);
        let running: Vec<NodeId> = self
            .slots
            .iter()
            .filter_map(|s| match s.current {
                Current::Running { node, .. } => Some(node),
                _ => None,
            })
            .collect();
        let nodes = order
            .iter()
            .filter_map(|&id| self.wm.get(id))
            .map(|n| WmNodeView {
                id: n.id,
                parent: n.parent.map_or(-1, index),
                name: n.label.clone(),
                kind: n.kind,
                releaser: n.releaser.to_string(),
                releaser_value: n.releaser_value,
                postcondition: n.post.to_string(),
                concrete: matches!(n.kind, NodeKind::Action(_) | NodeKind::Subtask),
                emphasis: n.emphasis,
                magnitude: n.mu,
                period: n.lambda,
                done: n.accomplished,
                enabled: n.enabled,
                status: status(n),
                assigned_to: if n.human {
                    "human"
                } else if running.contains(&n.id) {
                    "robot"
                } else {
                    "none"
                },
                arm: n.arm.map(|a| self.state.arm_names()[a].clone()).unwrap_or_default(),
            })
            .collect();
        WmSnapshot { nodes, true_variables: self.state.true_vars().map(str::to_owned).collect() }
    }

    /// The WM as indented text.
    pub fn render_text(&self) -> String {
        self.wm.render_text(&self.state)
    }

    /// The WM in Graphviz DOT.
    pub fn render_dot(&self) -> String {
        self.wm.render_dot()
    }
}
