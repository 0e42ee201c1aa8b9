//! `ds_controller`: the reactive DS controller as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use cowork_robot::RobotModel;
use ds_controller::Params;

/// Reactive DS controller (thesis Sec. 5.1.1, 5.1.3) at 1 kHz: goal adaptation, velocity
/// scaling from `/human/state`, DS modulation and null-space avoidance from `/fded/distances`,
/// watchdog on stale inputs. Runs `/motion/command`, publishes `/lwr/joint_velocity_command`
/// and `/motion/status`.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Robot description (URDF with per-link meshes).
    #[arg(long, default_value = "config/robot/lwr4plus.urdf")]
    urdf: PathBuf,
    /// ROS 2 parameter file with a `ds_controller: ros__parameters:` block.
    #[arg(long, default_value = "config/ds_controller.yaml")]
    params: PathBuf,
    #[command(flatten)]
    node: cowork_ros::NodeArgs,
}

fn main() -> std::process::ExitCode {
    cowork_ros::node_main(run)
}

fn run(mut args: Args) -> Result<()> {
    // `config/...` defaults resolve to the bundled config directory from any working directory.
    args.urdf = cowork_ros::config::resolve(&args.urdf);
    let (mut params, place): (Params, _) = args.node.load(&args.params, "ds_controller")?;
    params.use_sim_time |= args.node.use_sim_time;
    params.validate(&place).with_context(|| format!("invalid parameters in {place}"))?;
    let model = RobotModel::from_urdf_file(&args.urdf)
        .with_context(|| format!("cannot load robot description {}", args.urdf.display()))?;
    let (node, options) = args.node.start("ds_controller", params.use_sim_time)?;
    ds_controller::run(node, model, &params, &options)
}
