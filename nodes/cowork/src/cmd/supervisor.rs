//! `cowork supervisor ...`: the attentional supervisor without ROS — run it on a timed event
//! script and log every decision, or show its working memory tree.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail};
use clap::{Subcommand, ValueEnum};
use cowork_supervisor::{Decision, Ltm, RunConfig, SimRobot, Supervisor, SupervisorConfig, TimedEvent, parse_jsonl, runner};
use serde::Serialize;

/// Supervisor commands.
#[derive(Debug, Subcommand)]
pub enum SupervisorCommand {
    /// Drive the supervisor from a JSON-lines event script; write every decision and a WM
    /// snapshot after every tick that decided something (JSON lines).
    Run {
        /// Long-term memory (schema file), e.g. config/tasks/kitchen.schema.
        #[arg(long)]
        ltm: PathBuf,
        /// Task to allocate, e.g. prepareCoffee or 'add(water)'.
        #[arg(long)]
        task: String,
        /// Timed stimuli (JSON lines: objects, gripper, action_done/failed, segment, speech, state).
        #[arg(long)]
        events: PathBuf,
        /// Decisions and WM snapshots (JSON lines).
        #[arg(short, long)]
        output: PathBuf,
        /// Supervisor tick rate (Hz).
        #[arg(long, default_value_t = 100.0)]
        rate: f64,
        /// Time to keep ticking after the last event (s); stops early once the task is done.
        #[arg(long, default_value_t = 30.0)]
        tail: f64,
        /// Simulate the robot manager: every commanded action is done after SECONDS (gripper
        /// actions named close…/open… also close/open the gripper).
        #[arg(long, value_name = "SECONDS")]
        sim_robot: Option<f64>,
        /// Save the LTM here (atomically) if anything was learned.
        #[arg(long)]
        save_ltm: Option<PathBuf>,
    },
    /// Print the working memory tree after replaying an event script up to a time.
    Show {
        /// Long-term memory (schema file).
        #[arg(long)]
        ltm: PathBuf,
        /// Task to allocate.
        #[arg(long)]
        task: String,
        /// Event script to replay first (none: the freshly expanded tree).
        #[arg(long)]
        events: Option<PathBuf>,
        /// Replay events up to this time (s); all of them when omitted.
        #[arg(long)]
        at: Option<f64>,
        /// Simulate the robot manager while replaying (see `run`).
        #[arg(long, value_name = "SECONDS")]
        sim_robot: Option<f64>,
        /// Output format.
        #[arg(long, value_enum, default_value_t = ShowFormat::Text)]
        format: ShowFormat,
        /// Also render the tree to a PNG with Graphviz `dot`.
        #[arg(long)]
        png: Option<PathBuf>,
    },
}

/// How `show` prints the tree.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ShowFormat {
    /// Indented tree with releasers, post-conditions, 1/e and μ.
    Text,
    /// Graphviz DOT.
    Dot,
    /// The snapshot as JSON (fields of cowork_msgs/WmNode).
    Json,
}

/// Runs a supervisor subcommand.
pub fn run(cmd: SupervisorCommand) -> Result<()> {
    match cmd {
        SupervisorCommand::Run { ltm, task, events, output, rate, tail, sim_robot, save_ltm } => {
            run_script(&ltm, &task, &events, &output, rate, tail, sim_robot, save_ltm.as_deref())
        }
        SupervisorCommand::Show { ltm, task, events, at, sim_robot, format, png } => {
            show(&ltm, &task, events.as_deref(), at, sim_robot, format, png.as_deref())
        }
    }
}

fn load(ltm: &Path, task: &str) -> Result<Supervisor> {
    let l = Ltm::load(ltm).with_context(|| format!("cannot load the LTM {}", ltm.display()))?;
    Supervisor::new(l, task, SupervisorConfig::default()).with_context(|| format!("--task {task:?} in {}", ltm.display()))
}

fn read_events(path: &Path) -> Result<Vec<TimedEvent>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_jsonl(&text).with_context(|| format!("bad event script {}", path.display()))
}

fn run_config(rate: f64, tail: f64, sim_robot: Option<f64>) -> Result<RunConfig> {
    if !(rate.is_finite() && rate > 0.0) {
        bail!("--rate {rate}: must be a positive number of Hz");
    }
    if !(tail.is_finite() && tail >= 0.0) {
        bail!("--tail {tail}: must be a non-negative number of seconds");
    }
    if let Some(d) = sim_robot
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--sim-robot {d}: must be a positive number of seconds");
    }
    Ok(RunConfig { rate_hz: rate, tail_s: tail, robot: sim_robot.map(|d| SimRobot { action_duration_s: d }) })
}

#[derive(Serialize)]
struct SnapshotLine<'a> {
    tick: u64,
    t: f64,
    #[serde(rename = "type")]
    kind: &'static str,
    #[serde(flatten)]
    snapshot: &'a cowork_supervisor::WmSnapshot,
}

#[allow(clippy::too_many_arguments)]
fn run_script(
    ltm: &Path,
    task: &str,
    events: &Path,
    output: &Path,
    rate: f64,
    tail: f64,
    sim_robot: Option<f64>,
    save_ltm: Option<&Path>,
) -> Result<()> {
    let cfg = run_config(rate, tail, sim_robot)?;
    let mut sup = load(ltm, task)?;
    let evs = read_events(events)?;
    // WM snapshots after every tick that decided something, written after that tick's decisions.
    let mut snapshots: Vec<(u64, String)> = Vec::new();
    let mut snap_err: Option<serde_json::Error> = None;
    let report = runner::run(&mut sup, &evs, &cfg, |s, tick, t, decisions| {
        if decisions.is_empty() || snap_err.is_some() {
            return;
        }
        let snap = s.snapshot();
        match serde_json::to_string(&SnapshotLine { tick, t, kind: "wm", snapshot: &snap }) {
            Ok(line) => snapshots.push((tick, line)),
            Err(e) => snap_err = Some(e),
        }
    });
    if let Some(e) = snap_err {
        return Err(e).context("serialising a WM snapshot");
    }
    let mut out = super::output::Output::create(output)?;
    let mut snaps = snapshots.iter().peekable();
    for r in &report.records {
        while let Some((tick, line)) = snaps.peek() {
            if *tick >= r.tick {
                break;
            }
            writeln!(out, "{line}")?;
            snaps.next();
        }
        serde_json::to_writer(&mut out, r)?;
        out.write_all(b"\n")?;
    }
    for (_, line) in snaps {
        writeln!(out, "{line}")?;
    }
    out.commit().with_context(|| format!("writing {}", output.display()))?;

    let count = |f: fn(&Decision) -> bool| report.records.iter().filter(|r| f(&r.decision)).count();
    println!("ticks:              {} at {} Hz ({:.2} s)", report.ticks, rate, report.ticks as f64 / rate);
    println!("decisions:          {}", report.records.len());
    println!("actions commanded:  {}", count(|d| matches!(d, Decision::Action { .. })));
    println!("actions learned:    {}", count(|d| matches!(d, Decision::Attached { .. })));
    println!("warnings:           {}", count(|d| matches!(d, Decision::Warning { .. })));
    println!("max stimulus→action latency: {} tick(s) ({:.1} ms)", report.max_latency_ticks, report.max_latency_ticks as f64 * 1000.0 / rate);
    println!("task accomplished:  {}", report.task_accomplished());
    for r in &report.records {
        if let Decision::Warning { message, .. } = &r.decision {
            eprintln!("warning at t={:.2} s: {message}", r.t);
        }
    }
    if let Some(p) = save_ltm {
        if sup.ltm_changed() {
            sup.ltm().save(p).with_context(|| format!("saving the learned LTM to {}", p.display()))?;
            println!("learned LTM saved:  {}", p.display());
        } else {
            println!("nothing learned; {} not written", p.display());
        }
    }
    println!("decisions written:  {}", output.display());
    Ok(())
}

fn show(
    ltm: &Path,
    task: &str,
    events: Option<&Path>,
    at: Option<f64>,
    sim_robot: Option<f64>,
    format: ShowFormat,
    png: Option<&Path>,
) -> Result<()> {
    let mut sup = load(ltm, task)?;
    let mut evs = match events {
        Some(p) => read_events(p)?,
        None => Vec::new(),
    };
    if let Some(t) = at {
        if !t.is_finite() {
            bail!("--at {t}: not a finite time");
        }
        evs.retain(|e| e.t <= t);
    }
    let tail = match (at, evs.last()) {
        (Some(t), Some(last)) => (t - last.t).max(0.0),
        (Some(t), None) => t.max(0.0),
        (None, _) => 0.0,
    };
    let cfg = run_config(100.0, tail, sim_robot)?;
    runner::run(&mut sup, &evs, &cfg, |_, _, _, _| {});
    match format {
        ShowFormat::Text => print!("{}", sup.render_text()),
        ShowFormat::Dot => print!("{}", sup.render_dot()),
        ShowFormat::Json => println!("{}", serde_json::to_string_pretty(&sup.snapshot())?),
    }
    if let Some(p) = png {
        let mut child = Command::new("dot")
            .arg("-Tpng")
            .arg("-o")
            .arg(p)
            .stdin(Stdio::piped())
            .spawn()
            .context("--png needs Graphviz `dot` on the PATH (apt-get install graphviz); use --format dot instead")?;
        child.stdin.take().context("dot stdin")?.write_all(sup.render_dot().as_bytes())?;
        let status = child.wait()?;
        if !status.success() {
            bail!("dot failed ({status}) writing {}", p.display());
        }
    }
    Ok(())
}
