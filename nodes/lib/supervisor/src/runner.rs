//! Drives a [`Supervisor`] from a timed event script at a fixed tick rate (the standalone
//! runner of `cowork supervisor run` and of the scenario tests), optionally with a simulated
//! robot manager that accomplishes every commanded action after a fixed duration.
//!
//! Per tick at time t: script events with time ≤ t are handled in file order, then simulated
//! robot events that fell due, then `tick(t)`. The latency of a new action command is counted
//! in ticks from the tick in which its triggering stimulus arrived (1 = the same tick).

use serde::Serialize;

use crate::events::{Event, GripperState, TimedEvent};
use crate::executive::{Decision, Supervisor};
use crate::schema::{ActionKind, Arg, Term};

/// A stand-in for the robot manager during script runs: each commanded action is reported
/// done `action_duration_s` later; gripper actions whose label starts with `close`/`open`
/// (e.g. `close3(water)`) also close the gripper on their object / open it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SimRobot {
    /// Time every action takes (s).
    pub action_duration_s: f64,
}

/// Run settings.
#[derive(Debug, Clone, PartialEq)]
pub struct RunConfig {
    /// Supervisor tick rate (Hz).
    pub rate_hz: f64,
    /// Time run after the last event (s); the run also stops early once the task is
    /// accomplished and no events remain.
    pub tail_s: f64,
    /// Simulated robot manager, if any.
    pub robot: Option<SimRobot>,
}

impl Default for RunConfig {
    fn default() -> Self {
        Self { rate_hz: 100.0, tail_s: 30.0, robot: None }
    }
}

/// A decision with when it was made.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Record {
    /// Tick index (1-based).
    pub tick: u64,
    /// Tick time (s).
    pub t: f64,
    /// Ticks from the triggering stimulus to this decision (actions only; 1 = same tick).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub latency_ticks: Option<u64>,
    /// The decision.
    #[serde(flatten)]
    pub decision: Decision,
}

/// What a run produced.
#[derive(Debug, Clone, Default)]
pub struct RunReport {
    /// Every decision in order.
    pub records: Vec<Record>,
    /// Ticks run.
    pub ticks: u64,
    /// Largest stimulus → action latency seen (ticks).
    pub max_latency_ticks: u64,
}

impl RunReport {
    /// Labels of the commanded actions, in order.
    pub fn actions(&self) -> Vec<String> {
        self.records
            .iter()
            .filter_map(|r| match &r.decision {
                Decision::Action { label, .. } => Some(label.clone()),
                _ => None,
            })
            .collect()
    }

    /// Accomplished behaviours, in order.
    pub fn accomplished(&self) -> Vec<String> {
        self.records
            .iter()
            .filter_map(|r| match &r.decision {
                Decision::Accomplished { behaviour } => Some(behaviour.clone()),
                _ => None,
            })
            .collect()
    }

    /// True if the task was reported accomplished.
    pub fn task_accomplished(&self) -> bool {
        self.records.iter().any(|r| matches!(r.decision, Decision::TaskAccomplished { .. }))
    }
}

struct Pending {
    due: f64,
    arm: Option<String>,
    label: String,
    kind: ActionKind,
}

/// Runs the script. `each_tick` sees the supervisor after every tick with that tick's
/// decisions (for invariant checks, snapshots, logging).
pub fn run(
    sup: &mut Supervisor,
    events: &[TimedEvent],
    cfg: &RunConfig,
    mut each_tick: impl FnMut(&Supervisor, u64, f64, &[Decision]),
) -> RunReport {
    let dt = 1.0 / cfg.rate_hz.max(1e-3);
    let end = events.last().map_or(0.0, |e| e.t) + cfg.tail_s.max(0.0);
    let mut report = RunReport::default();
    let mut next_ev = 0usize;
    let mut pending: Vec<Pending> = Vec::new();
    let mut decisions = Vec::new();
    let mut stimulus_tick: u64 = 1;
    let mut k: u64 = 0;
    loop {
        k += 1;
        let t = (k - 1) as f64 * dt;
        if t > end + 1e-9 {
            break;
        }
        let mut stimulated = k == 1;
        while next_ev < events.len() && events[next_ev].t <= t + 1e-9 {
            sup.handle(&events[next_ev].event, t);
            next_ev += 1;
            stimulated = true;
        }
        pending.sort_by(|a, b| a.due.total_cmp(&b.due));
        while pending.first().is_some_and(|p| p.due <= t + 1e-9) {
            let p = pending.remove(0);
            for ev in robot_events(&p) {
                sup.handle(&ev, t);
            }
            stimulated = true;
        }
        if stimulated {
            stimulus_tick = k;
        }
        decisions.clear();
        sup.tick(t, &mut decisions);
        for d in &decisions {
            let mut latency = None;
            match d {
                Decision::Action { arm, label, kind, .. } => {
                    let l = k - stimulus_tick + 1;
                    report.max_latency_ticks = report.max_latency_ticks.max(l);
                    latency = Some(l);
                    if let Some(r) = &cfg.robot {
                        pending.retain(|p| &p.arm != arm);
                        pending.push(Pending { due: t + r.action_duration_s, arm: arm.clone(), label: label.clone(), kind: *kind });
                    }
                }
                Decision::Stop { arm, .. } | Decision::AwaitDemonstration { arm, .. } => pending.retain(|p| &p.arm != arm),
                Decision::Mode { .. } => pending.clear(),
                _ => {}
            }
            report.records.push(Record { tick: k, t, latency_ticks: latency, decision: d.clone() });
        }
        each_tick(sup, k, t, &decisions);
        if next_ev >= events.len() && pending.is_empty() && sup.task_accomplished() {
            break;
        }
    }
    report.ticks = k;
    report
}

fn robot_events(p: &Pending) -> Vec<Event> {
    let mut out = Vec::new();
    if p.kind == ActionKind::Gripper
        && let Ok(t) = Term::parse(&p.label)
    {
        let object = match t.args.first() {
            Some(Arg::Term(o)) if o.args.is_empty() => Some(o.functor.clone()),
            _ => None,
        };
        if t.functor.starts_with("close") {
            out.push(Event::Gripper { arm: p.arm.clone(), state: GripperState::Close, object });
        } else if t.functor.starts_with("open") {
            out.push(Event::Gripper { arm: p.arm.clone(), state: GripperState::Open, object: None });
        }
    }
    out.push(Event::ActionDone { arm: p.arm.clone(), label: p.label.clone() });
    out
}
