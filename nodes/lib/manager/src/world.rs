//! What the manager knows about the world: the simulator's report (`/lwr/world`) with scene
//! names mapped to task names.

use nalgebra::Isometry3;

use crate::config::ManagerConfig;

/// One object as reported by the simulator (scene name).
#[derive(Debug, Clone, PartialEq)]
pub struct ObjectReport {
    /// Scene name, e.g. `bottle`.
    pub name: String,
    /// Pose of the shape centre, base frame.
    pub pose: Isometry3<f64>,
    /// Tool point to surface distance, m.
    pub distance: f64,
    /// Tilt of the object's z axis from the vertical, rad.
    pub tilt: f64,
    /// Seen now (a tracker may lose it; the simulator always sees it).
    pub visible: bool,
}

/// A world report (simulated time `t`, s).
#[derive(Debug, Clone, PartialEq)]
pub struct WorldReport {
    /// Time of the report, s.
    pub t: f64,
    /// Tool pose, base frame.
    pub tool: Isometry3<f64>,
    /// Gripper closed.
    pub gripper_closed: bool,
    /// Held object (scene name).
    pub held: Option<String>,
    /// Every object.
    pub objects: Vec<ObjectReport>,
}

/// An object under its task name.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskObject {
    /// Task name, e.g. `water`.
    pub name: String,
    /// Pose, base frame (the last seen one when not visible).
    pub pose: Isometry3<f64>,
    /// Tool point to surface distance, m.
    pub distance: f64,
    /// Tilt from the vertical, rad.
    pub tilt: f64,
    /// Seen now.
    pub visible: bool,
    /// Held by the gripper.
    pub held: bool,
}

/// The world under task names.
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    /// Time of the report, s.
    pub t: f64,
    /// Tool pose, base frame.
    pub tool: Isometry3<f64>,
    /// Gripper closed.
    pub gripper_closed: bool,
    /// Held object (task name; the scene name when it has none).
    pub held: Option<String>,
    /// Listed objects, in report order.
    pub objects: Vec<TaskObject>,
}

impl World {
    /// Maps a report to task names; a report with a non-finite value is refused (the field
    /// is named in the error).
    pub fn from_report(r: &WorldReport, cfg: &ManagerConfig) -> Result<Self, String> {
        let finite = |p: &Isometry3<f64>| {
            p.translation.vector.iter().chain(p.rotation.coords.iter()).all(|v| v.is_finite())
        };
        if !r.t.is_finite() {
            return Err("header.stamp is not finite".into());
        }
        if !finite(&r.tool) {
            return Err("tool_pose is not finite".into());
        }
        let held_scene = r.held.as_deref().filter(|h| !h.is_empty());
        let mut objects = Vec::with_capacity(r.objects.len());
        for o in &r.objects {
            let Some(task) = cfg.task_name(&o.name) else { continue };
            if !finite(&o.pose) || !o.distance.is_finite() || !o.tilt.is_finite() {
                return Err(format!("object `{}`: pose, tool_distance or tilt is not finite", o.name));
            }
            objects.push(TaskObject {
                name: task.to_owned(),
                pose: o.pose,
                distance: o.distance,
                tilt: o.tilt,
                visible: o.visible && cfg.workspace.is_none_or(|w| w.contains(&o.pose.translation.vector.into())),
                held: held_scene == Some(o.name.as_str()),
            });
        }
        let held = held_scene.map(|h| cfg.task_name(h).unwrap_or(h).to_owned());
        Ok(Self { t: r.t, tool: r.tool, gripper_closed: r.gripper_closed, held, objects })
    }

    /// The object with this task name.
    pub fn object(&self, name: &str) -> Option<&TaskObject> {
        self.objects.iter().find(|o| o.name == name)
    }
}
