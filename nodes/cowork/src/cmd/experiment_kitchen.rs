//! The kitchen experiments of `cowork experiment` (thesis Sec. 5.2.3, Table 5.4): per trial a
//! scripted teacher drawn from the seed demonstrates the task (`cowork_synth`,
//! `--vary-teacher`), the demonstration is taught in the graph (`cowork teach`'s
//! [`super::teach::teach`]: lwr_sim, robot_manager, attentional_supervisor as processes), then
//! the whole graph (lwr_sim with its depth camera, fded_distance, human_observer, ds_controller
//! with obstacle avoidance, robot_manager with the taught primitives, attentional_supervisor with
//! the learned LTM) executes it with the objects moved, judged from `/lwr/world` only.
//!
//! `pouring`: the bottle at a random reachable spot of the table, clear of the other objects;
//! success = the bottle was grasped, tilted more than 90° with its centre within 15 cm of the
//! cup's, released upright on the table, and no other object moved more than 1 cm.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use cowork_graph::Graph;
use cowork_msgs::msg::{LinkDistances, RobotStream, WorldState};
use cowork_ros::{NodeConfig, RosNode, qos, shutdown};
use cowork_sim::Scene;
use cowork_synth::{Scenario, SynthOptions};
use serde::Serialize;

use super::experiment::ExperimentArgs;
use super::teach::{TeachSetup, Taught, teach};

/// Kitchen experiments this runner knows.
pub const NAMES: [&str; 1] = ["pouring"];

/// Thesis Table 5.4 (pourDrink), means over ten trials: (subtask, teaching s, execution s).
const THESIS_POURING: [(&str, f64, f64); 3] = [("take(water)", 20.1, 31.0), ("pour(water)", 30.3, 46.5), ("pourDrink", 50.4, 77.5)];

/// Where the bottle may stand during execution (base frame, m): reachable, on the table.
const BOTTLE_X: (f64, f64) = (0.38, 0.58);
const BOTTLE_Y: (f64, f64) = (0.12, 0.42);
/// Smallest horizontal distance between the bottle's centre and another object's, m.
const CLEARANCE_M: f64 = 0.14;

/// One subtask's time.
#[derive(Debug, Clone, Serialize)]
pub struct SubtaskTime {
    /// Simulated time from its first action's start to its last action's end, s.
    pub time_s: Option<f64>,
    /// Its actions all done.
    pub success: bool,
}

/// One trial (the `cowork experiment` JSON contract plus the kitchen's own fields).
#[derive(Debug, Clone, Serialize)]
pub struct KitchenTrial {
    /// Seed.
    pub seed: u64,
    /// Judged from the world.
    pub success: bool,
    /// Why not (empty on success).
    pub reason: String,
    /// Simulated execution time (task start → accomplished or limit), s.
    pub duration_s: f64,
    /// No person in this experiment yet.
    pub min_distance_m: Option<f64>,
    /// No person in this experiment yet.
    pub collisions: u32,
    /// Per subtask (and the whole task), simulated s.
    pub subtasks: BTreeMap<String, SubtaskTime>,
    /// Teaching time: the demonstration's length, s.
    pub teaching_s: f64,
    /// Teaching time per subtask: its first segment's start to its last segment's end, s.
    pub teaching_subtasks: BTreeMap<String, f64>,
    /// Wall time of teaching and execution, s.
    pub wall_s: f64,
    /// Where the bottle stood during execution (x, y base frame, m).
    pub bottle_xy: [f64; 2],
    /// Segments the manager cut from the demonstration.
    pub segments: Vec<String>,
    /// Largest bottle tilt over the cup while held, deg.
    pub max_tilt_over_cup_deg: f64,
    /// Actions the manager reported failed (label: reason).
    pub failed_actions: Vec<String>,
}

/// The run.
#[derive(Debug, Clone, Serialize)]
pub struct KitchenRun {
    /// `pouring`.
    pub experiment: String,
    /// Trials.
    pub trials: Vec<KitchenTrial>,
    /// Successes, medians.
    pub summary: BTreeMap<String, f64>,
}

/// Runs a kitchen experiment.
pub fn run(args: &ExperimentArgs) -> Result<()> {
    if args.trials == 0 {
        bail!("--trials must be at least 1");
    }
    if args.max {
        bail!("{}: --max is not supported (the depth camera → fDED → controller chain needs a paced clock); use --rate", args.name);
    }
    if !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate {} must be > 0", args.rate);
    }
    if args.scene.is_some() {
        bail!("{}: --scene is not supported (the kitchen scene is config/scenes/kitchen.yaml)", args.name);
    }
    for bin in ["lwr_sim", "fded_distance", "ds_controller", "human_observer", "robot_manager", "attentional_supervisor"] {
        let p = args.bin_dir.join(bin);
        if !p.is_file() {
            bail!("{} missing; build with: cargo build --release --bins -p {bin}", p.display());
        }
    }
    let scene = Scene::from_file(Path::new("config/scenes/kitchen.yaml")).context("config/scenes/kitchen.yaml (run from the repository root)")?;
    shutdown::install();
    let mut trials = Vec::new();
    for k in 0..args.trials {
        if shutdown::requested() {
            break;
        }
        let seed = args.seed + u64::from(k);
        let t = pouring_trial(args, &scene, seed, k)?;
        println!(
            "pouring seed {seed}: {} — teaching {:.1} s, bottle at ({:.2}, {:.2}), take {} s, pour {} s, task {} s, tilt {:.0}°, {:.0} s wall{}",
            if t.success { "success" } else { "FAILED" },
            t.teaching_s,
            t.bottle_xy[0],
            t.bottle_xy[1],
            secs(t.subtasks.get("take(water)")),
            secs(t.subtasks.get("pour(water)")),
            secs(t.subtasks.get("pourDrink")),
            t.max_tilt_over_cup_deg,
            t.wall_s,
            if t.reason.is_empty() { String::new() } else { format!(": {}", t.reason) }
        );
        trials.push(t);
        let run = summarise(&args.name, trials.clone());
        if let Some(path) = &args.json {
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            std::fs::write(path, serde_json::to_string_pretty(&run)? + "\n").with_context(|| format!("writing {}", path.display()))?;
        }
    }
    let run = summarise(&args.name, trials);
    print_table(&run);
    Ok(())
}

fn secs(s: Option<&SubtaskTime>) -> String {
    s.and_then(|s| s.time_s).map_or("-".into(), |t| format!("{t:.1}"))
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) })
}

fn summarise(name: &str, trials: Vec<KitchenTrial>) -> KitchenRun {
    let mut summary = BTreeMap::new();
    summary.insert("trials".into(), trials.len() as f64);
    summary.insert("successes".into(), trials.iter().filter(|t| t.success).count() as f64);
    if let Some(m) = median(trials.iter().map(|t| t.teaching_s).collect()) {
        summary.insert("teaching_s_median".into(), m);
    }
    for (sub, _, _) in THESIS_POURING {
        if let Some(m) = median(trials.iter().filter_map(|t| t.subtasks.get(sub).and_then(|s| s.time_s)).collect()) {
            summary.insert(format!("{sub}_s_median"), m);
        }
        if let Some(m) = median(trials.iter().filter_map(|t| t.teaching_subtasks.get(sub).copied()).collect()) {
            summary.insert(format!("{sub}_teaching_s_median"), m);
        }
    }
    KitchenRun { experiment: name.to_owned(), trials, summary }
}

fn print_table(run: &KitchenRun) {
    let get = |k: &str| run.summary.get(k).copied();
    let f = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.1}"));
    println!("\nTable 5.4 (pourDrink), medians over {} trials, simulated s:", run.trials.len());
    println!("| | teaching, thesis | teaching, ours | execution, thesis | execution, ours |");
    println!("|---|---|---|---|---|");
    for (sub, teach, exec) in THESIS_POURING {
        println!(
            "| {sub} | {teach:.1} | {} | {exec:.1} | {} |",
            f(get(&format!("{sub}_teaching_s_median"))),
            f(get(&format!("{sub}_s_median")))
        );
    }
    println!("| whole demonstration | | {} | | |", f(get("teaching_s_median")));
    println!(
        "| success | 100 % | {}/{} |",
        get("successes").unwrap_or(0.0) as usize,
        run.trials.len()
    );
}

/// A bottle position for `seed`: uniform in the reachable box, clear of every other object.
fn bottle_position(scene: &Scene, seed: u64) -> Result<[f64; 2]> {
    // splitmix64: a few uniform draws need no generator crate.
    let mut state = seed ^ 0x706f_7572;
    let mut uniform = |lo: f64, hi: f64| {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        lo + (hi - lo) * ((z >> 11) as f64 / (1u64 << 53) as f64)
    };
    for _ in 0..1000 {
        let p = [uniform(BOTTLE_X.0, BOTTLE_X.1), uniform(BOTTLE_Y.0, BOTTLE_Y.1)];
        let clear = scene.objects.iter().filter(|o| o.name != "bottle").all(|o| {
            let c = o.pose.position;
            (c[0] - p[0]).hypot(c[1] - p[1]) > CLEARANCE_M
        });
        if clear {
            return Ok(p);
        }
    }
    bail!("no clear bottle position found for seed {seed}")
}

/// What the judge keeps of `/lwr/world`.
#[derive(Debug, Default)]
struct Judge {
    worlds: u64,
    grasped: bool,
    max_tilt_over_cup: f64,
    last: Option<WorldState>,
    last_t: Option<f64>,
    first: Option<WorldState>,
}

impl Judge {
    fn on_world(&mut self, w: WorldState) {
        self.last_t = Some(w.header.stamp.to_secs_f64());
        self.worlds += 1;
        if self.first.is_none() {
            self.first = Some(w.clone());
        }
        let find = |n: &str| w.objects.iter().find(|o| o.name == n);
        if w.held_object == "bottle" {
            self.grasped = true;
            if let (Some(b), Some(c)) = (find("bottle"), find("cup")) {
                let d = (b.pose.position.x - c.pose.position.x).hypot(b.pose.position.y - c.pose.position.y);
                if d < 0.15 {
                    self.max_tilt_over_cup = self.max_tilt_over_cup.max(b.tilt);
                }
            }
        }
        self.last = Some(w);
    }

    /// Why the trial failed, judged from the world; empty on success.
    fn verdict(&self) -> String {
        let (Some(first), Some(last)) = (&self.first, &self.last) else { return "no /lwr/world report".into() };
        let mut why = Vec::new();
        if !self.grasped {
            why.push("the bottle was never held".to_string());
        }
        if self.max_tilt_over_cup <= 90f64.to_radians() {
            why.push(format!("not poured over the cup (max tilt {:.0}°)", self.max_tilt_over_cup.to_degrees()));
        }
        match last.objects.iter().find(|o| o.name == "bottle") {
            Some(b) if last.held_object.is_empty() && b.tilt < 10f64.to_radians() && (b.pose.position.z - 0.11).abs() < 0.02 => {}
            Some(b) => why.push(format!(
                "the bottle is not back upright on the table (held {:?}, tilt {:.0}°, z {:.3} m)",
                last.held_object,
                b.tilt.to_degrees(),
                b.pose.position.z
            )),
            None => why.push("the bottle is gone".into()),
        }
        for o in first.objects.iter().filter(|o| o.name != "bottle") {
            let moved = last.objects.iter().find(|x| x.name == o.name).map_or(f64::INFINITY, |x| {
                let (a, b) = (&o.pose.position, &x.pose.position);
                ((a.x - b.x).powi(2) + (a.y - b.y).powi(2) + (a.z - b.z).powi(2)).sqrt()
            });
            if moved > 0.01 {
                why.push(format!("{} moved {:.3} m", o.name, moved));
            }
        }
        why.join("; ")
    }
}

fn pouring_trial(args: &ExperimentArgs, scene: &Scene, seed: u64, k: u32) -> Result<KitchenTrial> {
    let wall0 = Instant::now();
    let dir = args.logs.join(format!("pouring-{seed}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    // 1. The demonstration of this seed's teacher.
    let demo = dir.join("kinesthetic-pour.mcap");
    let synth = SynthOptions { seed, depth: false, vary_teacher: true, ..SynthOptions::default() };
    cowork_synth::synthesize(Scenario::KinestheticPour, &synth, &demo, &mut |_| {})
        .with_context(|| format!("synthesising the demonstration of seed {seed}"))?;
    // 2. Teaching in the graph.
    let setup = TeachSetup {
        bags: vec![demo],
        task: "pourDrink".into(),
        ltm: PathBuf::from("config/tasks/kitchen.schema"),
        ltm_out: dir.join("learned.schema"),
        database_dir: dir.join("primitives"),
        scene: PathBuf::from("config/scenes/kitchen.yaml"),
        sim_params: PathBuf::from("config/lwr_sim.yaml"),
        rate: 4.0,
        bin_dir: args.bin_dir.clone(),
        logs: dir.join("teach"),
        startup_timeout_s: args.startup_timeout,
        domain: cowork_graph::private_domain(120, 100, 2 * k),
    };
    let taught = teach(&setup)?;
    let segments: Vec<String> = taught.segments.iter().map(|s| s.label.clone()).collect();
    let seg = |label: Option<&String>| label.and_then(|l| taught.segments.iter().find(|s| &s.label == l)).map(|s| s.span_s);
    let mut teaching_subtasks = BTreeMap::new();
    let mut whole: Option<(f64, f64)> = None;
    for l in &taught.learned {
        if let (Some(a), Some(b)) = (seg(l.actions.first()), seg(l.actions.last())) {
            teaching_subtasks.insert(l.subtask.replacen("subtask(", "", 1).replacen(',', "(", 1), b.1 - a.0);
            whole = Some(whole.map_or((a.0, b.1), |w| (w.0.min(a.0), w.1.max(b.1))));
        }
    }
    if let Some(w) = whole {
        teaching_subtasks.insert("pourDrink".into(), w.1 - w.0);
    }
    let mut trial = KitchenTrial {
        seed,
        success: false,
        reason: String::new(),
        duration_s: 0.0,
        min_distance_m: None,
        collisions: 0,
        subtasks: BTreeMap::new(),
        teaching_s: taught.demonstration_s,
        teaching_subtasks,
        wall_s: 0.0,
        bottle_xy: [0.0; 2],
        segments,
        max_tilt_over_cup_deg: 0.0,
        failed_actions: Vec::new(),
    };
    if !taught.task_done || taught.learned.is_empty() {
        trial.reason = format!("teaching did not complete pourDrink (learned {:?})", taught.learned);
        trial.wall_s = wall0.elapsed().as_secs_f64();
        return Ok(trial);
    }
    // 3. Execution with the bottle moved.
    let xy = bottle_position(scene, seed)?;
    trial.bottle_xy = xy;
    let mut exec_scene = scene.clone();
    if let Some(b) = exec_scene.objects.iter_mut().find(|o| o.name == "bottle") {
        b.pose.position[0] = xy[0];
        b.pose.position[1] = xy[1];
    }
    let scene_path = dir.join("kitchen.yaml");
    std::fs::write(&scene_path, serde_yaml_ng::to_string(&exec_scene)?).with_context(|| format!("writing {}", scene_path.display()))?;
    execute(args, &setup, &taught, &scene_path, &dir, k, &mut trial)?;
    trial.wall_s = wall0.elapsed().as_secs_f64();
    Ok(trial)
}

fn execute(args: &ExperimentArgs, setup: &TeachSetup, taught: &Taught, scene: &Path, dir: &Path, k: u32, trial: &mut KitchenTrial) -> Result<()> {
    let domain = cowork_graph::private_domain(120, 100, 2 * k + 1);
    let limit_s = args.time_limit.unwrap_or(150.0);
    let wall_limit = args.startup_timeout + 4.0 * limit_s / args.rate + 60.0;
    let dur = format!("{wall_limit:.0}");
    let s = |p: &Path| p.display().to_string();
    let mut node = RosNode::new("cowork_experiment", &NodeConfig { use_sim_time: true, domain_id: Some(domain), ..NodeConfig::default() })?;
    let world = node.subscription::<WorldState>("/lwr/world", &qos::reliable_depth(100))?;
    let robot = node.subscription::<RobotStream>("/robot_stream", &qos::reliable_depth(100))?;
    let distances = node.subscription::<LinkDistances>("/fded/distances", &qos::reliable())?;
    let mut g = Graph::new(domain, &dir.join("exec"))?;
    let bin = |b: &str| args.bin_dir.join(b);
    g.spawn("lwr_sim", &bin("lwr_sim"), &["--scene".into(), s(scene), "--rate".into(), args.rate.to_string(), "--duration".into(), format!("{:.0}", limit_s + 60.0)])?;
    let args_of = |v: &[&str]| v.iter().map(|a| (*a).to_owned()).collect::<Vec<String>>();
    g.spawn("fded_distance", &bin("fded_distance"), &args_of(&["--params", "config/fded_distance.yaml", "--use-sim-time", "--backend", "cpu", "--duration", dur.as_str()]))?;
    g.spawn("human_observer", &bin("human_observer"), &args_of(&["--params", s(&args.observer_params).as_str(), "--use-sim-time", "--duration", dur.as_str()]))?;
    g.spawn("ds_controller", &bin("ds_controller"), &args_of(&["--params", s(&args.ds_params).as_str(), "--use-sim-time", "--duration", dur.as_str()]))?;
    let until = Instant::now() + cowork_ros::duration_s(args.startup_timeout);
    while distances.take().is_none() {
        g.check_alive()?;
        if Instant::now() > until || shutdown::requested() {
            bail!("no /fded/distances after {} s (logs in {})", args.startup_timeout, g.log_dir().display());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    g.spawn("robot_manager", &bin("robot_manager"), &args_of(&["--use-sim-time", "--database-dir", s(&setup.database_dir).as_str(), "--duration", dur.as_str()]))?;
    g.spawn(
        "attentional_supervisor",
        &bin("attentional_supervisor"),
        &args_of(&["--ltm", s(&setup.ltm_out).as_str(), "--task", "pourDrink", "--use-sim-time", "--duration", dur.as_str()]),
    )?;
    let mut judge = Judge::default();
    // (sim t, label, done, failed, reason)
    let mut events: Vec<(f64, String, bool, bool, String)> = Vec::new();
    let mut t_start: Option<f64> = None;
    let accomplished = |g: &Graph| g.log("attentional_supervisor").contains("task accomplished");
    let mut failure = String::new();
    let mut settle_until: Option<f64> = None;
    loop {
        while let Some(w) = world.take() {
            judge.on_world(w);
        }
        while let Some(r) = robot.take() {
            let t = r.header.stamp.to_secs_f64();
            for e in &r.events {
                if t_start.is_none() && !e.done && !e.failed {
                    t_start = Some(t);
                }
                events.push((t, e.label.clone(), e.done, e.failed, e.reason.clone()));
            }
        }
        if let Err(e) = g.check_alive() {
            failure = format!("node died: {e}");
            break;
        }
        if shutdown::requested() {
            failure = "interrupted (Ctrl-C)".into();
            break;
        }
        let now = judge.last_t.unwrap_or(0.0);
        let elapsed = t_start.map_or(0.0, |s| now - s);
        if let Some(until) = settle_until {
            if now >= until {
                break;
            }
        } else if accomplished(&g) {
            // The world half a second after the task: still released upright.
            settle_until = Some(now + 0.5);
            trial.duration_s = elapsed;
        }
        if elapsed > limit_s {
            failure = format!("time limit {limit_s} s reached");
            trial.duration_s = elapsed;
            break;
        }
        if Instant::now() > until + cowork_ros::duration_s(4.0 * limit_s / args.rate) {
            failure = "wall-time limit reached".into();
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    g.stop();
    // Subtask times from the manager's action events: first action started → last action done.
    let span = |labels: &[String]| -> SubtaskTime {
        let first = labels.first().and_then(|l| events.iter().find(|e| &e.1 == l && !e.2 && !e.3).map(|e| e.0));
        let last = labels.last().and_then(|l| events.iter().find(|e| &e.1 == l && e.2).map(|e| e.0));
        let all = labels.iter().all(|l| events.iter().any(|e| &e.1 == l && e.2));
        SubtaskTime { time_s: first.zip(last).map(|(a, b)| b - a), success: all }
    };
    let mut all = Vec::new();
    for l in &taught.learned {
        // subtask(take,water) → take(water)
        let name = l.subtask.replacen("subtask(", "", 1).replacen(',', "(", 1);
        trial.subtasks.insert(name, span(&l.actions));
        all.extend(l.actions.iter().cloned());
    }
    trial.subtasks.insert("pourDrink".into(), span(&all));
    trial.failed_actions = events.iter().filter(|e| e.3).map(|e| format!("{}: {}", e.1, e.4)).collect();
    trial.max_tilt_over_cup_deg = judge.max_tilt_over_cup.to_degrees();
    let verdict = judge.verdict();
    trial.reason = [failure, verdict].into_iter().filter(|s| !s.is_empty()).collect::<Vec<_>>().join("; ");
    if trial.reason.is_empty() && !accomplished(&g) {
        trial.reason = "the supervisor did not report the task accomplished".into();
    }
    trial.success = trial.reason.is_empty();
    Ok(())
}
