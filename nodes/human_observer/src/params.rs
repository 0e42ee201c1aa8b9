//! The node's parameters: the `human_observer: ros__parameters:` block of its YAML file.

use anyhow::{Result, bail};
use cowork_observer::{ObserverConfig, RetargetConfig};
use cowork_people::Side;
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
    /// Imitation teaching (thesis Sec. 4.2): the robot arms a demonstrator in a motion-capture
    /// suit drives.
    pub retarget: RetargetParams,
}

/// The `retarget:` block: each Xsens skeleton's arms retargeted (eq. 4.7) onto robot arms,
/// published as `<arm namespace>/lwr/follow_joints` for the simulator to follow.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RetargetParams {
    /// The arms driven; empty: no imitation teaching (the default).
    pub arms: Vec<RetargetArm>,
}

/// One robot arm driven by one of the demonstrator's arms.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RetargetArm {
    /// The arm's ROS namespace name (`left` → `/left/lwr/follow_joints`, `/left/joint_states`);
    /// `""`: the arm of a single-arm graph, in this node's namespace.
    pub arm: String,
    /// The demonstrator's arm that drives it.
    pub side: Side,
    /// Roll, pitch, yaw (rad) of the demonstrator's sternum frame in the arm's base frame: the
    /// inverse of the base's rotation in the world when the robot's trunk faces the world's +x
    /// as the demonstrator's does (pizza scene: left [π/2, 0, 0], right [−π/2, 0, 0]).
    #[serde(default)]
    pub mount_rpy: [f64; 3],
    /// Joint targets move at most this fraction of each joint's speed limit between frames.
    #[serde(default = "one")]
    pub speed_limit_fraction: f64,
}

fn one() -> f64 {
    1.0
}

impl RetargetArm {
    /// The library's configuration for this arm (IK defaults).
    pub fn config(&self) -> RetargetConfig {
        RetargetConfig { side: self.side, mount_rpy: self.mount_rpy, speed_limit_fraction: self.speed_limit_fraction, ..RetargetConfig::default() }
    }
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
            retarget: RetargetParams::default(),
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
        for (i, a) in self.retarget.arms.iter().enumerate() {
            if !a.arm.is_empty() && !cowork_ros::is_name_token(&a.arm) {
                bail!("{place}: `retarget.arms[{i}].arm` = {:?} is not a ROS name (letters, digits, _; not starting with a digit)", a.arm);
            }
            if self.retarget.arms[..i].iter().any(|b| b.arm == a.arm) {
                bail!("{place}: `retarget.arms[{i}].arm` = {:?} is given twice", a.arm);
            }
            if !a.mount_rpy.iter().all(|v| v.is_finite() && v.abs() <= 2.0 * std::f64::consts::PI) {
                bail!("{place}: `retarget.arms[{i}].mount_rpy` = {:?} must be finite angles within ±2π rad", a.mount_rpy);
            }
            if !(0.0..=1.0).contains(&a.speed_limit_fraction) {
                bail!("{place}: `retarget.arms[{i}].speed_limit_fraction` = {} must be in [0, 1]", a.speed_limit_fraction);
            }
        }
        Ok(())
    }
}
