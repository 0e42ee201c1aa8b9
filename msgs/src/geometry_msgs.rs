//! `geometry_msgs`: points, vectors, orientations, poses, twists, wrenches and transforms.
//!
//! Frames are given by the enclosing message (a `Header` or the field's documentation).

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::ros_message;
use crate::std_msgs::Header;

/// Position in free space (m).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

impl Point {
    /// The point (x, y, z) in m.
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }
}

ros_message!(Point = "geometry_msgs" / "Point" in "ros_std/geometry_msgs/msg", deps []);

/// Position in free space with f32 coordinates (m).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point32 {
    /// x (m).
    pub x: f32,
    /// y (m).
    pub y: f32,
    /// z (m).
    pub z: f32,
}

ros_message!(Point32 = "geometry_msgs" / "Point32" in "ros_std/geometry_msgs/msg", deps []);

/// Free-space vector; units depend on the field (m, m/s, N, Nm, rad/s).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

impl Vector3 {
    /// The vector (x, y, z).
    pub const fn new(x: f64, y: f64, z: f64) -> Self {
        Self { x, y, z }
    }
}

ros_message!(Vector3 = "geometry_msgs" / "Vector3" in "ros_std/geometry_msgs/msg", deps []);

/// Orientation as a unit quaternion (x, y, z, w). The default is the identity (w = 1), as
/// the `.msg` default values say.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x (vector part).
    pub x: f64,
    /// y (vector part).
    pub y: f64,
    /// z (vector part).
    pub z: f64,
    /// w (scalar part).
    pub w: f64,
}

impl Quaternion {
    /// The identity rotation.
    pub const IDENTITY: Self = Self {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };

    /// The quaternion with scalar part `w` and vector part (x, y, z), not normalised.
    pub const fn new(x: f64, y: f64, z: f64, w: f64) -> Self {
        Self { x, y, z, w }
    }
}

impl Default for Quaternion {
    fn default() -> Self {
        Self::IDENTITY
    }
}

ros_message!(Quaternion = "geometry_msgs" / "Quaternion" in "ros_std/geometry_msgs/msg", deps []);

/// Position (m) and orientation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Point,
    /// Orientation (unit quaternion).
    pub orientation: Quaternion,
}

ros_message!(Pose = "geometry_msgs" / "Pose" in "ros_std/geometry_msgs/msg", deps [Point, Quaternion]);

/// A pose in `header.frame_id` at `header.stamp`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Frame and time.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

ros_message!(PoseStamped = "geometry_msgs" / "PoseStamped" in "ros_std/geometry_msgs/msg", deps [Header, Pose]);

/// Velocity: linear (m/s) and angular (rad/s).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity (m/s).
    pub linear: Vector3,
    /// Angular velocity (rad/s).
    pub angular: Vector3,
}

ros_message!(Twist = "geometry_msgs" / "Twist" in "ros_std/geometry_msgs/msg", deps [Vector3]);

/// Force (N) and torque (Nm).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Wrench {
    /// Force (N).
    pub force: Vector3,
    /// Torque (Nm).
    pub torque: Vector3,
}

ros_message!(Wrench = "geometry_msgs" / "Wrench" in "ros_std/geometry_msgs/msg", deps [Vector3]);

/// A wrench in `header.frame_id` at `header.stamp`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WrenchStamped {
    /// Frame and time.
    pub header: Header,
    /// The wrench.
    pub wrench: Wrench,
}

ros_message!(WrenchStamped = "geometry_msgs" / "WrenchStamped" in "ros_std/geometry_msgs/msg", deps [Header, Wrench]);

/// Transform between two frames: translation (m) and rotation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation (m).
    pub translation: Vector3,
    /// Rotation (unit quaternion).
    pub rotation: Quaternion,
}

ros_message!(Transform = "geometry_msgs" / "Transform" in "ros_std/geometry_msgs/msg", deps [Vector3, Quaternion]);

/// The pose of `child_frame_id` in `header.frame_id` at `header.stamp`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Parent frame and time.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// Transform from parent to child.
    pub transform: Transform,
}

impl TransformStamped {
    /// The transform of `child` in `parent` at `stamp`.
    pub fn new(
        stamp: Time,
        parent: impl Into<String>,
        child: impl Into<String>,
        transform: Transform,
    ) -> Self {
        Self {
            header: Header::new(stamp, parent),
            child_frame_id: child.into(),
            transform,
        }
    }
}

ros_message!(TransformStamped = "geometry_msgs" / "TransformStamped" in "ros_std/geometry_msgs/msg", deps [Header, Transform]);
