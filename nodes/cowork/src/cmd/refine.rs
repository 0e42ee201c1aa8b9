//! `cowork experiment refine-goal` (thesis Sec. 4.1.3, Fig. 4.3–4.4): incremental kinesthetic
//! refinement of a pick-and-place in the graph.
//!
//! Per trial (seed): five synthetic demonstrations of a pick-and-place from the pick point P to
//! the goal g (minimum-jerk with a lift, durations, arcs and end points drawn from the seed)
//! teach an HMM primitive (left-to-right, 7 states, 1 Gaussian, η = 0.7), stored in a primitive
//! database of the trial (`cowork_manager`). `lwr_sim` (execute mode: a push is reported on
//! `/lwr/external_wrench`, the arm moves only as commanded; no depth camera) and
//! `ds_controller` (task transition control on, from `--ds-params`) run as processes on a
//! private DDS domain and the simulated clock. The runner plays the rest of the world: it sends
//! "no obstacle" distances and "nobody close" human states (this experiment has no camera, as
//! in the thesis), moves the tool back to P between executions (a linear DS with the tool
//! pointing down), sends the HMM as a `MotionCommand` of kind `KIND_HMM`, and is the person
//! ([`cowork_people::guide::Guide`]): from t_c = 3 s on, pressing the tool on `/external_wrench`
//! (≥ 16 N, above f_s) towards the robot's own path bent to end at g′.
//!
//! Sequence: execution 0 alone; then per round an execution with the person, the HMM refined
//! with what the tool did (read from `/lwr/world`, never from what was commanded) after the
//! first contact (as `lwr_sim` reported it) and saved atomically with its history
//! ([`cowork_manager::Database::refine_hmm_saved`]), and an execution alone. The trial succeeds
//! when an execution alone ends within the threshold of g′ — the primitive's own reproduction
//! error at g in execution 0, at least 10 mm — within `--refinements` rounds (thesis: 3).
//! Reported per execution: tool end point's distance to g′ (mm) and the largest distance
//! between its path and execution 0's before the first contact (mm).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context, Result, bail};
use cowork_ds::tracker::{DEFAULT_GAIN, PathTracker};
use cowork_ds::TtcConfig;
use cowork_graph::Graph;
use cowork_manager::Database;
use cowork_motion::Demonstration;
use cowork_motion::hmm::{HmmConfig, HmmPrimitive};
use cowork_motion::model::Model;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3 as RosVector3, Wrench, WrenchStamped};
use cowork_msgs::msg::{HumanState, LinkDistance, LinkDistances, MotionCommand, MotionStatus, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Float64MultiArray;
use cowork_msgs::std_msgs::Header;
use cowork_msgs::topics::{self, Delivery};
use cowork_people::guide::Guide;
use cowork_robot::{JointVector, RobotModel};
use cowork_ros::{NodeConfig, Publisher, RosNode, Subscription, shutdown};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use super::experiment::ExperimentArgs;

/// The experiments of this module (refine-elbow in [`super::refine_elbow`]).
pub const NAMES: [&str; 2] = ["refine-goal", "refine-elbow"];

/// Pick point P (m, base frame of `config/scenes/refine.yaml`).
pub const PICK: [f64; 3] = [0.40, 0.25, 0.10];
/// Learned goal g: the thesis's [−0.6, 0.14, 0.027] m in this base frame (turned 180° about z).
pub const GOAL: [f64; 3] = [0.6, -0.14, 0.027];
/// New goal g′: the thesis's [−0.5, 0.006, 0.027] m in this base frame.
pub const NEW_GOAL: [f64; 3] = [0.5, -0.006, 0.027];
/// The person's first contact, s after the start of an execution (thesis: "about 3 seconds").
pub const T_CONTACT_S: f64 = 3.0;
/// Sampling of the demonstrations, of the generated path and of the executed path (s).
pub const SAMPLE_S: f64 = 0.01;
/// An execution is watched this long after its path ends (s); the end point is the mean tool
/// position over the last [`END_WINDOW_S`] of it.
pub const SETTLE_S: f64 = 1.0;
/// See [`SETTLE_S`] (s).
pub const END_WINDOW_S: f64 = 0.2;
/// The HMM's key in the trial's primitive database.
pub const HMM_ID: &str = "pick_place";
/// Least threshold of "reached g′" (m).
pub const MIN_THRESHOLD_M: f64 = 0.01;
/// Executions the thesis needed (Sec. 4.1.3).
pub const THESIS_EXECUTIONS: u32 = 3;

/// The learned model's settings (Sec. 4.1.3: 7 states, 1 Gaussian; η the weight of the new
/// demonstration in the refinement).
pub fn hmm_config() -> HmmConfig {
    HmmConfig { states: 7, forgetting: 0.7, ..HmmConfig::default() }
}

/// Five demonstrations of the pick-and-place from P to g, drawn from `seed`: 4.6–5.4 s,
/// a lift of 7–12 cm and a sideways arc of up to ±1.5 cm at mid-way, the object put down
/// within ±3 mm of g per axis, then 0.5 s at rest (m, base frame).
pub fn demonstrations(seed: u64) -> Result<Vec<Demonstration>> {
    demonstrations_lasting(seed, 4.6..5.4)
}

/// [`demonstrations`] lasting `durations` (s) each, drawn from `seed`.
pub fn demonstrations_lasting(seed: u64, durations: std::ops::Range<f64>) -> Result<Vec<Demonstration>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..5)
        .map(|_| {
            let duration = rng.random_range(durations.clone());
            let bow = [rng.random_range(-0.015..0.015), rng.random_range(-0.015..0.015), rng.random_range(0.07..0.12)];
            let end: Vec<f64> = GOAL.iter().map(|g| g + rng.random_range(-0.003..0.003)).collect();
            Demonstration::minimum_jerk(&PICK, &end, &bow, duration, 0.5, SAMPLE_S).context("synthetic demonstration")
        })
        .collect()
}

/// One execution, as the simulated world saw it.
#[derive(Debug, Clone, Serialize)]
pub struct ExecutionRow {
    /// 0 for the learned primitive alone, then 1, 2, … in the order run.
    pub index: u32,
    /// Model version executed (1 = learned, +1 per refinement).
    pub version: u32,
    /// The person guided the tool.
    pub pushed: bool,
    /// First push reported by lwr_sim of at least f_i, s after the command.
    pub first_contact_s: Option<f64>,
    /// Largest push reported (N).
    pub max_push_n: f64,
    /// From the runner's command to ds_controller's first status of it (s, sim clock).
    pub start_delay_s: Option<f64>,
    /// Tool end point (m, base frame).
    pub end_m: [f64; 3],
    /// Distance of the end point to g′ (mm).
    pub error_at_new_goal_mm: f64,
    /// Distance of the end point to g (mm).
    pub error_at_goal_mm: f64,
    /// Largest distance between this path and execution 0's before the reference contact
    /// time (the first push of the first guided execution; [`T_CONTACT_S`] before it) (mm).
    pub max_deviation_before_contact_mm: f64,
    /// The same, in space only: the largest distance from this path's points before that time
    /// to execution 0's path before it (a path followed faster or slower is no deviation) (mm).
    pub max_path_offset_before_contact_mm: f64,
    /// Duration of the generated path (s).
    pub path_duration_s: f64,
    /// Refinement made from this execution: states kept / changed.
    pub kept_states: Option<Vec<usize>>,
    /// See `kept_states`.
    pub changed_states: Option<Vec<usize>>,
}

/// One trial.
#[derive(Debug, Clone, Serialize)]
pub struct RefineTrial {
    /// Seed.
    pub seed: u64,
    /// An execution alone ended within the threshold of g′ within `--refinements` rounds.
    pub success: bool,
    /// Why not (empty on success).
    pub reason: String,
    /// Simulated seconds from the first command to the end.
    pub duration_s: f64,
    /// Wall-clock seconds of the trial.
    pub wall_s: f64,
    /// Refined executions (rounds) until an execution alone reached g′; thesis: 3.
    pub executions_to_reach: Option<u32>,
    /// Threshold of "reached" (mm).
    pub threshold_mm: f64,
    /// Every execution.
    pub executions: Vec<ExecutionRow>,
    /// The trial's primitive database.
    pub database: String,
    /// Not judged here (nobody is seen; no camera).
    pub min_distance_m: Option<f64>,
    /// Not judged here.
    pub collisions: Option<u32>,
}

/// The run.
#[derive(Debug, Clone, Serialize)]
pub struct RefineRun {
    /// Experiment name.
    pub experiment: String,
    /// Trials.
    pub trials: Vec<RefineTrial>,
    /// Summary.
    pub summary: Summary,
}

/// Summary of a run.
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    /// Trials run.
    pub trials: usize,
    /// Trials that reached g′.
    pub successes: usize,
    /// Median refined executions to reach g′ over the successful trials.
    pub executions_to_reach_median: Option<f64>,
    /// Largest refined executions to reach g′.
    pub executions_to_reach_max: Option<u32>,
    /// Median over trials of the last execution alone's distance to g′ (mm).
    pub final_error_at_new_goal_mm_median: Option<f64>,
    /// Largest deviation before the contact of any execution alone (mm).
    pub max_deviation_before_contact_mm: Option<f64>,
    /// Largest path offset (space only) before the contact of any execution alone (mm).
    pub max_path_offset_before_contact_mm: Option<f64>,
    /// The thesis's figure.
    pub thesis_executions: u32,
}

pub(super) fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) })
}

impl Summary {
    fn of(trials: &[RefineTrial]) -> Self {
        let reached: Vec<u32> = trials.iter().filter_map(|t| t.executions_to_reach).collect();
        let alone = |t: &RefineTrial| t.executions.iter().filter(|e| !e.pushed && e.index > 0).cloned().collect::<Vec<_>>();
        Self {
            trials: trials.len(),
            successes: trials.iter().filter(|t| t.success).count(),
            executions_to_reach_median: median(reached.iter().map(|&n| f64::from(n)).collect()),
            executions_to_reach_max: reached.iter().copied().max(),
            final_error_at_new_goal_mm_median: median(
                trials.iter().filter_map(|t| alone(t).last().map(|e| e.error_at_new_goal_mm)).collect(),
            ),
            max_deviation_before_contact_mm: trials
                .iter()
                .flat_map(alone)
                .map(|e| e.max_deviation_before_contact_mm)
                .reduce(f64::max),
            max_path_offset_before_contact_mm: trials
                .iter()
                .flat_map(alone)
                .map(|e| e.max_path_offset_before_contact_mm)
                .reduce(f64::max),
            thesis_executions: THESIS_EXECUTIONS,
        }
    }
}

/// The TTC keys of ds_controller's parameter file (the rest is ds_controller's business).
#[derive(Debug, Default, Deserialize)]
#[serde(default)]
struct DsParamsTtc {
    controller: DsControllerTtc,
}

#[derive(Debug, Default, Deserialize)]
#[serde(default)]
struct DsControllerTtc {
    ttc: TtcConfig,
}

/// Checks the flags, the binaries and ds_controller's TTC parameters shared by refine-goal and
/// refine-elbow; the robot model and the TTC settings.
pub(super) fn prepare(args: &ExperimentArgs) -> Result<(RobotModel, TtcConfig)> {
    if args.trials == 0 {
        bail!("--trials must be at least 1");
    }
    if args.max {
        bail!("{} needs a paced clock (--rate): the person pushes on the simulated clock", args.name);
    }
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate {} must be > 0", args.rate);
    }
    if args.refinements == 0 {
        bail!("--refinements must be at least 1");
    }
    let root = crate::cmd::config_root()?;
    for bin in ["lwr_sim", "ds_controller"] {
        let p = args.bin_dir.join(bin);
        if !p.is_file() {
            bail!("{} missing; build with: cargo build --release --bins -p {bin}", p.display());
        }
    }
    let ds: DsParamsTtc = cowork_ros::params::load(&args.ds_params, "ds_controller")
        .with_context(|| format!("--ds-params {}", args.ds_params.display()))?;
    if !ds.controller.ttc.enabled {
        bail!("--ds-params {}: controller.ttc.enabled is false; {} needs task transition control", args.ds_params.display(), args.name);
    }
    let mut ttc = ds.controller.ttc;
    if let Some(f) = args.switch_force {
        ttc.switch_force = f;
        ttc.validate().with_context(|| format!("--switch-force {f} with --ds-params {}", args.ds_params.display()))?;
    }
    let model = RobotModel::from_urdf_file(root.join("config/robot/lwr4plus.urdf"))?;
    Ok((model, ttc))
}

/// ds_controller's parameter file for a trial: `--ds-params` itself, or a copy in `dir` with
/// `--switch-force` as controller.ttc.switch_force.
fn ds_params(args: &ExperimentArgs, dir: &Path) -> Result<PathBuf> {
    let Some(f) = args.switch_force else { return Ok(args.ds_params.clone()) };
    let src = &args.ds_params;
    let text = std::fs::read_to_string(src).with_context(|| format!("reading {}", src.display()))?;
    let mut v: serde_yaml_ng::Value = serde_yaml_ng::from_str(&text).with_context(|| format!("parsing {}", src.display()))?;
    let ttc = v
        .get_mut("ds_controller")
        .and_then(|n| n.get_mut("ros__parameters"))
        .and_then(|n| n.get_mut("controller"))
        .and_then(|n| n.get_mut("ttc"))
        .and_then(|n| n.as_mapping_mut())
        .with_context(|| format!("{}: no ds_controller.ros__parameters.controller.ttc", src.display()))?;
    ttc.insert("switch_force".into(), f.into());
    let out = dir.join("ds_controller.yaml");
    crate::cmd::output::write(&out, serde_yaml_ng::to_string(&v)?)?;
    Ok(out)
}

/// Runs `cowork experiment refine-goal` (or refine-elbow).
pub fn run(args: &ExperimentArgs) -> Result<()> {
    if args.name == "refine-elbow" {
        return super::refine_elbow::run(args);
    }
    let (model, ttc) = prepare(args)?;
    shutdown::install();
    let mut trials = Vec::new();
    for k in 0..args.trials {
        if shutdown::requested() {
            break;
        }
        let seed = args.seed + u64::from(k);
        let t = run_trial(args, &model, seed, k, ttc.insert_force)?;
        print_trial(&t);
        trials.push(t);
        if let Some(path) = &args.json {
            write_json(path, &RefineRun { experiment: args.name.clone(), summary: Summary::of(&trials), trials: trials.clone() })?;
        }
    }
    let summary = Summary::of(&trials);
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}

pub(super) fn write_json(path: &Path, run: &impl Serialize) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    crate::cmd::output::write(path, serde_json::to_string_pretty(run)? + "\n")
}

pub(super) fn opt_mm(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.2}"))
}

fn print_trial(t: &RefineTrial) {
    println!("refine-goal seed {}: {}{}", t.seed, if t.success { "success" } else { "FAILED" }, if t.reason.is_empty() { String::new() } else { format!(": {}", t.reason) });
    println!("  exec  version  pushed  contact(s)  max push(N)  EE error at g' (mm)  before contact: max dev. / path offset (mm)  states kept/changed");
    for e in &t.executions {
        println!(
            "  {:>4}  {:>7}  {:>6}  {:>10}  {:>11.1}  {:>19.1}  {:>23.1} / {:>5.1}  {}",
            e.index,
            e.version,
            if e.pushed { "yes" } else { "no" },
            opt_mm(e.first_contact_s),
            e.max_push_n,
            e.error_at_new_goal_mm,
            e.max_deviation_before_contact_mm,
            e.max_path_offset_before_contact_mm,
            e.kept_states.as_ref().zip(e.changed_states.as_ref()).map_or("-".into(), |(k, c)| format!("{k:?} / {c:?}"))
        );
    }
    let reached = match t.executions_to_reach {
        Some(n) => format!("reached g' (within {:.1} mm) on its own after {n} refined execution(s)", t.threshold_mm),
        None => format!("did not reach g' (within {:.1} mm) on its own", t.threshold_mm),
    };
    println!("  {reached} (thesis: {THESIS_EXECUTIONS}); {:.1} s simulated, {:.0} s wall", t.duration_s, t.wall_s);
}

/// lwr_sim's parameter file with the depth camera off (nothing here looks at it), written
/// into `dir`.
fn sim_params(dir: &Path) -> Result<PathBuf> {
    let src = cowork_ros::config::resolve(Path::new("config/lwr_sim.yaml"));
    let text = std::fs::read_to_string(&src).with_context(|| format!("reading {}", src.display()))?;
    let mut v: serde_yaml_ng::Value = serde_yaml_ng::from_str(&text).with_context(|| format!("parsing {}", src.display()))?;
    let depth = v
        .get_mut("lwr_sim")
        .and_then(|n| n.get_mut("ros__parameters"))
        .and_then(|n| n.get_mut("depth"))
        .and_then(|n| n.get_mut("enabled"))
        .with_context(|| format!("{}: no lwr_sim.ros__parameters.depth.enabled", src.display()))?;
    *depth = serde_yaml_ng::Value::Bool(false);
    let out = dir.join("lwr_sim.yaml");
    crate::cmd::output::write(&out, serde_yaml_ng::to_string(&v)?)?;
    Ok(out)
}

/// Who pushes the arm during an execution.
pub(super) trait Person {
    /// The push `t` s after the command, with the tool at `tool` (m, base frame) and the joints
    /// at `q` (rad): the frame it is expressed in and applied at (`""`: base frame, at the
    /// tool; a link name: that link's frame, on that link) and the force (N), or none.
    fn push(&self, t: f64, tool: &Vector3<f64>, q: &JointVector) -> Option<(String, Vector3<f64>)>;
}

impl Person for Guide {
    fn push(&self, t: f64, tool: &Vector3<f64>, _q: &JointVector) -> Option<(String, Vector3<f64>)> {
        Guide::push(self, t, tool).map(|f| (String::new(), f))
    }
}

/// The runner's side of the graph.
pub(super) struct Io {
    pub(super) node: RosNode,
    world: Subscription<WorldState>,
    joints: Subscription<JointState>,
    ttc: Subscription<Float64MultiArray>,
    status: Subscription<MotionStatus>,
    reports: Subscription<WrenchStamped>,
    motion: Publisher<MotionCommand>,
    push: Publisher<WrenchStamped>,
    distances: Publisher<LinkDistances>,
    human: Publisher<HumanState>,
    link_names: Vec<String>,
    pub(super) model: RobotModel,
    /// Each model joint's index in `/joint_states` (from the first message's names).
    joint_order: Option<[usize; cowork_robot::DOF]>,
    /// Newest joint positions (stamp s, rad).
    pub(super) q: Option<(f64, JointVector)>,
    /// Joint positions with their stamps while recording.
    joint_samples: Vec<(f64, JointVector)>,
    /// ds_controller's distinct "guided: …" status reasons while recording (which TTC stacks).
    guided: Vec<String>,
    /// `/ds_controller/ttc` while recording: arrival (s) and [w1, w2, w3, push N].
    ttc_samples: Vec<(f64, [f64; 4])>,
    pub(super) insert_force: f64,
    last_feed: f64,
    /// Newest tool pose (stamp s, position m, orientation).
    tool: Option<(f64, Vector3<f64>, UnitQuaternion<f64>)>,
    /// Tool positions with their stamps while recording.
    samples: Vec<(f64, Vector3<f64>)>,
    recording: bool,
    /// Pushes of at least f_i reported by lwr_sim since armed: the first stamp and the largest.
    first_report: Option<f64>,
    max_report: f64,
    status_msg: Option<MotionStatus>,
    heard_status: bool,
    /// Command whose start is watched, and the stamp of ds_controller's first status of it.
    watch_id: u32,
    started_at: Option<f64>,
    /// Simulated seconds per wall-clock second (`--rate`).
    rate: f64,
}

fn header(t: f64, frame: &str) -> Header {
    Header { stamp: Time::from_secs_f64(t), frame_id: frame.into() }
}

impl Io {
    pub(super) fn now(&self) -> f64 {
        self.node.now().to_secs_f64()
    }

    /// Drains the subscriptions, feeds the controller's other inputs every 10 ms of simulated
    /// time; fails when a node died.
    pub(super) fn pump(&mut self, graph: &mut Graph) -> Result<f64> {
        // A node that died, or a stranger writing on the graph's domain, ends the trial.
        match graph.check_alive() {
            Ok(()) => {}
            Err(e @ cowork_graph::Error::Exited { .. }) => bail!("node died: {e}"),
            Err(e) => bail!("{e}"),
        }
        if shutdown::requested() {
            bail!("interrupted (Ctrl-C)");
        }
        while let Some(w) = self.world.take() {
            let p = &w.tool_pose;
            let x = Vector3::new(p.position.x, p.position.y, p.position.z);
            let o = &p.orientation;
            let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(o.w, o.x, o.y, o.z));
            let t = w.header.stamp.to_secs_f64();
            if self.recording {
                self.samples.push((t, x));
            }
            self.tool = Some((t, x, q));
        }
        while let Some(js) = self.joints.take() {
            if self.joint_order.is_none() {
                let order: Option<Vec<usize>> =
                    self.model.joint_names().iter().map(|n| js.name.iter().position(|m| m == n)).collect();
                self.joint_order = order.and_then(|o| o.try_into().ok());
            }
            let Some(order) = self.joint_order else { continue };
            if order.iter().any(|&i| i >= js.position.len()) {
                continue;
            }
            let q = JointVector::from_fn(|j, _| js.position[order[j]]);
            let t = js.header.stamp.to_secs_f64();
            if self.recording {
                self.joint_samples.push((t, q));
            }
            self.q = Some((t, q));
        }
        while let Some(m) = self.ttc.take() {
            if self.recording
                && let [w1, w2, w3, f] = m.data[..]
            {
                let t = self.now();
                self.ttc_samples.push((t, [w1, w2, w3, f]));
            }
        }
        while let Some(s) = self.status.take() {
            self.heard_status = true;
            if self.recording && s.reason.starts_with("guided") && !self.guided.contains(&s.reason) {
                self.guided.push(s.reason.clone());
            }
            if s.command_id == self.watch_id && self.started_at.is_none() {
                self.started_at = Some(s.header.stamp.to_secs_f64());
            }
            self.status_msg = Some(s);
        }
        while let Some(r) = self.reports.take() {
            let f = &r.wrench.force;
            let n = (f.x * f.x + f.y * f.y + f.z * f.z).sqrt();
            if n >= self.insert_force && self.first_report.is_none() {
                self.first_report = Some(r.header.stamp.to_secs_f64());
            }
            if n.is_finite() {
                self.max_report = self.max_report.max(n);
            }
        }
        let now = self.now();
        if self.node.clock_started() && (now - self.last_feed >= 0.01 || now < self.last_feed) {
            self.last_feed = now;
            let links = self.link_names.iter().map(|n| LinkDistance { link_name: n.clone(), ..Default::default() }).collect();
            self.distances.publish(LinkDistances {
                header: header(now, "lwr_base_link"),
                links,
                min_index: -1,
                backend: "none (refine-goal: no camera)".into(),
                ..Default::default()
            })?;
            self.human.publish(HumanState {
                header: header(now, "lwr_base_link"),
                mode: HumanState::MODE_FAR,
                speed_scale: 0.3,
                ..Default::default()
            })?;
        }
        std::thread::sleep(Duration::from_micros(500));
        Ok(now)
    }

    /// Wall-clock limit for `sim_s` simulated seconds (a loaded machine runs slower).
    fn wall_limit(&self, sim_s: f64) -> Instant {
        Instant::now() + cowork_ros::duration_s(sim_s / self.rate * 4.0 + 30.0)
    }

    pub(super) fn tool(&self) -> Result<(Vector3<f64>, UnitQuaternion<f64>)> {
        self.tool.map(|(_, x, q)| (x, q)).context("no /lwr/world from lwr_sim")
    }

    fn command(&self, id: u32, kind: u8, goal: &Vector3<f64>, orientation: Option<&UnitQuaternion<f64>>, json: String, gain: Option<f64>) -> Result<()> {
        let q = orientation.map_or(Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 1.0 }, |q| Quaternion { x: q.i, y: q.j, z: q.k, w: q.w });
        self.motion.publish(MotionCommand {
            header: header(self.now(), "lwr_base_link"),
            id,
            kind,
            label: HMM_ID.into(),
            parameters_json: json,
            parameters: gain.into_iter().collect(),
            goal: Pose { position: Point { x: goal.x, y: goal.y, z: goal.z }, orientation: q },
            nominal_speed: 0.0,
            hold_orientation: orientation.is_none(),
            end_effector_avoidance_off: false,
        })?;
        Ok(())
    }
}

/// What one execution did.
pub(super) struct Run {
    /// Tool path on the [`SAMPLE_S`] grid from the command over the generated path's duration.
    pub(super) path: Vec<Vector3<f64>>,
    /// Joint positions on the same grid (the newest report at or before each time; rad).
    pub(super) joints: Vec<JointVector>,
    pub(super) end: Vector3<f64>,
    pub(super) first_contact_s: Option<f64>,
    pub(super) max_push_n: f64,
    pub(super) sim_end: f64,
    pub(super) start_delay_s: Option<f64>,
    /// ds_controller's distinct "guided: …" reasons during the execution (the TTC stacks).
    pub(super) guided: Vec<String>,
    /// ds_controller's TTC blend during the execution: s after the command, [w1, w2, w3, push N].
    pub(super) ttc: Vec<(f64, [f64; 4])>,
}

/// Linear interpolation of stamped samples on the grid `t0 + k·dt`, k < n (clamped at the ends).
fn resample(samples: &[(f64, Vector3<f64>)], t0: f64, dt: f64, n: usize) -> Vec<Vector3<f64>> {
    let mut out = Vec::with_capacity(n);
    let mut j = 0;
    for k in 0..n {
        let t = t0 + k as f64 * dt;
        while j + 1 < samples.len() && samples[j + 1].0 <= t {
            j += 1;
        }
        let (ta, a) = samples[j];
        let p = match samples.get(j + 1) {
            Some(&(tb, b)) if t > ta && tb > ta => a + (b - a) * ((t - ta) / (tb - ta)).min(1.0),
            _ => a,
        };
        out.push(p);
    }
    out
}

/// The newest of the stamped `samples` at or before each time `t0 + k·dt`, k < n (the first
/// before it starts).
fn hold_last(samples: &[(f64, JointVector)], t0: f64, dt: f64, n: usize) -> Vec<JointVector> {
    let mut j = 0;
    (0..n)
        .map(|k| {
            let t = t0 + k as f64 * dt;
            while j + 1 < samples.len() && samples[j + 1].0 <= t {
                j += 1;
            }
            samples[j].1
        })
        .collect()
}

/// Largest distance from the first `n` points of `a` to the polyline of the first `n` of `b` (m).
pub(super) fn max_offset(a: &[Vector3<f64>], b: &[Vector3<f64>], n: usize) -> f64 {
    let b = &b[..n.min(b.len())];
    a.iter().take(n).map(|p| distance_to_path(p, b)).fold(0.0, f64::max)
}

/// Distance from `p` to the polyline `path` (m; NaN for an empty path).
pub(super) fn distance_to_path(p: &Vector3<f64>, path: &[Vector3<f64>]) -> f64 {
    let to_segment = |s: &[Vector3<f64>]| {
        let d = s[1] - s[0];
        let u = if d.norm_squared() > 0.0 { ((p - s[0]).dot(&d) / d.norm_squared()).clamp(0.0, 1.0) } else { 0.0 };
        (p - (s[0] + d * u)).norm()
    };
    match path.len() {
        0 => f64::NAN,
        1 => (p - path[0]).norm(),
        _ => path.windows(2).map(to_segment).fold(f64::INFINITY, f64::min),
    }
}

/// Largest distance between `a` and `b` over their first `n` samples (m).
pub(super) fn max_deviation(a: &[Vector3<f64>], b: &[Vector3<f64>], n: usize) -> f64 {
    a.iter().zip(b).take(n).map(|(p, q)| (p - q).norm()).fold(0.0, f64::max)
}

pub(super) struct Trial<'a> {
    pub(super) io: Io,
    pub(super) graph: Graph,
    next_id: u32,
    pub(super) pick: Vector3<f64>,
    down: UnitQuaternion<f64>,
    pub(super) args: &'a ExperimentArgs,
    /// At the pick point also wait (up to [`SETTLE_LINK_MAX_S`]) until this link's origin is
    /// within 3 mm of this position (m): the posture task brings the elbow back where the first
    /// execution started, so every execution starts from the same arm configuration.
    pub(super) settle_link: Option<(usize, Vector3<f64>)>,
}

/// Longest wait at the pick point for [`Trial::settle_link`] (s, simulated).
pub const SETTLE_LINK_MAX_S: f64 = 8.0;

impl Trial<'_> {
    /// Back to the pick point with the tool pointing down (linear DS, gain 2/s), until the
    /// tool has been within 0.5 mm of it for 0.3 s (and [`Trial::settle_link`] is met).
    pub(super) fn go_to_pick(&mut self) -> Result<()> {
        self.next_id += 1;
        let id = self.next_id;
        self.io.command(id, MotionCommand::KIND_LINEAR, &self.pick, Some(&self.down), String::new(), Some(2.0))?;
        let limit_s = 20.0 + if self.settle_link.is_some() { SETTLE_LINK_MAX_S } else { 0.0 };
        let deadline = self.io.wall_limit(limit_s);
        let t0 = self.io.now();
        let mut since: Option<f64> = None;
        loop {
            let now = self.io.pump(&mut self.graph)?;
            let (x, q) = self.io.tool()?;
            let close = (x - self.pick).norm() < 5e-4 && q.angle_to(&self.down) < 0.02;
            since = if close { since.or(Some(now)) } else { None };
            let settled = match (self.settle_link, self.io.q) {
                (Some((link, p)), Some((_, joints))) => (self.io.model.link_pose(&joints, link).translation.vector - p).norm() < 3e-3,
                _ => true,
            };
            if since.is_some_and(|s| now - s >= 0.3 && (settled || now - s >= SETTLE_LINK_MAX_S)) {
                return Ok(());
            }
            if Instant::now() > deadline || now - t0 > limit_s {
                bail!(
                    "the tool did not return to the pick point within {limit_s} s: {:.1} mm away; ds_controller: {}",
                    (x - self.pick).norm() * 1e3,
                    self.io.status_msg.as_ref().map_or("no /motion/status".into(), |s| format!("state {} {}", s.state, s.reason))
                );
            }
        }
    }

    /// Runs the HMM `json` (path `tracker`) from the pick point; with `person` somebody
    /// pushes. Returns what the arm did.
    pub(super) fn execute(&mut self, json: &str, tracker: &PathTracker, person: Option<&dyn Person>) -> Result<Run> {
        self.go_to_pick()?;
        let (x0, _) = self.io.tool()?;
        self.next_id += 1;
        let id = self.next_id;
        let duration = tracker.duration_s();
        let n = (duration / SAMPLE_S).round() as usize + 1;
        // The newest sample before the command starts the recording (interpolation at t = 0).
        self.io.samples.clear();
        if let Some((t, x, _)) = self.io.tool {
            self.io.samples.push((t, x));
        }
        self.io.joint_samples.clear();
        self.io.guided.clear();
        self.io.ttc_samples.clear();
        if let Some(q) = self.io.q {
            self.io.joint_samples.push(q);
        }
        self.io.recording = true;
        self.io.first_report = None;
        self.io.max_report = 0.0;
        self.io.watch_id = id;
        self.io.started_at = None;
        let t_cmd = self.io.now();
        self.io.command(id, MotionCommand::KIND_HMM, &tracker.end_from(&x0), None, json.to_owned(), None)?;
        let deadline = self.io.wall_limit(duration + SETTLE_S);
        let mut last_push = f64::NEG_INFINITY;
        let mut last_tool_stamp = f64::NEG_INFINITY;
        loop {
            let now = self.io.pump(&mut self.graph)?;
            let t = now - t_cmd;
            if t >= duration + SETTLE_S {
                break;
            }
            if let Some(s) = &self.io.status_msg
                && s.command_id == id
                && s.state == MotionStatus::STATE_ABORTED
            {
                bail!("ds_controller aborted the HMM command: {}", s.reason);
            }
            if Instant::now() > deadline {
                bail!("simulated time too slow: {t:.1} s of {:.1} s in the wall-clock limit", duration + SETTLE_S);
            }
            // The person reacts to where the arm is (/lwr/world, 100 Hz) every 5 ms.
            if let (Some(p), Some((stamp, x, _)), Some((_, q))) = (person, self.io.tool, self.io.q)
                && now - last_push >= 0.005
                && stamp > last_tool_stamp
            {
                last_push = now;
                last_tool_stamp = stamp;
                if let Some((frame, f)) = p.push(t, &x, &q) {
                    self.io.push.publish(WrenchStamped {
                        header: header(now, &frame),
                        wrench: Wrench { force: RosVector3 { x: f.x, y: f.y, z: f.z }, torque: RosVector3::default() },
                    })?;
                }
            }
        }
        self.io.recording = false;
        // How long ds_controller took to start the command (its first status of it), for the
        // JSON; the execution's clock stays the runner's send time.
        let start_delay_s = self.io.started_at.map(|t| t - t_cmd);
        let samples = std::mem::take(&mut self.io.samples);
        if samples.len() < 2 {
            bail!("no /lwr/world reports during the execution");
        }
        let joint_samples = std::mem::take(&mut self.io.joint_samples);
        if joint_samples.is_empty() {
            bail!("no /joint_states during the execution");
        }
        let end_from = t_cmd + duration + SETTLE_S - END_WINDOW_S;
        let tail: Vec<_> = samples.iter().filter(|s| s.0 >= end_from).map(|s| s.1).collect();
        if tail.is_empty() {
            bail!("no /lwr/world report in the last {END_WINDOW_S} s of the execution");
        }
        let end = tail.iter().sum::<Vector3<f64>>() / tail.len() as f64;
        Ok(Run {
            path: resample(&samples, t_cmd, SAMPLE_S, n),
            joints: hold_last(&joint_samples, t_cmd, SAMPLE_S, n),
            guided: std::mem::take(&mut self.io.guided),
            ttc: std::mem::take(&mut self.io.ttc_samples).into_iter().map(|(t, v)| (t - t_cmd, v)).collect(),
            end,
            first_contact_s: self.io.first_report.map(|t| t - t_cmd),
            max_push_n: self.io.max_report,
            sim_end: self.io.now(),
            start_delay_s,
        })
    }
}

/// The model as the controller gets it (with the null-space HMM `elbow` of the database on
/// link `link`, if given), its path (as ds_controller generates it) and its version.
pub(super) fn model_of(db: &Database, elbow: Option<(&str, &str)>) -> Result<(String, PathTracker, u32)> {
    let e = db.hmm(HMM_ID).context("the HMM is not in the database")?;
    let mut value = serde_json::to_value(Model::Hmm(e.model.clone()))?;
    if let Some((id, link)) = elbow {
        let ns = db.hmm(id).with_context(|| format!("the null-space HMM {id} is not in the database"))?;
        value["null_space"] = serde_json::json!({ "link": link, "model": Model::Hmm(ns.model.clone()) });
    }
    let json = value.to_string();
    let tr = e.model.generate(None, SAMPLE_S)?;
    let tracker = PathTracker::from_flat(&tr.pos, &tr.vel, SAMPLE_S, DEFAULT_GAIN)?;
    Ok((json, tracker, e.version))
}

pub(super) fn unix_now() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0)
}

fn run_trial(args: &ExperimentArgs, model: &RobotModel, seed: u64, k: u32, insert_force: f64) -> Result<RefineTrial> {
    let wall0 = Instant::now();
    let mut result = RefineTrial {
        seed,
        success: false,
        reason: String::new(),
        duration_s: 0.0,
        wall_s: 0.0,
        executions_to_reach: None,
        threshold_mm: MIN_THRESHOLD_M * 1e3,
        executions: Vec::new(),
        database: String::new(),
        min_distance_m: None,
        collisions: None,
    };
    let demos = demonstrations(seed)?;
    let (outcome, db_path) = with_graph(args, model, &demos, seed, k, insert_force, |trial, db, db_path| {
        wait_for_graph(trial)?;
        study(trial, db, db_path, seed, &mut result)
    })?;
    result.database = db_path.display().to_string();
    if let Err(e) = outcome {
        result.reason = format!("{e:#}");
    }
    result.wall_s = wall0.elapsed().as_secs_f64();
    Ok(result)
}

/// One trial's graph: learns the pick-and-place HMM from `demos` into a new primitive database
/// (`--logs`/NAME-SEED/lwr.primitives.json), starts `ds_controller` and `lwr_sim` on a private
/// domain, runs `study` on them and stops them. Returns what `study` returned and the
/// database's path.
pub(super) fn with_graph<R>(
    args: &ExperimentArgs,
    model: &RobotModel,
    demos: &[Demonstration],
    seed: u64,
    k: u32,
    insert_force: f64,
    study: impl FnOnce(&mut Trial<'_>, &mut Database, &Path) -> R,
) -> Result<(R, PathBuf)> {
    let tag = format!("{}-{seed}", args.name);
    let logs = args.logs.join(&tag);
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    // Learn the primitive and store it.
    let hmm = HmmPrimitive::fit(demos, &hmm_config()).context("learning the pick-and-place HMM")?;
    let db_path = Database::path(&logs, "lwr");
    let mut db = Database::new("lwr");
    db.insert_hmm(HMM_ID, "place(object)", hmm, unix_now())?;
    db.save(&db_path)?;

    let mut graph = Graph::leased(&format!("cowork experiment refine seed {k}"), &logs)?;
    let domain = graph.domain();
    let sim_params = sim_params(&logs)?;
    let mut node = RosNode::new("cowork_experiment", &NodeConfig { use_sim_time: true, domain_id: Some(domain), ..NodeConfig::default() })?;
    let io = Io {
        world: node.subscribe(&topics::WORLD)?,
        joints: node.subscribe(&topics::JOINT_STATES)?,
        ttc: node.subscribe(&topics::TTC_WEIGHTS)?,
        status: node.subscribe(&topics::MOTION_STATUS)?,
        reports: node.subscribe(&topics::LWR_EXTERNAL_WRENCH.reading(Delivery::BestEffort { depth: 2000 }))?,
        motion: node.advertise(&topics::MOTION_COMMAND)?,
        push: node.advertise(&topics::EXTERNAL_WRENCH)?,
        distances: node.advertise(&topics::FDED_DISTANCES)?,
        human: node.advertise(&topics::HUMAN_STATE)?,
        node,
        link_names: model.link_names().to_vec(),
        model: model.clone(),
        joint_order: None,
        q: None,
        joint_samples: Vec::new(),
        guided: Vec::new(),
        ttc_samples: Vec::new(),
        insert_force,
        last_feed: f64::NEG_INFINITY,
        tool: None,
        samples: Vec::new(),
        recording: false,
        first_report: None,
        max_report: 0.0,
        status_msg: None,
        heard_status: false,
        watch_id: 0,
        started_at: None,
        rate: args.rate,
    };
    let limit_s = 60.0 + 25.0 * (2.0 * f64::from(args.refinements) + 1.0);
    let wall_limit = format!("{:.0}", args.startup_timeout + limit_s / args.rate * 4.0 + 60.0);
    graph.spawn(
        "ds_controller",
        &args.bin_dir.join("ds_controller"),
        &["--params".into(), ds_params(args, &logs)?.display().to_string(), "--use-sim-time".into(), "--duration".into(), wall_limit],
    )?;
    graph.spawn(
        "lwr_sim",
        &args.bin_dir.join("lwr_sim"),
        &[
            "--scene".into(),
            "config/scenes/refine.yaml".into(),
            "--params".into(),
            sim_params.display().to_string(),
            "--wrench-mode".into(),
            "execute".into(),
            "--rate".into(),
            args.rate.to_string(),
            "--duration".into(),
            format!("{limit_s:.0}"),
        ],
    )?;
    std::fs::write(logs.join("pids.txt"), graph.pids().iter().map(|(n, p)| format!("{n} {p}\n")).collect::<String>())?;
    let mut trial = Trial {
        io,
        graph,
        next_id: 0,
        pick: Vector3::from(PICK),
        down: UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(0.0, 0.0, 1.0, 0.0)),
        args,
        settle_link: None,
    };
    let out = study(&mut trial, &mut db, &db_path);
    trial.graph.stop();
    Ok((out, db_path))
}

/// Waits until the graph runs: the clock, the tool pose, ds_controller's status, the joint
/// states and every topic matched.
pub(super) fn wait_for_graph(trial: &mut Trial<'_>) -> Result<()> {
    let deadline = Instant::now() + cowork_ros::duration_s(trial.args.startup_timeout);
    loop {
        trial.io.pump(&mut trial.graph)?;
        let matched = trial.io.motion.subscription_count(&trial.io.node) >= 1
            && trial.io.push.subscription_count(&trial.io.node) >= 1
            && trial.io.distances.subscription_count(&trial.io.node) >= 1
            && trial.io.human.subscription_count(&trial.io.node) >= 1
            && trial.io.reports.publisher_count(&trial.io.node) >= 1;
        if trial.io.node.clock_started() && trial.io.tool.is_some() && trial.io.q.is_some() && trial.io.heard_status && matched {
            return Ok(());
        }
        if Instant::now() > deadline {
            bail!(
                "graph not up after {} s (clock {}, /lwr/world {}, /joint_states {}, /motion/status {}, topics matched {matched})",
                trial.args.startup_timeout,
                trial.io.node.clock_started(),
                trial.io.tool.is_some(),
                trial.io.q.is_some(),
                trial.io.heard_status
            );
        }
    }
}

/// Runs the executions (see the module docs).
fn study(trial: &mut Trial<'_>, db: &mut Database, db_path: &Path, seed: u64, result: &mut RefineTrial) -> Result<()> {
    let sim0 = trial.io.now();
    let g = Vector3::from(GOAL);
    let g_new = Vector3::from(NEW_GOAL);
    let row = |index: u32, version: u32, pushed: bool, r: &Run, reference: &[Vector3<f64>], n_before: usize, duration: f64| ExecutionRow {
        index,
        version,
        pushed,
        first_contact_s: r.first_contact_s,
        max_push_n: r.max_push_n,
        start_delay_s: r.start_delay_s,
        end_m: [r.end.x, r.end.y, r.end.z],
        error_at_new_goal_mm: (r.end - g_new).norm() * 1e3,
        error_at_goal_mm: (r.end - g).norm() * 1e3,
        max_deviation_before_contact_mm: max_deviation(&r.path, reference, n_before) * 1e3,
        max_path_offset_before_contact_mm: max_offset(&r.path, reference, n_before) * 1e3,
        path_duration_s: duration,
        kept_states: None,
        changed_states: None,
    };
    // Execution 0: the learned primitive alone.
    let (json, tracker, version) = model_of(db, None)?;
    let first = trial.execute(&json, &tracker, None)?;
    let reproduction = (first.end - g).norm();
    let threshold = reproduction.max(MIN_THRESHOLD_M);
    result.threshold_mm = threshold * 1e3;
    let reference = first.path.clone();
    let mut n_before = (T_CONTACT_S / SAMPLE_S) as usize;
    result.executions.push(row(0, version, false, &first, &reference, n_before, tracker.duration_s()));
    result.duration_s = first.sim_end - sim0;
    let mut index = 0;
    for round in 1..=trial.args.refinements {
        // With the person.
        let (json, tracker, version) = model_of(db, None)?;
        // The person watched the robot's path from the pick point.
        let path: Vec<Vector3<f64>> = tracker.positions().iter().map(|p| p + (trial.pick - tracker.positions()[0])).collect();
        let guide = Guide::new(path, SAMPLE_S, T_CONTACT_S, g_new).context("the person's path")?;
        let taught = trial.execute(&json, &tracker, Some(&guide as &dyn Person))?;
        index += 1;
        let Some(contact) = taught.first_contact_s else {
            bail!("round {round}: lwr_sim reported no push of at least f_i = {} N", trial.io.insert_force);
        };
        if round == 1 {
            n_before = (contact / SAMPLE_S).floor() as usize;
        }
        let demo_t: Vec<f64> = (0..taught.path.len()).map(|k| k as f64 * SAMPLE_S).collect();
        let demo_p: Vec<f64> = taught.path.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let demo = Demonstration::new(3, demo_t, demo_p, None).context("the executed demonstration")?;
        let revision = db.refine_hmm_saved(db_path, HMM_ID, &demo, contact, &format!("seed {seed} execution {index}"), unix_now())?;
        let mut r = row(index, version, true, &taught, &reference, n_before, tracker.duration_s());
        r.kept_states = Some(revision.kept_states);
        r.changed_states = Some(revision.changed_states);
        result.executions.push(r);
        // Alone, refined.
        let (json, tracker, version) = model_of(db, None)?;
        let alone = trial.execute(&json, &tracker, None)?;
        index += 1;
        result.executions.push(row(index, version, false, &alone, &reference, n_before, tracker.duration_s()));
        result.duration_s = alone.sim_end - sim0;
        if (alone.end - g_new).norm() <= threshold {
            result.executions_to_reach = Some(round);
            result.success = true;
            return Ok(());
        }
    }
    result.reason = format!(
        "an execution alone did not end within {:.1} mm of g' after {} refined executions",
        threshold * 1e3,
        trial.args.refinements
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn demonstrations_differ_per_seed_and_end_near_g() {
        let a = demonstrations(1).expect("demos");
        let b = demonstrations(2).expect("demos");
        assert_eq!(a.len(), 5);
        assert_ne!(a[0].pos, b[0].pos);
        for d in &a {
            let n = d.len();
            let end = Vector3::from_column_slice(d.position(n - 1));
            assert!((end - Vector3::from(GOAL)).norm() < 0.006, "{end:?}");
            assert_eq!(d.position(0), &PICK);
        }
    }

    #[test]
    fn resampling_interpolates_and_clamps() {
        let s = [(1.0, Vector3::new(0.0, 0.0, 0.0)), (1.02, Vector3::new(0.02, 0.0, 0.0)), (1.05, Vector3::new(0.05, 0.0, 0.0))];
        let r = resample(&s, 1.0, 0.01, 7);
        let x: Vec<f64> = r.iter().map(|p| (p.x * 1e6).round() / 1e6).collect();
        assert_eq!(x, vec![0.0, 0.01, 0.02, 0.03, 0.04, 0.05, 0.05]);
        assert!((max_deviation(&r, &[Vector3::zeros(); 7], 3) - 0.02).abs() < 1e-12);
        // The same path twice as slow: no offset in space, a deviation in time.
        let slow: Vec<_> = (0..7).map(|k| Vector3::new(0.005 * k as f64, 0.0, 0.0)).collect();
        assert!(max_offset(&slow, &r, 7) < 1e-12);
        assert!(max_deviation(&slow, &r, 7) > 0.02);
        let off: Vec<_> = r.iter().map(|p| p + Vector3::new(0.0, 0.003, 0.0)).collect();
        assert!((max_offset(&off, &r, 7) - 0.003).abs() < 1e-12);
    }
}
