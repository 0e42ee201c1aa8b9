//! [`Params`]: the `ds_controller: ros__parameters:` block, its thesis defaults and its
//! validation (every numeric key refused when NaN, infinite or out of range, naming the key).

use anyhow::{Result, bail};
use cowork_ds::ControllerConfig;
use serde::{Deserialize, Serialize};

use crate::scene::SceneObjectsParams;

/// The `ds_controller: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Take time from `/clock`.
    pub use_sim_time: bool,
    /// Minimum rate of `/motion/status` (Hz, node clock); it is also published on every change.
    pub status_rate_hz: f64,
    /// Gain k (1/s) of a `KIND_LINEAR` command without parameters.
    pub default_linear_gain: f64,
    /// Directory `{"model_file": NAME}` commands may read models from (relative to the working
    /// directory); empty refuses every `model_file`.
    pub primitive_dir: String,
    /// Largest model file read (bytes).
    pub max_model_file_bytes: u64,
    /// A warning of one kind (e.g. a rejected `/joint_states`, which arrive at 1 kHz) is logged
    /// at most once per this many seconds, with the count of the ones held back.
    pub warning_period_s: f64,
    /// The controller (period, watchdog bound, speeds, modulation, IK).
    pub controller: ControllerConfig,
    /// Which obstacle points are known scene objects (the link damper's shorter distances).
    pub scene_objects: SceneObjectsParams,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            use_sim_time: false,
            status_rate_hz: 50.0,
            default_linear_gain: 2.0,
            primitive_dir: "out/primitives".into(),
            max_model_file_bytes: 4 << 20,
            warning_period_s: 2.0,
            controller: ControllerConfig::default(),
            scene_objects: SceneObjectsParams::default(),
        }
    }
}

/// Largest accepted `status_rate_hz` (the control rate: one status per step at most).
pub const MAX_STATUS_RATE_HZ: f64 = 1000.0;
/// Largest accepted `default_linear_gain` (1/s): ẋ = k (g − x) beyond this is a typo.
pub const MAX_LINEAR_GAIN: f64 = 100.0;
/// Largest accepted `warning_period_s` (s).
pub const MAX_WARNING_PERIOD_S: f64 = 3600.0;

impl Params {
    /// Rejects NaN, infinite and out-of-range values, naming the key; `place` names the file.
    /// The controller's keys (`controller.modulation.full_distance`, `…influence_distance`,
    /// `…ttc.max_force` …) are checked by [`ControllerConfig::validate`].
    pub fn validate(&self, place: &str) -> Result<()> {
        self.controller.validate().map_err(|e| anyhow::anyhow!("{place}: controller: {e}"))?;
        for (field, v, max) in [
            ("status_rate_hz", self.status_rate_hz, MAX_STATUS_RATE_HZ),
            ("default_linear_gain", self.default_linear_gain, MAX_LINEAR_GAIN),
            ("warning_period_s", self.warning_period_s, MAX_WARNING_PERIOD_S),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                bail!("{place}: `{field}` = {v} must be in (0, {max}]");
            }
        }
        self.scene_objects.validate(place)?;
        if !(1..=(256 << 20)).contains(&self.max_model_file_bytes) {
            bail!("{place}: `max_model_file_bytes` = {} must be in 1..=268435456", self.max_model_file_bytes);
        }
        Ok(())
    }
}
