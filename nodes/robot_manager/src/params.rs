//! The node's parameters: the `robot_manager: ros__parameters:` block of its YAML file.

use anyhow::{Result, bail};
use cowork_manager::ManagerConfig;
use serde::{Deserialize, Serialize};

/// The `robot_manager: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Take time from `/clock`.
    pub use_sim_time: bool,
    /// Directory of the primitive database (`<robot>.primitives.json` inside).
    pub database_dir: String,
    /// Timeouts are checked at this rate, Hz.
    pub tick_rate_hz: f64,
    /// `/robot_stream` and `/object_stream` at most at this rate (Hz of the node's clock);
    /// a message with action events or segments is sent at once.
    pub stream_rate_hz: f64,
    /// Identical warnings are logged at most once per this period, s (wall clock).
    pub warning_period_s: f64,
    /// The robot manager (thesis Table 5.3).
    pub manager: ManagerConfig,
    /// Where the motion preview that turns round objects (`manager.turn`) takes the arm, the
    /// objects' shapes and the controller from.
    pub preview: PreviewParams,
}

/// The `preview:` block. An empty `urdf` turns the preview off: actions keep the taught yaw.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PreviewParams {
    /// Robot description (URDF with per-link meshes), the one ds_controller runs.
    pub urdf: String,
    /// Scene file whose `objects:` give each object's shape by name (poses come from
    /// `/lwr/world`).
    pub scene: String,
    /// ds_controller's parameter file: its `controller:` block is what the preview runs.
    pub controller_params: String,
}

impl Default for PreviewParams {
    fn default() -> Self {
        Self { urdf: String::new(), scene: String::new(), controller_params: "config/ds_controller.yaml".into() }
    }
}

impl Default for Params {
    fn default() -> Self {
        Self {
            use_sim_time: false,
            database_dir: "out/primitives".into(),
            tick_rate_hz: 50.0,
            stream_rate_hz: 30.0,
            warning_period_s: 5.0,
            manager: ManagerConfig::default(),
            preview: PreviewParams::default(),
        }
    }
}

impl Params {
    /// Rejects NaN and out-of-range values; `place` names the parameter file.
    pub fn validate(&self, place: &str) -> Result<()> {
        for (field, v, max) in [
            ("tick_rate_hz", self.tick_rate_hz, 1000.0),
            ("stream_rate_hz", self.stream_rate_hz, 1000.0),
            ("warning_period_s", self.warning_period_s, 3600.0),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                bail!("{place}: `{field}` = {v} must be in (0, {max}]");
            }
        }
        if self.database_dir.trim().is_empty() {
            bail!("{place}: `database_dir` is empty");
        }
        if !self.preview.urdf.is_empty() && (self.preview.scene.is_empty() || self.preview.controller_params.is_empty()) {
            bail!("{place}: `preview.urdf` is set, so `preview.scene` and `preview.controller_params` must be too");
        }
        if let Err(e) = self.manager.validate() {
            bail!("{place}: `manager`: {e}");
        }
        Ok(())
    }
}
