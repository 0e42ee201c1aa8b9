//! `cowork experiment NAME`: runs a thesis experiment in the whole graph. The runner owns the
//! graph (node processes on a private DDS domain, sim clock), feeds the scripted people and
//! the task script, judges from the simulated world and stops everything; descriptions,
//! sequencing and judging are in `cowork_experiment`.

mod gestures;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use clap::Args;
use cowork_experiment::cooperation::Latency;
use cowork_experiment::judge::Subtask;
use cowork_experiment::report::{Metadata, ReportHead, ReportTrial, Table};
use cowork_experiment::{
    DistanceMethod, Experiment, Judge, Output, Progress, RunResult, Sequencer, Stats,
    THESIS_MIN_DISTANCE_M, TrialResult,
};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{
    Gesture, HumanState, LinkDistances, MotionStatus, Skeleton, WorldState,
};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::topics::{self, Delivery};
use cowork_msgs::std_msgs::{Float64MultiArray, String as RosString};
use cowork_people::MessageMeta;
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, shutdown};
use indicatif::{ProgressBar, ProgressStyle};

/// Arguments of `cowork experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Experiment: stacking-hri, gestures-hri (Sec. 5.1.3), pouring (Table 5.4), coffee (Table 5.5), coffee-cooperative (Fig. 5.21), coffee-closed-bottle (Fig. 5.22), tea-reuse (Table 5.6), pizza --arms uni|dual (Table 5.7), refine-goal (Sec. 4.1.3, Fig. 4.4), refine-elbow (Sec. 4.1.3, Fig. 4.5-4.7).
    pub name: String,
    /// Trials (seeds seed, seed + 1, ...).
    #[arg(long, default_value_t = 1)]
    pub trials: u32,
    /// Seed of the first trial.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scene file instead of the experiment's own.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Robot–obstacle distances: fded or flacco (stacking-hri).
    #[arg(long, default_value = "fded")]
    pub distance: String,
    /// Write the run as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Record every topic of each trial to DIR/<experiment>-<distance>-<seed>.mcap (kitchen
    /// experiments: DIR/<experiment>-<seed>.mcap).
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// With --record: record only these topics (space- or comma-separated, e.g.
    /// "/left/joint_states /left/fded/distances"); every topic if not given. The depth image
    /// alone is about 36 MB/s of simulated time.
    #[arg(long, value_delimiter = ',', requires = "record")]
    pub record_topics: Vec<String>,
    /// Write a report (index.html + PNG plots per trial) into DIR (HRI experiments and
    /// refine-elbow).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0, conflicts_with = "max")]
    pub rate: f64,
    /// Run the simulated clock as fast as possible: a plumbing check only. The controller
    /// cannot follow a clock that outruns it, so its watchdog holds the arm on joint states
    /// stamped in its future; trials run this way say nothing about the robot's behaviour.
    #[arg(long)]
    pub max: bool,
    /// A trial still running after this many simulated seconds fails.
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Node logs go to DIR/<experiment>-<distance>-<seed>/<node>.log.
    #[arg(long, default_value = "out/experiments/logs")]
    pub logs: PathBuf,
    /// Directory of the node binaries.
    #[arg(long, default_value = "target/release", value_parser = crate::cmd::bin_dir_arg)]
    pub bin_dir: PathBuf,
    /// ds_controller's parameter file (e.g. a copy with `safety: enabled: false` to measure
    /// the thesis's controller alone).
    #[arg(long, default_value = "config/ds_controller.yaml", value_parser = cowork_ros::config::path_arg)]
    pub ds_params: PathBuf,
    /// human_observer's parameter file.
    #[arg(long, default_value = "config/human_observer.yaml", value_parser = cowork_ros::config::path_arg)]
    pub observer_params: PathBuf,
    /// Kitchen experiments: nobody passes by (by default a person drawn from the seed walks
    /// up to the table, reaches once into the robot's workspace and leaves).
    #[arg(long)]
    pub no_person: bool,
    /// Kitchen experiments: chaos — one node of the executing graph `NODE:kill` (SIGKILL, then
    /// started again) or `NODE:stop` (SIGSTOP, then SIGCONT), e.g. `robot_manager:kill`; the
    /// trial reports when the robot was held, how far it moved, when it resumed, and whether
    /// the task still completed.
    #[arg(long, value_parser = super::kitchen::fault::parse_fault)]
    pub fault: Option<super::kitchen::fault::FaultSpec>,
    /// With --fault: when it strikes, simulated s after the robot's first action.
    #[arg(long, default_value_t = 8.0)]
    pub fault_at: f64,
    /// With --fault: wall-clock s the node stays down.
    #[arg(long, default_value_t = 2.0)]
    pub fault_down: f64,
    /// refine-goal, refine-elbow: most refined executions (rounds of one execution with the
    /// person and one alone) before the trial fails.
    #[arg(long, default_value_t = 5)]
    pub refinements: u32,
    /// refine-goal, refine-elbow: ds_controller's TTC switch force f_s (N) instead of the one
    /// in --ds-params (Fig. 4.7's sweep: 5, 15, 30).
    #[arg(long)]
    pub switch_force: Option<f64>,
    /// refine-elbow: the person's largest push (N; default 14, under the thesis's f_s = 15 N).
    /// Above f_s the guidance takes the tool along (Fig. 4.7).
    #[arg(long, default_value_t = 14.0)]
    pub push_max: f64,
    /// Wall-clock seconds to wait for every node to be up.
    #[arg(long, default_value_t = 90.0)]
    pub startup_timeout: f64,
    /// pizza: `uni` (one arm does the whole task, the ingredients in its area) or `dual` (both
    /// arms, the ingredients in both areas).
    #[arg(long)]
    pub arms: Option<String>,
}

impl ExperimentArgs {
    /// The topics `--record-topics` names (split at spaces as well as commas), for the
    /// recorder's command line; empty: every topic.
    pub fn recorded_topics(&self) -> Vec<String> {
        self.record_topics.iter().flat_map(|t| t.split_whitespace()).map(str::to_owned).collect()
    }
}

/// Runs the experiment and writes what was asked.
pub fn run(args: ExperimentArgs) -> Result<()> {
    if args.fault.is_some() && !super::kitchen::NAMES.contains(&args.name.as_str()) {
        bail!("--fault is for the kitchen experiments ({})", super::kitchen::NAMES.join(", "));
    }
    if args.name == super::pizza::NAME {
        return super::pizza::run(&args);
    }
    if args.arms.is_some() {
        bail!("--arms is for the pizza experiment only");
    }
    if super::kitchen::NAMES.contains(&args.name.as_str()) {
        return super::kitchen::run(&args);
    }

    if super::refine::NAMES.contains(&args.name.as_str()) {
        return super::refine::run(&args);
    }
    if !cowork_experiment::plan::NAMES.contains(&args.name.as_str()) {
        let known: Vec<&str> =
            cowork_experiment::plan::NAMES.iter().chain(&super::kitchen::NAMES).chain(&super::refine::NAMES).chain(&[super::pizza::NAME]).copied().collect();
        bail!("unknown experiment `{}`; known: {}", args.name, known.join(", "));
    }
    if args.trials == 0 {
        bail!("--trials must be at least 1");
    }
    if !args.max && !(args.rate.is_finite() && args.rate > 0.0) {
        bail!("--rate {} must be > 0", args.rate);
    }
    if args.max {
        eprintln!(
            "note: --max runs the clock faster than the controller can follow (it holds the arm): \
             a plumbing check, not a measurement"
        );
    }
    let distance = DistanceMethod::parse(&args.distance)
        .with_context(|| format!("--distance {:?}: must be fded or flacco", args.distance))?;
    let root = crate::cmd::config_root()?;
    // Build every trial first: a bad name, scene or option fails before anything starts.
    let trials: Vec<Experiment> = (0..args.trials)
        .map(|k| {
            cowork_experiment::build(
                &args.name,
                &root,
                &cowork_experiment::Options {
                    seed: args.seed + u64::from(k),
                    scene: args.scene.clone(),
                    distance,
                    time_limit_s: args.time_limit,
                },
            )
        })
        .collect::<std::result::Result<_, _>>()?;
    for bin in [
        "lwr_sim",
        "fded_distance",
        "ds_controller",
        "human_observer",
    ] {
        let p = args.bin_dir.join(bin);
        if !p.is_file() {
            bail!(
                "{} missing; build with: cargo build --release --bins -p {bin}",
                p.display()
            );
        }
    }
    for (opt, p) in [("--ds-params", &args.ds_params), ("--observer-params", &args.observer_params)] {
        if !p.is_file() {
            bail!("{opt} {}: no such file", p.display());
        }
    }
    let model = RobotModel::from_urdf_file(root.join("config/robot/lwr4plus.urdf"))?;
    shutdown::install();
    let mut results = Vec::new();
    let mut report = Vec::new();
    for exp in &trials {
        if shutdown::requested() {
            break;
        }
        let (r, series) = run_trial(&args, exp, &model)?;
        report.push(report_trial(
            &format!("{} seed {} ({})", exp.name, r.seed, r.distance),
            &r,
            series,
        ));
        println!(
            "{} seed {}: {} (min distance {}, collisions {}, link damper {:.1} s, {:.1} s simulated, {:.0} s wall){}",
            exp.name,
            r.seed,
            if r.success { "success" } else { "FAILED" },
            r.closest_approach.as_ref().map_or("-".into(), |c| format!(
                "{:.3} m at {:.1} s, {} to {}",
                c.distance_m, c.t_s, c.link, c.body_part
            )),
            r.collisions,
            r.approach_limited_s,
            r.duration_s,
            r.wall_s,
            if r.reason.is_empty() {
                String::new()
            } else {
                format!(": {}", r.reason)
            }
        );
        if !r.latency_ms.is_empty() {
            let l: Vec<String> = r
                .latency_ms
                .iter()
                .map(|(k, s)| format!("{k} {:.1}/{:.1}", s.median, s.p99))
                .collect();
            println!("  latency ms median/p99 (sim clock): {}", l.join(", "));
        }
        if !r.gesture_reactions.is_empty() {
            print!(
                "{}{}",
                gestures::TABLE_HEADER,
                gestures::table(r.seed, &r.gesture_reactions)
            );
        }
        results.push(r);
        // Write after every trial: an interrupted run keeps what was done.
        if let Some(path) = &args.json {
            write_json(path, &RunResult::new(&args.name, results.clone()))?;
        }
    }
    let run = RunResult::new(&args.name, results);
    println!("{}", serde_json::to_string_pretty(&run.summary)?);
    if let Some(dir) = &args.report {
        cowork_experiment::report::write_report(dir, report_head(&args, &run), &report)?;
        println!("report: {}", dir.join("index.html").display());
    }
    Ok(())
}

/// The runner's latency samples as statistics in ms, by name.
fn latency_ms(l: &Latency) -> BTreeMap<String, Stats> {
    [
        ("depth_to_distances", &l.depth_to_distances),
        ("distances_to_command", &l.distances_to_command),
        ("skeleton_to_state", &l.skeleton_to_state),
        ("state_to_command", &l.state_to_command),
    ]
    .into_iter()
    .filter_map(|(k, v)| Stats::of(v.iter().map(|x| x * 1e3)).map(|s| (k.to_owned(), s)))
    .collect()
}

/// `/motion/status` in words: `command 3 held: stale /fded/distances ...`.
fn describe_status(s: &MotionStatus) -> String {
    let state = match s.state {
        MotionStatus::STATE_RUNNING => "running",
        MotionStatus::STATE_CONVERGED => "converged",
        MotionStatus::STATE_ABORTED => "aborted",
        MotionStatus::STATE_HELD => "held",
        _ => "unknown state",
    };
    let reason = if s.reason.is_empty() {
        String::new()
    } else {
        format!(": {}", s.reason)
    };
    format!("command {} {state}{reason}", s.command_id)
}

fn metres(v: Option<f64>) -> String {
    v.map_or("-".into(), |d| format!("{d:.3}"))
}

/// The report row of a trial.
pub fn report_trial(
    title: &str,
    r: &TrialResult,
    series: cowork_experiment::Series,
) -> ReportTrial {
    let row = vec![
        (
            "success".into(),
            if r.success {
                "yes".into()
            } else {
                format!("no: {}", r.reason)
            },
        ),
        ("min distance (m)".into(), metres(r.min_distance_m)),
        ("collisions".into(), r.collisions.to_string()),
        (
            "steps".into(),
            format!("{}/{}", r.steps_done, r.steps_total),
        ),
        ("duration (s)".into(), format!("{:.1}", r.duration_s)),
        ("backend".into(), r.backend.clone()),
        (
            "processing median / p99 (ms)".into(),
            r.processing_ms
                .map_or("-".into(), |s| format!("{:.2} / {:.2}", s.median, s.p99)),
        ),
        (
            "speed far / interaction (m/s)".into(),
            format!(
                "{} / {}",
                metres(r.speed_far_m_s),
                metres(r.speed_interaction_m_s)
            ),
        ),
        ("speed switches".into(), r.speed_switches.to_string()),
        (
            "link damper active (s)".into(),
            format!("{:.1}", r.approach_limited_s),
        ),
    ];
    let mut row = row;
    row.extend(cowork_experiment::report::near_person_columns(&series));
    if !r.gesture_reactions.is_empty() {
        let acted = r.gesture_reactions.iter().filter(|g| g.acted).count();
        row.push((
            "gestures acted on".into(),
            format!("{acted}/{}", r.gesture_reactions.len()),
        ));
        row.push((
            "release to hand (m)".into(),
            r.releases
                .iter()
                .map(|x| format!("{} {:.3}", x.object, x.distance_to_hand_m))
                .collect::<Vec<_>>()
                .join(", "),
        ));
    }
    ReportTrial {
        title: title.to_owned(),
        row,
        series,
    }
}

/// The report's head: the run's metadata and the thesis's numbers beside ours (Sec. 5.1.3).
fn report_head(args: &ExperimentArgs, run: &RunResult) -> ReportHead {
    let mut meta = Metadata::of_this_run()
        .with("experiment", args.name.clone())
        .with(
            "rate",
            if args.max { "--max (as fast as possible: a plumbing check)".to_owned() } else { format!("{} simulated s per wall-clock s", args.rate) },
        )
        .with(
            "seeds",
            match run.trials.len() {
                1 => args.seed.to_string(),
                n => format!("{}–{} ({n} trials)", args.seed, args.seed + n as u64 - 1),
            },
        )
        .with("distances", args.distance.clone());
    if let Some(l) = args.time_limit {
        meta = meta.with("time limit", format!("{l} simulated s"));
    }
    for t in &run.trials {
        let person = t.variant.as_ref().map_or("-".into(), cowork_experiment::report::describe_person);
        meta = meta.with(format!("person, seed {}", t.seed), person);
    }
    let n = run.trials.len();
    let speed = |f: fn(&TrialResult) -> Option<f64>| {
        Stats::of(run.trials.iter().filter_map(f)).map_or("-".into(), |s| format!("{:.3}", s.median))
    };
    let table = Table {
        caption: format!("Thesis Sec. 5.1.3 beside our {n} trial(s)"),
        header: ["", "thesis", "ours"].map(String::from).to_vec(),
        rows: vec![
            vec![
                "smallest robot–person distance (m)".into(),
                format!("{THESIS_MIN_DISTANCE_M:.3} (with fDED)"),
                run.summary.min_distance_m.map_or("-".into(), |d| format!("{d:.3} (true geometry; the robot avoided with {})", args.distance)),
            ],
            vec![
                "trials closer than the thesis's smallest distance".into(),
                String::new(),
                format!("{}/{n}", run.summary.below_thesis_min_distance),
            ],
            vec!["tool speed, person far (m/s; median)".into(), "0.3 (α_h)".into(), speed(|t| t.speed_far_m_s)],
            vec!["tool speed, person close (m/s; median)".into(), "0.1 (α_h)".into(), speed(|t| t.speed_interaction_m_s)],
            vec!["collisions (true geometry)".into(), String::new(), run.summary.collisions.to_string()],
        ],
    };
    ReportHead { title: format!("cowork experiment {}", args.name), meta, tables: vec![table] }
}

fn write_json(path: &Path, run: &RunResult) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    crate::cmd::output::write(path, serde_json::to_string_pretty(run)? + "\n")
}

/// Latest messages of the graph the runner reads.
struct Inputs {
    joints: cowork_ros::Subscription<JointState>,
    world: cowork_ros::Subscription<WorldState>,
    status: cowork_ros::Subscription<MotionStatus>,
    distances: cowork_ros::Subscription<LinkDistances>,
    human: cowork_ros::Subscription<HumanState>,
    gestures: cowork_ros::Subscription<Gesture>,
    commands: cowork_ros::Subscription<Float64MultiArray>,
}

/// Readiness of the graph: what has been heard from each node.
#[derive(Debug, Default)]
struct Heard {
    joints: bool,
    world: bool,
    status: bool,
    distances: bool,
    human: bool,
}

impl Heard {
    fn missing(&self) -> Vec<&'static str> {
        let mut m = Vec::new();
        for (ok, what) in [
            (self.joints, "/joint_states (lwr_sim)"),
            (self.world, "/lwr/world (lwr_sim)"),
            (self.status, "/motion/status (ds_controller)"),
            (self.distances, "/fded/distances (fded_distance)"),
            (self.human, "/human/state (human_observer)"),
        ] {
            if !ok {
                m.push(what);
            }
        }
        m
    }
}

impl Inputs {
    /// Drains every subscription into `judge`; returns the newest status of the motion.
    fn drain(
        &self,
        judge: &mut Judge,
        seq: &mut Sequencer,
        heard: &mut Heard,
        status: &mut Option<MotionStatus>,
        lat: &mut Latency,
        now: f64,
    ) {
        while let Some(m) = self.joints.take() {
            heard.joints = true;
            judge.on_joint_state(&m);
        }
        while let Some(m) = self.world.take() {
            heard.world = true;
            judge.on_world(&m);
        }
        while let Some(m) = self.status.take() {
            heard.status = true;
            judge.on_status(&m);
            *status = Some(m);
        }
        while let Some(m) = self.distances.take() {
            heard.distances = true;
            judge.on_distances(&m);
            lat.on_distances(m.header.stamp.to_secs_f64(), now);
        }
        while let Some(m) = self.human.take() {
            heard.human = true;
            judge.on_human_state(&m);
            lat.on_state(now);
            if m.present {
                let (h, v) = (&m.hand_position, &m.hand_velocity);
                seq.on_hand(m.header.stamp.to_secs_f64(), [h.x, h.y, h.z], [v.x, v.y, v.z]);
            }
        }
        while let Some(m) = self.gestures.take() {
            judge.on_gesture(&m);
            seq.on_gesture(m.header.stamp.to_secs_f64(), &m.label);
        }
        while let Some(m) = self.commands.take() {
            judge.on_command(&m);
            lat.on_command(now);
        }
    }
}

fn run_trial(
    args: &ExperimentArgs,
    exp: &Experiment,
    model: &RobotModel,
) -> Result<(TrialResult, cowork_experiment::Series)> {
    let wall0 = Instant::now();
    let tag = format!("{}-{}-{}", exp.name, exp.distance.as_str(), exp.seed);
    let logs = args.logs.join(&tag);
    std::fs::create_dir_all(&logs).with_context(|| format!("creating {}", logs.display()))?;
    let mut graph = cowork_graph::Graph::leased(&format!("cowork experiment {tag}"), &logs)?;
    let domain = graph.domain();
    let bin = |b: &str| args.bin_dir.join(b);
    let scene = exp.scene_path.display().to_string();
    let mut sim_args = vec![
        "--scene".into(),
        scene,
        "--params".into(),
        "config/lwr_sim.yaml".into(),
    ];
    if args.max {
        sim_args.push("--max".into());
    } else {
        sim_args.extend(["--rate".into(), args.rate.to_string()]);
    }
    // Nothing may outlive the runner for long, even if it is killed: every node has a limit.
    let wall_limit = args.startup_timeout
        + if args.max {
            exp.time_limit_s * 4.0
        } else {
            exp.time_limit_s / args.rate * 4.0
        }
        + 60.0;
    sim_args.extend(["--duration".into(), format!("{}", exp.time_limit_s + 60.0)]);
    let wall = |v: &mut Vec<String>| v.extend(["--duration".into(), format!("{wall_limit:.0}")]);
    let mut fded_args = vec![
        "--params".into(),
        "config/fded_distance.yaml".into(),
        "--use-sim-time".into(),
    ];
    if exp.distance == DistanceMethod::Flacco {
        fded_args.extend(["--method".into(), "flacco".into()]);
    }
    wall(&mut fded_args);
    let mut ds_args = vec![
        "--params".into(),
        args.ds_params.display().to_string(),
        "--use-sim-time".into(),
    ];
    wall(&mut ds_args);
    let mut obs_args = vec![
        "--params".into(),
        args.observer_params.display().to_string(),
        "--use-sim-time".into(),
    ];
    if !gestures::recognises_gestures(exp) {
        // Stacking alone: a reach that looks like a `stop` must not hold the task.
        obs_args.extend(["--gestures".into(), String::new()]);
    }
    wall(&mut obs_args);

    // The runner's own node first, so that no early message of the graph is missed.
    let mut node = RosNode::new(
        "cowork_experiment",
        &NodeConfig {
            use_sim_time: true,
            domain_id: Some(domain),
            ..NodeConfig::default()
        },
    )?;
    let inputs = Inputs {
        joints: node.subscribe(&topics::JOINT_STATES.reading(Delivery::BestEffort { depth: 2000 }))?,
        world: node.subscribe(&topics::WORLD)?,
        status: node.subscribe(&topics::MOTION_STATUS)?,
        distances: node.subscribe(&topics::FDED_DISTANCES.reading(Delivery::Reliable { depth: 100 }))?,
        human: node.subscribe(&topics::HUMAN_STATE.reading(Delivery::Reliable { depth: 100 }))?,
        gestures: node.subscribe(&topics::GESTURE.reading(Delivery::Reliable { depth: 100 }))?,
        commands: node
            .subscribe(&topics::JOINT_VELOCITY_COMMAND.reading(Delivery::BestEffort { depth: 2000 }))?,
    };
    let motion_pub =
        node.advertise(&topics::MOTION_COMMAND)?;
    let gripper_pub = node.advertise(&topics::GRIPPER_COMMAND)?;
    let skeleton_pub = node.advertise(&topics::SKELETON)?;

    let bag = args.record.as_ref().map(|d| d.join(format!("{tag}.mcap")));
    let started = (|| -> Result<()> {
        if let Some(bag) = &bag {
            std::fs::create_dir_all(bag.parent().unwrap_or(Path::new(".")))?;
            let me =
                std::env::current_exe().context("locating the cowork binary for the recorder")?;
            let mut rec = vec![
                "bag".into(),
                "record".into(),
                "-o".into(),
                bag.display().to_string(),
            ];
            wall(&mut rec);
            rec.extend(args.recorded_topics());
            graph.spawn("recorder", &me, &rec)?;
        }
        graph.spawn("human_observer", &bin("human_observer"), &obs_args)?;
        graph.spawn("ds_controller", &bin("ds_controller"), &ds_args)?;
        graph.spawn("fded_distance", &bin("fded_distance"), &fded_args)?;
        graph.spawn("lwr_sim", &bin("lwr_sim"), &sim_args)?;
        Ok(())
    })();
    // Which processes ran (for the log reader, and for checking that none is left over).
    let pids: String = graph
        .pids()
        .iter()
        .map(|(name, pid)| format!("{name} {pid}\n"))
        .collect();
    std::fs::write(logs.join("pids.txt"), pids)
        .with_context(|| format!("writing {}", logs.join("pids.txt").display()))?;

    let mut judge = Judge::new(model.clone(), cowork_people::DEFAULT_FLOOR_Z)?;
    let mut sequencer = Sequencer::new(exp.steps.clone());
    let bar = ProgressBar::new(sequencer.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{bar:30}] {pos}/{len} steps {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_prefix(format!("{} seed {}", exp.name, exp.seed));
    let mut heard = Heard::default();
    let mut status: Option<MotionStatus> = None;
    let mut outputs = Vec::new();
    let mut releases = Vec::new();
    let mut latency = Latency::default();
    let mut failure: Option<String> = started.err().map(|e| format!("graph did not start: {e:#}"));
    let startup_deadline = wall0 + cowork_ros::duration_s(args.startup_timeout);
    let mut t0: Option<f64> = None;
    let mut done_at: Option<f64> = None;
    let mut next_person = 0u64;
    let mut people_dropped = 0u64;
    let people_end = exp.people.duration();
    let person_period = 1.0 / exp.people_rate_hz;
    let mut skeleton = Skeleton::default();
    let mut last_t = 0.0;
    while failure.is_none() {
        if shutdown::requested() {
            failure = Some("interrupted (Ctrl-C)".into());
            break;
        }
        // A node that died, or a stranger writing on the graph's domain, ends the trial.
        if let Err(e) = graph.check_alive() {
            failure = Some(match e {
                cowork_graph::Error::Exited { .. } => format!("node died: {e}"),
                e => e.to_string(),
            });
            break;
        }
        let now = node.now().to_secs_f64();
        // Latency only once the graph is up (start-up queues are not latency).
        let lat_now = if t0.is_some() { now } else { f64::NAN };
        inputs.drain(&mut judge, &mut sequencer, &mut heard, &mut status, &mut latency, lat_now);
        if !node.clock_started() {
            if Instant::now() > startup_deadline {
                failure = Some(format!(
                    "graph not up after {} s: no /clock from lwr_sim",
                    args.startup_timeout
                ));
            }
            std::thread::sleep(Duration::from_millis(5));
            continue;
        }
        last_t = now;
        let Some(start) = t0 else {
            // Ready when every node has spoken and our writers are matched.
            let matched = motion_pub.subscription_count(&node) >= 1
                && gripper_pub.subscription_count(&node) >= 1
                && skeleton_pub.subscription_count(&node) >= 2;
            if heard.missing().is_empty() && matched {
                t0 = Some(now);
                bar.set_message(format!("t = 0 at sim {now:.2} s"));
            } else if Instant::now() > startup_deadline {
                let mut m = heard.missing();
                if !matched {
                    m.push("subscribers of /motion/command, /lwr/gripper_command, /human/skeleton");
                }
                failure = Some(format!(
                    "graph not up after {} s: nothing yet from {}",
                    args.startup_timeout,
                    m.join(", ")
                ));
            }
            std::thread::sleep(Duration::from_millis(2));
            continue;
        };
        let t = now - start;
        // The scripted people, on the simulated clock. A runner that fell behind (a slow build,
        // a loaded machine) publishes only the newest frame, as a tracker that drops frames.
        let due = (t.min(people_end) / person_period).floor() as u64;
        if due > next_person + 2 {
            people_dropped += due - next_person;
            next_person = due;
        }
        while (next_person as f64) * person_period <= t.min(people_end) {
            let tp = next_person as f64 * person_period;
            for (id, pose) in exp.people.poses_at(tp) {
                let meta = MessageMeta {
                    stamp: Time::from_secs_f64(start + tp),
                    frame_id: cowork_people::BASE_FRAME,
                    source: Skeleton::SOURCE_XSENS,
                    person_id: id,
                    with_velocities: true,
                };
                pose.write_message(&meta, &mut skeleton);
                judge.on_skeleton(&skeleton);
                skeleton_pub.publish(skeleton.clone())?;
                latency.on_skeleton(now);
            }
            next_person += 1;
        }
        if done_at.is_none() {
            outputs.clear();
            let progress = sequencer.update(now, status.as_ref(), judge.world(), &mut outputs);
            for o in outputs.drain(..) {
                match o {
                    Output::Motion(m) => motion_pub.publish(m)?,
                    Output::Gripper(g) => {
                        if g == "open" {
                            gestures::note_release(&sequencer, &judge, exp, now, &mut releases);
                        }
                        gripper_pub.publish(RosString { data: g.into() })?
                    }
                }
            }
            bar.set_position(sequencer.finished().len() as u64);
            match progress {
                Progress::Running => {}
                Progress::Done => done_at = Some(t),
                Progress::Failed(reason) => failure = Some(reason),
            }
            if let Some(step) = sequencer.current() {
                bar.set_message(format!("t = {t:.1} s: {}", Sequencer::label(step)));
            }
        }
        if let Some(d) = done_at
            && t >= (d + exp.settle_s).max(people_end)
        {
            break;
        }
        if t > exp.time_limit_s {
            failure = Some(format!(
                "time limit {} s reached at step {}/{} ({}); ds_controller: {}",
                exp.time_limit_s,
                sequencer.finished().len() + 1,
                sequencer.len(),
                sequencer
                    .current()
                    .map(Sequencer::label)
                    .unwrap_or_default(),
                status
                    .as_ref()
                    .map_or("no /motion/status".into(), describe_status)
            ));
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    bar.finish_and_clear();
    // Last messages in flight, then stop everything.
    std::thread::sleep(Duration::from_millis(100));
    let now = node.now().to_secs_f64();
    inputs.drain(&mut judge, &mut sequencer, &mut heard, &mut status, &mut latency, now);
    graph.stop();
    drop(node);

    let placements = judge.placements(&exp.placements);
    let mut subtasks = BTreeMap::new();
    for pl in &exp.placements {
        let Some(name) = &pl.subtask else { continue };
        let f = sequencer.finished();
        let begin = f
            .iter()
            .find(|s| s.1.contains(pl.object.as_str()))
            .map(|s| s.2);
        let end = f
            .iter()
            .find(|s| s.1 == format!("release {}", pl.object))
            .map(|s| s.3);
        let placed = placements
            .iter()
            .any(|p| p.object == pl.object && p.success);
        let time_s = begin.zip(end).map(|(b, e)| e - b);
        subtasks.insert(
            name.clone(),
            Subtask {
                time_s,
                success: time_s.is_some() && placed,
            },
        );
    }
    let mut reason = failure.unwrap_or_default();
    if reason.is_empty() {
        let bad: Vec<String> = placements
            .iter()
            .filter(|p| !p.success)
            .map(|p| {
                format!(
                    "{} off by {}",
                    p.object,
                    p.error_m
                        .map_or("? (missing)".into(), |e| format!("{:.3} m", e))
                )
            })
            .collect();
        if !bad.is_empty() {
            reason = format!("placement: {}", bad.join(", "));
        } else if judge.collisions > 0 {
            reason = format!("{} collision(s) between robot and person", judge.collisions);
        }
    }
    let duration_s = t0.map_or(0.0, |s| (last_t - s).max(0.0));
    let gesture_reactions = gestures::reactions(exp, &judge, &sequencer, t0, last_t, &releases);
    if reason.is_empty() {
        let bad = cowork_experiment::cooperation::failures(&gesture_reactions);
        if !bad.is_empty() {
            reason = format!("gestures not acted on: {}", bad.join("; "));
        }
    }
    let result = TrialResult {
        seed: exp.seed,
        success: reason.is_empty(),
        reason,
        duration_s,
        wall_s: wall0.elapsed().as_secs_f64(),
        min_distance_m: judge.min_distance(),
        closest_approach: judge.closest.clone(),
        collisions: judge.collisions,
        subtasks,
        distance: exp.distance.as_str().into(),
        backend: judge.series.backend.clone(),
        processing_ms: Stats::of(judge.series.processing_ms.iter().map(|p| p.1)),
        speed_far_m_s: judge.speed_at(0.3),
        speed_interaction_m_s: judge.speed_at(0.1),
        speed_switches: judge.speed_switches(),
        placements,
        people_frames_dropped: people_dropped,
        last_status: status.as_ref().map(describe_status),
        steps_done: sequencer.finished().len(),
        steps_total: sequencer.len(),
        gestures: judge.series.gestures.iter().map(|g| g.1.clone()).collect(),
        variant: Some(exp.variant.clone()),
        bag: bag.map(|b| b.display().to_string()),
        approach_limited_s: judge.approach_limited_s,
        approach_limited_links: judge.approach_limited_links.clone(),
        gesture_reactions,
        releases,
        latency_ms: latency_ms(&latency),
    };
    Ok((result, judge.series))
}
