//! `lwr_sim`: the kinematic LWR IV+ simulator as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use lwr_sim::{LwrSim, LwrSimConfig, Pacing};

/// Kinematic KUKA LWR IV+ simulator: integrates `/lwr/joint_velocity_command` at 1 kHz of
/// simulated time and publishes `/clock`, `/joint_states`, `/tf` and the depth camera
/// (`/camera/depth/image_raw`, `/camera/depth/camera_info`).
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Robot description (URDF with per-link meshes).
    #[arg(long, default_value = "config/robot/lwr4plus.urdf")]
    urdf: PathBuf,
    /// Scene file: table, objects, camera, initial joints.
    #[arg(long, default_value = "config/scenes/kitchen.yaml")]
    scene: PathBuf,
    /// ROS 2 parameter file with an `lwr_sim: ros__parameters:` block.
    #[arg(long, default_value = "config/lwr_sim.yaml")]
    params: PathBuf,
    /// Simulated seconds per wall-clock second (1 = real time).
    #[arg(long, default_value_t = 1.0, conflicts_with = "max")]
    rate: f64,
    /// Run as fast as possible.
    #[arg(long)]
    max: bool,
    /// Stop after this many simulated seconds (runs until Ctrl-C otherwise).
    #[arg(long)]
    duration: Option<f64>,
    /// Replaying a recorded teacher: apply each /external_wrench at its header stamp and never
    /// let simulated time pass the newest stamp received (a slow teacher holds the clock).
    #[arg(long)]
    follow_wrench_stamps: bool,
    /// What an /external_wrench does: `teach` (the arm yields by admittance) or `execute`
    /// (reported on /lwr/external_wrench for the controller; the arm moves only as commanded).
    /// Overrides `external_wrench.mode` of the parameter file.
    #[arg(long, value_enum)]
    wrench_mode: Option<lwr_sim::WrenchMode>,
}

fn main() -> std::process::ExitCode {
    cowork_ros::node_main(run)
}

/// The simulation, kept when `node_main` runs the node again in this process (its DDS threads
/// were lost to a stop and continue): the robot, the objects and the clock go on from where
/// they were, as a real robot's would.
static KEPT: std::sync::Mutex<Option<LwrSim>> = std::sync::Mutex::new(None);

fn run(mut args: Args) -> Result<()> {
    // `config/...` defaults resolve to the bundled config directory from any working directory.
    args.urdf = cowork_ros::config::resolve(&args.urdf);
    args.scene = cowork_ros::config::resolve(&args.scene);
    let config: LwrSimConfig = cowork_ros::params::load(&args.params, "lwr_sim")?;
    config
        .validate(&args.params.display().to_string())
        .with_context(|| format!("invalid parameters in {}", args.params.display()))?;
    let model = RobotModel::from_urdf_file(&args.urdf)
        .with_context(|| format!("cannot load robot description {}", args.urdf.display()))?;
    let scene = Scene::from_file(&args.scene)
        .with_context(|| format!("cannot load scene {}", args.scene.display()))?;
    let sim = Simulator::new(model, scene, config.simulation.clone())
        .with_context(|| format!("scene {} does not fit the robot", args.scene.display()))?;
    let pacing = Pacing::from_args(args.rate, args.max)?;
    let node = cowork_ros::start_node("lwr_sim", false, args.duration)?;
    let kept = KEPT.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take();
    let mut lwr = match kept {
        Some(lwr) => {
            tracing::warn!("going on with the simulation kept from before the restart, at t_sim = {:.3} s", lwr.time_s());
            lwr
        }
        None => {
            let mut lwr = LwrSim::new(sim, config);
            if args.follow_wrench_stamps {
                lwr.follow_wrench_stamps();
            }
            if let Some(mode) = args.wrench_mode {
                lwr.set_wrench_mode(mode);
            }
            lwr
        }
    };
    let result = lwr_sim::run_with(node, &mut lwr, pacing, args.duration);
    if cowork_ros::shutdown::restarting() {
        *KEPT.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(lwr);
    }
    result
}
