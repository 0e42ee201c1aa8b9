//! Teaching (thesis Sec. 4.3.3–4.3.4, Algorithm 4): segmented actions from a demonstration are
//! attached to the most emphasised enabled open subtask, chained to the previous action's
//! `done`, and stored in the LTM.
//!
//! Rules beyond the algorithm's text, needed to run it on streams:
//! * the subtasks competing are the open ones plus those that received actions in this
//!   session (a subtask keeps collecting actions while it is the most emphasised);
//! * a demonstrated subtask is finished when its releaser turns false (the hand closed on the
//!   object in a take, opened at the end of a pour): its post-condition is then asserted, so
//!   the next subtasks (e.g. `use(spoon)` after both `add`s) become enabled;
//! * a label already used by another action is made unique with a `_N` suffix;
//! * a NOA or gripper action that would open a new subtask but acts on the object of the
//!   subtask that acquired the previous action (the retreat from the bottle just put down,
//!   `noa8(water)` after `open7`) stays in that previous subtask as its last action. Without
//!   this, Algorithm 4 gives `take(coffee)` the releaser `open7.done` of `pour(water)`, and
//!   when the person adds the water instead of the robot, `take(coffee)` can never start.
//!   With it every subtask starts with a FOA and a `true` releaser, as in Fig. 4.16 ("the
//!   first action of each subtask has always a true releaser").

use crate::ltm::Ltm;
use crate::schema::{ActionKind, Arg, Cond, Term};
use crate::state::{GroundCond, State};
use crate::wm::{NodeId, NodeKind, Wm};
use crate::error::Warning;

/// Per-session teaching memory.
#[derive(Debug, Clone, Default)]
pub struct TeachSession {
    /// Post-condition of the previously attached action (p_prev in Algorithm 4).
    pub last_post: Option<Cond>,
    /// Subtask that acquired the previous action: its term, post-condition, object and arm.
    pub last_subtask: Option<PrevSubtask>,
    /// Subtasks already reported unfinished in this session (one warning each).
    pub reported_unfinished: Vec<NodeId>,
}

/// The subtask that acquired the previous action (it may be finished and gone from the WM).
#[derive(Debug, Clone, PartialEq)]
pub struct PrevSubtask {
    /// Its node (while it is in the WM).
    pub node: NodeId,
    /// Its ground term, e.g. `subtask(pour,water)`.
    pub term: Term,
    /// Its post-condition.
    pub post: Cond,
    /// The object it is about.
    pub object: Option<String>,
    /// Arm (dual-arm).
    pub arm: Option<usize>,
}

/// A learned action, reported as a decision.
#[derive(Debug, Clone, PartialEq)]
pub struct Attached {
    /// Stored action label (possibly made unique).
    pub label: String,
    /// Kind.
    pub kind: ActionKind,
    /// Subtask that acquired it.
    pub subtask: String,
    /// Its releaser.
    pub releaser: String,
    /// Arm (dual-arm).
    pub arm: Option<usize>,
}

/// Algorithm 4, line 3: the most emphasised enabled subtask that is open or being taught,
/// for `arm` (dual-arm: subtasks of that arm compete).
pub fn winner(wm: &Wm, arm: Option<usize>) -> Option<NodeId> {
    wm.iter()
        .filter(|n| n.kind == NodeKind::Subtask && !n.accomplished && n.enabled && n.releaser_value && n.accessible)
        .filter(|n| n.is_open() || n.taught)
        .filter(|n| arm.is_none() || n.arm.is_none() || n.arm == arm)
        .max_by(|a, b| a.emphasis.total_cmp(&b.emphasis).then(b.id.cmp(&a.id)))
        .map(|n| n.id)
}

/// Builds the action term from a segment label (`foa1(water)`, or `foa1` plus its object).
pub fn action_term(label: &str, object: Option<&str>) -> Result<Term, Warning> {
    let bad = |reason: String| Warning::BadLabel { label: label.to_owned(), reason };
    let mut t = Term::parse(label).map_err(|e| bad(e.to_string()))?;
    if !t.is_ground() {
        return Err(bad("labels must not contain variables".into()));
    }
    if t.args.is_empty()
        && let Some(o) = object.filter(|o| !o.is_empty())
    {
        t.args.push(Arg::Term(Term::atom(o)));
    }
    Ok(t)
}

/// Algorithm 4, lines 3–12, for one segment: picks the winning subtask, sets releaser and
/// post-condition, allocates the action in the WM (as demonstrated, i.e. accomplished) and
/// updates the LTM.
pub fn attach(
    wm: &mut Wm,
    ltm: &mut Ltm,
    state: &mut State,
    session: &mut TeachSession,
    mut term: Term,
    kind: ActionKind,
    arm: Option<usize>,
) -> Result<Attached, Warning> {
    let label_in = term.to_string();
    let won = winner(wm, arm);
    let retreat = retreat_owner(wm, ltm, session, won, &term, kind);
    let Some(mut sub) = won.or(retreat.as_ref().map(|p| p.node)) else { return Err(Warning::NoOpenSubtask { label: label_in }) };
    if ltm.has_action(&term.functor) {
        let base = term.functor.clone();
        let mut n = 2;
        while ltm.has_action(&format!("{base}_{n}")) {
            n += 1;
        }
        term.functor = format!("{base}_{n}");
    }
    if let Some(prev) = retreat {
        match wm.get(prev.node) {
            Some(p) if !p.accomplished => sub = prev.node,
            // Finished (and possibly deallocated): the retreat goes to the LTM only; in the WM
            // it is demonstrated already.
            _ => {
                let releaser = session.last_post.clone().unwrap_or_default();
                ltm.learn_action(&prev.term, &prev.post, &term, kind, &releaser);
                let post = crate::ltm::done_cond(&term.functor);
                state.assert_cond(&GroundCond::new(post.clone()));
                session.last_post = Some(post);
                return Ok(Attached {
                    label: term.to_string(),
                    kind,
                    subtask: prev.term.to_string(),
                    releaser: releaser.to_string(),
                    arm: prev.arm,
                });
            }
        }
    }
    let (sub_term, sub_post, last_child) = match wm.get(sub) {
        Some(s) => (s.term.clone(), s.post.cond.clone(), s.children.last().copied()),
        None => return Err(Warning::NoOpenSubtask { label: label_in }),
    };
    let releaser = match last_child.and_then(|c| wm.get(c)) {
        // Same subtask: chain to the previous action of this subtask.
        Some(prev) => prev.post.cond.clone(),
        // New subtask starting with a FOA: decoupled from the previous subtask.
        None if kind == ActionKind::Foa => Cond::truth(),
        // New subtask starting with a NOA or gripper action: needs the previous end point.
        None => session.last_post.clone().unwrap_or_default(),
    };
    let sid = ltm.learn_action(&sub_term, &sub_post, &term, kind, &releaser);
    let id = wm.alloc_child(sub, term.clone(), GroundCond::new(releaser.clone()), None, ltm, state);
    let post = wm.get(id).map(|n| n.post.clone()).unwrap_or_default();
    state.assert_cond(&post);
    session.last_post = Some(post.cond.clone());
    session.last_subtask = wm.get(sub).map(|s| PrevSubtask {
        node: sub,
        term: s.term.clone(),
        post: s.post.cond.clone(),
        object: s.object.clone(),
        arm: s.arm,
    });
    if let Some(a) = wm.get_mut(id) {
        a.accomplished = true;
        a.expanded = true;
    }
    let mut sub_arm = None;
    if let Some(s) = wm.get_mut(sub) {
        s.schema = Some(sid);
        s.n_done += 1;
        s.taught = true;
        s.started = true;
        s.expanded = true;
        sub_arm = s.arm;
    }
    wm.commit_groups(sub);
    Ok(Attached {
        label: term.to_string(),
        kind,
        subtask: sub_term.to_string(),
        releaser: releaser.to_string(),
        arm: sub_arm,
    })
}

/// The subtask that keeps a retreat: `Some(prev)` when the winner `won` has no action yet (or
/// there is none: the retreat after the task's last release, whatever object it is relative
/// to), the action is not a FOA, and it acts on the object of `prev`, the subtask that acquired
/// the previous action (module docs).
fn retreat_owner(wm: &Wm, ltm: &Ltm, session: &TeachSession, won: Option<NodeId>, term: &Term, kind: ActionKind) -> Option<PrevSubtask> {
    let fresh = won.is_none_or(|w| wm.get(w).is_some_and(|s| s.children.is_empty()));
    if kind == ActionKind::Foa || !fresh {
        return None;
    }
    let prev = session.last_subtask.clone().filter(|p| Some(p.node) != won)?;
    if won.is_none() {
        // Nothing else could own it (the task's last release): the previous subtask keeps it.
        return Some(prev);
    }
    let own = term.constant_args().filter(|c| ltm.is_object(c)).last()?;
    (prev.object.as_deref() == Some(own)).then_some(prev)
}

/// Ends the demonstration of subtasks whose releaser turned false: asserts their
/// post-condition (the `alive` pass then marks them accomplished) — unless the gripper events
/// contradict it (the hand closed on nothing: `tea.taken` never held). Such a subtask stays
/// unfinished and is reported once in `warnings`.
pub fn finish_demonstrated(wm: &Wm, state: &mut State, session: &mut TeachSession, warnings: &mut Vec<Warning>) {
    let ended: Vec<(NodeId, GroundCond)> = wm
        .iter()
        .filter(|n| n.kind == NodeKind::Subtask && n.taught && !n.accomplished && !state.eval(&n.releaser))
        .map(|n| (n.id, n.post.clone()))
        .collect();
    for (id, post) in ended {
        match state.unmet_observed(&post) {
            None => state.assert_cond(&post),
            Some(missing) if !session.reported_unfinished.contains(&id) => {
                session.reported_unfinished.push(id);
                let subtask = wm.get(id).map(|n| n.term.to_string()).unwrap_or_default();
                let reason = format!("its releaser turned false but {missing} does not hold (did the hand close on nothing?)");
                warnings.push(Warning::UnfinishedDemonstration { subtask, reason });
            }
            Some(_) => {}
        }
    }
}

/// At `done`: every subtask demonstrated in this session that did not reach its
/// post-condition is forgotten — its actions leave the working memory and its learned schema
/// (the LTM keeps the subtask open for another demonstration) — so it is neither declared
/// accomplished nor executed later without, say, its grasp. Returns one warning per subtask.
pub fn forget_unfinished(wm: &mut Wm, ltm: &mut Ltm, state: &State) -> Vec<Warning> {
    let unfinished: Vec<NodeId> = wm
        .iter()
        .filter(|n| n.kind == NodeKind::Subtask && n.taught && !n.accomplished && !state.eval(&n.post))
        .map(|n| n.id)
        .collect();
    let mut warnings = Vec::new();
    for id in unfinished {
        let Some(n) = wm.get(id) else { continue };
        let (term, actions) = (n.term.clone(), n.children.len());
        let missing = state.unmet_observed(&n.post).unwrap_or_else(|| n.post.to_string());
        ltm.forget_subtask_actions(&term);
        wm.dealloc_children(id);
        if let Some(n) = wm.get_mut(id) {
            (n.taught, n.started, n.n_done) = (false, false, 0);
        }
        let reason = format!("{missing} never held; its {actions} demonstrated actions are forgotten and it stays open");
        warnings.push(Warning::UnfinishedDemonstration { subtask: term.to_string(), reason });
    }
    warnings
}
