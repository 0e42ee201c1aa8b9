//! Builds the manager's motion previewer (`cowork_manager::turn`) from the `preview:` block:
//! the URDF ds_controller runs, the scene file's object shapes, and the `controller:` block of
//! ds_controller's parameter file.

use anyhow::{Context, Result};
use cowork_ds::ControllerConfig;
use cowork_manager::Previewer;
use cowork_robot::RobotModel;
use cowork_sim::Scene;
use serde::Deserialize;

use crate::params::Params;

/// The part of ds_controller's parameters the preview runs.
#[derive(Debug, Default, Deserialize)]
struct ControllerBlock {
    #[serde(default)]
    controller: ControllerConfig,
}

/// The previewer and its model's joint names, or `None` when `preview.urdf` is empty or
/// `manager.turn.objects` names nothing. `place` names the parameter file in errors; every file
/// named is `config/`-resolved as the nodes do.
pub fn load(params: &Params, place: &str) -> Result<Option<(Previewer, Vec<String>)>> {
    let p = &params.preview;
    if p.urdf.is_empty() || params.manager.turn.objects.is_empty() {
        return Ok(None);
    }
    let urdf = cowork_ros::config::resolve(&p.urdf);
    let model = RobotModel::from_urdf_file(&urdf)
        .with_context(|| format!("{place}: `preview.urdf`: cannot load {}", urdf.display()))?;
    let scene_path = cowork_ros::config::resolve(&p.scene);
    let scene = Scene::from_file(&scene_path).with_context(|| format!("{place}: `preview.scene`"))?;
    let block: ControllerBlock = cowork_ros::params::load(std::path::Path::new(&p.controller_params), "ds_controller")
        .with_context(|| format!("{place}: `preview.controller_params`"))?;
    // The world's up in this arm's base frame: the arm of the node's namespace (`/left` is arm
    // `left`), or the single arm of a scene without named arms.
    let namespace = cowork_ros::ros_args().namespace.as_deref().unwrap_or_default();
    let arm = namespace.trim_matches('/').rsplit('/').next().unwrap_or_default();
    let prefix = if arm.is_empty() { String::new() } else { format!("{arm}/") };
    let base = scene
        .arm_base_for_prefix(&prefix)
        .with_context(|| format!("{place}: `preview.scene` {} has no arm for the namespace {namespace:?}", scene_path.display()))?;
    let shapes = scene.objects.iter().map(|o| (o.name.clone(), o.shape));
    // The arm's ready pose: its start joints in the scene (an arm wound up is unwound to it).
    let ready = scene
        .arm_setups()
        .into_iter()
        .find(|a| a.name == arm || !scene.has_named_arms())
        .map(|a| a.initial_joints_deg)
        .filter(|d| d.len() == cowork_robot::DOF)
        .map(|d| cowork_robot::JointVector::from_iterator(d.iter().map(|v| v.to_radians())));
    let previewer = Previewer::new(model.clone(), block.controller, shapes, params.manager.turn.step_s)
        .map_err(|e| anyhow::anyhow!("{place}: `preview.controller_params` {}: {e}", p.controller_params))?
        .with_up(base.inverse().rotation * nalgebra::Vector3::z());
    let previewer = match ready {
        Some(q) => previewer.with_ready(q),
        None => {
            tracing::warn!("{place}: `preview.scene` {} gives no start joints for this arm: a wound-up arm is not unwound", scene_path.display());
            previewer
        }
    };
    tracing::info!(
        "motion preview on: {} may be turned up to ±{}° to keep the arm {} m from the other objects",
        params.manager.turn.objects.join(", "),
        params.manager.turn.max_deg,
        params.manager.turn.clearance_m
    );
    Ok(Some((previewer, model.joint_names().to_vec())))
}
