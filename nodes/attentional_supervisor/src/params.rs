//! The node's parameters: the `attentional_supervisor: ros__parameters:` block of its YAML file.

use anyhow::{Result, bail};
use cowork_supervisor::SupervisorConfig;
use serde::{Deserialize, Serialize};

/// The `attentional_supervisor: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Decision loop rate (Hz): every tick re-decides the action, so a stimulus is answered
    /// within one period 1 / `tick_rate_hz` (plus transport).
    pub tick_rate_hz: f64,
    /// `/supervisor/working_memory` rate (Hz); 0 publishes no snapshots.
    pub snapshot_rate_hz: f64,
    /// Take time (tick pacing, stamps) from `/clock` instead of the wall clock.
    pub use_sim_time: bool,
    /// Decide nothing until the first `/object_stream` arrived: without object distances
    /// the activation periods (eq. 4.8) are all λ_max and the first command would be arbitrary.
    pub wait_for_object_stream: bool,
    /// An action command with no `/robot_stream` event of its id (started, done or failed)
    /// this long after it was sent is sent again, s (node clock), at most
    /// [`MAX_ACTION_RESENDS`] times: a command published before the robot manager's reader
    /// matched is lost on the volatile topic, and the task would wait for it for ever.
    pub action_resend_s: f64,
    /// Attentional system (thesis Table 5.3).
    pub attention: SupervisorConfig,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            tick_rate_hz: 100.0,
            snapshot_rate_hz: 10.0,
            use_sim_time: false,
            wait_for_object_stream: true,
            action_resend_s: 1.0,
            attention: SupervisorConfig::default(),
        }
    }
}

/// How often one action command is sent again (see [`Params::action_resend_s`]).
pub const MAX_ACTION_RESENDS: u32 = 5;

/// Deepest task tree `attention.max_depth` may ask for (the kitchen tasks need 6).
pub const MAX_TASK_DEPTH: usize = 1000;

impl Params {
    /// Rejects NaN, infinite and out-of-range values, naming the key (`attention.r_max_m`);
    /// `place` names the parameter file.
    pub fn validate(&self, place: &str) -> Result<()> {
        let t = self.tick_rate_hz;
        if !(t.is_finite() && t > 0.0 && t <= 10_000.0) {
            bail!("{place}: `tick_rate_hz` = {t} must be in (0, 10000] Hz");
        }
        let s = self.snapshot_rate_hz;
        if !(s.is_finite() && s >= 0.0 && s <= t) {
            bail!("{place}: `snapshot_rate_hz` = {s} must be in [0, tick_rate_hz = {t}] Hz (0 = off)");
        }
        let r = self.action_resend_s;
        if !(r.is_finite() && r > 0.0 && r <= 60.0) {
            bail!("{place}: `action_resend_s` = {r} must be in (0, 60] s");
        }
        if let Err(e) = self.attention.validate() {
            match e {
                cowork_supervisor::Error::InvalidParameter { name, value, reason } => {
                    bail!("{place}: `attention.{name}` = {value} {reason}")
                }
                other => bail!("{place}: `attention`: {other}"),
            }
        }
        let d = self.attention.max_depth;
        if d > MAX_TASK_DEPTH {
            bail!("{place}: `attention.max_depth` = {d} must be in [1, {MAX_TASK_DEPTH}]");
        }
        Ok(())
    }

    /// Tick period (s).
    pub fn tick_period_s(&self) -> f64 {
        1.0 / self.tick_rate_hz
    }
}
