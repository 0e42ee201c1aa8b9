//! The node's parameters: the `lwr_sim: ros__parameters:` block of its YAML file.

use anyhow::{Result, bail};
use cowork_sim::{SimError, SimParams};
use serde::{Deserialize, Serialize};

use crate::depth::DepthConfig;

/// Publication rates of the node, Hz of simulated time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PublishRates {
    /// `/clock`.
    pub clock_rate_hz: f64,
    /// `/joint_states`.
    pub joint_state_rate_hz: f64,
    /// `/tf` (links and objects).
    pub tf_rate_hz: f64,
    /// `/lwr/world` (grasp state and object poses).
    pub world_rate_hz: f64,
}

impl Default for PublishRates {
    fn default() -> Self {
        Self { clock_rate_hz: 1000.0, joint_state_rate_hz: 1000.0, tf_rate_hz: 50.0, world_rate_hz: 100.0 }
    }
}

/// What an `/external_wrench` does to the arm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum WrenchMode {
    /// Kinesthetic teaching: the arm yields by admittance (ẋ = c f at the link), whatever
    /// the joint velocity command.
    #[default]
    Teach,
    /// Executing: the arm moves only as commanded; the wrench is reported on
    /// `/lwr/external_wrench` for the controller.
    Execute,
}

/// The `external_wrench:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WrenchConfig {
    /// `teach` (admittance) or `execute` (reported).
    pub mode: WrenchMode,
    /// Rate of `/lwr/external_wrench` while a wrench acts (execute mode), Hz of simulated time.
    pub report_rate_hz: f64,
}

impl Default for WrenchConfig {
    fn default() -> Self {
        Self { mode: WrenchMode::Teach, report_rate_hz: 1000.0 }
    }
}

/// The `lwr_sim: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LwrSimConfig {
    /// Simulator parameters.
    pub simulation: SimParams,
    /// Topic rates.
    pub publish: PublishRates,
    /// The simulated depth camera.
    pub depth: DepthConfig,
    /// What an `/external_wrench` does (teach: admittance; execute: reported).
    pub external_wrench: WrenchConfig,
}

impl LwrSimConfig {
    /// Rejects NaN, infinite and out-of-range values, naming the key (`simulation.step_s`,
    /// `publish.tf_rate_hz`, …); `place` names the file.
    pub fn validate(&self, place: &str) -> Result<()> {
        match self.simulation.validate(place) {
            Ok(()) => {}
            Err(SimError::BadValue { field, value, reason, .. }) => {
                bail!("{place}: `simulation.{field}` = {value}: {reason}")
            }
            Err(e) => bail!("{place}: `simulation`: {e}"),
        }
        let max = 1.0 / self.simulation.step_s;
        for (field, v) in [
            ("publish.clock_rate_hz", self.publish.clock_rate_hz),
            ("publish.joint_state_rate_hz", self.publish.joint_state_rate_hz),
            ("publish.tf_rate_hz", self.publish.tf_rate_hz),
            ("publish.world_rate_hz", self.publish.world_rate_hz),
            ("external_wrench.report_rate_hz", self.external_wrench.report_rate_hz),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                bail!("{place}: `{field}` = {v} must be in (0, {max}] Hz (one message per step at most)");
            }
        }
        self.depth.validate(place)?;
        Ok(())
    }
}
