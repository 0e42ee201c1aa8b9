//! The working memory (`cowork_msgs/WorkingMemory`, a pre-order list with parent indices) as a
//! nested tree for the page `cowork bridge --wm-page` serves, with the reason of each decision
//! put into words: why a behaviour is enabled or not (the releaser literal that fails, the
//! ancestor that is not enabled), and for the concrete actions the winner-takes-all competition
//! of each arm (eq. 4.9): which action won and by how much.
//!
//! The reasons are derived from the message alone, as the supervisor's `attention::update` and
//! `decide` compute them. What the message does not carry is named as possibilities, not
//! guessed: whether an action's object is reachable (`accessible`), whether the shared central
//! area is held by the other arm, the hysteresis the running action keeps its arm with, and a
//! subtask's `started` latch (inferred when it is enabled while its releaser is false).

use std::collections::{BTreeMap, HashMap, VecDeque};

use cowork_msgs::msg::{WmNode, WorkingMemory};
use serde::Serialize;

/// Deepest nesting the tree keeps; a node below it (only a malformed message has one: the
/// supervisor expands at most `max_depth` = 16 levels) is shown at the top level with a
/// problem line, so neither the serialiser nor the page recurses without bound.
pub const MAX_NESTING: usize = 64;

/// The hysteresis the page names (the supervisor's default, `SupervisorConfig::hysteresis`);
/// the message does not say which one the running supervisor uses.
const DEFAULT_HYSTERESIS: f64 = 0.1;

/// One releaser literal and whether the true variables of the message satisfy it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Literal {
    /// As written in the releaser (`~water.added`).
    pub text: String,
    /// The literal holds in `true_variables`.
    pub holds: bool,
}

/// One behaviour of the tree, with its state and the reason for it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TreeNode {
    /// Index in `WorkingMemory::nodes`.
    pub index: usize,
    /// Stable WM id.
    pub id: u32,
    /// m: the behaviour, e.g. `foa1(water)`.
    pub name: String,
    /// `root`, `task` (abstract), `subtask` or `action`.
    pub kind: &'static str,
    /// `done`, `running`, `waiting` (an enabled action not selected), `enabled`, `person`,
    /// `blocked` or `disabled`.
    pub state: &'static str,
    /// Robot arm (`left`, `right`), empty for a single-arm robot.
    pub arm: String,
    /// e = μ/λ (1/s); null when not finite.
    pub emphasis: f64,
    /// μ.
    pub magnitude: f64,
    /// λ (s).
    pub period: f64,
    /// r as written (`true` when empty).
    pub releaser: String,
    /// r's value in the supervisor.
    pub releaser_value: bool,
    /// The literals of r, each evaluated against the message's true variables.
    pub literals: Vec<Literal>,
    /// p as written.
    pub postcondition: String,
    /// Why the node is in its state, in one or two sentences.
    pub reason: String,
    /// Rank of the action's emphasis among the enabled actions competing for its arm (1 =
    /// highest); absent for nodes that do not compete.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rank: Option<usize>,
    /// Sub-behaviours, in the message's order.
    pub children: Vec<TreeNode>,
}

/// What one arm is doing, for the page's header.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ArmSummary {
    /// Arm name; empty for a single-arm robot.
    pub arm: String,
    /// The running action, if any.
    pub running: Option<String>,
    /// Its emphasis (1/s).
    pub emphasis: Option<f64>,
    /// Enabled actions competing for the arm (the running one included).
    pub candidates: usize,
    /// The most emphasised behaviour of the arm that waits to be enabled (not accomplished,
    /// not enabled, its parent enabled): what the arm does next once its releaser holds.
    pub next: Option<String>,
    /// Why that behaviour is not enabled yet.
    pub next_reason: Option<String>,
}

/// The whole tree.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Tree {
    /// Header stamp of the message (s; sim time in a simulated graph).
    pub stamp_s: f64,
    /// Nodes in the message.
    pub count: usize,
    /// The top-level nodes: the root, and any node whose parent index is not usable.
    pub roots: Vec<TreeNode>,
    /// One entry per arm seen in the message.
    pub arms: Vec<ArmSummary>,
    /// The state variables that are true.
    pub true_variables: Vec<String>,
    /// What was wrong with the message (bad parent indices), one line each.
    pub problems: Vec<String>,
}

/// Decisions the log keeps (the newest).
pub const MAX_DECISIONS: usize = 200;

/// One change of a behaviour's state between two messages: an action selected or stopped, a
/// behaviour accomplished, assigned to the person, given up.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Decision {
    /// Stamp of the message that showed it (s).
    pub stamp_s: f64,
    /// The behaviour.
    pub name: String,
    /// Its arm; empty for a single-arm robot.
    pub arm: String,
    /// Its state before; empty when the bridge had not seen it (it joined late, or the node
    /// was just allocated).
    pub was: &'static str,
    /// Its state now.
    pub state: &'static str,
    /// Why, as [`TreeNode::reason`] says it in that message.
    pub reason: String,
}

/// The decisions of the supervisor as the stream of working memories shows them: kept by the
/// bridge, which sees every message, rather than by the page, which polls.
#[derive(Debug, Default)]
pub struct DecisionLog {
    /// State of each node (by WM id) in the previous message.
    last: HashMap<u32, &'static str>,
    last_stamp_s: Option<f64>,
    decisions: VecDeque<Decision>,
}

impl DecisionLog {
    /// Records what changed from the previous tree to `t`. A stamp that goes back (a new
    /// supervisor, a looped bag) starts over, since WM ids start over with it.
    pub fn observe(&mut self, t: &Tree) {
        if self.last_stamp_s.is_some_and(|s| t.stamp_s < s) {
            self.last.clear();
            self.decisions.clear();
            self.last_stamp_s = None;
        }
        let joined = self.last_stamp_s.is_none();
        let mut running: Vec<&TreeNode> = Vec::new();
        let mut stack: Vec<&TreeNode> = t.roots.iter().collect();
        while let Some(n) = stack.pop() {
            stack.extend(n.children.iter());
            if n.state == "running" {
                running.push(n);
            }
        }
        let mut now = HashMap::with_capacity(t.count);
        let mut stack: Vec<&TreeNode> = t.roots.iter().rev().collect();
        while let Some(n) = stack.pop() {
            stack.extend(n.children.iter().rev());
            now.insert(n.id, n.state);
            let was = self.last.get(&n.id).copied();
            let notable = matches!(n.state, "running" | "done" | "person" | "blocked");
            let changed = match was {
                Some(w) => w != n.state && (notable || w == "running"),
                // The bridge joined: what runs and who has what, not the accomplished past.
                None if joined => notable && n.state != "done",
                None => notable,
            };
            if changed {
                if self.decisions.len() == MAX_DECISIONS {
                    self.decisions.pop_front();
                }
                self.decisions.push_back(Decision {
                    stamp_s: t.stamp_s,
                    name: n.name.clone(),
                    arm: n.arm.clone(),
                    was: was.unwrap_or(""),
                    state: n.state,
                    reason: if was == Some("running") { stopped(n, &running) } else { n.reason.clone() },
                });
            }
        }
        self.last = now;
        self.last_stamp_s = Some(t.stamp_s);
    }

    /// The decisions kept, newest first.
    pub fn recent(&self) -> Vec<Decision> {
        self.decisions.iter().rev().cloned().collect()
    }
}

/// Why the running action `n` stopped. Replaced by a more emphasised one within the hysteresis
/// of its own, it was not outweighed (the running action keeps its arm): it could no longer be
/// granted, which the message does not say.
fn stopped(n: &TreeNode, running: &[&TreeNode]) -> String {
    let winner = running
        .iter()
        .filter(|w| w.id != n.id && (w.arm.is_empty() || n.arm.is_empty() || w.arm == n.arm))
        .max_by(|a, b| a.emphasis.total_cmp(&b.emphasis));
    match winner {
        Some(w) if n.state == "waiting" && w.emphasis <= n.emphasis * (1.0 + DEFAULT_HYSTERESIS) => format!(
            "stopped for {} although its e = {:.2} is within the hysteresis ({:.0} % by default) of {}'s {:.2}{}: {NOT_GRANTED}",
            quote(&w.name),
            n.emphasis,
            DEFAULT_HYSTERESIS * 100.0,
            quote(&w.name),
            w.emphasis,
            margin(n.emphasis, w.emphasis)
        ),
        _ => n.reason.clone(),
    }
}

/// A candidate of the winner-takes-all selection (an enabled, not accomplished action).
struct Candidate {
    index: usize,
    arm: String,
    emphasis: f64,
    running: bool,
}

fn is_running(n: &WmNode) -> bool {
    n.assigned_to == WmNode::ASSIGNED_ROBOT
}

fn quote(s: &str) -> String {
    format!("`{s}`")
}

/// Why `decide` may pass over an enabled action; the message says neither.
const NOT_GRANTED: &str = "its object may not be accessible (out of sight — a person may hold it — or in the other arm's area), or the shared central area is held by the other arm";

/// Why an action of emphasis `higher` did not take the arm from the running one of emphasis
/// `running`: the running action keeps its arm while the other's emphasis is within the
/// hysteresis of its own; beyond it, only what the message does not carry explains it.
/// `whose` names the action passed over (`its`, `this one's`).
fn passed_over(running: f64, higher: f64, whose: &str) -> String {
    let within = higher <= running * (1.0 + DEFAULT_HYSTERESIS);
    let not_granted = NOT_GRANTED.replacen("its object", &format!("{whose} object"), 1);
    if within {
        format!(
            "the running action keeps its arm unless beaten by more than the hysteresis ({:.0} % by default); or {not_granted}",
            DEFAULT_HYSTERESIS * 100.0
        )
    } else {
        not_granted
    }
}

/// `+12 %` / `−8 %`: how much `a` exceeds `b`, relative to `b`.
fn margin(a: f64, b: f64) -> String {
    if b.abs() < 1e-12 || !a.is_finite() || !b.is_finite() {
        return String::new();
    }
    let p = (a - b) / b * 100.0;
    if p >= 0.0 { format!(" (+{p:.0} %)") } else { format!(" (−{:.0} %)", -p) }
}

fn on_arm(arm: &str) -> String {
    if arm.is_empty() { "the arm".to_owned() } else { format!("arm {arm}") }
}

/// Splits a releaser (`hand.free & ~water.added`, `true`) into literals evaluated against the
/// true variables.
fn literals(releaser: &str, true_vars: &[String]) -> Vec<Literal> {
    releaser
        .split('&')
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "true")
        .map(|text| {
            let (negated, key) = text.strip_prefix('~').map_or((false, text), |k| (true, k.trim()));
            let set = true_vars.iter().any(|v| v == key);
            Literal { text: text.to_owned(), holds: set != negated }
        })
        .collect()
}

/// Why the releaser is false, naming the literals that fail, or the releaser when the message's
/// variables do not explain its value.
fn failing_releaser(n: &WmNode, lits: &[Literal]) -> String {
    let failing: Vec<String> = lits
        .iter()
        .filter(|l| !l.holds)
        .map(|l| match l.text.strip_prefix('~') {
            Some(k) => format!("{} fails ({} is true)", quote(&l.text), quote(k.trim())),
            None => format!("{} is false", quote(&l.text)),
        })
        .collect();
    if failing.is_empty() {
        format!("releaser {} is false", quote(&n.releaser))
    } else {
        format!("waits for its releaser: {}", failing.join(", "))
    }
}

/// The kind of node `i`: actions are concrete nodes under a concrete subtask.
fn kind(nodes: &[WmNode], i: usize, parent: Option<usize>) -> &'static str {
    let n = &nodes[i];
    if parent.is_none() && n.parent < 0 && i == 0 {
        "root"
    } else if !n.concrete {
        "task"
    } else if parent.is_some_and(|p| nodes[p].concrete) {
        "action"
    } else {
        "subtask"
    }
}

/// Converts a `WorkingMemory` into the nested tree, never panicking on a malformed message: a
/// parent index that is out of range, not before the node (the list is in pre-order) or would
/// nest deeper than [`MAX_NESTING`] puts the node at the top level, with a line in `problems`.
///
/// Cost: O(n log n) in the number of nodes, no recursion.
pub fn tree(wm: &WorkingMemory) -> Tree {
    let nodes = &wm.nodes;
    let count = nodes.len();
    let mut problems = Vec::new();

    // Valid parents: before the node (pre-order), so the tree is acyclic by construction.
    let mut parent: Vec<Option<usize>> = Vec::with_capacity(count);
    let mut depth: Vec<usize> = Vec::with_capacity(count);
    for (i, n) in nodes.iter().enumerate() {
        let p = match usize::try_from(n.parent) {
            Err(_) if n.parent == -1 => {
                if i != 0 {
                    problems.push(format!("node {i} ({}) has no parent (-1) but is not the first; shown at the top", n.name));
                }
                None
            }
            Err(_) => {
                problems.push(format!("node {i} ({}): parent index {} is negative; shown at the top", n.name, n.parent));
                None
            }
            Ok(p) if p >= i => {
                let what = if p >= count { format!("is out of range (the message has {count} nodes)") } else { "does not precede it (the list is in pre-order)".into() };
                problems.push(format!("node {i} ({}): parent index {p} {what}; shown at the top", n.name));
                None
            }
            Ok(p) if depth[p] + 1 > MAX_NESTING => {
                problems.push(format!("node {i} ({}) is nested deeper than {MAX_NESTING} levels; shown at the top", n.name));
                None
            }
            Ok(p) => Some(p),
        };
        depth.push(p.map_or(0, |p| depth[p] + 1));
        parent.push(p);
    }
    let mut has_children = vec![false; count];
    for p in parent.iter().flatten() {
        has_children[*p] = true;
    }

    // Winner-takes-all per arm (eq. 4.9): enabled, not accomplished actions (and open subtasks,
    // which ask for a demonstration when selected), not the person's.
    let candidates: Vec<Candidate> = (0..count)
        .filter(|&i| {
            let n = &nodes[i];
            n.enabled && !n.done && n.concrete && !has_children[i] && n.assigned_to != WmNode::ASSIGNED_HUMAN
        })
        .map(|i| Candidate { index: i, arm: nodes[i].arm.clone(), emphasis: nodes[i].emphasis, running: is_running(&nodes[i]) })
        .collect();
    let competes = |a: &str, b: &str| a.is_empty() || b.is_empty() || a == b;

    let mut built: Vec<Option<TreeNode>> = Vec::with_capacity(count);
    for (i, n) in nodes.iter().enumerate() {
        let lits = literals(&n.releaser, &wm.true_variables);
        let k = kind(nodes, i, parent[i]);
        let rivals: Vec<&Candidate> = candidates.iter().filter(|c| competes(&c.arm, &n.arm)).collect();
        let me = candidates.iter().find(|c| c.index == i);
        let rank = me.map(|m| 1 + rivals.iter().filter(|c| c.index != i && c.emphasis > m.emphasis).count());
        let (state, reason) = state_and_reason(nodes, i, parent[i], k, &lits, me, &rivals);
        built.push(Some(TreeNode {
            index: i,
            id: n.id,
            name: n.name.clone(),
            kind: k,
            state,
            arm: n.arm.clone(),
            emphasis: n.emphasis,
            magnitude: n.magnitude,
            period: n.period,
            releaser: if n.releaser.is_empty() { "true".into() } else { n.releaser.clone() },
            releaser_value: n.releaser_value,
            literals: lits,
            postcondition: n.postcondition.clone(),
            reason,
            rank,
            children: Vec::new(),
        }));
    }
    let mut arms: BTreeMap<String, ArmSummary> = BTreeMap::new();
    for n in nodes.iter().filter(|n| n.concrete) {
        arms.entry(n.arm.clone()).or_insert_with(|| ArmSummary { arm: n.arm.clone(), running: None, emphasis: None, candidates: 0, next: None, next_reason: None });
    }
    for (arm, s) in &mut arms {
        s.candidates = candidates.iter().filter(|c| competes(&c.arm, arm)).count();
        if let Some(c) = candidates.iter().filter(|c| c.running && c.arm == *arm).max_by(|a, b| a.emphasis.total_cmp(&b.emphasis)) {
            s.running = Some(nodes[c.index].name.clone());
            s.emphasis = Some(c.emphasis);
        }
        let waiting = (0..count)
            .filter(|&i| {
                let n = &nodes[i];
                n.arm == *arm
                    && !n.done
                    && !n.enabled
                    && n.assigned_to != WmNode::ASSIGNED_HUMAN
                    && parent[i].is_none_or(|p| nodes[p].enabled)
            })
            .max_by(|&a, &b| nodes[a].emphasis.total_cmp(&nodes[b].emphasis));
        if let Some(i) = waiting
            && let Some(n) = built[i].as_ref()
        {
            s.next = Some(n.name.clone());
            s.next_reason = Some(n.reason.clone());
        }
    }

    // Children come after their parent, so taking nodes from the back completes every child
    // before it is moved into its parent (pushed in reverse, turned round once complete).
    let mut roots = Vec::new();
    for i in (0..count).rev() {
        let Some(mut node) = built[i].take() else { continue };
        node.children.reverse();
        match parent[i].and_then(|p| built[p].as_mut()) {
            Some(p) => p.children.push(node),
            None => roots.push(node),
        }
    }
    roots.reverse();
    Tree {
        stamp_s: f64::from(wm.header.stamp.sec) + f64::from(wm.header.stamp.nanosec) * 1e-9,
        count,
        roots,
        arms: arms.into_values().collect(),
        true_variables: wm.true_variables.clone(),
        problems,
    }
}

/// The state of node `i` and why, as `attention::update` (enabling) and `decide`
/// (winner-takes-all with hysteresis, accessibility and the central area) set it.
fn state_and_reason(
    nodes: &[WmNode],
    i: usize,
    parent: Option<usize>,
    kind: &str,
    lits: &[Literal],
    me: Option<&Candidate>,
    rivals: &[&Candidate],
) -> (&'static str, String) {
    let n = &nodes[i];
    if kind == "root" {
        return ("enabled", "the alive process: keeps the tree, retrieving schemas and freeing accomplished behaviours".into());
    }
    if n.done {
        return ("done", format!("accomplished: post-condition {} holds", quote(&n.postcondition)));
    }
    if n.assigned_to == WmNode::ASSIGNED_HUMAN {
        return ("person", "assigned to the person (`human …`): the robot leaves it and everything below it".into());
    }
    if !n.enabled {
        if let Some(p) = parent.map(|p| &nodes[p])
            && !p.enabled
        {
            let why = if p.assigned_to == WmNode::ASSIGNED_HUMAN { " (the person's)" } else { "" };
            return ("disabled", format!("its parent {} is not enabled{why}", quote(&p.name)));
        }
        if !n.releaser_value {
            return ("disabled", failing_releaser(n, lits));
        }
        return ("blocked", format!("releaser {} holds but it is not enabled: given up after repeated failures (left to the person)", quote(&n.releaser)));
    }
    let Some(me) = me else {
        let why = if n.releaser.is_empty() || n.releaser == "true" {
            "no releaser, and its parent is enabled".to_owned()
        } else if n.releaser_value {
            format!("releaser {} holds", quote(&n.releaser))
        } else {
            format!("started, so it stays enabled although its releaser {} is false now", quote(&n.releaser))
        };
        return ("enabled", why);
    };
    let others: Vec<&&Candidate> = rivals.iter().filter(|c| c.index != i).collect();
    let best_other = others.iter().max_by(|a, b| a.emphasis.total_cmp(&b.emphasis));
    let name = |c: &Candidate| quote(&nodes[c.index].name);
    if me.running {
        let arm = on_arm(&n.arm);
        let reason = match best_other {
            None => format!("selected for {arm}: the only enabled action for it (e = {:.2})", me.emphasis),
            Some(o) if o.emphasis <= me.emphasis => format!(
                "selected for {arm}: the highest e = {:.2} of {} enabled actions; next {} e = {:.2}{}",
                me.emphasis,
                others.len() + 1,
                name(o),
                o.emphasis,
                margin(me.emphasis, o.emphasis)
            ),
            Some(o) => format!(
                "selected for {arm} (e = {:.2}) although {} has a higher e = {:.2}{}: {}",
                me.emphasis,
                name(o),
                o.emphasis,
                margin(o.emphasis, me.emphasis),
                passed_over(me.emphasis, o.emphasis, "its")
            ),
        };
        return ("running", reason);
    }
    let open = kind == "subtask";
    let winner = others.iter().filter(|c| c.running).max_by(|a, b| a.emphasis.total_cmp(&b.emphasis));
    let reason = match winner {
        Some(w) if w.emphasis > me.emphasis => format!(
            "lost to {} on {}: e = {:.2} vs {:.2}{}",
            name(w),
            on_arm(&nodes[w.index].arm),
            me.emphasis,
            w.emphasis,
            margin(me.emphasis, w.emphasis)
        ),
        Some(w) => format!(
            "e = {:.2} ≥ {:.2} of the running {}{}, which keeps {}: {}",
            me.emphasis,
            w.emphasis,
            name(w),
            margin(me.emphasis, w.emphasis),
            on_arm(&nodes[w.index].arm),
            passed_over(w.emphasis, me.emphasis, "this one's")
        ),
        None if open => format!(
            "open subtask (no actions learned yet): when selected for {}, the robot asks for a demonstration",
            on_arm(&n.arm)
        ),
        None => format!(
            "enabled, e = {:.2}, but nothing runs on {}: {NOT_GRANTED}, or the supervisor is teaching, stopped or awaiting a demonstration",
            me.emphasis,
            on_arm(&n.arm)
        ),
    };
    ("waiting", reason)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node(parent: i32, name: &str, concrete: bool) -> WmNode {
        WmNode {
            id: 0,
            parent,
            name: name.into(),
            releaser: "true".into(),
            releaser_value: true,
            postcondition: format!("{name}.done"),
            concrete,
            emphasis: 1.0,
            magnitude: 1.0,
            period: 1.0,
            done: false,
            enabled: true,
            assigned_to: WmNode::ASSIGNED_NONE,
            arm: String::new(),
        }
    }

    fn names(t: &[TreeNode]) -> Vec<String> {
        t.iter().map(|n| n.name.clone()).collect()
    }

    fn find<'a>(t: &'a [TreeNode], name: &str) -> &'a TreeNode {
        let mut stack: Vec<&TreeNode> = t.iter().collect();
        while let Some(n) = stack.pop() {
            if n.name == name {
                return n;
            }
            stack.extend(n.children.iter());
        }
        panic!("no node {name}")
    }

    /// The coffee task in the middle of add(water): the bottle taken, the pour running.
    fn coffee() -> WorkingMemory {
        let mut nodes = vec![
            node(-1, "alive", false),
            node(0, "prepareCoffee", false),
            node(1, "add(water)", false),
            node(2, "subtask(take,water)", true),
            node(3, "foa1(water)", true),
            node(2, "subtask(pour,water)", true),
            node(5, "foa2(water)", true),
            node(5, "noa3(water)", true),
            node(1, "add(coffee)", false),
            node(8, "subtask(take,coffee)", true),
            node(9, "foa9(coffee)", true),
        ];
        nodes[3].done = true;
        nodes[3].postcondition = "water.taken".into();
        nodes[4].done = true;
        nodes[5].releaser = "water.taken".into();
        nodes[6].emphasis = 4.0;
        nodes[6].assigned_to = WmNode::ASSIGNED_ROBOT;
        nodes[7].releaser = "foa2.done".into();
        nodes[7].releaser_value = false;
        nodes[7].enabled = false;
        nodes[8].releaser = "hand.free & ~water.added".into();
        nodes[8].releaser_value = false;
        nodes[8].enabled = false;
        nodes[9].enabled = false;
        nodes[10].enabled = false;
        for (i, n) in nodes.iter_mut().enumerate() {
            n.id = 100 + i as u32;
        }
        WorkingMemory { nodes, true_variables: vec!["water.taken".into()], ..WorkingMemory::default() }
    }

    #[test]
    fn parent_indices_become_a_nested_tree_in_message_order() {
        let t = tree(&coffee());
        assert_eq!(t.count, 11);
        assert!(t.problems.is_empty(), "{:?}", t.problems);
        assert_eq!(names(&t.roots), ["alive"]);
        let task = &t.roots[0].children[0];
        assert_eq!(task.name, "prepareCoffee");
        assert_eq!(names(&task.children), ["add(water)", "add(coffee)"]);
        assert_eq!(names(&task.children[0].children), ["subtask(take,water)", "subtask(pour,water)"]);
        assert_eq!(names(&task.children[0].children[1].children), ["foa2(water)", "noa3(water)"]);
        let kinds: Vec<_> = [&t.roots[0], task, &task.children[0].children[1], &task.children[0].children[1].children[0]]
            .iter()
            .map(|n| n.kind)
            .collect();
        assert_eq!(kinds, ["root", "task", "subtask", "action"]);
    }

    #[test]
    fn each_state_comes_with_its_reason() {
        let t = tree(&coffee());
        let n = find(&t.roots, "subtask(take,water)");
        assert_eq!(n.state, "done");
        assert!(n.reason.contains("`water.taken` holds"), "{}", n.reason);
        let n = find(&t.roots, "foa2(water)");
        assert_eq!(n.state, "running");
        assert!(n.reason.contains("the only enabled action"), "{}", n.reason);
        let n = find(&t.roots, "noa3(water)");
        assert_eq!(n.state, "disabled");
        assert!(n.reason.contains("`foa2.done` is false"), "{}", n.reason);
        let n = find(&t.roots, "add(coffee)");
        assert_eq!(n.state, "disabled");
        assert_eq!(n.literals, [Literal { text: "hand.free".into(), holds: false }, Literal { text: "~water.added".into(), holds: true }]);
        assert_eq!(n.reason, "waits for its releaser: `hand.free` is false");
        let n = find(&t.roots, "foa9(coffee)");
        assert!(n.reason.contains("parent `subtask(take,coffee)` is not enabled"), "{}", n.reason);
        assert_eq!(t.arms.len(), 1);
        assert_eq!(t.arms[0].running.as_deref(), Some("foa2(water)"));
        // What waits to be enabled below an enabled parent: noa3 (after foa2) and add(coffee).
        assert!(matches!(t.arms[0].next.as_deref(), Some("noa3(water)" | "add(coffee)")), "{:?}", t.arms[0]);
        assert!(t.arms[0].next_reason.as_deref().is_some_and(|r| r.starts_with("waits for its releaser")));
    }

    #[test]
    fn the_competition_of_each_arm_names_the_winner_and_the_margin() {
        let mut nodes = vec![node(-1, "alive", false), node(0, "makePizza", false)];
        for (name, arm, e, running) in [
            ("subtask(take,tomato)", "left", 0.0, false),
            ("foa1(tomato)", "left", 4.0, true),
            ("subtask(take,cheese)", "left", 0.0, false),
            ("foa5(cheese)", "left", 3.0, false),
            ("subtask(take,olive)", "right", 0.0, false),
            ("foa7(olive)", "right", 2.0, false),
        ] {
            let parent = if name.starts_with("subtask") { 1 } else { nodes.len() as i32 - 1 };
            let mut n = node(parent, name, true);
            n.arm = arm.into();
            n.emphasis = e;
            n.assigned_to = if running { WmNode::ASSIGNED_ROBOT } else { WmNode::ASSIGNED_NONE };
            nodes.push(n);
        }
        let t = tree(&WorkingMemory { nodes, ..WorkingMemory::default() });
        let run = find(&t.roots, "foa1(tomato)");
        assert_eq!((run.state, run.rank), ("running", Some(1)));
        assert!(run.reason.contains("arm left") && run.reason.contains("next `foa5(cheese)` e = 3.00 (+33 %)"), "{}", run.reason);
        let lost = find(&t.roots, "foa5(cheese)");
        assert_eq!((lost.state, lost.rank), ("waiting", Some(2)));
        assert!(lost.reason.contains("lost to `foa1(tomato)` on arm left: e = 3.00 vs 4.00 (−25 %)"), "{}", lost.reason);
        let idle = find(&t.roots, "foa7(olive)");
        assert_eq!((idle.state, idle.rank), ("waiting", Some(1)));
        assert!(idle.reason.contains("nothing runs on arm right"), "{}", idle.reason);
        let arms: Vec<_> = t.arms.iter().map(|a| (a.arm.as_str(), a.running.as_deref(), a.candidates)).collect();
        assert_eq!(arms, [("left", Some("foa1(tomato)"), 2), ("right", None, 1)]);
        assert!(t.arms.iter().all(|a| a.next.is_none()), "nothing waits to be enabled");
    }

    #[test]
    fn the_decision_log_records_selections_stops_and_accomplishments() {
        let mut log = DecisionLog::default();
        let mut wm = coffee();
        wm.header.stamp.sec = 10;
        log.observe(&tree(&wm));
        // Joining: what runs now, not what was accomplished before.
        let d = log.recent();
        assert_eq!(d.len(), 1, "{d:?}");
        assert_eq!((d[0].name.as_str(), d[0].was, d[0].state), ("foa2(water)", "", "running"));
        // foa2 done, noa3 enabled and selected.
        wm.header.stamp.sec = 11;
        wm.nodes[6].done = true;
        wm.nodes[6].assigned_to = WmNode::ASSIGNED_NONE;
        wm.nodes[7].releaser_value = true;
        wm.nodes[7].enabled = true;
        wm.nodes[7].assigned_to = WmNode::ASSIGNED_ROBOT;
        wm.true_variables.push("foa2.done".into());
        log.observe(&tree(&wm));
        let d = log.recent();
        let got: Vec<_> = d.iter().map(|d| (d.stamp_s, d.name.as_str(), d.was, d.state)).collect();
        assert_eq!(got, [(11.0, "noa3(water)", "disabled", "running"), (11.0, "foa2(water)", "running", "done"), (10.0, "foa2(water)", "", "running")]);
        assert!(d[0].reason.starts_with("selected for the arm: the only enabled action"), "{}", d[0].reason);
        // Unchanged: nothing new.
        log.observe(&tree(&wm));
        assert_eq!(log.recent().len(), 3);
        // noa3 stopped for a new action only 5 % more emphasised: not outweighed (hysteresis).
        wm.header.stamp.sec = 12;
        wm.nodes[7].assigned_to = WmNode::ASSIGNED_NONE;
        let mut other = wm.nodes[7].clone();
        (other.id, other.name, other.parent, other.emphasis, other.assigned_to) = (999, "foa9(coffee)".into(), 5, 1.05, WmNode::ASSIGNED_ROBOT);
        wm.nodes.push(other);
        log.observe(&tree(&wm));
        let d = log.recent();
        assert_eq!((d[0].name.as_str(), d[0].state, d[1].name.as_str(), d[1].was, d[1].state), ("foa9(coffee)", "running", "noa3(water)", "running", "waiting"));
        assert!(d[1].reason.starts_with("stopped for `foa9(coffee)` although its e = 1.00 is within the hysteresis"), "{}", d[1].reason);
        assert!(d[1].reason.contains("not be accessible"), "{}", d[1].reason);
        wm.nodes.pop();
        wm.nodes[7].assigned_to = WmNode::ASSIGNED_ROBOT;
        wm.header.stamp.sec = 13;
        log.observe(&tree(&wm));
        assert_eq!(log.recent().len(), 6, "noa3 selected again; foa9 gone without a word");
        // A stamp back in time: a new supervisor, the log starts over.
        wm.header.stamp.sec = 1;
        log.observe(&tree(&wm));
        assert_eq!(log.recent().len(), 1);
    }

    #[test]
    fn hysteresis_is_named_only_where_it_can_explain_the_choice() {
        let near = passed_over(4.0, 4.2, "its");
        assert!(near.contains("hysteresis") && near.contains("its object may not be accessible"), "{near}");
        let far = passed_over(2.76, 5.83, "this one's");
        assert!(!far.contains("hysteresis") && far.starts_with("this one's object may not be accessible"), "{far}");
    }

    #[test]
    fn bad_parent_indices_go_to_the_top_without_panicking() {
        let nodes = vec![
            node(-1, "alive", false),
            node(0, "task", false),
            node(99, "orphan", true),
            node(3, "self", true),
            node(-7, "negative", true),
            node(-1, "second root", false),
            node(4, "under negative", true),
        ];
        let t = tree(&WorkingMemory { nodes, ..WorkingMemory::default() });
        assert_eq!(t.count, 7);
        assert_eq!(names(&t.roots), ["alive", "orphan", "self", "negative", "second root"]);
        assert_eq!(names(&t.roots[3].children), ["under negative"]);
        assert_eq!(t.problems.len(), 4, "{:?}", t.problems);
        assert!(t.problems[0].contains("parent index 99 is out of range"), "{:?}", t.problems);
        assert!(t.problems[1].contains("does not precede it"), "{:?}", t.problems);
        assert!(tree(&WorkingMemory::default()).roots.is_empty());
    }

    #[test]
    fn a_chain_deeper_than_the_nesting_limit_is_cut_not_recursed() {
        let mut nodes = vec![node(-1, "alive", false)];
        for i in 1..10_000 {
            nodes.push(node(i - 1, &format!("n{i}"), false));
        }
        let t = tree(&WorkingMemory { nodes, ..WorkingMemory::default() });
        assert_eq!(t.count, 10_000);
        let mut depth = 0;
        let mut cur = &t.roots[0];
        while let Some(c) = cur.children.first() {
            depth += 1;
            cur = c;
        }
        assert_eq!(depth, MAX_NESTING);
        assert!(!t.problems.is_empty());
        assert!(serde_json::to_string(&t).is_ok());
    }
}
