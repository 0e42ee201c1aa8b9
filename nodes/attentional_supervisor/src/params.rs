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
    /// Workspace areas of a dual-arm robot (thesis Sec. 5.2.4): which objects lie in the shared
    /// central area and which in one arm's own area. Unused with a single-arm LTM.
    pub areas: AreaParams,
}

/// The `areas:` block: the central area as a box in the world x-y plane and the side rule
/// (see [`AreaParams::classify`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AreaParams {
    /// Parent frame of the arm bases on `/tf_static` (x forward, y left, z up) and the frame the
    /// central box is given in: the node keeps the newest transform `frame -> <arm>/<base_link>`.
    pub frame: String,
    /// Base link of each arm's model; arm `left`'s base frame is `left/<base_link>` (the prefix
    /// of `cowork_msgs::topics::frame_prefix`), the frame its `/left/object_stream` poses are in.
    pub base_link: String,
    /// The shared central area (m, `frame`).
    pub central: CentralBox,
    /// The arm whose own area lies at y > `central.y` max (the robot's left).
    pub left_arm: String,
    /// The arm whose own area lies at y < `central.y` min (the robot's right).
    pub right_arm: String,
}

/// A box in the x-y plane of [`AreaParams::frame`], bounds included (m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CentralBox {
    /// `[min, max]` along x (forward), m.
    pub x: [f64; 2],
    /// `[min, max]` along y (left), m.
    pub y: [f64; 2],
}

impl Default for CentralBox {
    /// The pizza of `config/scenes/pizza.yaml` (centre (0.45, 0), radius 0.14 m) with a margin;
    /// its ingredient bottles (|y| ≥ 0.29 m, `cowork experiment pizza`) lie outside.
    fn default() -> Self {
        Self { x: [0.2, 0.7], y: [-0.2, 0.2] }
    }
}

impl Default for AreaParams {
    fn default() -> Self {
        Self {
            frame: "world".into(),
            base_link: "lwr_base_link".into(),
            central: CentralBox::default(),
            left_arm: "left".into(),
            right_arm: "right".into(),
        }
    }
}

/// Where [`AreaParams::classify`] puts a point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Side {
    /// In the central box.
    Central,
    /// y > `central.y` max: [`AreaParams::left_arm`]'s area.
    Left,
    /// y < `central.y` min: [`AreaParams::right_arm`]'s area.
    Right,
    /// y within `central.y` but x outside `central.x` (between the arms, in front of or
    /// behind the box): counted as central, since both arms reach it.
    BetweenOutsideBox,
}

impl AreaParams {
    /// The side rule for a point (m, [`frame`](Self::frame)): y > `central.y[1]` is the left
    /// arm's area, y < `central.y[0]` the right arm's, anything else is shared
    /// ([`Side::Central`] inside the box, bounds included, [`Side::BetweenOutsideBox`] beside
    /// it along x). z is not looked at. A non-finite coordinate gives `None`.
    pub fn classify(&self, x: f64, y: f64) -> Option<Side> {
        if !(x.is_finite() && y.is_finite()) {
            return None;
        }
        let [x0, x1] = self.central.x;
        let [y0, y1] = self.central.y;
        Some(if y > y1 {
            Side::Left
        } else if y < y0 {
            Side::Right
        } else if (x0..=x1).contains(&x) {
            Side::Central
        } else {
            Side::BetweenOutsideBox
        })
    }

    /// The base frame of `arm` on `/tf_static`: `left/lwr_base_link`.
    pub fn base_frame(&self, arm: &str) -> String {
        format!("{}{}", cowork_msgs::topics::frame_prefix(arm), self.base_link)
    }

    fn validate(&self, place: &str) -> Result<()> {
        for (key, name) in [("frame", &self.frame), ("base_link", &self.base_link), ("left_arm", &self.left_arm), ("right_arm", &self.right_arm)] {
            if name.trim().is_empty() || name.chars().any(char::is_whitespace) {
                bail!("{place}: `areas.{key}` = {name:?} must be a non-empty name without spaces");
            }
        }
        if self.left_arm == self.right_arm {
            bail!("{place}: `areas.left_arm` and `areas.right_arm` are both {:?}: the two sides need two arms", self.left_arm);
        }
        for (key, [lo, hi]) in [("x", self.central.x), ("y", self.central.y)] {
            if !(lo.is_finite() && hi.is_finite() && lo < hi && lo.abs() <= 100.0 && hi.abs() <= 100.0) {
                bail!("{place}: `areas.central.{key}` = [{lo}, {hi}] must be finite [min, max] with min < max, within ±100 m");
            }
        }
        Ok(())
    }

    /// Checks the side arms against the arms the LTM declares (none: a single-arm LTM, no
    /// check): an area named after an arm the LTM does not know would be no arm's area, and
    /// the library would let every arm reach into it.
    pub fn check_arms(&self, place: &str, arms: &[String]) -> Result<()> {
        if arms.is_empty() {
            return Ok(());
        }
        for (key, name) in [("left_arm", &self.left_arm), ("right_arm", &self.right_arm)] {
            if !arms.iter().any(|a| a == name) {
                bail!("{place}: `areas.{key}` = {name:?} is not an arm of the LTM (arms: {})", arms.join(", "));
            }
        }
        Ok(())
    }
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
            areas: AreaParams::default(),
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
        self.areas.validate(place)?;
        let central = &self.attention.central_area;
        if central.trim().is_empty() || *central == self.areas.left_arm || *central == self.areas.right_arm {
            bail!("{place}: `attention.central_area` = {central:?} must be a name that is not an arm's (`areas.left_arm`, `areas.right_arm`)");
        }
        Ok(())
    }

    /// Tick period (s).
    pub fn tick_period_s(&self) -> f64 {
        1.0 / self.tick_rate_hz
    }
}
