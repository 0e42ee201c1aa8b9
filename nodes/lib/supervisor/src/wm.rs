//! Working memory (thesis Sec. 4.3.2, Fig. 4.12, 5.16): a rooted tree of behaviours
//! (m, r, p, x, e, μ) kept by the `alive` process, which retrieves schemas from the LTM,
//! expands and instantiates them with variable bindings, marks behaviours accomplished when
//! their post-condition holds and deallocates accomplished subtrees.

use std::fmt::Write as _;

use serde::Serialize;

use crate::ltm::{Bindings, Ltm, SchemaId, done_cond, substitute, substitute_cond};
use crate::schema::{ActionKind, Arg, Term};
use crate::state::{GroundCond, State};

/// Id of a WM node; ids are never reused while the WM lives.
pub type NodeId = u32;

/// What a node stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum NodeKind {
    /// The `alive` process.
    Root,
    /// A (concrete or abstract) task decomposed into further tasks or subtasks.
    Abstract,
    /// A subtask: its children are atomic actions (none while open).
    Subtask,
    /// A learned atomic action.
    Action(ActionKind),
}

/// One behaviour B = (m, r, p, x, e, μ) and its bookkeeping.
#[derive(Debug, Clone)]
pub struct Node {
    /// Stable id.
    pub id: NodeId,
    /// Parent (None for the root).
    pub parent: Option<NodeId>,
    /// m: instantiated behaviour.
    pub term: Term,
    /// m printed.
    pub label: String,
    /// r: releaser.
    pub releaser: GroundCond,
    /// p: post-condition.
    pub post: GroundCond,
    /// x: sub-behaviours.
    pub children: Vec<NodeId>,
    /// Kind.
    pub kind: NodeKind,
    /// LTM schema that expands it (None for the root).
    pub schema: Option<SchemaId>,
    /// Children allocated.
    pub expanded: bool,
    /// Arm index (dual-arm), inherited from the parent unless the term names an arm.
    pub arm: Option<usize>,
    /// Target object whose distance drives λ (a subtask's object; actions use their subtask's).
    pub object: Option<String>,
    /// The action's own object (decides the shared-area resource).
    pub action_object: Option<String>,
    /// Depth (root 0).
    pub depth: usize,
    /// μ: magnitude.
    pub mu: f64,
    /// λ: activation period (s).
    pub lambda: f64,
    /// e = μ/λ (1/s).
    pub emphasis: f64,
    /// Accomplished sub-behaviours.
    pub n_done: u32,
    /// Post-condition reached (latched).
    pub accomplished: bool,
    /// An action below it has been commanded (or, teaching, attached).
    pub started: bool,
    /// Assigned to the person (`human <subtask>`).
    pub human: bool,
    /// Given up after repeated failures.
    pub blocked: bool,
    /// Releaser value at the last update.
    pub releaser_value: bool,
    /// Enabled at the last update.
    pub enabled: bool,
    /// Target object accessible at the last update.
    pub accessible: bool,
    /// Conflict group: instances of one entry over the arms (Sec. 4.3.4).
    pub group: Option<u32>,
    /// Received actions in the current teaching session.
    pub taught: bool,
    /// Failures of this action.
    pub failures: u32,
}

impl Node {
    /// True for an open subtask: concrete, but with no actions to execute.
    pub fn is_open(&self) -> bool {
        self.kind == NodeKind::Subtask && self.children.is_empty()
    }
}

/// The working memory tree.
#[derive(Debug, Clone)]
pub struct Wm {
    nodes: Vec<Option<Node>>,
    root: NodeId,
    task: NodeId,
    next_group: u32,
}

/// Things `alive` did, for the decision log.
#[derive(Debug, Default)]
pub struct AliveReport {
    /// Behaviours accomplished in this pass, in order.
    pub accomplished: Vec<String>,
}

impl Wm {
    /// A WM whose root (`alive`) holds the task behaviour. `task` must be ground.
    pub fn new(task: &Term, ltm: &Ltm, state: &mut State) -> Self {
        let mut wm = Self { nodes: Vec::new(), root: 0, task: 0, next_group: 0 };
        let root = wm.push(Node::blank(0, None, Term::atom("alive"), NodeKind::Root, 0));
        wm.root = root;
        let t = wm.alloc_child(root, task.clone(), GroundCond::default(), None, ltm, state);
        wm.task = t;
        wm
    }

    /// Root id.
    pub fn root(&self) -> NodeId {
        self.root
    }

    /// Task node id.
    pub fn task(&self) -> NodeId {
        self.task
    }

    /// Node by id, if allocated.
    pub fn get(&self, id: NodeId) -> Option<&Node> {
        self.nodes.get(id as usize).and_then(Option::as_ref)
    }

    /// Mutable node by id.
    pub fn get_mut(&mut self, id: NodeId) -> Option<&mut Node> {
        self.nodes.get_mut(id as usize).and_then(Option::as_mut)
    }

    /// Allocated nodes in pre-order.
    pub fn preorder(&self) -> Vec<NodeId> {
        let mut out = Vec::with_capacity(self.nodes.len());
        let mut stack = vec![self.root];
        while let Some(id) = stack.pop() {
            if let Some(n) = self.get(id) {
                out.push(id);
                stack.extend(n.children.iter().rev());
            }
        }
        out
    }

    /// Allocated nodes (any order).
    pub fn iter(&self) -> impl Iterator<Item = &Node> {
        self.nodes.iter().flatten()
    }

    /// Ancestors of `id`, nearest first (excluding `id`).
    pub fn ancestors(&self, id: NodeId) -> Vec<NodeId> {
        let mut out = Vec::new();
        let mut cur = self.get(id).and_then(|n| n.parent);
        while let Some(p) = cur {
            out.push(p);
            cur = self.get(p).and_then(|n| n.parent);
        }
        out
    }

    fn push(&mut self, mut n: Node) -> NodeId {
        let id = self.nodes.len() as NodeId;
        n.id = id;
        self.nodes.push(Some(n));
        id
    }

    /// Allocates a child behaviour, retrieving its schema (without expanding it).
    pub fn alloc_child(
        &mut self,
        parent: NodeId,
        term: Term,
        releaser: GroundCond,
        group: Option<u32>,
        ltm: &Ltm,
        state: &mut State,
    ) -> NodeId {
        let (pdepth, parm, pobj) = match self.get(parent) {
            Some(p) => (p.depth, p.arm, p.object.clone()),
            None => (0, None, None),
        };
        let retrieved = ltm.retrieve(&term);
        let (kind, schema, post) = match &retrieved {
            Some((sid, b)) => {
                let s = ltm.schema(*sid);
                let kind = match s.kind {
                    Some(k) => NodeKind::Action(k),
                    None if s.list.is_empty() => NodeKind::Subtask,
                    None if s.list.iter().all(|e| is_action(ltm, &substitute(&e.term, b))) => NodeKind::Subtask,
                    None => NodeKind::Abstract,
                };
                let post = substitute_cond(&s.post, b).unwrap_or_default();
                (kind, Some(*sid), GroundCond::new(post))
            }
            None => (NodeKind::Subtask, None, GroundCond::new(done_cond(&term.functor))),
        };
        let arm = term.constant_args().find_map(|c| state.arm_index(c).filter(|_| state.is_dual())).or(parm);
        let own_obj = term
            .constant_args()
            .filter(|c| state.arm_index(c).is_none() || !state.is_dual())
            .filter(|c| ltm.is_object(c))
            .last()
            .map(str::to_owned);
        let (object, action_object) = match kind {
            NodeKind::Action(_) => (pobj, own_obj),
            _ => (own_obj.or(pobj), None),
        };
        if let NodeKind::Action(_) = kind {
            // A fresh instance: its `done` from an earlier execution must not leak in.
            for (_, k) in &post.keys {
                state.set(k, false);
            }
        }
        let mut n = Node::blank(0, Some(parent), term, kind, pdepth + 1);
        n.releaser = releaser;
        n.post = post;
        n.schema = schema;
        n.arm = arm;
        n.object = object;
        n.action_object = action_object;
        n.group = group;
        let id = self.push(n);
        if let Some(p) = self.get_mut(parent) {
            p.children.push(id);
        }
        id
    }

    /// Expands one node from its schema: instantiates every entry with the head bindings;
    /// variables left free (arm variables, Sec. 4.3.4) are enumerated over the arms and the
    /// resulting instances form one conflict group.
    fn expand(&mut self, id: NodeId, ltm: &Ltm, state: &mut State, max_depth: usize) {
        let Some(n) = self.get_mut(id) else { return };
        n.expanded = true;
        if matches!(n.kind, NodeKind::Action(_)) || n.depth >= max_depth {
            return;
        }
        let term = n.term.clone();
        let Some((sid, b)) = ltm.retrieve(&term) else { return };
        if let Some(n) = self.get_mut(id) {
            n.schema = Some(sid);
        }
        let schema = ltm.schema(sid).clone();
        for e in &schema.list {
            let t = substitute(&e.term, &b);
            let mut free = Vec::new();
            t.collect_vars(&mut free);
            let free: Vec<String> = free.into_iter().map(str::to_owned).collect();
            if free.is_empty() {
                let r = GroundCond::new(substitute_cond(&e.releaser, &b).unwrap_or_default());
                self.alloc_child(id, t, r, None, ltm, state);
                continue;
            }
            let group = self.next_group;
            self.next_group += 1;
            for combo in arm_combinations(free.len(), state.arm_names()) {
                let mut b2: Bindings = b.clone();
                for (v, a) in free.iter().zip(&combo) {
                    b2.push((v.clone(), Term::atom(a.clone())));
                }
                let t2 = substitute(&e.term, &b2);
                let r = GroundCond::new(substitute_cond(&e.releaser, &b2).unwrap_or_default());
                self.alloc_child(id, t2, r, Some(group), ltm, state);
            }
        }
    }

    /// Removes the subtree below `id` (the node itself stays).
    pub fn dealloc_children(&mut self, id: NodeId) {
        let children = match self.get_mut(id) {
            Some(n) => std::mem::take(&mut n.children),
            None => return,
        };
        for c in children {
            self.remove_subtree(c);
        }
    }

    /// Removes `id` and its subtree, unlinking it from its parent.
    pub fn remove_subtree(&mut self, id: NodeId) {
        if let Some(p) = self.get(id).and_then(|n| n.parent)
            && let Some(pn) = self.get_mut(p)
        {
            pn.children.retain(|&c| c != id);
        }
        let mut stack = vec![id];
        while let Some(x) = stack.pop() {
            if let Some(n) = self.nodes.get_mut(x as usize).and_then(Option::take) {
                stack.extend(n.children);
            }
        }
    }

    /// Marks a node accomplished: parent's n += 1, subtree deallocated.
    fn accomplish(&mut self, id: NodeId, report: &mut AliveReport) {
        let Some(n) = self.get_mut(id) else { return };
        if n.accomplished {
            return;
        }
        n.accomplished = true;
        let parent = n.parent;
        report.accomplished.push(n.label.clone());
        if let Some(p) = parent.and_then(|p| self.get_mut(p)) {
            p.n_done += 1;
        }
        self.dealloc_children(id);
    }

    /// The `alive` process: expands unexpanded behaviours, marks behaviours whose
    /// post-condition holds as accomplished (asserting the post-condition of a node whose
    /// children are all accomplished), and deallocates accomplished subtrees; repeats until
    /// nothing changes. `teaching` suspends completion-by-children of subtasks being taught.
    pub fn alive(&mut self, ltm: &Ltm, state: &mut State, max_depth: usize, teaching: bool) -> AliveReport {
        let mut report = AliveReport::default();
        for _ in 0..(4 * max_depth + 8) {
            let mut changed = false;
            for id in self.preorder() {
                let Some(n) = self.get(id) else { continue };
                if n.accomplished || n.kind == NodeKind::Root {
                    continue;
                }
                if !n.post.is_true() && state.eval(&n.post) {
                    self.accomplish(id, &mut report);
                    changed = true;
                    continue;
                }
                if !n.expanded && !matches!(n.kind, NodeKind::Action(_)) {
                    self.expand(id, ltm, state, max_depth);
                    changed = true;
                    continue;
                }
                let all_done = !n.children.is_empty()
                    && n.children.iter().all(|c| self.get(*c).is_some_and(|c| c.accomplished));
                if all_done && !(teaching && n.taught) {
                    let post = n.post.clone();
                    state.assert_cond(&post);
                    self.accomplish(id, &mut report);
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        report
    }

    /// Removes the other instances of every conflict group that `id` or an ancestor belongs
    /// to: once one arm has started a task, the other arm's instance is dropped.
    pub fn commit_groups(&mut self, id: NodeId) {
        let mut chain = vec![id];
        chain.extend(self.ancestors(id));
        for x in chain {
            let Some(n) = self.get(x) else { continue };
            let (Some(g), Some(p)) = (n.group, n.parent) else { continue };
            let siblings: Vec<NodeId> = self
                .get(p)
                .map(|pn| pn.children.iter().copied().filter(|&c| c != x && self.get(c).is_some_and(|s| s.group == Some(g))).collect())
                .unwrap_or_default();
            for s in siblings {
                self.remove_subtree(s);
            }
        }
    }

    /// Renders the tree as indented text: name, releaser, post-condition, 1/e and μ as in the
    /// thesis's figures, and the state.
    pub fn render_text(&self, state: &State) -> String {
        let mut s = String::new();
        self.text_rec(self.root, "", true, true, state, &mut s);
        s
    }

    fn text_rec(&self, id: NodeId, prefix: &str, last: bool, top: bool, state: &State, s: &mut String) {
        let Some(n) = self.get(id) else { return };
        let branch = if top { "" } else if last { "└─ " } else { "├─ " };
        let _ = write!(s, "{prefix}{branch}{}", n.label);
        if n.kind != NodeKind::Root {
            let arm = n.arm.map(|a| format!(" arm={}", state.arm_names()[a])).unwrap_or_default();
            let _ = write!(
                s,
                "  r: {} p: {}  {:.2} ({})  [{}]{arm}",
                n.releaser,
                n.post,
                if n.emphasis > 0.0 { 1.0 / n.emphasis } else { f64::INFINITY },
                trim_float(n.mu),
                status(n)
            );
        }
        s.push('\n');
        let child_prefix = if top { prefix.to_owned() } else { format!("{prefix}{}", if last { "   " } else { "│  " }) };
        for (i, c) in n.children.iter().enumerate() {
            self.text_rec(*c, &child_prefix, i + 1 == n.children.len(), false, state, s);
        }
    }

    /// Renders the tree in Graphviz DOT: green enabled, red disabled, blue accomplished,
    /// orange assigned to the person, dotted abstract behaviours; edges carry releasers.
    pub fn render_dot(&self) -> String {
        let mut s = String::from("digraph wm {\n  node [shape=ellipse, fontname=\"Helvetica\"];\n");
        for id in self.preorder() {
            let Some(n) = self.get(id) else { continue };
            let color = match status(n) {
                "done" => "blue",
                "human" => "orange",
                "enabled" => "green",
                _ => "red",
            };
            let style = if matches!(n.kind, NodeKind::Abstract | NodeKind::Root) { "dotted" } else { "solid" };
            let _ = writeln!(
                s,
                "  n{id} [label=\"{}\\n{:.2} ({})\", color={color}, style={style}];",
                n.label.replace('"', "'"),
                if n.emphasis > 0.0 { 1.0 / n.emphasis } else { 0.0 },
                trim_float(n.mu)
            );
            if let Some(p) = n.parent {
                let _ = writeln!(s, "  n{p} -> n{id} [label=\"{}\"];", n.releaser.to_string().replace('"', "'"));
            }
        }
        s.push_str("}\n");
        s
    }
}

fn trim_float(x: f64) -> String {
    if x.fract() == 0.0 { format!("{x:.0}") } else { format!("{x:.2}") }
}

/// Status word used by the renderers and the snapshot.
pub fn status(n: &Node) -> &'static str {
    if n.accomplished {
        "done"
    } else if n.human {
        "human"
    } else if n.blocked {
        "blocked"
    } else if n.enabled && n.accessible {
        "enabled"
    } else {
        "disabled"
    }
}

fn is_action(ltm: &Ltm, t: &Term) -> bool {
    ltm.retrieve(t).is_some_and(|(sid, _)| ltm.schema(sid).kind.is_some())
}

fn arm_combinations(n: usize, arms: &[String]) -> Vec<Vec<String>> {
    let mut out: Vec<Vec<String>> = vec![Vec::new()];
    for _ in 0..n {
        let mut next = Vec::new();
        for prefix in &out {
            for a in arms {
                let mut p = prefix.clone();
                p.push(a.clone());
                next.push(p);
            }
        }
        out = next;
    }
    out
}

impl Node {
    fn blank(id: NodeId, parent: Option<NodeId>, term: Term, kind: NodeKind, depth: usize) -> Self {
        let label = term.to_string();
        Self {
            id,
            parent,
            term,
            label,
            releaser: GroundCond::default(),
            post: GroundCond::default(),
            children: Vec::new(),
            kind,
            schema: None,
            expanded: kind == NodeKind::Root,
            arm: None,
            object: None,
            action_object: None,
            depth,
            mu: 1.0,
            lambda: 1.0,
            emphasis: 1.0,
            n_done: 0,
            accomplished: false,
            started: false,
            human: false,
            blocked: false,
            releaser_value: true,
            enabled: true,
            accessible: true,
            group: None,
            taught: false,
            failures: 0,
        }
    }
}

/// Helper for `Term` arguments that are constants.
pub fn const_arg(t: &Term, i: usize) -> Option<&str> {
    match t.args.get(i) {
        Some(Arg::Term(a)) if a.args.is_empty() => Some(&a.functor),
        _ => None,
    }
}
