//! Chaos in a kitchen trial (`--fault NODE:kill|stop`): one node of the executing graph is
//! killed (SIGKILL, as a crash: nothing saved, no goodbye to its DDS peers) and started again,
//! or stopped (SIGSTOP, as a debugger or Ctrl-Z) and continued, at the first moment from
//! `--fault-at` simulated seconds after the robot's first action on when the tool moves faster
//! than [`MOVING_M_S`] (so that there is a motion to stop; whatever it does at `--fault-at` +
//! [`STRIKE_WAIT_S`]), for `--fault-down` wall-clock seconds. The trial goes on and
//! is judged as any other; the fault adds what it did to the robot, from the simulated world
//! only (`/lwr/world`'s tool pose, `/joint_states`):
//! * **held after**: simulated s from the fault until the tool stays under [`HELD_M_S`] for
//!   [`HELD_FOR_S`] (`None`: it never did while the node was down — the robot went on with its
//!   action, which ds_controller still runs with obstacle avoidance);
//! * **tool path** and **largest joint excursion** from the fault until the node is back;
//! * **resumed after**: simulated s from the node's return until the tool moves faster than
//!   [`MOVING_M_S`] again.
//!
//! `lwr_sim:kill` is refused: lwr_sim is the simulated robot and its world, and one started
//! again starts them over (the objects back at the scene's places, the clock at 0), so nothing
//! after it could be judged. `lwr_sim:stop` freezes robot, world and clock together.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use cowork_graph::{Graph, Killed, Signal};
use cowork_msgs::msg::WorldState;
use cowork_msgs::sensor_msgs::JointState;
use serde::Serialize;

/// The nodes a fault may strike.
pub const NODES: [&str; 6] = ["lwr_sim", "fded_distance", "human_observer", "ds_controller", "robot_manager", "attentional_supervisor"];
/// Tool speed under which the robot counts as held, m/s.
pub const HELD_M_S: f64 = 0.01;
/// How long the tool must stay under [`HELD_M_S`], simulated s.
pub const HELD_FOR_S: f64 = 0.2;
/// Tool speed over which the robot counts as moving again, m/s.
pub const MOVING_M_S: f64 = 0.05;
/// How long after `--fault-at` the fault waits for the tool to move, simulated s.
pub const STRIKE_WAIT_S: f64 = 5.0;
/// The window the tool speed is taken over, simulated s.
const SPEED_WINDOW_S: f64 = 0.05;

/// What happens to the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FaultKind {
    /// SIGKILL, then started again.
    Kill,
    /// SIGSTOP, then SIGCONT.
    Stop,
}

/// `--fault NODE:KIND`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultSpec {
    /// The node.
    pub node: String,
    /// Kill or stop.
    pub kind: FaultKind,
}

/// Parses `NODE:kill` or `NODE:stop` (clap's value parser of `--fault`).
pub fn parse_fault(s: &str) -> Result<FaultSpec, String> {
    let (node, kind) = s.split_once(':').ok_or_else(|| format!("`{s}`: expected NODE:kill or NODE:stop"))?;
    if !NODES.contains(&node) {
        return Err(format!("`{node}` is not a node of the kitchen graph ({})", NODES.join(", ")));
    }
    let kind = match kind {
        "kill" => FaultKind::Kill,
        "stop" => FaultKind::Stop,
        other => return Err(format!("`{other}`: expected kill or stop")),
    };
    if node == "lwr_sim" && kind == FaultKind::Kill {
        return Err("lwr_sim:kill: lwr_sim is the simulated robot and world; started again they start over (objects at the scene's places, the clock at 0), so the trial could not be judged; use lwr_sim:stop".into());
    }
    Ok(FaultSpec { node: node.to_owned(), kind })
}

/// What the fault did, in the trial's JSON.
#[derive(Debug, Clone, Serialize)]
pub struct FaultOutcome {
    /// The node.
    pub node: String,
    /// Kill or stop.
    pub kind: FaultKind,
    /// When it struck: simulated s after the robot's first action (`None`: the task ended first).
    pub at_s: Option<f64>,
    /// The action the robot manager was on then.
    pub during: Option<String>,
    /// The tool's speed then, m/s.
    pub tool_speed_m_s: f64,
    /// Wall-clock s the node was down.
    pub down_wall_s: f64,
    /// Simulated s the clock ran while the node was down.
    pub down_sim_s: f64,
    /// Simulated s from the fault until the tool stayed under [`HELD_M_S`] for [`HELD_FOR_S`]
    /// (`None`: not while the node was down).
    pub held_after_s: Option<f64>,
    /// Tool path from the fault until the node was back, m.
    pub tool_path_m: f64,
    /// Largest joint excursion from the configuration at the fault until the node was back, rad.
    pub joint_excursion_rad: f64,
    /// Simulated s from the node's return until the tool moved faster than [`MOVING_M_S`]
    /// (`None`: it never did again).
    pub resumed_after_s: Option<f64>,
}

enum Phase {
    Waiting,
    Down { since: Instant, killed: Option<Killed> },
    Back,
}

/// Strikes the fault and measures it; fed with the world and the joints.
pub struct FaultRun {
    spec: FaultSpec,
    at_s: f64,
    down: Duration,
    phase: Phase,
    outcome: FaultOutcome,
    /// Recent (t, tool position) for the speed.
    recent: VecDeque<(f64, [f64; 3])>,
    t_fault: f64,
    t_back: Option<f64>,
    /// Since when the tool has been under [`HELD_M_S`] (after the fault).
    slow_since: Option<f64>,
    q_fault: Option<Vec<f64>>,
    last_t: Option<f64>,
    /// The tool's newest speed, m/s.
    speed: f64,
}

impl FaultRun {
    /// `spec` strikes `at_s` simulated s after the first action and lasts `down_s` wall s.
    pub fn new(spec: FaultSpec, at_s: f64, down_s: f64) -> Self {
        let outcome = FaultOutcome {
            node: spec.node.clone(),
            kind: spec.kind,
            at_s: None,
            during: None,
            tool_speed_m_s: 0.0,
            down_wall_s: 0.0,
            down_sim_s: 0.0,
            held_after_s: None,
            tool_path_m: 0.0,
            joint_excursion_rad: 0.0,
            resumed_after_s: None,
        };
        Self {
            spec,
            at_s,
            down: cowork_ros::duration_s(down_s),
            phase: Phase::Waiting,
            outcome,
            recent: VecDeque::new(),
            t_fault: 0.0,
            t_back: None,
            slow_since: None,
            q_fault: None,
            last_t: None,
            speed: 0.0,
        }
    }

    /// A `/lwr/world` report: the tool's speed, path, hold and resumption.
    pub fn on_world(&mut self, w: &WorldState) {
        let t = w.header.stamp.to_secs_f64();
        let p = [w.tool_pose.position.x, w.tool_pose.position.y, w.tool_pose.position.z];
        if let Some(&(_, last)) = self.recent.back()
            && matches!(self.phase, Phase::Down { .. })
        {
            self.outcome.tool_path_m += dist(p, last);
        }
        self.last_t = Some(t);
        self.recent.push_back((t, p));
        while self.recent.len() > 2 && self.recent.front().is_some_and(|&(t0, _)| t - t0 > SPEED_WINDOW_S) {
            self.recent.pop_front();
        }
        let Some(&(t0, p0)) = self.recent.front() else { return };
        if t - t0 < 0.5 * SPEED_WINDOW_S {
            return;
        }
        let speed = dist(p, p0) / (t - t0);
        self.speed = speed;
        match self.phase {
            Phase::Waiting => {}
            Phase::Down { .. } => {
                if speed < HELD_M_S {
                    let since = *self.slow_since.get_or_insert(t0.max(self.t_fault));
                    if self.outcome.held_after_s.is_none() && t - since >= HELD_FOR_S {
                        self.outcome.held_after_s = Some(since - self.t_fault);
                    }
                } else {
                    self.slow_since = None;
                }
            }
            Phase::Back => {
                if let Some(back) = self.t_back
                    && self.outcome.resumed_after_s.is_none()
                    && speed > MOVING_M_S
                {
                    self.outcome.resumed_after_s = Some(t - back);
                }
            }
        }
    }

    /// A `/joint_states` message: the excursion from the configuration at the fault.
    pub fn on_joints(&mut self, j: &JointState) {
        match self.phase {
            Phase::Waiting => self.q_fault = Some(j.position.clone()),
            Phase::Down { .. } => {
                if let Some(q0) = &self.q_fault {
                    let most = j.position.iter().zip(q0).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                    self.outcome.joint_excursion_rad = self.outcome.joint_excursion_rad.max(most);
                }
            }
            Phase::Back => {}
        }
    }

    /// Strikes when `elapsed_s` (simulated s since the first action) reaches `--fault-at`,
    /// brings the node back after `--fault-down`; `during` names the running action.
    pub fn step(&mut self, g: &mut Graph, elapsed_s: Option<f64>, during: Option<&str>) -> Result<()> {
        match &mut self.phase {
            Phase::Waiting => {
                let Some(elapsed) = elapsed_s.filter(|e| *e >= self.at_s) else { return Ok(()) };
                if self.speed < MOVING_M_S && elapsed < self.at_s + STRIKE_WAIT_S {
                    return Ok(());
                }
                let killed = match self.spec.kind {
                    FaultKind::Kill => match g.kill(&self.spec.node) {
                        Some(k) => Some(k),
                        None => bail!("--fault: {} is not running", self.spec.node),
                    },
                    FaultKind::Stop => {
                        if !g.signal(&self.spec.node, Signal::SIGSTOP) {
                            bail!("--fault: {} is not running", self.spec.node);
                        }
                        None
                    }
                };
                self.t_fault = self.last_t.unwrap_or(0.0);
                self.outcome.at_s = Some(elapsed);
                self.outcome.during = during.map(str::to_owned);
                self.outcome.tool_speed_m_s = self.speed;
                self.slow_since = None;
                self.phase = Phase::Down { since: Instant::now(), killed };
            }
            Phase::Down { since, killed } => {
                if since.elapsed() < self.down {
                    return Ok(());
                }
                self.outcome.down_wall_s = since.elapsed().as_secs_f64();
                match killed.take() {
                    Some(k) => g.restart(k)?,
                    None => {
                        g.signal(&self.spec.node, Signal::SIGCONT);
                    }
                }
                let now = self.last_t.unwrap_or(self.t_fault);
                self.outcome.down_sim_s = now - self.t_fault;
                self.t_back = Some(now);
                self.phase = Phase::Back;
            }
            Phase::Back => {}
        }
        Ok(())
    }

    /// At the end of the trial: a node still stopped is continued (a killed one stays down).
    pub fn finish(&mut self, g: &mut Graph) {
        if let Phase::Down { since, killed: None } = &self.phase {
            self.outcome.down_wall_s = since.elapsed().as_secs_f64();
            g.signal(&self.spec.node, Signal::SIGCONT);
            self.phase = Phase::Back;
        }
    }

    /// What the fault did.
    pub fn outcome(&self) -> FaultOutcome {
        self.outcome.clone()
    }

    /// One console line.
    pub fn describe(o: &FaultOutcome) -> String {
        let Some(at) = o.at_s else { return format!("fault {}:{:?}: the task ended before it was due", o.node, o.kind) };
        let verb = match o.kind {
            FaultKind::Kill => "killed (SIGKILL), started again",
            FaultKind::Stop => "stopped (SIGSTOP), continued",
        };
        format!(
            "fault: {} {verb} {:.1} s after the first action{}, the tool at {:.3} m/s, down {:.1} s wall / {:.1} s simulated: {}; tool path {:.3} m, joints at most {:.3} rad off while down; {}",
            o.node,
            at,
            o.during.as_ref().map(|a| format!(" (during {a})")).unwrap_or_default(),
            o.tool_speed_m_s,
            o.down_wall_s,
            o.down_sim_s,
            o.held_after_s.map_or_else(|| "the robot was not held while it was down".to_owned(), |h| format!("the robot held after {h:.2} s")),
            o.tool_path_m,
            o.joint_excursion_rad,
            o.resumed_after_s.map_or_else(|| "never moved again".to_owned(), |r| format!("moving again {r:.2} s after it was back")),
        )
    }
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fault_specs_parse_and_name_what_is_wrong() {
        assert_eq!(parse_fault("robot_manager:kill"), Ok(FaultSpec { node: "robot_manager".into(), kind: FaultKind::Kill }));
        assert_eq!(parse_fault("lwr_sim:stop").map(|f| f.kind), Ok(FaultKind::Stop));
        assert!(parse_fault("lwr_sim:kill").unwrap_err().contains("lwr_sim:stop"));
        assert!(parse_fault("rviz:kill").unwrap_err().contains("not a node"));
        assert!(parse_fault("ds_controller:pause").unwrap_err().contains("kill or stop"));
        assert!(parse_fault("ds_controller").unwrap_err().contains("NODE:kill"));
    }

    fn world(t: f64, x: f64) -> WorldState {
        let mut w = WorldState::default();
        w.header.stamp = cowork_msgs::builtin_interfaces::Time::from_secs_f64(t);
        w.tool_pose.position.x = x;
        w
    }

    /// The tool moving at 0.1 m/s, then (after the fault) braking to a stand in 0.1 s: held
    /// after about 0.1 s, the path is what it moved after the fault.
    #[test]
    fn hold_path_and_resumption_come_from_the_world() {
        let mut f = FaultRun::new(FaultSpec { node: "ds_controller".into(), kind: FaultKind::Kill }, 1.0, 0.0);
        let mut x = 0.0;
        let mut t = 0.0;
        let mut v = 0.1;
        for _ in 0..100 {
            t += 0.01;
            x += v * 0.01;
            f.on_world(&world(t, x));
        }
        f.phase = Phase::Down { since: Instant::now(), killed: None };
        f.t_fault = t;
        f.outcome.at_s = Some(1.0);
        for k in 0..100 {
            t += 0.01;
            v = if k < 10 { 0.1 * (1.0 - f64::from(k) / 10.0) } else { 0.0 };
            x += v * 0.01;
            f.on_world(&world(t, x));
        }
        let held = f.outcome.held_after_s.expect("held");
        assert!((0.05..0.2).contains(&held), "{held}");
        assert!((f.outcome.tool_path_m - 0.0055).abs() < 1e-4, "{}", f.outcome.tool_path_m);
        f.phase = Phase::Back;
        f.t_back = Some(t);
        for _ in 0..50 {
            t += 0.01;
            x += 0.1 * 0.01;
            f.on_world(&world(t, x));
        }
        let resumed = f.outcome.resumed_after_s.expect("resumed");
        assert!(resumed < 0.1, "{resumed}");
        assert!(FaultRun::describe(&f.outcome).contains("held after"));
    }
}
