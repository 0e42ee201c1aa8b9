//! `cowork experiment refine-elbow` (thesis Sec. 4.1.3, Fig. 4.5–4.7): incremental kinesthetic
//! refinement of a null-space (elbow) primitive in the graph.
//!
//! The graph is refine-goal's ([`super::refine`]): `lwr_sim` in execute mode and
//! `ds_controller` with task transition control, on a private domain and the simulated clock.
//! Five synthetic demonstrations of refine-goal's pick-and-place, at half its speed
//! ([`DEMO_DURATIONS_S`]), teach the end-effector HMM. The same demonstrations, as the arm
//! would have moved under them (a kinematic IK from the arm's configuration at the pick point,
//! tool orientation held), teach the elbow HMM (the origin of `lwr_link_4`; left-to-right, 7
//! states, 1 Gaussian, η = 0.7). Both travel in one `MotionCommand` (`KIND_HMM` with
//! `null_space`): ds_controller runs the elbow path in the null space of the tool's pose.
//!
//! Execution 0 runs alone. An obstacle the robot does not see — a sphere; no camera runs, as in
//! the thesis — is then placed on the elbow's path at [`T_OBSTACLE_S`], [`OBSTACLE_OFFSET_M`]
//! behind it against the direction the elbow can move without moving the tool, so execution 0
//! went through it. Per round the person ([`cowork_people::guide::ElbowGuide`]) guides the
//! upper arm (`lwr_link_3`; the TTC's contact at its end is the elbow) from [`T_CONTACT_S`] on
//! along execution 0's elbow path bent [`BEND_M`] away from the obstacle, with at most 14 N
//! (between f_i and f_s: the guidance stays in the end-effector task's null space); the elbow
//! path the arm took (forward kinematics of `/joint_states`, never what was commanded) refines
//! the elbow HMM after the first contact lwr_sim reported, saved with its history; then an
//! execution alone. The trial succeeds when an execution alone keeps the elbow
//! [`CLEARANCE_GOAL_M`] off the obstacle while the tool's path stays within
//! [`TOOL_TOLERANCE_M`] of execution 0's (thesis: 3 executions). `--switch-force` runs the same
//! with another f_s (Fig. 4.7: 5 N puts the guidance first at once, 30 N never).

use std::time::Instant;

use anyhow::{Context, Result, bail};
use cowork_ds::ik::{Ik, IkConfig, IkReport, Twist, orientation_error};
use cowork_manager::Database;
use cowork_motion::Demonstration;
use cowork_motion::hmm::HmmPrimitive;
use cowork_people::guide::ElbowGuide;
use cowork_robot::{Jacobian, JointVector, LinkPoses, PositionJacobian, RobotModel, damped_pseudo_inverse, null_space_projector};
use cowork_experiment::report::{Line, RGBColor, plot_lines};
use cowork_ros::shutdown;
use nalgebra::{Point3, Vector3};
use serde::Serialize;

use super::experiment::ExperimentArgs;
use super::refine::{
    Person, Run, SAMPLE_S, Trial, demonstrations_lasting, distance_to_path, hmm_config, max_deviation, max_offset, median, model_of, opt_mm,
    prepare, unix_now, wait_for_graph, with_graph, write_json,
};

/// The elbow HMM's key in the trial's primitive database.
pub const ELBOW_ID: &str = "pick_place_elbow";
/// The elbow: the origin of this link (the LWR's joint 4).
pub const ELBOW_LINK: &str = "lwr_link_4";
/// The link the person presses; the TTC takes the contact at its end, the elbow.
pub const PUSH_LINK: &str = "lwr_link_3";
/// Durations of the demonstrations (s): the pick-and-place of refine-goal at half its speed,
/// as the thesis's (its contact comes 5.4 s after the start). A person guides an elbow through
/// an admittance of c = 0.005 m/(N·s): below f_s = 15 N it can be moved at 7.5 cm/s at most,
/// less than the elbow's own speed in the 5 s motion.
pub const DEMO_DURATIONS_S: std::ops::Range<f64> = 9.2..10.8;
/// The person's first contact, s after the start of an execution.
pub const T_CONTACT_S: f64 = 2.5;
/// The obstacle stands where execution 0's elbow was this long after its start (s).
pub const T_OBSTACLE_S: f64 = 6.5;
/// How far the person moves the elbow off its path (m).
pub const BEND_M: f64 = 0.09;
/// Obstacle radius (m).
pub const OBSTACLE_RADIUS_M: f64 = 0.04;
/// The obstacle's centre lies this far behind execution 0's elbow, against the push (m).
pub const OBSTACLE_OFFSET_M: f64 = 0.03;
/// The elbow must keep this far off the obstacle's surface on its own (m; issue #17).
pub const CLEARANCE_GOAL_M: f64 = 0.05;
/// …while the tool's path stays this close to execution 0's (m; thesis Fig. 4.7: < 3 mm).
pub const TOOL_TOLERANCE_M: f64 = 0.003;
/// Executions the thesis needed (Sec. 4.1.3).
pub const THESIS_EXECUTIONS: u32 = 3;

/// Elbow positions (origin of `elbow`, m, base frame) of the arm following each of `demos` (tool
/// positions) from the configuration `q0`: a kinematic closed loop at 1 ms (q̇ = J† [v + 5 (p −
/// x); 5 e_R], tool orientation held at q0's), sampled on the demonstrations' times.
pub fn elbow_demonstrations(model: &RobotModel, q0: &JointVector, elbow: usize, demos: &[Demonstration]) -> Result<Vec<Demonstration>> {
    let tip = model.tip_link();
    let mut ik = Ik::new(IkConfig::default());
    let mut poses = LinkPoses::new();
    let mut report = IkReport::default();
    let hold = model.link_pose(q0, tip).rotation;
    let x_start = model.link_pose(q0, tip).translation.vector;
    const SUB: usize = 10;
    demos
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let n = d.len();
            let at = |k: usize| Vector3::from_column_slice(d.position(k));
            // The demonstration starts where the tool is.
            let shift = x_start - at(0);
            let mut q = *q0;
            let mut pos: Vec<f64> = Vec::with_capacity(3 * n);
            for k in 0..n {
                model.forward_kinematics(&q, &mut poses);
                pos.extend(poses.get(elbow).translation.vector.iter());
                if k + 1 == n {
                    break;
                }
                let dt = (d.t[k + 1] - d.t[k]) / SUB as f64;
                let v = (at(k + 1) - at(k)) / (d.t[k + 1] - d.t[k]);
                for s in 0..SUB {
                    model.forward_kinematics(&q, &mut poses);
                    let tool = poses.get(tip);
                    let p = at(k) + v * (s as f64 * dt) + shift;
                    let lin = v + (p - tool.translation.vector) * 5.0;
                    let ang = orientation_error(&tool.rotation, &hold) * 5.0;
                    let twist = Twist::new(lin.x, lin.y, lin.z, ang.x, ang.y, ang.z);
                    q += ik.solve(model, &poses, tip, &twist, None, &mut report) * dt;
                }
            }
            if !pos.iter().all(|v| v.is_finite()) {
                bail!("demonstration {i}: the arm's elbow path is not finite");
            }
            Demonstration::new(3, d.t.clone(), pos, None).with_context(|| format!("elbow demonstration {i}"))
        })
        .collect()
}

/// The direction (unit, base frame) in which the origin of `link` moves when the arm moves in
/// the null space of the tool's full pose at `q` (the LWR's elbow swivel), turned upwards (or
/// towards +y when it is horizontal). `None` at a configuration without such a motion.
pub fn swivel_direction(model: &RobotModel, q: &JointVector, link: usize) -> Option<Vector3<f64>> {
    let mut poses = LinkPoses::new();
    model.forward_kinematics(q, &mut poses);
    let mut j = Jacobian::zeros();
    model.jacobian(&poses, model.tip_link(), &Point3::origin(), &mut j);
    let n = null_space_projector(&j, &damped_pseudo_inverse(&j, 1e-6));
    let v = (0..n.ncols()).map(|c| n.column(c).into_owned()).max_by(|a, b| a.norm().total_cmp(&b.norm()))?;
    let mut jl = PositionJacobian::zeros();
    model.position_jacobian(&poses, link, &Point3::origin(), &mut jl);
    let u = jl * v;
    if !(u.norm() > 1e-6) {
        return None;
    }
    let u = u.normalize();
    let up = if u.z.abs() > 1e-3 { u.z > 0.0 } else { u.y >= 0.0 };
    Some(if up { u } else { -u })
}

/// The person pressing the upper arm ([`ElbowGuide`] with the arm's forward kinematics): the
/// push goes out on `PUSH_LINK`, expressed in that link's frame.
struct ElbowPerson<'a> {
    guide: ElbowGuide,
    model: &'a RobotModel,
    elbow: usize,
    push_link: usize,
}

impl Person for ElbowPerson<'_> {
    fn push(&self, t: f64, _tool: &Vector3<f64>, q: &JointVector) -> Option<(String, Vector3<f64>)> {
        let elbow = self.model.link_pose(q, self.elbow).translation.vector;
        let f = self.guide.push(t, &elbow)?;
        let frame = self.model.link_pose(q, self.push_link).rotation;
        Some((PUSH_LINK.to_owned(), frame.inverse() * f))
    }
}

/// One execution, as the simulated world saw it.
#[derive(Debug, Clone, Serialize)]
pub struct ElbowRow {
    /// 0 for the learned primitives alone, then 1, 2, … in the order run.
    pub index: u32,
    /// Elbow model version executed (1 = learned, +1 per refinement).
    pub version: u32,
    /// The person pressed the elbow.
    pub pushed: bool,
    /// First push reported by lwr_sim of at least f_i, s after the command.
    pub first_contact_s: Option<f64>,
    /// Largest push reported (N).
    pub max_push_n: f64,
    /// ds_controller's TTC stacks during the execution ("guided: push on LINK, STACK").
    pub guided: Vec<String>,
    /// Least distance of the elbow to the obstacle's surface (mm; negative: through it).
    pub min_clearance_mm: f64,
    /// Largest distance of the tool's path from execution 0's path, in space (mm).
    pub tool_path_offset_mm: f64,
    /// Largest distance of the tool from execution 0's at equal times (mm).
    pub tool_deviation_mm: f64,
    /// Largest distance of the elbow from execution 0's at equal times before the reference
    /// contact time (the first guided execution's first push) (mm).
    pub elbow_deviation_before_contact_mm: f64,
    /// Refinement made from this execution: states kept / changed.
    pub kept_states: Option<Vec<usize>>,
    /// See `kept_states`.
    pub changed_states: Option<Vec<usize>>,
    /// The elbow's distance to the obstacle's surface every 0.1 s from the command (mm).
    pub clearance_series_mm: Vec<f64>,
    /// The tool's distance from execution 0's path (in space: a tool late on its path is not
    /// off it), every 0.1 s (mm).
    pub tool_offset_series_mm: Vec<f64>,
    /// ds_controller's TTC blend (`/ds_controller/ttc`) about every 50 ms while a push was
    /// blended in: [s after the command, w1, w2, w3, push N].
    pub ttc_series: Vec<[f64; 5]>,
}

/// One trial.
#[derive(Debug, Clone, Serialize)]
pub struct ElbowTrial {
    /// Seed.
    pub seed: u64,
    /// An execution alone cleared the obstacle with the tool on its path within `--refinements`.
    pub success: bool,
    /// Why not (empty on success).
    pub reason: String,
    /// Simulated seconds from the first command to the end.
    pub duration_s: f64,
    /// Wall-clock seconds of the trial.
    pub wall_s: f64,
    /// TTC switch force f_s of the run (N).
    pub switch_force_n: f64,
    /// The person's largest push (N).
    pub push_max_n: f64,
    /// Refined executions until an execution alone cleared the obstacle; thesis: 3.
    pub executions_to_clear: Option<u32>,
    /// Obstacle centre (m, base frame) and radius (m).
    pub obstacle_m: [f64; 3],
    /// See `obstacle_m`.
    pub obstacle_radius_m: f64,
    /// Every execution.
    pub executions: Vec<ElbowRow>,
    /// The trial's primitive database.
    pub database: String,
}

/// The run.
#[derive(Debug, Clone, Serialize)]
pub struct ElbowRun {
    /// Experiment name.
    pub experiment: String,
    /// Trials.
    pub trials: Vec<ElbowTrial>,
    /// Summary.
    pub summary: ElbowSummary,
}

/// Summary of a run.
#[derive(Debug, Clone, Serialize)]
pub struct ElbowSummary {
    /// Trials run.
    pub trials: usize,
    /// Trials whose elbow cleared the obstacle on its own.
    pub successes: usize,
    /// Median refined executions until then.
    pub executions_to_clear_median: Option<f64>,
    /// Largest refined executions until then.
    pub executions_to_clear_max: Option<u32>,
    /// Median over trials of the last execution alone's least clearance (mm).
    pub final_clearance_mm_median: Option<f64>,
    /// Largest tool path offset of any execution (mm).
    pub max_tool_path_offset_mm: Option<f64>,
    /// The thesis's figure.
    pub thesis_executions: u32,
}

impl ElbowSummary {
    fn of(trials: &[ElbowTrial]) -> Self {
        let reached: Vec<u32> = trials.iter().filter_map(|t| t.executions_to_clear).collect();
        Self {
            trials: trials.len(),
            successes: trials.iter().filter(|t| t.success).count(),
            executions_to_clear_median: median(reached.iter().map(|&n| f64::from(n)).collect()),
            executions_to_clear_max: reached.iter().copied().max(),
            final_clearance_mm_median: median(
                trials
                    .iter()
                    .filter_map(|t| t.executions.iter().filter(|e| !e.pushed && e.index > 0).last().map(|e| e.min_clearance_mm))
                    .collect(),
            ),
            max_tool_path_offset_mm: trials.iter().flat_map(|t| &t.executions).map(|e| e.tool_path_offset_mm).reduce(f64::max),
            thesis_executions: THESIS_EXECUTIONS,
        }
    }
}

/// Runs `cowork experiment refine-elbow`.
pub fn run(args: &ExperimentArgs) -> Result<()> {
    let (model, ttc) = prepare(args)?;
    if !(args.push_max.is_finite() && args.push_max > ttc.insert_force) {
        bail!("--push-max {} N must be finite and above f_i = {} N", args.push_max, ttc.insert_force);
    }
    shutdown::install();
    let mut trials = Vec::new();
    for k in 0..args.trials {
        if shutdown::requested() {
            break;
        }
        let seed = args.seed + u64::from(k);
        let t = run_trial(args, &model, seed, k, ttc.insert_force, ttc.switch_force)?;
        print_trial(&t);
        trials.push(t);
        if let Some(dir) = &args.report {
            write_report(dir, &trials, ttc.insert_force)?;
        }
        if let Some(path) = &args.json {
            write_json(path, &ElbowRun { experiment: args.name.clone(), summary: ElbowSummary::of(&trials), trials: trials.clone() })?;
        }
    }
    println!("{}", serde_json::to_string_pretty(&ElbowSummary::of(&trials))?);
    if let Some(dir) = &args.report {
        println!("report: {}", dir.join("index.html").display());
    }
    Ok(())
}

const PALETTE: [(u8, u8, u8); 7] =
    [(31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189), (140, 86, 75), (227, 119, 194)];

fn color(k: usize) -> RGBColor {
    let (r, g, b) = PALETTE[k % PALETTE.len()];
    RGBColor(r, g, b)
}

/// The PNGs of one trial in `dir` (Fig. 4.6–4.7): the TTC weights and the push of the first
/// guided execution, the tool's deviation from execution 0 and the elbow's clearance per
/// execution. Returns the file names.
fn plot_trial(dir: &std::path::Path, t: &ElbowTrial, insert_force: f64) -> Result<Vec<String>> {
    let stem = format!("refine-elbow-{}-fs{}", t.seed, t.switch_force_n);
    let mut files = Vec::new();
    let mut file = |name: &str| {
        let f = format!("{stem}-{name}.png");
        files.push(f.clone());
        dir.join(f)
    };
    let series = |v: &[f64]| v.iter().enumerate().map(|(k, &y)| (k as f64 * 0.1, y)).collect::<Vec<_>>();
    if let Some(e) = t.executions.iter().find(|e| e.pushed) {
        let w = |i: usize| e.ttc_series.iter().map(|s| (s[0], s[i])).collect::<Vec<_>>();
        let title = format!("TTC weights, execution {} (f_s = {} N)", e.index, t.switch_force_n);
        let lines = [
            Line { name: "w1: T_ee", points: w(1), color: color(0) },
            Line { name: "w2: [T_ee, T_ic]", points: w(2), color: color(1) },
            Line { name: "w3: [T_ic, T_ee]", points: w(3), color: color(2) },
        ];
        plot_lines(&file("ttc"), &title, "weight", &lines, &[], Some(0.0))?;
        let push = [Line { name: "push on lwr_link_3", points: w(4), color: color(3) }];
        let marks = [(insert_force, "f_i"), (t.switch_force_n, "f_s")];
        plot_lines(&file("push"), &format!("The person's push, execution {}", e.index), "N", &push, &marks, Some(0.0))?;
    }
    let names: Vec<String> =
        t.executions.iter().map(|e| format!("exec {} (v{}{})", e.index, e.version, if e.pushed { ", pushed" } else { "" })).collect();
    let lines: Vec<Line<'_>> =
        t.executions.iter().enumerate().map(|(k, e)| Line { name: &names[k], points: series(&e.tool_offset_series_mm), color: color(k) }).collect();
    plot_lines(&file("tool"), "Tool: distance from execution 0's path", "mm", &lines, &[(TOOL_TOLERANCE_M * 1e3, "3 mm")], Some(0.0))?;
    let lines: Vec<Line<'_>> =
        t.executions.iter().enumerate().map(|(k, e)| Line { name: &names[k], points: series(&e.clearance_series_mm), color: color(k) }).collect();
    plot_lines(&file("clearance"), "Elbow: distance to the obstacle's surface", "mm", &lines, &[(CLEARANCE_GOAL_M * 1e3, "goal"), (0.0, "contact")], None)?;
    Ok(files)
}

/// `dir`/index.html with every trial's table and plots so far.
fn write_report(dir: &std::path::Path, trials: &[ElbowTrial], insert_force: f64) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut html = String::from(
        "<!doctype html><meta charset=\"utf-8\"><title>refine-elbow</title><h1>refine-elbow: elbow refinement (thesis Sec. 4.1.3, Fig. 4.5-4.7)</h1>\n",
    );
    for t in trials {
        let files = plot_trial(dir, t, insert_force)?;
        let text = trial_text(t).replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
        html += &format!("<h2>seed {} (f_s = {} N)</h2><pre>{text}</pre>\n", t.seed, t.switch_force_n);
        for f in files {
            html += &format!("<p><img src=\"{f}\" alt=\"{f}\"></p>\n");
        }
    }
    let path = dir.join("index.html");
    crate::cmd::output::write(&path, html)
}

fn print_trial(t: &ElbowTrial) {
    print!("{}", trial_text(t));
}

/// The terminal table of a trial.
fn trial_text(t: &ElbowTrial) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "refine-elbow seed {} (f_s = {} N, pushes up to {} N): {}{}\n",
        t.seed,
        t.switch_force_n,
        t.push_max_n,
        if t.success { "success" } else { "FAILED" },
        if t.reason.is_empty() { String::new() } else { format!(": {}", t.reason) }
    );
    s += "  exec  version  pushed  contact(s)  max push(N)  elbow clearance (mm)  tool: path offset / deviation (mm)  elbow dev. before contact (mm)  TTC\n";
    for e in &t.executions {
        let _ = writeln!(
            s,
            "  {:>4}  {:>7}  {:>6}  {:>10}  {:>11.1}  {:>20.1}  {:>17.2} / {:>9.2}  {:>30.1}  {}",
            e.index,
            e.version,
            if e.pushed { "yes" } else { "no" },
            opt_mm(e.first_contact_s),
            e.max_push_n,
            e.min_clearance_mm,
            e.tool_path_offset_mm,
            e.tool_deviation_mm,
            e.elbow_deviation_before_contact_mm,
            if e.guided.is_empty() { "-".to_owned() } else { e.guided.join("; ") }
        );
    }
    let reached = match t.executions_to_clear {
        Some(n) => format!("the elbow cleared the obstacle on its own after {n} refined execution(s)"),
        None => "the elbow did not clear the obstacle on its own".to_owned(),
    };
    let _ = writeln!(
        s,
        "  {reached} (goal: >= {:.0} mm with the tool within {:.0} mm of its path; thesis: {THESIS_EXECUTIONS}); {:.1} s simulated, {:.0} s wall",
        CLEARANCE_GOAL_M * 1e3,
        TOOL_TOLERANCE_M * 1e3,
        t.duration_s,
        t.wall_s
    );
    s
}

fn run_trial(args: &ExperimentArgs, model: &RobotModel, seed: u64, k: u32, insert_force: f64, switch_force: f64) -> Result<ElbowTrial> {
    let wall0 = Instant::now();
    let mut result = ElbowTrial {
        seed,
        success: false,
        reason: String::new(),
        duration_s: 0.0,
        wall_s: 0.0,
        switch_force_n: switch_force,
        push_max_n: args.push_max,
        executions_to_clear: None,
        obstacle_m: [f64::NAN; 3],
        obstacle_radius_m: OBSTACLE_RADIUS_M,
        executions: Vec::new(),
        database: String::new(),
    };
    let demos = demonstrations_lasting(seed, DEMO_DURATIONS_S)?;
    let (outcome, db_path) = with_graph(args, model, &demos, seed, k, insert_force, |trial, db, db_path| {
        wait_for_graph(trial)?;
        study(trial, db, db_path, &demos, seed, &mut result)
    })?;
    result.database = db_path.display().to_string();
    if let Err(e) = outcome {
        result.reason = format!("{e:#}");
    }
    result.wall_s = wall0.elapsed().as_secs_f64();
    Ok(result)
}

fn round1(v: f64) -> f64 {
    (v * 10.0).round() / 10.0
}

/// The samples of `ttc` at least `dt` s apart (and the last).
fn decimate(ttc: &[(f64, [f64; 4])], dt: f64) -> Vec<[f64; 5]> {
    let mut out: Vec<[f64; 5]> = Vec::new();
    for (i, &(t, [a, b, c, f])) in ttc.iter().enumerate() {
        if out.last().is_none_or(|l| t - l[0] >= dt) || i + 1 == ttc.len() {
            out.push([t, a, b, c, f]);
        }
    }
    out
}

/// Elbow positions (m) of a run's joint samples.
fn elbow_path(model: &RobotModel, elbow: usize, run: &Run) -> Vec<Vector3<f64>> {
    run.joints.iter().map(|q| model.link_pose(q, elbow).translation.vector).collect()
}

fn study(
    trial: &mut Trial<'_>,
    db: &mut Database,
    db_path: &std::path::Path,
    demos: &[Demonstration],
    seed: u64,
    result: &mut ElbowTrial,
) -> Result<()> {
    let model = trial.io.model.clone();
    let link = |name: &str| model.link_index(name).with_context(|| format!("{name} is not a link of the robot model"));
    let (elbow, push_link) = (link(ELBOW_LINK)?, link(PUSH_LINK)?);
    let sim0 = trial.io.now();
    // Teach the elbow from the arm's configuration at the pick point.
    trial.go_to_pick()?;
    let (_, q_pick) = trial.io.q.context("no /joint_states from lwr_sim")?;
    let elbow_demos = elbow_demonstrations(&model, &q_pick, elbow, demos)?;
    let elbow_hmm = HmmPrimitive::fit(&elbow_demos, &hmm_config()).context("learning the elbow HMM")?;
    db.insert_hmm(ELBOW_ID, "place(object) elbow", elbow_hmm, unix_now())?;
    db.save(db_path)?;
    let primitives = Some((ELBOW_ID, ELBOW_LINK));

    // Execution 0: both primitives alone; the obstacle is put on its elbow path.
    let (json, tracker, _) = model_of(db, primitives)?;
    let version = |db: &Database| db.hmm(ELBOW_ID).map_or(0, |e| e.version);
    let first = trial.execute(&json, &tracker, None)?;
    let elbow0 = elbow_path(&model, elbow, &first);
    // Every later execution starts with the elbow where this one did.
    trial.settle_link = Some((elbow, elbow0[0]));
    let k_o = ((T_OBSTACLE_S / SAMPLE_S) as usize).min(elbow0.len() - 1);
    let k_c = ((T_CONTACT_S / SAMPLE_S) as usize).min(k_o);
    let u = swivel_direction(&model, &first.joints[k_o], elbow)
        .context("execution 0's arm has no elbow motion at the obstacle's time (singular)")?;
    // The obstacle stands on the side the elbow swivels towards between the contact and the
    // obstacle; the person bends it back the other way. The guidance sets the elbow's absolute
    // swivel speed (ẋ = c f), so bending against the elbow's own swivel takes the least force.
    let u = if u.dot(&(elbow0[k_o] - elbow0[k_c])) > 0.0 { -u } else { u };
    let centre = elbow0[k_o] - u * OBSTACLE_OFFSET_M;
    result.obstacle_m = [centre.x, centre.y, centre.z];
    let mut guide = ElbowGuide::new(elbow0.clone(), SAMPLE_S, T_CONTACT_S, u, BEND_M).context("the person")?;
    guide.max_force_n = trial.args.push_max;
    // Past the obstacle the person lets the elbow back onto its path.
    guide.release_s = Some(T_OBSTACLE_S + 1.5);
    let clearance_at = |p: &Vector3<f64>| (p - centre).norm() - OBSTACLE_RADIUS_M;
    let clearance = |path: &[Vector3<f64>]| path.iter().map(clearance_at).fold(f64::INFINITY, f64::min);
    let mut n_before = (T_CONTACT_S / SAMPLE_S) as usize;
    let row = |index: u32, version: u32, pushed: bool, r: &Run, elbows: &[Vector3<f64>], n_before: usize| ElbowRow {
        index,
        version,
        pushed,
        first_contact_s: r.first_contact_s,
        max_push_n: r.max_push_n,
        guided: r.guided.clone(),
        min_clearance_mm: clearance(elbows) * 1e3,
        tool_path_offset_mm: max_offset(&r.path, &first.path, r.path.len()) * 1e3,
        tool_deviation_mm: max_deviation(&r.path, &first.path, r.path.len()) * 1e3,
        elbow_deviation_before_contact_mm: max_deviation(elbows, &elbow0, n_before) * 1e3,
        kept_states: None,
        changed_states: None,
        clearance_series_mm: elbows.iter().step_by(10).map(|p| round1(clearance_at(p) * 1e3)).collect(),
        tool_offset_series_mm: r.path.iter().step_by(10).map(|p| (distance_to_path(p, &first.path) * 1e3 * 100.0).round() / 100.0).collect(),
        ttc_series: decimate(&r.ttc, 0.05),
    };
    result.executions.push(row(0, version(db), false, &first, &elbow0, n_before));
    result.duration_s = first.sim_end - sim0;
    let person = ElbowPerson { guide: guide.clone(), model: &model, elbow, push_link };
    let mut index = 0;
    for round in 1..=trial.args.refinements {
        let (json, tracker, _) = model_of(db, primitives)?;
        let v = version(db);
        let taught = trial.execute(&json, &tracker, Some(&person as &dyn Person))?;
        index += 1;
        let Some(contact) = taught.first_contact_s else {
            bail!("round {round}: lwr_sim reported no push of at least f_i = {} N", trial.io.insert_force);
        };
        if round == 1 {
            n_before = (contact / SAMPLE_S).floor() as usize;
        }
        let elbows = elbow_path(&model, elbow, &taught);
        let demo_t: Vec<f64> = (0..elbows.len()).map(|k| k as f64 * SAMPLE_S).collect();
        let demo_p: Vec<f64> = elbows.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let demo = Demonstration::new(3, demo_t, demo_p, None).context("the executed elbow demonstration")?;
        let revision = db.refine_hmm_saved(db_path, ELBOW_ID, &demo, contact, &format!("seed {seed} execution {index}"), unix_now())?;
        let mut r = row(index, v, true, &taught, &elbows, n_before);
        r.kept_states = Some(revision.kept_states);
        r.changed_states = Some(revision.changed_states);
        result.executions.push(r);
        // Alone, refined.
        let (json, tracker, _) = model_of(db, primitives)?;
        let v = version(db);
        let alone = trial.execute(&json, &tracker, None)?;
        index += 1;
        let elbows = elbow_path(&model, elbow, &alone);
        let r = row(index, v, false, &alone, &elbows, n_before);
        let cleared = r.min_clearance_mm >= CLEARANCE_GOAL_M * 1e3 && r.tool_path_offset_mm <= TOOL_TOLERANCE_M * 1e3;
        result.executions.push(r);
        result.duration_s = alone.sim_end - sim0;
        if cleared {
            result.executions_to_clear = Some(round);
            result.success = true;
            return Ok(());
        }
    }
    result.reason = format!(
        "no execution alone kept the elbow {:.0} mm off the obstacle with the tool within {:.0} mm of its path after {} refined executions",
        CLEARANCE_GOAL_M * 1e3,
        TOOL_TOLERANCE_M * 1e3,
        trial.args.refinements
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lwr() -> RobotModel {
        RobotModel::from_urdf_file(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/robot/lwr4plus.urdf")).expect("URDF")
    }

    #[test]
    fn elbow_demonstrations_follow_the_tool_demonstrations_with_the_arm() {
        let model = lwr();
        let q0 = JointVector::from_row_slice(&[0.6, 0.5, 0.0, -1.4, 0.0, 0.9, 0.0]);
        let elbow = model.link_index(ELBOW_LINK).expect("elbow");
        let demos = demonstrations_lasting(1, DEMO_DURATIONS_S).expect("demos");
        let elbows = elbow_demonstrations(&model, &q0, elbow, &demos[..2]).expect("elbow demos");
        assert_eq!(elbows.len(), 2);
        assert_eq!(elbows[0].len(), demos[0].len());
        let start = model.link_pose(&q0, elbow).translation.vector;
        assert!((Vector3::from_column_slice(elbows[0].position(0)) - start).norm() < 1e-12);
        // The elbow moves with the arm (the tool travels ≈ 0.45 m).
        let end = Vector3::from_column_slice(elbows[0].position(elbows[0].len() - 1));
        assert!((end - start).norm() > 0.05, "{start:?} -> {end:?}");
        let u = swivel_direction(&model, &q0, elbow).expect("swivel");
        assert!((u.norm() - 1.0).abs() < 1e-9 && u.z >= 0.0, "{u:?}");
    }

    #[test]
    fn a_push_along_the_swivel_direction_moves_the_elbow_that_way_in_t2() {
        use cowork_ds::{Contact, Ttc, TtcConfig, TtcReport};
        use cowork_ds::ttc::contact_point_at_link_end;
        let model = lwr();
        let q = JointVector::from_row_slice(&[10.9f64, 32.8, 4.3, 104.8, -3.4, 42.5, 17.0].map(f64::to_radians));
        let elbow = model.link_index(ELBOW_LINK).expect("elbow");
        let push = model.link_index(PUSH_LINK).expect("push link");
        let u = swivel_direction(&model, &q, elbow).expect("swivel");
        let mut poses = LinkPoses::new();
        model.forward_kinematics(&q, &mut poses);
        let point = contact_point_at_link_end(&model, &poses, push);
        assert!((point.coords - poses.get(elbow).translation.vector).norm() < 1e-12, "the contact is the elbow");
        let mut ttc = Ttc::new(TtcConfig::default()).expect("ttc");
        let mut report = TtcReport::default();
        let c = Contact { link: push, point, force: u * 12.0 };
        let mut qdot = JointVector::zeros();
        for _ in 0..1000 {
            qdot = ttc.step(&model, &poses, model.tip_link(), &Twist::zeros(), Some(&c), 1e-3, &mut report);
        }
        let mut jl = PositionJacobian::zeros();
        model.position_jacobian(&poses, elbow, &Point3::origin(), &mut jl);
        let v = jl * qdot;
        eprintln!("u {u:?} elbow velocity {v:?} weights {:?} ee twist {:?}", report.weights, report.end_effector_twist.as_slice());
        assert!(v.dot(&u) > 0.03, "{v:?} along {u:?}");
        assert!(report.end_effector_twist.norm() < 1e-5, "T² moved the tool: {:?}", report.end_effector_twist);
    }
}
