//! The in-process experiment loop on the simulated clock: `cowork_sim::Simulator` at 1 kHz,
//! analytic obstacles measured exactly ([`LinkGeometry`]), the DS controller in the loop.

use std::io::Write;

use cowork_ds::{
    ControlInput, ControlOutput, ControllerConfig, Distances, DsController, HumanInput, HumanMode,
    HumanState, MotionCommand, Primitive, Status,
};
use cowork_ds::primitive::Linear;
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::{Scene, SceneObject, SimParams, Simulator};
use nalgebra::{Point3, Vector3};
use serde::Serialize;

use crate::distance::{Closest, LinkGeometry};
use crate::error::{Error, Result};
use crate::obstacle::Obstacle;

/// One point-to-point motion of a scenario.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Goal {
    /// Goal position of the TCP (m, base frame).
    pub position: Vector3<f64>,
    /// The DS towards it.
    pub primitive: Primitive,
    /// Stay this long within tolerance before the next goal (s).
    pub dwell_s: f64,
    /// The motion is not commanded before this time (s); the previous goal is held until then.
    pub not_before_s: f64,
    /// Gripper command on arrival: `Some(true)` close (grasp), `Some(false)` open.
    pub gripper: Option<bool>,
    /// DS modulation of the end effector (off for a handover).
    pub end_effector_avoidance: bool,
}

impl Goal {
    /// A linear DS ẋ = k (g − x) to `position`.
    pub fn linear(position: Vector3<f64>, gain: f64) -> Self {
        Self {
            position,
            primitive: Primitive::Linear(Linear { gain }),
            dwell_s: 0.2,
            not_before_s: 0.0,
            gripper: None,
            end_effector_avoidance: true,
        }
    }
}

/// Everything that moves in a scenario besides the robot: obstacles and the person.
pub trait World {
    /// Obstacles at time `t` (s), appended to the cleared `out`.
    fn obstacles(&mut self, t: f64, out: &mut Vec<Obstacle>);

    /// Sees the robot at `t` (s) before [`World::obstacles`] is asked: TCP position (m, base
    /// frame). Lets a scripted person react to where the gripper is. Default: ignored.
    fn observe(&mut self, _t: f64, _tcp: &Point3<f64>) {}

    /// The human state the controller gets at `t`, given the current smallest robot–person
    /// distance (m, ∞ without a person). Default: nobody there.
    fn human(&mut self, _t: f64, _human_distance: f64) -> HumanState {
        HumanState::default()
    }
}

/// Static obstacles.
#[derive(Debug, Clone)]
pub struct StaticWorld(pub Vec<Obstacle>);

impl World for StaticWorld {
    fn obstacles(&mut self, _t: f64, out: &mut Vec<Obstacle>) {
        out.extend(self.0.iter().cloned());
    }
}

/// Where the robot starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Start {
    /// Joint positions (rad).
    Joints(JointVector),
    /// TCP position (m, base frame), reached from `Setup::ready` by the controller before the
    /// run (no obstacles; not part of the figures); orientation as at the ready pose.
    Position(Vector3<f64>),
}

/// A scenario ready to run.
pub struct Setup {
    /// Name (for the summary).
    pub name: String,
    /// Ready configuration (rad): tool pointing down above the table.
    pub ready: JointVector,
    /// Start of the run.
    pub start: Start,
    /// Motions in order.
    pub goals: Vec<Goal>,
    /// Obstacles and person.
    pub world: Box<dyn World>,
    /// Objects on the table for the gripper (stacking blocks).
    pub objects: Vec<SceneObject>,
    /// Run at most this long (s).
    pub duration_s: f64,
    /// End the run this long after the last goal is reached (s); `None` runs to `duration_s`.
    pub settle_s: Option<f64>,
    /// Controller configuration.
    pub controller: ControllerConfig,
    /// Rate of the distance measurements the controller gets (Hz): 1000 = every step, 30 =
    /// a depth camera's rate. The figures are measured every step regardless.
    pub distance_rate_hz: f64,
    /// Only the hand links count for `collisions` (Fig. 5.5–5.6 judge the end effector).
    pub hand_collisions_only: bool,
}

impl std::fmt::Debug for Setup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Setup").field("name", &self.name).field("goals", &self.goals).finish_non_exhaustive()
    }
}

/// The JSON summary of one run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Smallest robot–obstacle distance over the run (m; negative = penetration).
    pub min_distance_m: f64,
    /// Smallest distance of the hand links (those moved by the last joint) (m).
    pub min_hand_distance_m: f64,
    /// TCP–goal distance at the end (m).
    pub final_goal_error_m: f64,
    /// max over time and joints of |q̇ᵢ| / q̇ᵢ,max, as executed by the simulator.
    pub max_joint_velocity_ratio: f64,
    /// Time the last goal was reached for good (s); `null` when the run ends outside tolerance.
    pub time_to_goal_s: Option<f64>,
    /// Contacts: times a counted link went from clear to touching (distance ≤ 0).
    pub collisions: u32,
    /// Goals reached (within tolerance) out of `goals_total`.
    pub goals_reached: usize,
    /// Goals of the scenario.
    pub goals_total: usize,
    /// Where the obstacle distances come from.
    pub distance_source: &'static str,
    /// Rate of the distances given to the controller (Hz).
    pub distance_rate_hz: f64,
    /// Simulated time run (s).
    pub duration_s: f64,
    /// Controller steps that faulted (stale / bad input).
    pub faults: u64,
    /// Time with the person tracked as interacting (s): speed scaled to `interaction_speed`.
    pub interaction_time_s: f64,
    /// Commanded nominal speeds seen (m/s, α_h × far speed, rounded to mm/s), ascending.
    pub speeds_m_s: Vec<f64>,
    /// Final positions of the scene objects (name, [x, y, z] m).
    pub objects: Vec<(String, [f64; 3])>,
}

/// A scene with a table (top at z = 0) and the given objects, ready joints `ready` (rad).
fn scene(ready: &JointVector, objects: Vec<SceneObject>) -> Result<Scene> {
    // `cowork_sim` exposes the scene as data (its table type is not public): build it as such.
    let value = serde_json::json!({
        "description": "scenario",
        "robot": { "initial_joints_deg": ready.iter().map(|q| q.to_degrees()).collect::<Vec<_>>() },
        "table": { "size": [1.4, 1.8, 0.04], "pose": { "position": [0.45, 0.0, -0.02] } },
        "objects": objects,
        "camera": {
            "frame_id": "camera_depth_optical_frame",
            "pose": { "position": [1.9, 0.0, 0.9], "look_at": [0.45, 0.0, 0.2] },
            "width": 640, "height": 480, "fx": 525.0, "fy": 525.0, "cx": 319.5, "cy": 239.5,
            "rate_hz": 30.0
        }
    });
    serde_json::from_value(value).map_err(|e| Error::Scene { message: e.to_string() })
}

/// Drives the simulator from its ready pose to TCP position `target` with no obstacles.
fn go_to_start(sim: &mut Simulator, ctl_cfg: &ControllerConfig, target: Vector3<f64>) -> Result<()> {
    let mut cfg = *ctl_cfg;
    cfg.ik.posture_gain = 0.0;
    let mut ctl = DsController::new(sim.model().clone(), cfg)?;
    let mut out = ControlOutput::default();
    let cmd = MotionCommand {
        id: 1,
        primitive: Primitive::Linear(Linear { gain: 3.0 }),
        goal: target,
        orientation: None,
        end_effector_avoidance: false,
    };
    let dt = ctl_cfg.period_s;
    let mut err = f64::INFINITY;
    for k in 0..20_000 {
        let t = k as f64 * dt;
        let input = ControlInput {
            time: t,
            q: *sim.joint_positions(),
            command: cmd,
            distances: Distances::clear(t),
            human: HumanInput { stamp: t, state: HumanState::default() },
        };
        // Faults cannot happen here except an unreachable start, reported below.
        let _ = ctl.step(&input, &mut out);
        err = out.diagnostics.goal_error_m;
        if err < 5e-4 && out.qdot.norm() < 1e-2 {
            sim.hold();
            return Ok(());
        }
        sim.set_velocity_command(out.qdot.as_slice()).ok();
        sim.step();
    }
    Err(Error::StartNotReached { target: [target.x, target.y, target.z], error_m: err, time_s: 20.0 })
}

/// One row of the trajectory CSV.
const CSV_HEADER: &str = "t_s,x_m,y_m,z_m,goal_index,goal_error_m,min_distance_m,min_link,alpha,status,q1,q2,q3,q4,q5,q6,q7,qd1,qd2,qd3,qd4,qd5,qd6,qd7";

/// Runs `setup` on `model`; writes the trajectory to `csv` (every `csv_every` steps) if given.
pub fn run(model: &RobotModel, mut setup: Setup, mut csv: Option<(&mut dyn Write, usize)>) -> Result<Summary> {
    let cfg = setup.controller;
    let params = SimParams { step_s: cfg.period_s, drop_released_objects: false, ..SimParams::default() };
    let mut sim = Simulator::new(model.clone(), scene(&setup.ready, setup.objects.clone())?, params)?;
    if let Start::Position(x) = setup.start {
        go_to_start(&mut sim, &cfg, x)?;
    } else if let Start::Joints(q) = setup.start {
        let s = scene(&q, setup.objects.clone())?;
        sim = Simulator::new(model.clone(), s, SimParams { step_s: cfg.period_s, drop_released_objects: false, ..SimParams::default() })?;
    }
    let t0_ns = sim.time_ns();
    let debug = std::env::var_os("COWORK_SCENARIO_DEBUG").is_some();
    if debug {
        let p = sim.link_poses();
        eprintln!("start q {:?}", sim.joint_positions().as_slice());
        for l in 0..model.link_count() {
            eprintln!("start link {l} origin {:?}", p.get(l).translation.vector.as_slice());
        }
    }
    let mut ctl = DsController::new(model.clone(), cfg)?;
    let ee_first = ctl.end_effector_first_link();
    let geometry = LinkGeometry::new(model, cfg.modulation.influence_distance.min(2.0).max(0.5))?;
    let limits = *model.joint_limits();
    let dt = cfg.period_s;
    let every = ((1.0 / (setup.distance_rate_hz * dt)).round() as u64).max(1);

    let mut obstacles = Vec::new();
    let mut latched = Distances::clear(0.0);
    let mut out = ControlOutput::default();
    let mut goal_index = 0usize;
    let mut reached = vec![false; setup.goals.len()];
    let mut in_tol_since: Option<f64> = None;
    let mut last_entry: Option<f64> = None;
    let mut all_done_at: Option<f64> = None;
    let mut s = Summary {
        scenario: setup.name.clone(),
        min_distance_m: f64::INFINITY,
        min_hand_distance_m: f64::INFINITY,
        final_goal_error_m: f64::NAN,
        max_joint_velocity_ratio: 0.0,
        time_to_goal_s: None,
        collisions: 0,
        goals_reached: 0,
        goals_total: setup.goals.len(),
        distance_source: "analytic (parry3d exact distances, link convex hulls vs obstacle shapes)",
        distance_rate_hz: 1.0 / (every as f64 * dt),
        duration_s: 0.0,
        faults: 0,
        interaction_time_s: 0.0,
        speeds_m_s: Vec::new(),
        objects: Vec::new(),
    };
    let mut touching = false;
    if let Some((w, _)) = csv.as_mut() {
        writeln!(w, "{CSV_HEADER}").map_err(|source| Error::Io { path: "csv".into(), source })?;
    }
    let steps = (setup.duration_s / dt).ceil() as u64;
    for k in 0..steps {
        let t = k as f64 * dt;
        obstacles.clear();
        setup.world.observe(t, &Point3::from(sim.link_poses().get(model.tip_link()).translation.vector));
        setup.world.obstacles(t, &mut obstacles);
        let (dist, closest) = geometry.distances(sim.link_poses(), &obstacles, t);
        if k % every == 0 {
            latched = dist;
        }
        // Figures, every step.
        let mut hand_min = f64::INFINITY;
        for l in ee_first..dist.count {
            if dist.links[l].valid {
                hand_min = hand_min.min(dist.links[l].distance);
            }
        }
        let Closest { distance, human_distance, .. } = closest;
        s.min_distance_m = s.min_distance_m.min(distance);
        s.min_hand_distance_m = s.min_hand_distance_m.min(hand_min);
        let counted = if setup.hand_collisions_only { hand_min } else { distance };
        let now_touching = counted <= 0.0;
        if now_touching && !touching {
            s.collisions += 1;
        }
        touching = now_touching;

        let human = setup.world.human(t, human_distance);
        if human.present && human.mode == HumanMode::Interaction && !human.stopped {
            s.interaction_time_s += dt;
        }
        let goal = setup.goals[goal_index];
        let input = ControlInput {
            time: t,
            q: *sim.joint_positions(),
            command: MotionCommand {
                id: goal_index as u32 + 1,
                primitive: goal.primitive,
                goal: goal.position,
                orientation: None,
                end_effector_avoidance: goal.end_effector_avoidance,
            },
            distances: latched,
            human: HumanInput { stamp: t, state: human },
        };
        if ctl.step(&input, &mut out).is_err() {
            s.faults += 1;
        }
        let speed = (out.diagnostics.alpha * cfg.scaling.far_speed * 1000.0).round() / 1000.0;
        if matches!(out.status, Status::Running | Status::Converged) && out.diagnostics.alpha > 0.0 {
            // The resume ramp passes through every value; record the plateaus only.
            if (out.diagnostics.alpha - 1.0).abs() < 1e-9
                || (out.diagnostics.alpha - cfg.scaling.interaction_speed / cfg.scaling.far_speed).abs() < 1e-9
            {
                if !s.speeds_m_s.contains(&speed) {
                    s.speeds_m_s.push(speed);
                }
            }
        }
        // lwr_sim rejects nothing the controller sends (finite, 7 values).
        sim.set_velocity_command(out.qdot.as_slice()).ok();
        sim.step();
        let qd = sim.joint_velocities();
        for i in 0..qd.len() {
            s.max_joint_velocity_ratio = s.max_joint_velocity_ratio.max(qd[i].abs() / limits[i].velocity);
        }

        // Goal bookkeeping on the state after the step.
        let x = sim.link_poses().get(model.tip_link()).translation.vector;
        let err = (x - goal.position).norm();
        let within = err <= cfg.goal_tolerance_m;
        if within {
            if in_tol_since.is_none() {
                in_tol_since = Some(t + dt);
                last_entry = Some(t + dt);
            }
        } else {
            in_tol_since = None;
        }
        if let Some((w, n)) = csv.as_mut()
            && k % (*n as u64) == 0
        {
            let status = match out.status {
                Status::Running => "running",
                Status::Converged => "converged",
                Status::Held(_) => "held",
            };
            let q = sim.joint_positions();
            writeln!(
                w,
                "{:.4},{:.5},{:.5},{:.5},{},{:.5},{:.5},{},{:.4},{},{}",
                t,
                x.x,
                x.y,
                x.z,
                goal_index,
                err,
                distance,
                closest.link.map_or(-1, |l| l as i64),
                out.diagnostics.alpha,
                status,
                q.iter().chain(qd.iter()).map(|v| format!("{v:.5}")).collect::<Vec<_>>().join(",")
            )
            .map_err(|source| Error::Io { path: "csv".into(), source })?;
        }
        if let Some(since) = in_tol_since {
            if !reached[goal_index] {
                reached[goal_index] = true;
                if let Some(g) = goal.gripper {
                    sim.command_gripper(g);
                }
            }
            let last = goal_index + 1 == setup.goals.len();
            if !last
                && t + dt - since >= goal.dwell_s
                && t + dt >= setup.goals[goal_index + 1].not_before_s
            {
                goal_index += 1;
                in_tol_since = None;
            } else if last && all_done_at.is_none() {
                all_done_at = Some(t + dt);
            }
        }
        if let (Some(done), Some(settle)) = (all_done_at, setup.settle_s)
            && t + dt >= done + settle
        {
            break;
        }
    }
    if debug {
        eprintln!("end q {:?}", sim.joint_positions().as_slice());
        for o in &obstacles {
            let (d, _) = geometry.distances(sim.link_poses(), std::slice::from_ref(o), 0.0);
            for l in 0..d.count {
                if d.links[l].valid && d.links[l].distance < 0.05 {
                    eprintln!("end: link {l} – {}: {:.4} m at {:?} / {:?}", o.name, d.links[l].distance, d.links[l].robot_point.coords.as_slice(), d.links[l].obstacle_point.coords.as_slice());
                }
            }
        }
    }
    let x = sim.link_poses().get(model.tip_link()).translation.vector;
    let last_goal = setup.goals[setup.goals.len() - 1].position;
    s.final_goal_error_m = (x - last_goal).norm();
    s.goals_reached = reached.iter().filter(|r| **r).count();
    if goal_index + 1 == setup.goals.len() && s.final_goal_error_m <= cfg.goal_tolerance_m {
        s.time_to_goal_s = last_entry;
    }
    s.duration_s = (sim.time_ns() - t0_ns) as f64 * 1e-9;
    s.speeds_m_s.sort_by(f64::total_cmp);
    s.objects = sim
        .objects()
        .iter()
        .map(|o| {
            let p = o.pose.translation.vector;
            (o.name.clone(), [p.x, p.y, p.z])
        })
        .collect();
    Ok(s)
}

/// TCP position of `model` at joint positions `q` (m, base frame).
pub fn tcp(model: &RobotModel, q: &JointVector) -> Point3<f64> {
    Point3::from(model.link_pose(q, model.tip_link()).translation.vector)
}
