//! `fded_distance`: fDED robot–obstacle distances (thesis Sec. 5.1.2) as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use cowork_robot::RobotModel;
use fded_distance::{FdedNode, Params};

/// fDED: per depth frame on `/camera/depth/image_raw`, the distance of every robot link to the
/// closest obstacle, with points, normal and obstacle velocity, on `/fded/distances`, and
/// markers for viewers on `/fded/markers`.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// ROS 2 parameter file with a `fded_distance: ros__parameters:` block.
    #[arg(long, default_value = "config/fded_distance.yaml")]
    params: PathBuf,
    /// Robot description (overrides `urdf` in the parameter file).
    #[arg(long)]
    urdf: Option<PathBuf>,
    /// `auto`, `cpu` or `gpu` (overrides `backend` in the parameter file).
    #[arg(long)]
    backend: Option<String>,
    /// `fded` or `flacco` (overrides `method` in the parameter file).
    #[arg(long)]
    method: Option<String>,
    #[command(flatten)]
    node: cowork_ros::NodeArgs,
}

fn main() -> std::process::ExitCode {
    cowork_ros::node_main(run)
}

fn run(args: Args) -> Result<()> {
    let (mut params, place): (Params, _) = args.node.load(&args.params, "fded_distance")?;
    if let Some(u) = &args.urdf {
        params.urdf = u.display().to_string();
    }
    if let Some(b) = &args.backend {
        params.backend = b.clone();
    }
    if let Some(m) = &args.method {
        params.method = m.clone();
    }
    params.urdf = cowork_ros::config::resolve(&params.urdf).display().to_string();
    params.validate(&place).with_context(|| format!("invalid parameters in {place}"))?;
    let model = RobotModel::from_urdf_file(&params.urdf)
        .with_context(|| format!("cannot load robot description {}", params.urdf))?;
    let use_sim_time = params.use_sim_time;
    let mut fded = FdedNode::new(model, params)?;
    let (node, options) = args.node.start("fded_distance", use_sim_time)?;
    // In an arm's namespace (`--ros-args -r __ns:=/left`) the arm's frames are `left/...`.
    fded.set_frame_prefix(&node.frame_prefix());
    fded_distance::run(node, fded, &options)?;
    Ok(())
}
