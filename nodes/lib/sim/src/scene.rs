//! Scene description: table, objects and depth camera, all in the robot base frame.

use std::path::Path;

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Vector3};
use parry3d_f64::shape::{Ball, Cuboid, Cylinder, Shape as ParryShape};
use serde::{Deserialize, Serialize};

use crate::error::{Result, SimError};

/// A pose in the robot base frame. Orientation is given by roll-pitch-yaw (rad, fixed axes
/// x-y-z), by a unit quaternion `[x, y, z, w]`, or — for cameras — by a point to look at.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// Position, m.
    pub position: [f64; 3],
    /// Roll, pitch, yaw, rad.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rpy: Option<[f64; 3]>,
    /// Unit quaternion `[x, y, z, w]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub quaternion_xyzw: Option<[f64; 4]>,
    /// Point the optical axis (+z) looks at, with image rows (+y) pointing down; cameras only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub look_at: Option<[f64; 3]>,
}

/// Primitive shape of a scene object, centred on its pose; cylinders are along the pose's z axis.
/// In YAML: `{ type: box, size: [x, y, z] }`, `{ type: cylinder, radius: r, height: h }`,
/// `{ type: sphere, radius: r }`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Shape {
    /// Axis-aligned box with full side lengths, m.
    Box { size: [f64; 3] },
    /// Cylinder along z, m.
    Cylinder { radius: f64, height: f64 },
    /// Sphere, m.
    Sphere { radius: f64 },
}

/// A rigid object on the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneObject {
    /// Unique name, also its tf frame and its name in `/object_stream`.
    pub name: String,
    /// Geometry.
    pub shape: Shape,
    /// Initial pose of the shape's centre, base frame.
    pub pose: Pose,
    /// Whether the gripper can pick it up.
    #[serde(default = "yes")]
    pub graspable: bool,
}

fn yes() -> bool {
    true
}

/// The table: a box whose top is the support surface for released objects.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Table {
    /// Full side lengths, m.
    pub size: [f64; 3],
    /// Pose of the box centre, base frame.
    pub pose: Pose,
}

/// A pin-hole depth camera (thesis eq. 5.14).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    /// tf frame of the optical frame (z forward, x right, y down).
    pub frame_id: String,
    /// Pose of the optical frame in the base frame.
    pub pose: Pose,
    /// Image width and height, px.
    pub width: u32,
    pub height: u32,
    /// Focal lengths and principal point, px.
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    /// Frame rate, Hz.
    pub rate_hz: f64,
}

/// Start configuration of the one arm of a single-arm scene, whose base frame is the scene frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotSetup {
    /// Joint positions at start, deg (one per actuated joint).
    pub initial_joints_deg: Vec<f64>,
}

/// One arm of a scene with several arms (`arms:`): an instance of the robot description with
/// its own name, base pose and start configuration. Its topics live in the ROS namespace
/// `/<name>` and its tf frames are prefixed `<name>/` (see lwr_sim).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmSetup {
    /// Arm name (`left`, `right`): a ROS name token, `[a-z_][a-z0-9_]*`.
    pub name: String,
    /// Pose of the arm's base frame in the scene (`world`) frame.
    pub base: Pose,
    /// Joint positions at start, deg (one per actuated joint).
    pub initial_joints_deg: Vec<f64>,
}

/// Arm bases closer than this (m, between base frame origins) overlap: an LWR base is a
/// cylinder of about 0.09 m radius.
pub const MIN_BASE_SEPARATION_M: f64 = 0.2;

/// A table-top scene. With `robot:` (one arm) everything is in the robot base frame; with
/// `arms:` (one entry per arm) everything is in the `world` frame and each arm has a base pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Free text shown in logs.
    #[serde(default)]
    pub description: String,
    /// The one arm of a single-arm scene (exclusive with `arms`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub robot: Option<RobotSetup>,
    /// The arms of a scene with named arms (exclusive with `robot`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub arms: Vec<ArmSetup>,
    pub table: Table,
    #[serde(default)]
    pub objects: Vec<SceneObject>,
    pub camera: Camera,
}

impl Scene {
    /// Reads and validates a scene YAML file.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| SimError::Io {
            path: path.to_owned(),
            source,
        })?;
        let scene: Scene = serde_yaml_ng::from_str(&text).map_err(|e| SimError::Parse {
            path: path.to_owned(),
            message: e.to_string(),
        })?;
        scene.validate(&path.display().to_string())?;
        Ok(scene)
    }

    /// Checks every number; `place` names the file in error messages.
    pub fn validate(&self, place: &str) -> Result<()> {
        self.validate_arms(place)?;
        for (i, v) in self.table.size.iter().enumerate() {
            positive(place, &format!("table.size[{i}]"), *v)?;
        }
        self.table.pose.validate(place, "table.pose")?;
        let mut names = std::collections::BTreeSet::new();
        for (i, o) in self.objects.iter().enumerate() {
            let at = format!("objects[{i}] ({})", o.name);
            if o.name.is_empty() || o.name.contains(char::is_whitespace) {
                return Err(SimError::BadValue {
                    place: place.to_owned(),
                    field: format!("objects[{i}].name"),
                    value: format!("{:?}", o.name),
                    reason: "must be a non-empty name without spaces".into(),
                });
            }
            if !names.insert(o.name.as_str()) {
                return Err(SimError::BadValue {
                    place: place.to_owned(),
                    field: format!("objects[{i}].name"),
                    value: o.name.clone(),
                    reason: "duplicate object name".into(),
                });
            }
            match o.shape {
                Shape::Box { size } => {
                    for (k, v) in size.iter().enumerate() {
                        positive(place, &format!("{at}.shape.box.size[{k}]"), *v)?;
                    }
                }
                Shape::Cylinder { radius, height } => {
                    positive(place, &format!("{at}.shape.cylinder.radius"), radius)?;
                    positive(place, &format!("{at}.shape.cylinder.height"), height)?;
                }
                Shape::Sphere { radius } => {
                    positive(place, &format!("{at}.shape.sphere.radius"), radius)?;
                }
            }
            o.pose.validate(place, &format!("{at}.pose"))?;
        }
        let c = &self.camera;
        c.pose.validate(place, "camera.pose")?;
        if c.width == 0 || c.height == 0 {
            return Err(SimError::BadValue {
                place: place.to_owned(),
                field: "camera.width/height".into(),
                value: format!("{}x{}", c.width, c.height),
                reason: "image size must be positive".into(),
            });
        }
        for (field, v) in [("camera.fx", c.fx), ("camera.fy", c.fy), ("camera.rate_hz", c.rate_hz)] {
            positive(place, field, v)?;
        }
        finite(place, "camera.cx", c.cx)?;
        finite(place, "camera.cy", c.cy)?;
        Ok(())
    }

    fn validate_arms(&self, place: &str) -> Result<()> {
        let bad = |field: String, value: String, reason: &str| SimError::BadValue {
            place: place.to_owned(),
            field,
            value,
            reason: reason.to_owned(),
        };
        match (&self.robot, self.arms.is_empty()) {
            (Some(_), false) => {
                return Err(bad("robot/arms".into(), "both".into(), "give `robot:` (one arm) or `arms:` (named arms), not both"));
            }
            (None, true) => {
                return Err(bad("robot/arms".into(), "neither".into(), "give `robot:` (one arm) or `arms:` (named arms)"));
            }
            (Some(robot), true) => {
                for (i, v) in robot.initial_joints_deg.iter().enumerate() {
                    finite(place, &format!("robot.initial_joints_deg[{i}]"), *v)?;
                }
            }
            (None, false) => {}
        }
        for (i, arm) in self.arms.iter().enumerate() {
            let name_ok = arm.name.chars().next().is_some_and(|c| c.is_ascii_lowercase() || c == '_')
                && arm.name.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
            if !name_ok {
                return Err(bad(format!("arms[{i}].name"), format!("{:?}", arm.name), "must be a ROS name token: [a-z_][a-z0-9_]*"));
            }
            if let Some(j) = self.arms[..i].iter().position(|a| a.name == arm.name) {
                return Err(bad(format!("arms[{i}].name"), arm.name.clone(), &format!("duplicate arm name (also arms[{j}])")));
            }
            arm.base.validate(place, &format!("arms[{i}].base"))?;
            if arm.base.look_at.is_some() {
                return Err(bad(format!("arms[{i}].base.look_at"), "given".into(), "an arm base takes rpy or quaternion_xyzw"));
            }
            for (k, v) in arm.initial_joints_deg.iter().enumerate() {
                finite(place, &format!("arms[{i}].initial_joints_deg[{k}]"), *v)?;
            }
            let here = Vector3::from(arm.base.position);
            for other in &self.arms[..i] {
                let apart = (here - Vector3::from(other.base.position)).norm();
                if apart < MIN_BASE_SEPARATION_M {
                    return Err(bad(
                        format!("arms[{i}].base.position"),
                        format!("{:?}", arm.base.position),
                        &format!(
                            "{apart:.3} m from arm `{}`'s base: arm bases overlap (they must be at least {MIN_BASE_SEPARATION_M} m apart)",
                            other.name
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The arms: the `arms:` list, or the one arm of `robot:` (empty name, base at the scene
    /// origin).
    pub fn arm_setups(&self) -> Vec<ArmSetup> {
        match &self.robot {
            Some(robot) if self.arms.is_empty() => vec![ArmSetup {
                name: String::new(),
                base: Pose::default(),
                initial_joints_deg: robot.initial_joints_deg.clone(),
            }],
            _ => self.arms.clone(),
        }
    }

    /// The base pose (scene frame) of the arm whose tf frames carry `frame_prefix` (`left/`
    /// for arm `left`; empty for the one arm of a single-arm scene, whose base is the scene
    /// frame). `None` when no arm matches.
    pub fn arm_base_for_prefix(&self, frame_prefix: &str) -> Option<Isometry3<f64>> {
        if !self.has_named_arms() {
            return frame_prefix.is_empty().then(Isometry3::identity);
        }
        let name = frame_prefix.strip_suffix('/')?;
        self.arms.iter().find(|a| a.name == name).map(|a| a.base.isometry())
    }

    /// Whether the scene names its arms (`arms:`): its frame is `world` and each arm's topics
    /// and frames carry the arm's name.
    pub fn has_named_arms(&self) -> bool {
        !self.arms.is_empty()
    }

    /// Start joints (deg) of the first arm (the only one of a single-arm scene); empty when the
    /// scene has no arm.
    pub fn initial_joints_deg(&self) -> &[f64] {
        match (&self.robot, self.arms.first()) {
            (Some(r), _) => &r.initial_joints_deg,
            (None, Some(a)) => &a.initial_joints_deg,
            (None, None) => &[],
        }
    }

    /// Sets the start joints (deg) of the first arm (the only one of a single-arm scene, which
    /// this makes the scene if it has no arm).
    pub fn set_initial_joints_deg(&mut self, deg: Vec<f64>) {
        match (&mut self.robot, self.arms.first_mut()) {
            (Some(r), _) => r.initial_joints_deg = deg,
            (None, Some(a)) => a.initial_joints_deg = deg,
            (None, None) => self.robot = Some(RobotSetup { initial_joints_deg: deg }),
        }
    }

    /// Height of the table top in the base frame, m.
    pub fn table_top_z(&self) -> f64 {
        self.table.pose.isometry().translation.vector.z + 0.5 * self.table.size[2]
    }
}

impl Pose {
    /// The pose as an isometry (base frame ← local frame).
    pub fn isometry(&self) -> Isometry3<f64> {
        let t = Translation3::new(self.position[0], self.position[1], self.position[2]);
        let r = if let Some([x, y, z, w]) = self.quaternion_xyzw {
            UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
        } else if let Some(target) = self.look_at {
            look_at_optical(Point3::from(self.position), Point3::from(target))
        } else if let Some([r, p, y]) = self.rpy {
            UnitQuaternion::from_euler_angles(r, p, y)
        } else {
            UnitQuaternion::identity()
        };
        Isometry3::from_parts(t, r)
    }

    fn validate(&self, place: &str, at: &str) -> Result<()> {
        for (i, v) in self.position.iter().enumerate() {
            finite(place, &format!("{at}.position[{i}]"), *v)?;
        }
        let given = [self.rpy.is_some(), self.quaternion_xyzw.is_some(), self.look_at.is_some()];
        if given.iter().filter(|g| **g).count() > 1 {
            return Err(SimError::BadValue {
                place: place.to_owned(),
                field: at.to_owned(),
                value: "rpy/quaternion_xyzw/look_at".into(),
                reason: "give at most one orientation".into(),
            });
        }
        if let Some(rpy) = self.rpy {
            for (i, v) in rpy.iter().enumerate() {
                finite(place, &format!("{at}.rpy[{i}]"), *v)?;
            }
        }
        if let Some(q) = self.quaternion_xyzw {
            let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            if !(n.is_finite() && (n - 1.0).abs() < 1e-3) {
                return Err(SimError::BadValue {
                    place: place.to_owned(),
                    field: format!("{at}.quaternion_xyzw"),
                    value: format!("{q:?}"),
                    reason: "must be a unit quaternion".into(),
                });
            }
        }
        if let Some(t) = self.look_at {
            for (i, v) in t.iter().enumerate() {
                finite(place, &format!("{at}.look_at[{i}]"), *v)?;
            }
            let d = Vector3::from(t) - Vector3::from(self.position);
            if d.norm() < 1e-6 || d.normalize().cross(&Vector3::z()).norm() < 1e-6 {
                return Err(SimError::BadValue {
                    place: place.to_owned(),
                    field: format!("{at}.look_at"),
                    value: format!("{t:?}"),
                    reason: "must differ from the position and not be straight above/below it".into(),
                });
            }
        }
        Ok(())
    }
}

/// Optical-frame orientation (z along the view direction, y towards the floor) looking from
/// `eye` at `target`, with the base frame's z as "up".
fn look_at_optical(eye: Point3<f64>, target: Point3<f64>) -> UnitQuaternion<f64> {
    let z = (target - eye).normalize();
    let x = z.cross(&Vector3::z()).normalize(); // image right
    let y = z.cross(&x); // image down
    let m = nalgebra::Matrix3::from_columns(&[x, y, z]);
    UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(m))
}

impl Shape {
    /// The shape as a parry shape in its own frame, with the frame offset that aligns parry's
    /// y-axis cylinders with our z-axis cylinders.
    pub fn parry(&self) -> (Box<dyn ParryShape>, Isometry3<f64>) {
        match *self {
            Shape::Box { size } => (
                Box::new(Cuboid::new(Vector3::from(size) * 0.5)),
                Isometry3::identity(),
            ),
            Shape::Cylinder { radius, height } => (
                Box::new(Cylinder::new(0.5 * height, radius)),
                Isometry3::rotation(Vector3::x() * std::f64::consts::FRAC_PI_2),
            ),
            Shape::Sphere { radius } => (Box::new(Ball::new(radius)), Isometry3::identity()),
        }
    }

    /// Whether `p` (m, in the shape's own frame: centred, cylinder along z) lies inside the
    /// shape grown by `margin` (m, ≥ 0) on every side. Boxes and cylinders are grown as boxes
    /// and cylinders (corners not rounded): a conservative test for "this point belongs to the
    /// object". Cost: a few flops.
    pub fn contains_grown(&self, p: &Point3<f64>, margin: f64) -> bool {
        match *self {
            Shape::Box { size } => (0..3).all(|i| p[i].abs() <= size[i] / 2.0 + margin),
            Shape::Cylinder { radius, height } => {
                p.x.hypot(p.y) <= radius + margin && p.z.abs() <= height / 2.0 + margin
            }
            Shape::Sphere { radius } => p.coords.norm() <= radius + margin,
        }
    }
}

fn finite(place: &str, field: &str, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SimError::BadValue {
            place: place.to_owned(),
            field: field.to_owned(),
            value: v.to_string(),
            reason: "must be finite".into(),
        })
    }
}

fn positive(place: &str, field: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(SimError::BadValue {
            place: place.to_owned(),
            field: field.to_owned(),
            value: v.to_string(),
            reason: "must be a finite number > 0".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_points_optical_axis_at_target() {
        let pose = Pose {
            position: [1.5, 0.0, 1.0],
            look_at: Some([0.5, 0.0, 0.0]),
            ..Default::default()
        };
        let iso = pose.isometry();
        let z = iso.rotation * Vector3::z();
        let want = (Vector3::new(0.5, 0.0, 0.0) - Vector3::new(1.5, 0.0, 1.0)).normalize();
        assert!((z - want).norm() < 1e-12);
        // Image "down" has a negative world z component.
        assert!((iso.rotation * Vector3::y()).z < 0.0);
    }

    #[test]
    fn cylinder_is_along_z() {
        let (shape, offset) = Shape::Cylinder { radius: 0.05, height: 0.2 }.parry();
        let aabb = shape.compute_aabb(&offset);
        assert!((aabb.maxs.z - 0.1).abs() < 1e-9);
        assert!((aabb.maxs.x - 0.05).abs() < 1e-9);
    }
}
