//! `human_observer`: the person near the robot (thesis Sec. 5.1.3) as a ROS 2 node.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;
use cowork_observer::GestureModel;
use cowork_robot::RobotModel;
use human_observer::{ObserverNode, Params};

/// Human observer: from `/human/skeleton`, `/joint_states` and `/speech_command`, the state of
/// the person near the robot on `/human/state` (far / interaction, distance, filtered hand,
/// α_h, stopped), recognised gestures on `/human/gesture`, markers on `/human/markers`.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// ROS 2 parameter file with a `human_observer: ros__parameters:` block.
    #[arg(long, default_value = "config/human_observer.yaml")]
    params: PathBuf,
    /// Robot description (overrides `urdf`).
    #[arg(long)]
    urdf: Option<PathBuf>,
    /// Gesture model (overrides `gestures`; `""` for none).
    #[arg(long)]
    gestures: Option<String>,
    #[command(flatten)]
    node: cowork_ros::NodeArgs,
}

fn main() -> std::process::ExitCode {
    cowork_ros::node_main(run)
}

fn run(args: Args) -> Result<()> {
    let (mut params, place): (Params, _) = args.node.load(&args.params, "human_observer")?;
    if let Some(u) = &args.urdf {
        params.urdf = u.display().to_string();
    }
    if let Some(g) = &args.gestures {
        params.gestures.clone_from(g);
    }
    // `config/...` paths resolve to the bundled config directory from any working directory.
    params.urdf = cowork_ros::config::resolve(&params.urdf).display().to_string();
    if !params.gestures.is_empty() {
        params.gestures = cowork_ros::config::resolve(&params.gestures).display().to_string();
    }
    params.validate(&place).with_context(|| format!("invalid parameters in {place}"))?;
    let model = RobotModel::from_urdf_file(&params.urdf).with_context(|| format!("cannot load robot description {}", params.urdf))?;
    let (gestures, unusable) = if params.gestures.is_empty() {
        tracing::warn!("no gesture model (`gestures` is empty): gestures are not recognised");
        (None, false)
    } else {
        match GestureModel::from_file(params.gestures.as_ref()) {
            Ok(m) => (Some(m), false),
            Err(e) => {
                // Keep running (the state still slows the robot near people), fail closed: a
                // stop gesture would go unseen, so never faster than the interaction speed.
                tracing::error!("`gestures` in {place}: {e}; gestures are not recognised and alpha_h is capped at the interaction speed");
                (None, true)
            }
        }
    };
    let use_sim_time = params.use_sim_time;
    let mut observer = ObserverNode::new(model, params, gestures)?;
    if unusable {
        observer.without_gestures_fail_closed();
    }
    let (node, options) = args.node.start("human_observer", use_sim_time)?;
    human_observer::run(node, observer, &options)?;
    Ok(())
}
