//! `robot_manager`: kinesthetic teaching with online segmentation, the primitive database and
//! execution of the supervisor's actions (thesis Sec. 4.3.1, 5.2.1) as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use robot_manager::{Params, RobotManagerNode};

/// Robot manager: segments demonstrations into NOA/FOA/gripper primitives while teaching,
/// executes `/supervisor/action` labels through ds_controller and the gripper, and reports the
/// robot and object state on `/robot_stream` and `/object_stream`.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// ROS 2 parameter file with a `robot_manager: ros__parameters:` block.
    #[arg(long, default_value = "config/robot_manager.yaml")]
    params: PathBuf,
    /// Directory of the primitive database (overrides `database_dir`).
    #[arg(long)]
    database_dir: Option<PathBuf>,
    #[command(flatten)]
    node: cowork_ros::NodeArgs,
}

fn main() -> std::process::ExitCode {
    cowork_ros::node_main(run)
}

/// The node state (the running action, the world, the database), kept when `node_main` runs
/// the node again in this process (its DDS threads were lost to a stop and continue).
static KEPT: std::sync::Mutex<Option<RobotManagerNode>> = std::sync::Mutex::new(None);

fn run(args: Args) -> Result<()> {
    let (mut params, place): (Params, _) = args.node.load(&args.params, "robot_manager")?;
    if let Some(d) = &args.database_dir {
        params.database_dir = d.display().to_string();
    }
    params.validate(&place).with_context(|| format!("invalid parameters in {place}"))?;
    let tick = params.tick_rate_hz;
    let use_sim_time = params.use_sim_time;
    if let Some(rm) = KEPT.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take() {
        tracing::warn!("going on with the action and the world kept from before the restart");
        let (node, options) = args.node.start("robot_manager", use_sim_time)?;
        return keep_for_restart(robot_manager::run(node, rm, tick, &options)?);
    }
    let preview = robot_manager::preview::load(&params, &place)?;
    let (mut rm, problem) = RobotManagerNode::new(params, robot_manager::run::unix_s());
    if let Some(p) = problem {
        tracing::error!("{p}");
    }
    if let Some((previewer, joint_names)) = preview {
        rm.set_previewer(previewer, joint_names);
    }
    let (node, options) = args.node.start("robot_manager", use_sim_time)?;
    // In an arm's namespace (`--ros-args -r __ns:=/left`) it serves that arm's commands only.
    rm.set_arm(node.namespace().rsplit('/').next().unwrap_or_default());
    keep_for_restart(robot_manager::run(node, rm, tick, &options)?)
}

fn keep_for_restart(rm: RobotManagerNode) -> Result<()> {
    if cowork_ros::shutdown::restarting() {
        *KEPT.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(rm);
    }
    Ok(())
}
