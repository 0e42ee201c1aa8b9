//! `cowork teach --bag BAG [--bag BAG ...] --task TASK --ltm-out FILE --database-dir DIR`:
//! kinesthetic teaching in the graph (thesis Sec. 4.3.3, Algorithm 4). Starts `lwr_sim`
//! (`--follow-wrench-stamps`, no camera), `robot_manager` and `attentional_supervisor` as
//! processes on a private DDS domain, replays the demonstrations' wrenches and speech into them
//! on the simulated clock, one bag after the other, and leaves the learned LTM and the primitive
//! database; prints the segments, what the supervisor learned and the state its working memory
//! ended in. The same teaching is the first half of every kitchen experiment
//! (`cowork experiment pouring|coffee|...`).
//!
//! With `--arms "left right"` (a scene with named arms, config/scenes/pizza.yaml) it teaches by
//! imitation (thesis Sec. 4.2, 5.2.4): the bags are an Xsens demonstrator's skeletons
//! (`cowork bag synth pizza-demo-left`), one `robot_manager` runs per arm in its namespace and
//! a `human_observer` retargets the demonstrator's arms onto the robot's, which `lwr_sim`
//! follows; the words are addressed to an arm (`left: gripper close`).

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cowork_graph::{FeedSummary, Graph, TeachingFeed};
use cowork_msgs::msg::{ActionSegment, WorkingMemory};
use cowork_msgs::topics;
use cowork_ros::{NodeConfig, RosNode};
use cowork_supervisor::{Ltm, Supervisor, SupervisorConfig};

/// Arguments of `cowork teach`.
#[derive(Debug, Args)]
pub struct TeachArgs {
    /// Kinesthetic demonstration (MCAP with /external_wrench and /speech_command, e.g. from
    /// `cowork bag synth kinesthetic-pour`); several play one after the other.
    #[arg(long = "bag", required = true)]
    pub bags: Vec<PathBuf>,
    /// Task the supervisor teaches (a behaviour of the LTM: pourDrink, prepareCoffee, ...).
    #[arg(long)]
    pub task: String,
    /// Where the learned LTM is saved (atomically; the input LTM is never overwritten).
    #[arg(long)]
    pub ltm_out: PathBuf,
    /// The robot manager's primitive database directory (created; an existing database is
    /// extended, so previously taught subtasks are reused).
    #[arg(long)]
    pub database_dir: PathBuf,
    /// The LTM taught from (the kitchen schemas, or an LTM learned before).
    #[arg(long, default_value = "config/tasks/kitchen.schema", value_parser = cowork_ros::config::path_arg)]
    pub ltm: PathBuf,
    /// Scene of the teaching (must be the scene the demonstrations were made in).
    #[arg(long, default_value = "config/scenes/kitchen.yaml", value_parser = cowork_ros::config::path_arg)]
    pub scene: PathBuf,
    /// lwr_sim's parameter file (its depth camera is switched off for teaching).
    #[arg(long, default_value = "config/lwr_sim.yaml", value_parser = cowork_ros::config::path_arg)]
    pub sim_params: PathBuf,
    /// Simulated seconds per wall-clock second (the teacher's wrenches act at their stamps at
    /// any rate; a feed that falls behind holds the simulated clock).
    #[arg(long, default_value_t = 4.0)]
    pub rate: f64,
    /// Directory of the node binaries.
    #[arg(long, default_value = "target/release", value_parser = crate::cmd::bin_dir_arg)]
    pub bin_dir: PathBuf,
    /// Node logs go here.
    #[arg(long, default_value = "out/teach/logs")]
    pub logs: PathBuf,
    /// Wall-clock seconds to wait for the nodes to be up.
    #[arg(long, default_value_t = 90.0)]
    pub startup_timeout: f64,
    /// The scene's named arms, e.g. "left right": imitation teaching, one robot manager per
    /// arm (the scene must have them).
    #[arg(long, value_delimiter = ' ', num_args = 1..)]
    pub arms: Vec<String>,
}

/// What a teaching run is given.
#[derive(Debug, Clone)]
pub struct TeachSetup {
    /// Demonstrations, in order.
    pub bags: Vec<PathBuf>,
    /// Task taught.
    pub task: String,
    /// LTM in.
    pub ltm: PathBuf,
    /// Learned LTM out.
    pub ltm_out: PathBuf,
    /// Primitive database directory.
    pub database_dir: PathBuf,
    /// Scene file.
    pub scene: PathBuf,
    /// lwr_sim parameter file (the camera is switched off in a copy).
    pub sim_params: PathBuf,
    /// Simulated s per wall s.
    pub rate: f64,
    /// Node binaries.
    pub bin_dir: PathBuf,
    /// Log directory.
    pub logs: PathBuf,
    /// Wall s for the graph to come up.
    pub startup_timeout_s: f64,
    /// The DDS domain leased for the teaching graph.
    pub domain: cowork_graph::DomainLease,
    /// Named arms (empty: the single-arm graph, kinesthetic teaching).
    pub arms: Vec<String>,
}

/// One segment the robot manager reported (Fig. 5.18).
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// The arm that made it (empty on a single-arm robot).
    pub arm: String,
    /// `foa1(water)`.
    pub label: String,
    /// `foa`, `noa` or `gripper`.
    pub kind: &'static str,
    /// Object of its frame.
    pub object: String,
    /// Simulated start and end, s from the first demonstration's start.
    pub span_s: (f64, f64),
}

/// A subtask the supervisor learned: its head and its actions in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Learned {
    /// `subtask(take,water)`.
    pub subtask: String,
    /// `[foa1(water), noa2(water), close3(water)]`.
    pub actions: Vec<String>,
}

/// What a teaching run produced.
#[derive(Debug, Clone)]
pub struct Taught {
    /// Length of the demonstrations (the teaching time), s.
    pub demonstration_s: f64,
    /// Each bag's length, s.
    pub bag_s: Vec<f64>,
    /// Wall-clock time of the replay, s.
    pub wall_s: f64,
    /// Segments, in order.
    pub segments: Vec<Segment>,
    /// Subtasks learned in this run (not in the input LTM).
    pub learned: Vec<Learned>,
    /// Primitives in the database afterwards.
    pub primitives: usize,
    /// True state variables of the working memory at the end (`water.added`, ...).
    pub true_variables: Vec<String>,
    /// Whether the task's post-condition held at the end of the demonstrations.
    pub task_done: bool,
    /// Warnings the manager and the supervisor logged.
    pub warnings: Vec<String>,
    /// The feed.
    pub feed: FeedSummary,
}

impl Taught {
    /// Segments the manager cut that the supervisor attached to no subtask (a lost
    /// `/robot_stream` sample, a segment it refused), except the last one: the free motion
    /// after the last action, cut when the teacher says `done`, belongs to no subtask.
    pub fn unattached(&self) -> Vec<&str> {
        let attached = |label: &str| {
            self.learned.iter().flat_map(|l| &l.actions).any(|a| a == label || a.strip_prefix(label).is_some_and(|r| r.starts_with('_')))
        };
        let n = self.segments.len().saturating_sub(1);
        self.segments[..n].iter().map(|s| s.label.as_str()).filter(|l| !attached(l)).collect()
    }
}

/// Runs `cowork teach`.
pub fn run(args: TeachArgs) -> Result<()> {
    let setup = TeachSetup {
        bags: args.bags,
        task: args.task,
        ltm: args.ltm,
        ltm_out: args.ltm_out,
        database_dir: args.database_dir,
        scene: args.scene,
        sim_params: args.sim_params,
        rate: args.rate,
        bin_dir: args.bin_dir,
        logs: args.logs,
        startup_timeout_s: args.startup_timeout,
        domain: cowork_graph::DomainLease::acquire("cowork teach")?,
        arms: args.arms.into_iter().filter(|a| !a.is_empty()).collect(),
    };
    cowork_ros::shutdown::install();
    let taught = teach(&setup)?;
    print(&setup, &taught);
    if taught.learned.is_empty() {
        bail!(
            "the demonstrations taught nothing: no action was attached to a subtask of {} (logs in {})",
            setup.task,
            setup.logs.display()
        );
    }
    let lost = taught.unattached();
    if !lost.is_empty() {
        bail!(
            "the supervisor attached no subtask to segment(s) {} that the manager cut: what was learned of {} misses them (see the supervisor's warnings in {})",
            lost.join(", "),
            setup.task,
            setup.logs.display()
        );
    }
    if !taught.task_done {
        bail!(
            "{} is not complete after the demonstrations (true: {}); what was learned is saved in {} and {}, but executing it would stop at the first open subtask — logs in {}",
            setup.task,
            if taught.true_variables.is_empty() { "nothing".into() } else { taught.true_variables.join(", ") },
            setup.ltm_out.display(),
            setup.database_dir.display(),
            setup.logs.display()
        );
    }
    Ok(())
}

/// Prints the segments, the learned subtasks and the end state.
pub fn print(setup: &TeachSetup, t: &Taught) {
    println!(
        "taught {} from {} demonstration(s), {:.1} s ({}), replayed in {:.1} s wall",
        setup.task,
        t.bag_s.len(),
        t.demonstration_s,
        t.bag_s.iter().map(|s| format!("{s:.1} s")).collect::<Vec<_>>().join(" + "),
        t.wall_s
    );
    println!(
        "teacher: {} messages, {} words more than 50 ms of simulated time late (latest {:.0} ms)",
        t.feed.published,
        t.feed.late_50ms,
        t.feed.max_late_s * 1e3
    );
    println!("segments ({}):", t.segments.len());
    for s in &t.segments {
        let arm = if s.arm.is_empty() { String::new() } else { format!("{:<6} ", s.arm) };
        println!("  {:>6.2} – {:>6.2} s  {arm}{:<8} {:<16} frame {}", s.span_s.0, s.span_s.1, s.kind, s.label, s.object);
    }
    println!("learned ({} subtasks):", t.learned.len());
    for l in &t.learned {
        println!("  {} = [{}]", l.subtask, l.actions.join(", "));
    }
    println!(
        "working memory at the end: {} {}; true: {}",
        setup.task,
        if t.task_done { "done" } else { "NOT done" },
        t.true_variables.join(", ")
    );
    for w in &t.warnings {
        println!("  warning: {w}");
    }
    println!("LTM: {}  primitives: {} in {}", setup.ltm_out.display(), t.primitives, setup.database_dir.display());
}

fn kind(k: u8) -> &'static str {
    match k {
        ActionSegment::KIND_NOA => "noa",
        ActionSegment::KIND_FOA => "foa",
        ActionSegment::KIND_GRIPPER => "gripper",
        _ => "?",
    }
}

/// A copy of lwr_sim's parameter file with the depth camera off, at `out`.
fn sim_params_without_camera(params: &Path, out: &Path) -> Result<()> {
    let text = std::fs::read_to_string(params).with_context(|| format!("reading {}", params.display()))?;
    let mut doc: serde_yaml_ng::Value =
        serde_yaml_ng::from_str(&text).with_context(|| format!("{}: not YAML", params.display()))?;
    let depth = doc
        .get_mut("lwr_sim")
        .and_then(|n| n.get_mut("ros__parameters"))
        .and_then(|p| p.get_mut("depth"))
        .and_then(serde_yaml_ng::Value::as_mapping_mut)
        .with_context(|| format!("{}: no lwr_sim.ros__parameters.depth block", params.display()))?;
    depth.insert("enabled".into(), false.into());
    crate::cmd::output::write(out, serde_yaml_ng::to_string(&doc)?)
}

/// Runs the teaching graph, replays the demonstrations, stops the graph and reads back what
/// was learned. Everything is checked before a process starts.
pub fn teach(s: &TeachSetup) -> Result<Taught> {
    if !(s.rate.is_finite() && s.rate > 0.0) {
        bail!("--rate {} must be > 0", s.rate);
    }
    let imitation = !s.arms.is_empty();
    let bins: &[&str] =
        if imitation { &["lwr_sim", "robot_manager", "attentional_supervisor", "human_observer"] } else { &["lwr_sim", "robot_manager", "attentional_supervisor"] };
    for &bin in bins {
        let p = s.bin_dir.join(bin);
        if !p.is_file() {
            bail!("{} missing; build with: cargo build --release --bins -p {bin}", p.display());
        }
    }
    for (what, p) in [("--scene", &s.scene), ("--sim-params", &s.sim_params)] {
        if !p.is_file() {
            bail!("{what} {}: no such file", p.display());
        }
    }
    if imitation {
        let scene = cowork_sim::Scene::from_file(&s.scene).with_context(|| format!("--scene {}", s.scene.display()))?;
        let names: Vec<String> = scene.arm_setups().iter().map(|a| a.name.clone()).collect();
        for arm in &s.arms {
            if !names.contains(arm) {
                bail!("--arms: the scene {} has no arm `{arm}` (its arms: {})", s.scene.display(), if names.is_empty() { "none named".into() } else { names.join(", ") });
            }
        }
    }
    let ltm_in = Ltm::load(&s.ltm).with_context(|| format!("the LTM {}", s.ltm.display()))?;
    Supervisor::new(ltm_in.clone(), &s.task, SupervisorConfig::default())
        .with_context(|| format!("task {:?} in {}", s.task, s.ltm.display()))?;
    if s.ltm_out == s.ltm {
        bail!("--ltm-out must differ from --ltm ({}): the input LTM is never overwritten", s.ltm.display());
    }
    std::fs::create_dir_all(&s.database_dir).with_context(|| format!("creating {}", s.database_dir.display()))?;
    std::fs::create_dir_all(&s.logs).with_context(|| format!("creating {}", s.logs.display()))?;
    if let Some(dir) = s.ltm_out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    // Each arm's manager keeps its own database (config/robot_manager.yaml's per-arm `robot`).
    let db_files: Vec<PathBuf> = if imitation {
        s.arms.iter().map(|a| s.database_dir.join(format!("lwr_{a}.primitives.json"))).collect()
    } else {
        vec![s.database_dir.join("lwr.primitives.json")]
    };
    for db_file in &db_files {
        if db_file.is_file() {
            cowork_manager::Database::load(db_file).with_context(|| format!("the database {}", db_file.display()))?;
        }
    }
    let sim_params = s.logs.join("lwr_sim.teach.yaml");
    sim_params_without_camera(&s.sim_params, &sim_params)?;

    let mut node = RosNode::new(
        "cowork_teach",
        &NodeConfig { domain_id: Some(s.domain.id()), use_sim_time: true, ..NodeConfig::default() },
    )?;
    let arm_namespaces: Vec<(String, String)> =
        if imitation { s.arms.iter().map(|a| (a.clone(), format!("/{a}"))).collect() } else { vec![(String::new(), "/".into())] };
    let robots = arm_namespaces
        .iter()
        .map(|(arm, ns)| Ok((arm.clone(), node.subscribe_in(&topics::ROBOT_STREAM, ns)?)))
        .collect::<Result<Vec<_>>>()?;
    let wm = node.subscribe(&topics::WORKING_MEMORY)?;
    // With named arms the clock-carrying wrenches go to the first arm (the simulator reads each
    // arm's `/external_wrench` in its namespace).
    let feed = TeachingFeed::from_bags_in(&mut node, &s.bags, &arm_namespaces[0].1)?;
    if imitation != feed.is_imitation() {
        bail!(
            "{}: --arms teaches by imitation (Xsens skeletons, `cowork bag synth pizza-demo-left`), without --arms kinesthetically (wrenches); the bags are {}",
            s.bags.iter().map(|b| b.display().to_string()).collect::<Vec<_>>().join(", "),
            if feed.is_imitation() { "an imitation" } else { "kinesthetic" }
        );
    }
    let bag_s: Vec<f64> = feed.bags().iter().map(|b| b.1).collect();
    let demonstration_s = bag_s.iter().sum();
    let feed_s = feed.duration_s();

    let mut g = Graph::new(s.domain.clone(), &s.logs)?;
    // Nothing outlives a killed `cowork teach` for long.
    let limit_s = s.startup_timeout_s + 30.0 + 8.0 * (feed_s + 5.0) / s.rate.min(1.0);
    let dur = format!("{limit_s:.0}");
    let p = |p: &Path| p.display().to_string();
    g.spawn(
        "lwr_sim",
        &s.bin_dir.join("lwr_sim"),
        &[
            "--scene".into(),
            p(&s.scene),
            "--params".into(),
            p(&sim_params),
            "--rate".into(),
            s.rate.to_string(),
            "--follow-wrench-stamps".into(),
            "--duration".into(),
            format!("{:.0}", feed_s + limit_s),
        ],
    )?;
    let managers: Vec<String> = if imitation { s.arms.iter().map(|a| format!("robot_manager_{a}")).collect() } else { vec!["robot_manager".into()] };
    for ((_, ns), name) in arm_namespaces.iter().zip(&managers) {
        let mut args = vec!["--use-sim-time".into(), "--database-dir".into(), p(&s.database_dir), "--duration".into(), dur.clone()];
        if imitation {
            args.extend(["--ros-args".into(), "-r".into(), format!("__ns:={ns}"), "--".into()]);
        }
        g.spawn(name, &s.bin_dir.join("robot_manager"), &args)?;
    }
    if imitation {
        // In the first arm's namespace, as launch_scripts/graph.sh runs it: its parameter block
        // there drives every arm (`retarget.arms`).
        g.spawn(
            "human_observer",
            &s.bin_dir.join("human_observer"),
            &[
                "--use-sim-time".into(),
                "--gestures".into(),
                String::new(),
                "--duration".into(),
                dur.clone(),
                "--ros-args".into(),
                "-r".into(),
                format!("__ns:={}", arm_namespaces[0].1),
                "--".into(),
            ],
        )?;
    }
    g.spawn(
        "attentional_supervisor",
        &s.bin_dir.join("attentional_supervisor"),
        &[
            "--ltm".into(),
            p(&s.ltm),
            "--task".into(),
            s.task.clone(),
            "--use-sim-time".into(),
            "--save-ltm".into(),
            p(&s.ltm_out),
            "--duration".into(),
            dur,
        ],
    )?;
    let until = Instant::now() + cowork_ros::duration_s(s.startup_timeout_s);
    let mut heard = vec![false; robots.len()];
    let mut last_wm: Option<WorkingMemory> = None;
    loop {
        g.check_alive()?;
        if cowork_ros::shutdown::requested() {
            bail!("interrupted (Ctrl-C) before teaching started");
        }
        for (k, (_, robot)) in robots.iter().enumerate() {
            heard[k] |= robot.take().is_some();
        }
        let heard_manager = heard.iter().all(|h| *h);
        while let Some(m) = wm.take() {
            last_wm = Some(m);
        }
        if heard_manager && last_wm.is_some() && feed.matched(&node, 1, 2) && node.now().to_secs_f64() > 0.0 {
            break;
        }
        if Instant::now() > until {
            bail!(
                "the teaching graph was not up after {} s (manager on /robot_stream: {heard_manager}, supervisor on /supervisor/working_memory: {}, wrench/speech{} readers matched: {}); logs in {}",
                s.startup_timeout_s,
                last_wm.is_some(),
                if imitation { "/skeleton" } else { "" },
                feed.matched(&node, 1, 2),
                s.logs.display()
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let t0 = node.now().to_secs_f64() + 0.5;
    let wall = Instant::now();
    let mut segments = Vec::new();
    // The manager's /robot_stream stamp: how far it has processed the world (simulated s).
    // Per arm, the newest /robot_stream stamp; the slowest manager paces the teacher.
    let mut stamps: Vec<Option<f64>> = vec![None; robots.len()];
    let bar = crate::cmd::observe::spinner("teaching: replaying the demonstration(s)");
    let mut shown = Instant::now();
    let mut collect = |g: &mut Graph, segments: &mut Vec<Segment>, last_wm: &mut Option<WorkingMemory>| -> Result<Option<f64>, String> {
        if shown.elapsed() >= Duration::from_millis(250) {
            shown = Instant::now();
            let sim = node.now().to_secs_f64() - t0;
            bar.set_message(format!("{:.1} of {feed_s:.1} s simulated, {} segment(s)", sim.clamp(0.0, feed_s), segments.len()));
        }
        let mut any = false;
        for (k, (arm, robot)) in robots.iter().enumerate() {
            while let Some(r) = robot.take() {
                stamps[k] = Some(r.header.stamp.to_secs_f64());
                any = true;
                segments.extend(r.segments.iter().map(|seg| Segment {
                    arm: arm.clone(),
                    label: seg.label.clone(),
                    kind: kind(seg.kind),
                    object: seg.object_name.clone(),
                    span_s: (seg.start_time.to_secs_f64() - t0, seg.end_time.to_secs_f64() - t0),
                }));
            }
        }
        let newest = if any { stamps.iter().copied().collect::<Option<Vec<f64>>>().map(|v| v.into_iter().fold(f64::INFINITY, f64::min)) } else { None };
        while let Some(m) = wm.take() {
            *last_wm = Some(m);
        }
        if cowork_ros::shutdown::requested() {
            return Err("interrupted (Ctrl-C)".into());
        }
        g.check_alive().map_err(|e| e.to_string())?;
        Ok(newest)
    };
    // Wrenches 0.2 s ahead of the clock and at most 0.3 s ahead of the manager (lockstep: a
    // manager stalled by a slow disk holds the simulated clock); 1.5 s after the last word for
    // the last segment, the database and the LTM.
    let fed = {
        let (g, segs, last) = (&mut g, &mut segments, &mut last_wm);
        let limit = Duration::from_secs_f64(120.0 + 6.0 * feed_s / s.rate.min(1.0));
        feed.play_paced(&node, t0, 0.2, 1.5, limit, 0.3, &mut || collect(g, segs, last))?
    };
    // The supervisor's snapshot after the last word (10 Hz).
    let settle = Instant::now() + Duration::from_secs(3);
    let t_end = node.now().to_secs_f64();
    while Instant::now() < settle {
        collect(&mut g, &mut segments, &mut last_wm).map_err(anyhow::Error::msg)?;
        if last_wm.as_ref().is_some_and(|w| w.header.stamp.to_secs_f64() > t_end) {
            break;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    bar.finish_and_clear();
    let wall_s = wall.elapsed().as_secs_f64();
    let warnings: Vec<String> = managers
        .iter()
        .map(String::as_str)
        .chain(["attentional_supervisor"])
        .flat_map(|n| {
            g.log(n)
                .lines()
                .filter(|l| l.contains(" WARN ") || l.contains("ERROR"))
                .map(|l| format!("{n}: {}", l.split_once("WARN").or(l.split_once("ERROR")).map_or(l, |x| x.1).trim()))
                .collect::<Vec<_>>()
        })
        .collect();
    // SIGINT: the supervisor saves the LTM once more, the manager its database.
    g.stop();
    if fed.dropped > 0 {
        bail!("{} of the teacher's messages were dropped by a full DDS queue", fed.dropped);
    }
    let ltm_out = Ltm::load(&s.ltm_out).with_context(|| {
        format!(
            "the supervisor saved no learned LTM at {} (nothing was attached?); its log: {}",
            s.ltm_out.display(),
            g.log_path("attentional_supervisor").display()
        )
    })?;
    let learned = learned_between(&ltm_in, &ltm_out);
    let mut primitives = 0;
    for db_file in db_files.iter().filter(|f| f.is_file()) {
        primitives += cowork_manager::Database::load(db_file).with_context(|| format!("the database {}", db_file.display()))?.primitives.len();
    }
    let (true_variables, task_done) = match &last_wm {
        Some(w) => (w.true_variables.clone(), w.nodes.iter().any(|n| compact(&n.name) == compact(&s.task) && n.done)),
        None => (Vec::new(), false),
    };
    Ok(Taught {
        demonstration_s,
        bag_s,
        wall_s,
        segments,
        learned,
        primitives,
        true_variables,
        task_done,
        warnings,
        feed: fed,
    })
}

/// The subtasks `after` holds that `before` does not: what a teaching added to an LTM.
pub fn learned_between(before: &Ltm, after: &Ltm) -> Vec<Learned> {
    let known: BTreeSet<String> = before.schemas().map(|(_, sc)| compact(&sc.head.to_string())).collect();
    after
        .schemas()
        .filter(|(_, sc)| sc.kind.is_none() && !sc.list.is_empty() && !known.contains(&compact(&sc.head.to_string())))
        .map(|(_, sc)| Learned {
            subtask: compact(&sc.head.to_string()),
            actions: sc.list.iter().map(|e| compact(&e.term.to_string())).collect(),
        })
        .collect()
}

fn compact(s: &str) -> String {
    s.replace(' ', "")
}
