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
//! * a label already used by another action is made unique with a `_N` suffix.

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
    let Some(sub) = winner(wm, arm) else { return Err(Warning::NoOpenSubtask { label: label_in }) };
    if ltm.has_action(&term.functor) {
        let base = term.functor.clone();
        let mut n = 2;
        while ltm.has_action(&format!("{base}_{n}")) {
            n += 1;
        }
        term.functor = format!("{base}_{n}");
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

/// Ends the demonstration of subtasks whose releaser turned false: asserts their
/// post-condition (the `alive` pass then marks them accomplished).
pub fn finish_demonstrated(wm: &Wm, state: &mut State) {
    let done: Vec<GroundCond> = wm
        .iter()
        .filter(|n| n.kind == NodeKind::Subtask && n.taught && !n.accomplished && !state.eval(&n.releaser))
        .map(|n| n.post.clone())
        .collect();
    for p in done {
        state.assert_cond(&p);
    }
}
