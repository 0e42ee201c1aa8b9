//! `robot_manager`: kinesthetic teaching with online segmentation, the primitive database and
//! execution of the supervisor's actions (thesis Sec. 4.3.1, 5.2.1) as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use robot_manager::{Params, RobotManagerNode, RunOptions};

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
    /// Take time from `/clock` (overrides `use_sim_time: false` in the parameter file).
    #[arg(long)]
    use_sim_time: bool,
    /// Stop after this many wall-clock seconds (runs until Ctrl-C otherwise).
    #[arg(long)]
    duration: Option<f64>,
}

fn main() -> Result<()> {
    cowork_ros::init_logging();
    let args = Args::parse();
    let place = args.params.display().to_string();
    let mut params: Params = cowork_ros::params::load(&args.params, "robot_manager")?;
    params.use_sim_time |= args.use_sim_time;
    if let Some(d) = &args.database_dir {
        params.database_dir = d.display().to_string();
    }
    params.validate(&place).with_context(|| format!("invalid parameters in {place}"))?;
    let tick = params.tick_rate_hz;
    let use_sim_time = params.use_sim_time;
    let (rm, problem) = RobotManagerNode::new(params, robot_manager::run::unix_s());
    if let Some(p) = problem {
        tracing::error!("{p}");
    }
    let node = cowork_ros::start_node("robot_manager", use_sim_time, args.duration)?;
    robot_manager::run(node, rm, tick, &RunOptions { duration_s: args.duration, stop: None })?;
    Ok(())
}
