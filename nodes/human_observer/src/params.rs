//! The node's parameters: the `human_observer: ros__parameters:` block of its YAML file.

use anyhow::{Result, bail};
use cowork_observer::ObserverConfig;
use serde::{Deserialize, Serialize};

/// The `human_observer: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Robot description (URDF with per-link meshes): the link geometry of the distance.
    pub urdf: String,
    /// Take time from `/clock`.
    pub use_sim_time: bool,
    /// Gesture model learned by `cowork learn gestures` (JSON); empty: no recognition.
    pub gestures: String,
    /// `/human/state` goes out with every skeleton frame and at least at this rate (with
    /// `present: false` when nobody is tracked), Hz.
    pub state_rate_hz: f64,
    /// Publish `/human/markers`.
    pub publish_markers: bool,
    /// `/human/markers` at most at this rate, Hz.
    pub markers_rate_hz: f64,
    /// Hand velocity arrows are drawn `velocity × this` long, s.
    pub velocity_arrow_s: f64,
    /// Identical warnings are logged at most once per this period, s (wall clock).
    pub warning_period_s: f64,
    /// The observer (Kalman noise, thresholds, speeds, timeouts).
    pub observer: ObserverConfig,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            urdf: "config/robot/lwr4plus.urdf".into(),
            use_sim_time: false,
            gestures: "config/gestures.json".into(),
            state_rate_hz: 30.0,
            publish_markers: true,
            markers_rate_hz: 15.0,
            velocity_arrow_s: 0.5,
            warning_period_s: 5.0,
            observer: ObserverConfig::default(),
        }
    }
}

impl Params {
    /// Rejects NaN and out-of-range values; `place` names the parameter file.
    pub fn validate(&self, place: &str) -> Result<()> {
        for (name, v, lo, hi) in [
            ("state_rate_hz", self.state_rate_hz, 1.0, 1000.0),
            ("markers_rate_hz", self.markers_rate_hz, 0.1, 1000.0),
            ("velocity_arrow_s", self.velocity_arrow_s, 0.0, 10.0),
            ("warning_period_s", self.warning_period_s, 0.01, 3600.0),
        ] {
            if !(v.is_finite() && v >= lo && v <= hi) {
                bail!("{place}: `{name}` = {v} must be in [{lo}, {hi}]");
            }
        }
        if self.urdf.trim().is_empty() {
            bail!("{place}: `urdf` is empty");
        }
        if let Err(e) = self.observer.validate("observer.") {
            bail!("{place}: {e}");
        }
        Ok(())
    }
}
