//! `attentional_supervisor`: the attentional supervisor as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use attentional_supervisor::{Params, SupervisorNode};
use clap::Parser;
use cowork_supervisor::{Ltm, Supervisor};

/// Attentional supervisor (thesis Sec. 4.3, 5.2): plans the next action from `/robot_stream`,
/// `/object_stream` and `/speech_command`; publishes `/supervisor/action` and
/// `/supervisor/working_memory`.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Long-term memory: schema file in the thesis's notation.
    #[arg(long)]
    ltm: PathBuf,
    /// Task to allocate from the LTM, e.g. `pourDrink`, `prepareCoffee`, `add(water)`.
    #[arg(long)]
    task: String,
    /// Save the LTM here (atomically) whenever teaching attaches actions. Without it learned
    /// actions are kept in memory only; the input file is never overwritten unless named here.
    #[arg(long)]
    save_ltm: Option<PathBuf>,
    /// ROS 2 parameter file with an `attentional_supervisor: ros__parameters:` block.
    #[arg(long, default_value = "config/attentional_supervisor.yaml")]
    params: PathBuf,
    #[command(flatten)]
    node: cowork_ros::NodeArgs,
}

fn main() -> std::process::ExitCode {
    cowork_ros::node_main(run)
}

/// The node state (working memory, running action, what was learned), kept when `node_main`
/// runs the node again in this process (its DDS threads were lost to a stop and continue).
static KEPT: std::sync::Mutex<Option<SupervisorNode>> = std::sync::Mutex::new(None);

fn run(args: Args) -> Result<()> {
    let (mut params, place): (Params, _) = args.node.load(&args.params, "attentional_supervisor")?;
    // `--use-sim-time` paces the decisions on /clock too, not only the node's clock.
    params.use_sim_time |= args.node.use_sim_time;
    params.validate(&place).with_context(|| format!("invalid parameters in {place}"))?;
    if let Some(path) = &args.save_ltm {
        // A save killed half-way (kill -9) leaves its temporary file; the LTM itself is intact.
        match cowork_store::remove_orphan_temporaries(path) {
            Ok(removed) => removed.iter().for_each(|p| tracing::info!("removed {} (left by a save that was killed)", p.display())),
            Err(e) => tracing::warn!("{e}"),
        }
    }
    let kept = KEPT.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
    if let Some(mut node_state) = kept {
        tracing::warn!("going on with the working memory kept from before the restart");
        let (node, options) = args.node.start("attentional_supervisor", params.use_sim_time)?;
        let result = attentional_supervisor::run_with(node, &mut node_state, args.save_ltm.as_deref(), &options);
        keep_for_restart(node_state);
        return result;
    }
    let ltm = Ltm::load(&args.ltm).with_context(|| format!("cannot load the LTM {}", args.ltm.display()))?;
    params
        .areas
        .check_arms(&place, ltm.arms())
        .with_context(|| format!("the parameters do not fit the arms of {}", args.ltm.display()))?;
    let supervisor = Supervisor::new(ltm, &args.task, params.attention.clone())
        .with_context(|| format!("cannot allocate task {} from {}", args.task, args.ltm.display()))?;
    let (node, options) = args.node.start("attentional_supervisor", params.use_sim_time)?;
    let mut node_state = SupervisorNode::new(supervisor, &params);
    let result = attentional_supervisor::run_with(node, &mut node_state, args.save_ltm.as_deref(), &options);
    keep_for_restart(node_state);
    result
}

fn keep_for_restart(node_state: SupervisorNode) {
    if cowork_ros::shutdown::restarting() {
        *KEPT.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(node_state);
    }
}
