//! [`run`]: the node over DDS. [`run_loop`] is the whole behaviour, generic over where the
//! inputs come from: the DDS source here, a scripted one in the golden tests.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::topics;
use cowork_ros::{DdsSource, Event, InputSource, RosNode, RunOptions, Warnings};
use cowork_supervisor::{Decision, Supervisor};

use crate::node::{Input, Output, Pacer, SupervisorNode, WARNING_REPEAT_S};

/// What a run did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RunSummary {
    /// Inputs handled.
    pub inputs: u64,
    /// Ticks of the loop (deciding or waiting for the first `/object_stream`).
    pub ticks: u64,
    /// `/supervisor/action` messages put out.
    pub actions: u64,
    /// Warnings put out.
    pub warnings: u64,
}

/// Hands every input of `source` to `node` as it arrives and ticks the node at
/// `tick_rate_hz` on the source's clock (working memory at `snapshot_rate_hz`, the LTM when
/// teaching changed it), every output to `emit`, until the source ends. Inputs take effect at
/// the next tick.
pub fn run_loop<S: InputSource<Input>>(source: &mut S, node: &mut SupervisorNode, emit: &mut dyn FnMut(Output)) -> RunSummary {
    let mut ticks = Pacer::new(node.params().tick_period_s());
    let snapshot_rate = node.params().snapshot_rate_hz;
    let mut snapshots = (snapshot_rate > 0.0).then(|| Pacer::new(1.0 / snapshot_rate));
    let mut summary = RunSummary::default();
    let mut out = Vec::new();
    let mut next_s = source.now_s();
    loop {
        match source.next(next_s) {
            Event::End => break,
            Event::Input(input) => {
                summary.inputs += 1;
                node.on_input(&input);
            }
            Event::Deadline => {
                let now_s = source.now_s();
                if ticks.due(now_s) {
                    let now = Time::from_secs_f64(now_s);
                    summary.ticks += 1;
                    node.on_tick(now, &mut out);
                    if let Some(s) = snapshots.as_mut()
                        && s.due(now_s)
                    {
                        out.push(Output::WorkingMemory(node.working_memory(now)));
                    }
                    if let Some(ltm) = node.take_learned() {
                        out.push(Output::Learned { ltm });
                    }
                    for o in out.drain(..) {
                        match &o {
                            Output::Action(_) => summary.actions += 1,
                            Output::Warning(_) => summary.warnings += 1,
                            _ => {}
                        }
                        emit(o);
                    }
                }
                next_s = now_s + ticks.wait_s(now_s);
            }
        }
    }
    summary
}

impl SupervisorNode {
    /// Saves the LTM to `path` (atomically) if something was learned since the last save.
    /// Returns whether it saved.
    pub fn save_ltm_if_changed(&mut self, path: &Path) -> cowork_supervisor::Result<bool> {
        let sup = self.supervisor_mut();
        if !sup.ltm_changed() {
            return Ok(false);
        }
        sup.ltm().save(path)?;
        sup.mark_ltm_saved();
        Ok(true)
    }
}

/// The learned LTM on its way to `--save-ltm`: saved when it changes, a failed save retried
/// at most once a second (at the next output) and once more when the node stops.
struct LtmSaver {
    path: Option<PathBuf>,
    pending: Option<String>,
    retry_at_s: f64,
    told_unsaved: bool,
}

impl LtmSaver {
    fn learned(&mut self, text: String) {
        self.pending = Some(text);
        self.retry_at_s = f64::NEG_INFINITY;
        self.try_save();
    }

    fn try_save(&mut self) {
        let Some(text) = &self.pending else { return };
        let Some(path) = &self.path else {
            if !self.told_unsaved {
                self.told_unsaved = true;
                tracing::warn!("learned actions are kept in memory only; pass --save-ltm FILE to keep them");
            }
            self.pending = None;
            return;
        };
        let now = cowork_ros::monotonic_s();
        if now < self.retry_at_s {
            return;
        }
        match cowork_store::write_atomic(path, text.as_bytes()) {
            Ok(()) => {
                self.pending = None;
                tracing::info!("learned LTM saved to {}", path.display());
            }
            Err(e) => {
                self.retry_at_s = now + 1.0;
                tracing::error!("cannot save the learned LTM to {} (retrying every second): {e}", path.display());
            }
        }
    }
}

/// Runs the node until Ctrl-C, `options.stop` or `options.duration_s`; returns the supervisor
/// with what it learned, saved to `save_ltm` (atomically, after every change) when given.
/// `node` must have been created with `use_sim_time` = the node's `params().use_sim_time`.
pub fn run(node: RosNode, mut sn: SupervisorNode, save_ltm: Option<&Path>, options: &RunOptions) -> Result<Supervisor> {
    run_with(node, &mut sn, save_ltm, options)?;
    Ok(sn.into_supervisor())
}

/// [`run`] on a node state the caller keeps: the node binary keeps it across an in-process
/// restart (`cowork_ros::node_main` after a stop and continue), so the working memory and the
/// running action go on; the running action is then not stopped on the way out, and it is sent
/// again when the robot stream comes back ([`SupervisorNode`]'s silence rule).
pub fn run_with(node: RosNode, sn: &mut SupervisorNode, save_ltm: Option<&Path>, options: &RunOptions) -> Result<()> {
    let sn = &mut *sn;
    let mut source = DdsSource::new(node, options.start())?;
    let arms = sn.dual_arms();
    if arms.is_empty() {
        source.add(&topics::ROBOT_STREAM, Input::RobotStream)?;
        source.add(&topics::OBJECT_STREAM, Input::ObjectStream)?;
    } else {
        // The bases first: objects that arrive with them are placed at once.
        source.add(&topics::TF_STATIC, Input::TfStatic)?;
        for arm in &arms {
            let ns = format!("/{arm}");
            let a = arm.clone();
            source
                .add_in(&topics::ROBOT_STREAM, &ns, move |msg| Input::ArmRobotStream { arm: a.clone(), msg })
                .with_context(|| format!("arm `{arm}` of the LTM: {}", topics::ROBOT_STREAM.name_in(&ns)))?;
            let a = arm.clone();
            source
                .add_in(&topics::OBJECT_STREAM, &ns, move |msg| Input::ArmObjectStream { arm: a.clone(), msg })
                .with_context(|| format!("arm `{arm}` of the LTM: {}", topics::OBJECT_STREAM.name_in(&ns)))?;
        }
    }
    source.add(&topics::SPEECH_COMMAND, Input::Speech)?;
    let actions = source.node().advertise(&topics::SUPERVISOR_ACTION)?;
    let wm = source.node().advertise(&topics::WORKING_MEMORY)?;
    let params = sn.params().clone();
    tracing::info!(
        "attentional_supervisor running: tick {} Hz, snapshots {} Hz, {} time, LTM saved to {}",
        params.tick_rate_hz,
        params.snapshot_rate_hz,
        if params.use_sim_time { "/clock (waiting for the first)" } else { "wall-clock" },
        save_ltm.map_or("nowhere (no --save-ltm)".into(), |p| p.display().to_string())
    );
    if !arms.is_empty() {
        let a = &params.areas;
        tracing::info!(
            "arms {}: reading {}, /tf_static ({}); commands name the arm; central area `{}` = x in [{}, {}], y in [{}, {}] m ({}), `{}` above it in y, `{}` below",
            arms.join(", "),
            arms.iter()
                .flat_map(|arm| {
                    let ns = format!("/{arm}");
                    [topics::ROBOT_STREAM.name_in(&ns).into_owned(), topics::OBJECT_STREAM.name_in(&ns).into_owned()]
                })
                .collect::<Vec<_>>()
                .join(", "),
            arms.iter().map(|arm| format!("{} -> {}", a.frame, a.base_frame(arm))).collect::<Vec<_>>().join(", "),
            params.attention.central_area,
            a.central.x[0],
            a.central.x[1],
            a.central.y[0],
            a.central.y[1],
            a.frame,
            a.left_arm,
            a.right_arm
        );
    }
    if params.wait_for_object_stream {
        if arms.is_empty() {
            tracing::info!("deciding nothing before the first {}", topics::OBJECT_STREAM.name);
        } else {
            tracing::info!("deciding nothing before the first /<arm>{} of every arm", topics::OBJECT_STREAM.name);
        }
    }
    let mut warnings = Warnings::new(WARNING_REPEAT_S);
    let mut saver = LtmSaver { path: save_ltm.map(Path::to_owned), pending: None, retry_at_s: 0.0, told_unsaved: false };
    let summary = run_loop(&mut source, sn, &mut |out| {
        let failed = match out {
            Output::Action(c) => actions.send(c),
            Output::WorkingMemory(m) => wm.send(m),
            Output::Decision(d) => {
                log_decision(&d);
                None
            }
            Output::Learned { ltm } => {
                saver.learned(ltm);
                None
            }
            Output::Warning(w) => Some(w),
        };
        if let Some(w) = failed {
            warnings.warn(cowork_ros::monotonic_s(), &w);
        }
        saver.try_save();
    });

    let now = source.node().now();
    let goodbyes = if cowork_ros::shutdown::restarting() {
        tracing::warn!("restarting in this process: the working memory and the running action are kept");
        Vec::new()
    } else {
        sn.shutdown_commands(now)
    };
    for c in goodbyes {
        if c.arm.is_empty() {
            tracing::info!("stopping {} on shutdown", c.label);
        } else {
            tracing::info!("stopping {} on arm {} on shutdown", c.label, c.arm);
        }
        if let Some(w) = actions.send(c) {
            warnings.warn(cowork_ros::monotonic_s(), &w);
        }
    }
    if let Some(text) = saver.pending.take()
        && let Some(path) = &saver.path
        && let Err(e) = cowork_store::write_atomic(path, text.as_bytes())
    {
        bail!("cannot save the learned LTM to {}: {e}", path.display());
    }
    tracing::info!(
        "attentional_supervisor stopped after {} ticks ({} deciding, {} inputs, {} actions, {} warnings)",
        summary.ticks,
        sn.supervisor().ticks(),
        summary.inputs,
        summary.actions,
        summary.warnings
    );
    Ok(())
}

fn log_decision(d: &Decision) {
    match d {
        Decision::Action { id, arm, label, kind, subtask, releaser, emphasis } => tracing::info!(
            "action {id}: {label} ({}) of {subtask}{}, releaser {releaser}, emphasis {emphasis:.3} 1/s",
            kind.keyword(),
            arm.as_deref().map(|a| format!(" on arm {a}")).unwrap_or_default()
        ),
        Decision::Stop { arm, label, reason } => tracing::info!(
            "stop {label}{}: {reason}",
            arm.as_deref().map(|a| format!(" on arm {a}")).unwrap_or_default()
        ),
        Decision::AwaitDemonstration { arm, subtask } => tracing::info!(
            "subtask {subtask}{} is open: waiting for a demonstration (say `teach`)",
            arm.as_deref().map(|a| format!(" of arm {a}")).unwrap_or_default()
        ),
        Decision::Attached { arm, label, kind, subtask, releaser } => tracing::info!(
            "learned {label} ({}) in {subtask}{}, releaser {releaser}",
            kind.keyword(),
            arm.as_deref().map(|a| format!(" on arm {a}")).unwrap_or_default()
        ),
        Decision::HumanAssigned { subtask } => tracing::info!("{subtask} assigned to the person"),
        Decision::Mode { mode } => tracing::info!("mode: {mode:?}"),
        Decision::Accomplished { behaviour } => tracing::info!("accomplished: {behaviour}"),
        Decision::TaskAccomplished { task } => tracing::info!("task accomplished: {task}"),
        Decision::Warning { message, .. } => tracing::warn!("{message}"),
    }
}
