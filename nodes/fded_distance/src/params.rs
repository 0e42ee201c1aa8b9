//! The node's parameters: the `fded_distance: ros__parameters:` block of its YAML file.

use anyhow::{Result, bail};
use cowork_fded::FdedParams;
use cowork_fded::gpu::BackendRequest;
use cowork_sim::Pose;
use serde::{Deserialize, Serialize};

/// The `fded_distance: ros__parameters:` block.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Robot description (URDF with per-link meshes).
    pub urdf: String,
    /// `auto`, `cpu` or `gpu` (`COWORK_FDED_BACKEND` overrides it).
    pub backend: String,
    /// `fded` (thesis Sec. 5.1.2), or `flacco`: Flacco et al.'s sphere method on the same
    /// robot-removed image, CPU, at its real cost — the Sec. 5.1.3 baseline (backend
    /// `spheres`; no obstacle velocity).
    pub method: String,
    /// Take time from `/clock` (only the log uses time; message stamps are copied).
    pub use_sim_time: bool,
    /// Camera optical frame pose in the base frame, used until `/tf_static` gives one.
    pub camera_pose: Pose,
    /// The joint state used for a frame is the one whose stamp is closest to the frame's; when
    /// even that one is further away than this, the newest is used with a warning, s.
    pub max_joint_state_age_s: f64,
    /// Period of the processing-time log line, s (wall clock).
    pub report_period_s: f64,
    /// Identical warnings are logged at most once per this period, s (wall clock).
    pub warning_period_s: f64,
    /// Publish `visualization_msgs/MarkerArray` on `/fded/markers` with every result.
    pub publish_markers: bool,
    /// Length of the obstacle-normal arrows on `/fded/markers`, m.
    pub normal_arrow_length_m: f64,
    /// A frame in which fewer than this fraction of the pixels have a depth return is a blind
    /// (covered, dazzled, broken) camera: no distances are published for it, so the
    /// controller's watchdog holds the robot instead of reading "no obstacle".
    pub min_valid_fraction: f64,
    /// fDED parameters (thesis Table 5.1 defaults).
    pub fded: FdedParams,
    /// The objects the robot manipulates are not obstacles (see [`crate::manipulated`]).
    pub manipulated: ManipulatedParams,
    /// `method: flacco`: the sphere method's depth window.
    pub flacco: FlaccoWindow,
}

/// The `flacco:` block: depths Flacco et al.'s method looks at (camera frame, m). The thesis's
/// 1.8–3.5 m (the defaults) fit its camera, which saw the robot beyond 1.8 m; a camera nearer
/// the workspace needs its own window, or the method never sees a person next to the arm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FlaccoWindow {
    /// Depths below this are skipped, m.
    pub min_depth: f64,
    /// Depths above this are skipped, m.
    pub max_depth: f64,
}

impl Default for FlaccoWindow {
    fn default() -> Self {
        let p = cowork_fded::baseline::FlaccoParams::default();
        Self { min_depth: p.min_depth, max_depth: p.max_depth }
    }
}

/// The `manipulated:` block: which pixels of `/manipulated_objects` are removed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ManipulatedParams {
    /// Remove the manipulated objects' pixels; false: every object is always an obstacle.
    pub enabled: bool,
    /// Scene file whose `objects:` give each object's shape by name (poses come with the
    /// list); empty: no shapes known, so nothing is removed.
    pub scene: String,
    /// Each shape is grown by this much before its pixels are removed, m: depth noise and
    /// the motion of a held object between its pose report and the frame.
    pub margin_m: f64,
    /// A list is used only for frames within this time of its stamp, s; otherwise (the
    /// manager is dead or late) every object stays an obstacle.
    pub max_age_s: f64,
}

impl Default for ManipulatedParams {
    fn default() -> Self {
        Self { enabled: true, scene: String::new(), margin_m: 0.03, max_age_s: 0.1 }
    }
}

impl Default for Params {
    fn default() -> Self {
        Self {
            urdf: "config/robot/lwr4plus.urdf".into(),
            backend: "auto".into(),
            method: "fded".into(),
            use_sim_time: false,
            camera_pose: Pose {
                position: [1.9, 0.0, 0.9],
                look_at: Some([0.45, 0.0, 0.2]),
                ..Pose::default()
            },
            max_joint_state_age_s: 0.1,
            report_period_s: 5.0,
            warning_period_s: 5.0,
            publish_markers: true,
            normal_arrow_length_m: 0.1,
            min_valid_fraction: 0.05,
            fded: FdedParams::default(),
            manipulated: ManipulatedParams::default(),
            flacco: FlaccoWindow::default(),
        }
    }
}

impl Params {
    /// Rejects NaN and out-of-range values; `place` names the parameter file.
    pub fn validate(&self, place: &str) -> Result<()> {
        self.backend_request(place)?;
        if !matches!(self.method.as_str(), "fded" | "flacco") {
            bail!("{place}: `method` = {:?} must be fded or flacco", self.method);
        }
        for (name, v) in [
            ("max_joint_state_age_s", self.max_joint_state_age_s),
            ("report_period_s", self.report_period_s),
            ("warning_period_s", self.warning_period_s),
            ("normal_arrow_length_m", self.normal_arrow_length_m),
        ] {
            if !(v.is_finite() && v > 0.0) {
                bail!("{place}: `{name}` = {v} must be a positive number");
            }
        }
        let f = &self.flacco;
        if !(f.min_depth.is_finite() && f.max_depth.is_finite() && 0.0 <= f.min_depth && f.min_depth < f.max_depth) {
            bail!(
                "{place}: `flacco.min_depth` = {} / `flacco.max_depth` = {} must be finite with 0 <= min < max (m)",
                f.min_depth,
                f.max_depth
            );
        }
        let m = &self.manipulated;
        if !(m.margin_m.is_finite() && (0.0..=0.2).contains(&m.margin_m)) {
            bail!("{place}: `manipulated.margin_m` = {} must be in [0, 0.2] m", m.margin_m);
        }
        if !(m.max_age_s.is_finite() && m.max_age_s > 0.0 && m.max_age_s <= 1.0) {
            bail!("{place}: `manipulated.max_age_s` = {} must be in (0, 1] s", m.max_age_s);
        }
        if !(0.0..1.0).contains(&self.min_valid_fraction) {
            bail!("{place}: `min_valid_fraction` = {} must be in [0, 1)", self.min_valid_fraction);
        }
        let p = &self.camera_pose;
        let fields: [(&str, &[f64]); 4] = [
            ("position", &p.position),
            ("rpy", p.rpy.as_ref().map_or(&[], |v| v.as_slice())),
            ("quaternion_xyzw", p.quaternion_xyzw.as_ref().map_or(&[], |v| v.as_slice())),
            ("look_at", p.look_at.as_ref().map_or(&[], |v| v.as_slice())),
        ];
        for (name, values) in fields {
            if let Some(i) = values.iter().position(|v| !v.is_finite()) {
                bail!("{place}: `camera_pose.{name}[{i}]` is {}: must be finite", values[i]);
            }
        }
        if let Some(t) = p.look_at
            && (0..3).all(|i| (t[i] - p.position[i]).abs() < 1e-9)
        {
            bail!("{place}: `camera_pose.look_at` equals its position: no viewing direction");
        }
        if let Some(q) = p.quaternion_xyzw
            && q.iter().map(|v| v * v).sum::<f64>() < 1e-12
        {
            bail!("{place}: `camera_pose.quaternion_xyzw` is zero");
        }
        if let Err(e) = self.fded.validate() {
            bail!("{place}: `fded`: {e}");
        }
        Ok(())
    }

    /// `backend` as a request.
    pub fn backend_request(&self, place: &str) -> Result<BackendRequest> {
        match BackendRequest::parse(&self.backend) {
            Ok(r) => Ok(r),
            Err(_) => bail!("{place}: `backend` = {:?} must be auto, cpu or gpu", self.backend),
        }
    }
}
