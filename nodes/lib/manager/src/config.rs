//! Parameters of the robot manager (thesis Table 5.3 defaults).

use std::collections::BTreeMap;

use cowork_motion::dmp::DmpConfig;
use serde::{Deserialize, Serialize};

use crate::error::{ManagerError, Result};
use crate::turn::TurnConfig;

/// Name of the pseudo-object whose frame is the robot base (goals that belong to no object).
pub const WORLD: &str = "world";

/// Robot manager configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ManagerConfig {
    /// Robot name: the primitive database is `<database_dir>/<robot>.primitives.json`.
    pub robot: String,
    /// Put before every label this manager learns (`l` → `lfoa1(tomato)`): the arms of a
    /// dual-arm robot share one LTM, so their primitives need distinct names (thesis Fig. 5.24).
    /// Lowercase letters; empty for none.
    pub label_prefix: String,
    /// Radius r of the proximity sphere around every object, m (Table 5.3: 0.12), measured
    /// from the tool point to the object's surface.
    pub proximity_radius_m: f64,
    /// Scene object name → task object name (the name the LTM uses, e.g. `bottle: water`).
    /// Scene objects not listed are neither segmented against nor reported.
    pub objects: BTreeMap<String, String>,
    /// NOA learning: DMP gains K (1/s²), D (None: 2√K), γ·duration (5), basis count.
    pub dmp: DmpConfig,
    /// A segment whose tool path is shorter than this and whose rotation is below
    /// `min_segment_rotation_rad` has no motion: it is dropped and logged, m.
    pub min_segment_motion_m: f64,
    /// See `min_segment_motion_m`, rad.
    pub min_segment_rotation_rad: f64,
    /// Gain k of the FOA linear DS ẋ = k (g − x), 1/s.
    pub foa_gain: f64,
    /// Nominal end-effector speed of every commanded motion, m/s (before human scaling).
    pub nominal_speed_m_s: f64,
    /// A motion that has not converged this long after it started fails, s.
    pub action_timeout_s: f64,
    /// A gripper action the simulator has not reported this long after the command fails, s.
    pub gripper_timeout_s: f64,
    /// A motion command the controller has not acknowledged (no `/motion/status` with its id
    /// or a newer one) this long after it was sent is sent again, s: a command published
    /// before the controller's reader matched is lost on a volatile topic.
    pub motion_resend_s: f64,
    /// World state older than this cannot start an action (the object pose is unknown), s.
    pub world_stale_s: f64,
    /// How a NOA is executed: `stream` — the manager rolls out both DMPs (position and
    /// orientation) and streams the poses as linear-DS goals (thesis Sec. 5.2.1: "the RM
    /// generates a set of Cartesian poses … sent to the low-level robot controller");
    /// `controller` — one `KIND_DMP` command (ds_controller runs the position DMP, the
    /// orientation goes straight to the goal's).
    pub noa_execution: NoaExecution,
    /// Streaming: a new goal every this many seconds of the rollout, s.
    pub stream_period_s: f64,
    /// Streaming: gain of each linear-DS goal, 1/s.
    pub stream_gain: f64,
    /// Streaming: the reference advances only while the tool is within this distance of it, m
    /// (a slowed or stopped robot is waited for, not left behind).
    pub stream_tracking_m: f64,
    /// The region the robot tracks objects in, base frame `[x, y, z]` corners, m: an object
    /// whose centre leaves it (a person carried it away) is reported not visible, so the
    /// supervisor replans (Fig. 5.21). `None`: every object is always visible.
    pub workspace: Option<Workspace>,
    /// Round objects whose frame an action may turn about its axis, chosen by previewing the
    /// motion (`crate::turn`); used only when the node gives the manager a previewer.
    pub turn: TurnConfig,
}

/// An axis-aligned box, base frame, m.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Workspace {
    /// Smallest corner.
    pub min: [f64; 3],
    /// Largest corner.
    pub max: [f64; 3],
}

impl Workspace {
    /// Whether `p` (base frame) lies inside (boundary included).
    pub fn contains(&self, p: &[f64; 3]) -> bool {
        (0..3).all(|i| self.min[i] <= p[i] && p[i] <= self.max[i])
    }
}

/// See [`ManagerConfig::noa_execution`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoaExecution {
    /// Poses streamed by the manager.
    Stream,
    /// One DMP command to ds_controller.
    Controller,
}

impl Default for ManagerConfig {
    fn default() -> Self {
        let objects = [("bottle", "water"), ("cup", "cup"), ("coffee", "coffee"), ("spoon", "spoon"), ("tea", "tea")]
            .into_iter()
            .map(|(a, b)| (a.to_owned(), b.to_owned()))
            .collect();
        Self {
            robot: "lwr".into(),
            label_prefix: String::new(),
            proximity_radius_m: 0.12,
            objects,
            dmp: DmpConfig { n_basis: 30, stiffness: 70.0, damping: None, gamma_times_duration: 5.0, ridge: 1e-8 },
            min_segment_motion_m: 0.01,
            min_segment_rotation_rad: 0.05,
            foa_gain: 2.0,
            nominal_speed_m_s: 0.3,
            action_timeout_s: 120.0,
            gripper_timeout_s: 3.0,
            motion_resend_s: 1.0,
            world_stale_s: 0.5,
            noa_execution: NoaExecution::Stream,
            stream_period_s: 0.05,
            stream_gain: 8.0,
            stream_tracking_m: 0.03,
            // The kitchen table's robot side up to 0.8 m above it (config/robot_manager.yaml).
            workspace: Some(Workspace { min: [-0.3, -1.0, -0.1], max: [1.0, 1.0, 0.8] }),
            turn: TurnConfig::default(),
        }
    }
}

impl ManagerConfig {
    /// Rejects NaN, out-of-range values and unusable names.
    pub fn validate(&self) -> Result<()> {
        let bad = |field: &str, value: String, reason: &str| {
            Err(ManagerError::Config { field: field.into(), value, reason: reason.into() })
        };
        if self.robot.is_empty() || !self.robot.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
            return bad("robot", format!("{:?}", self.robot), "must be a non-empty file-name-safe word ([A-Za-z0-9_-])");
        }
        if !self.label_prefix.chars().all(|c| c.is_ascii_lowercase()) || self.label_prefix.len() > 8 {
            return bad("label_prefix", format!("{:?}", self.label_prefix), "must be at most 8 lowercase letters");
        }
        for (field, v, lo) in [
            ("proximity_radius_m", self.proximity_radius_m, 0.0),
            ("min_segment_motion_m", self.min_segment_motion_m, -1.0),
            ("min_segment_rotation_rad", self.min_segment_rotation_rad, -1.0),
            ("foa_gain", self.foa_gain, 0.0),
            ("nominal_speed_m_s", self.nominal_speed_m_s, 0.0),
            ("action_timeout_s", self.action_timeout_s, 0.0),
            ("gripper_timeout_s", self.gripper_timeout_s, 0.0),
            ("motion_resend_s", self.motion_resend_s, 0.0),
            ("world_stale_s", self.world_stale_s, 0.0),
            ("stream_period_s", self.stream_period_s, 0.0),
            ("stream_gain", self.stream_gain, 0.0),
            ("stream_tracking_m", self.stream_tracking_m, 0.0),
        ] {
            if !(v.is_finite() && v > lo && (lo >= 0.0 || v >= 0.0)) {
                return bad(field, v.to_string(), "must be finite and positive (non-negative for the motion thresholds)");
            }
        }
        if self.nominal_speed_m_s > 2.0 {
            return bad("nominal_speed_m_s", self.nominal_speed_m_s.to_string(), "above 2 m/s");
        }
        if let Some(w) = &self.workspace
            && !(0..3).all(|i| w.min[i].is_finite() && w.max[i].is_finite() && w.min[i] < w.max[i])
        {
            return bad("workspace", format!("{w:?}"), "corners must be finite with min < max on every axis");
        }
        if let Some((field, reason)) = self.turn.problem() {
            return bad(field, format!("{:?}", self.turn), &reason);
        }
        if let Some(o) = self.turn.objects.iter().find(|o| !self.objects.values().any(|t| t == *o)) {
            return bad("turn.objects", o.clone(), "not a task object of `objects`");
        }
        if let Err(e) = self.dmp.validate() {
            return bad("dmp", format!("{:?}", self.dmp), &e.to_string());
        }
        let mut seen = std::collections::BTreeSet::new();
        for (scene, task) in &self.objects {
            let word = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
            if !word(scene) || !word(task) || task.chars().next().is_some_and(|c| c.is_ascii_uppercase()) {
                return bad(
                    "objects",
                    format!("{scene}: {task}"),
                    "names must be words of [A-Za-z0-9_], the task name starting lower-case (an LTM atom)",
                );
            }
            if task == WORLD {
                return bad("objects", format!("{scene}: {task}"), "`world` is the base frame, not an object");
            }
            if !seen.insert(task.as_str()) {
                return bad("objects", format!("{scene}: {task}"), "two scene objects map to the same task name");
            }
        }
        Ok(())
    }

    /// Task name of a scene object, if it is listed.
    pub fn task_name(&self, scene: &str) -> Option<&str> {
        self.objects.get(scene).map(String::as_str)
    }

    /// Scene name of a task object, if one maps to it.
    pub fn scene_name(&self, task: &str) -> Option<&str> {
        self.objects.iter().find(|(_, t)| t.as_str() == task).map(|(s, _)| s.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_table_5_3_and_valid() {
        let c = ManagerConfig::default();
        c.validate().expect("defaults");
        assert_eq!(c.proximity_radius_m, 0.12);
        assert_eq!(c.dmp.stiffness, 70.0);
        assert_eq!(c.dmp.damping, None, "D = 2 sqrt(K)");
        assert_eq!(c.dmp.gamma_times_duration, 5.0, "gamma = 5 / duration");
        assert_eq!(c.task_name("bottle"), Some("water"));
        assert_eq!(c.scene_name("water"), Some("bottle"));
    }

    #[test]
    fn bad_values_name_the_field() {
        let mut c = ManagerConfig { proximity_radius_m: f64::NAN, ..ManagerConfig::default() };
        assert!(c.validate().expect_err("nan").to_string().contains("proximity_radius_m"));
        c.proximity_radius_m = 0.12;
        c.objects.insert("box".into(), "water".into());
        assert!(c.validate().expect_err("dup").to_string().contains("same task name"));
        let c = ManagerConfig { robot: "../etc".into(), ..ManagerConfig::default() };
        assert!(c.validate().expect_err("path").to_string().contains("robot"));
        for w in [Workspace { min: [0.0, 0.0, f64::NAN], max: [1.0; 3] }, Workspace { min: [0.0, 2.0, 0.0], max: [1.0; 3] }] {
            let c = ManagerConfig { workspace: Some(w), ..ManagerConfig::default() };
            assert!(c.validate().expect_err("workspace").to_string().contains("workspace"));
        }
    }

    #[test]
    fn an_object_carried_out_of_the_workspace_is_not_visible() {
        use crate::world::{ObjectReport, World, WorldReport};
        use nalgebra::{Isometry3, Translation3, UnitQuaternion};
        let at = |x: f64| Isometry3::from_parts(Translation3::new(x, 0.2, 0.11), UnitQuaternion::identity());
        let report = |x: f64| WorldReport {
            t: 1.0,
            tool: at(0.3),
            gripper_closed: false,
            held: None,
            objects: vec![ObjectReport { name: "bottle".into(), pose: at(x), distance: 0.3, tilt: 0.0, visible: true }],
        };
        let cfg = ManagerConfig { workspace: Some(Workspace { min: [-0.3, -1.0, -0.1], max: [1.0, 1.0, 0.8] }), ..ManagerConfig::default() };
        cfg.validate().expect("valid");
        let visible = |cfg: &ManagerConfig, x: f64| World::from_report(&report(x), cfg).expect("good").objects[0].visible;
        assert!(visible(&cfg, 0.45));
        assert!(!visible(&cfg, 1.15), "taken away by the person");
        assert!(visible(&ManagerConfig { workspace: None, ..ManagerConfig::default() }, 1.15), "no workspace: always visible");
    }
}
