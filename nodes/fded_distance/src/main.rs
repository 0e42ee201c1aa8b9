//! `fded_distance`: fDED robot–obstacle distances (thesis Sec. 5.1.2) as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use cowork_robot::RobotModel;
use fded_distance::{FdedNode, Params, RunOptions};

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
    /// Take time from `/clock` (overrides `use_sim_time: false` in the parameter file).
    #[arg(long)]
    use_sim_time: bool,
    /// Stop after this many wall-clock seconds (runs until Ctrl-C otherwise).
    #[arg(long)]
    duration: Option<f64>,
}

/// One line `error: ...` on failure (a backtrace only with RUST_BACKTRACE=1).
fn main() -> std::process::ExitCode {
    cowork_ros::exit_code(run())
}

fn run() -> Result<()> {
    cowork_ros::init_logging();
    let args = Args::parse();
    let place = args.params.display().to_string();
    let mut params: Params = cowork_ros::params::load(&args.params, "fded_distance")?;
    params.use_sim_time |= args.use_sim_time;
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
    let fded = FdedNode::new(model, params)?;
    let node = cowork_ros::start_node("fded_distance", use_sim_time, args.duration)?;
    fded_distance::run(node, fded, &RunOptions { duration_s: args.duration, stop: None })?;
    Ok(())
}
