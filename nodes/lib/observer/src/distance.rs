//! Minimum distance between a person's body and the robot (thesis Sec. 5.1.3).
//!
//! The body is the capsule body the depth renderer of `lwr_sim` draws
//! ([`cowork_people::body_capsules`], 16 capsules sized from the skeleton); the robot is the
//! convex hull of each moving link's URDF mesh at the current joint positions, as
//! [`cowork_scenario::distance::LinkGeometry`] builds it. Distances come from parry's GJK/EPA
//! (negative when a capsule and a link overlap).

use cowork_people::{BODY_CAPSULE_NAMES, SkeletonPose, body_capsules};
use cowork_robot::{DOF, JointVector, LinkPoses, RobotModel};
use cowork_scenario::distance::LinkGeometry;
use cowork_scenario::obstacle::Obstacle;
use nalgebra::Vector3;

use crate::error::{ObserverError, Result};

/// Bodies further than this from every link are reported at this distance (m).
pub const MAX_RANGE_M: f64 = 20.0;

/// Closest approach of a body to the robot.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyDistance {
    /// Minimum capsule–link distance (m; ≤ 0 on contact).
    pub distance: f64,
    /// URDF name of the closest link.
    pub link: String,
}

/// The robot's link geometry at the last joint state.
#[derive(Debug)]
pub struct RobotBody {
    model: RobotModel,
    geometry: LinkGeometry,
    poses: LinkPoses,
    /// Stamp of the joint state in use (s), `None` before the first.
    stamp: Option<f64>,
    obstacles: Vec<Obstacle>,
}

impl RobotBody {
    /// Geometry of `model`'s moving links (hulls of their meshes).
    pub fn new(model: RobotModel) -> Result<Self> {
        let geometry = LinkGeometry::new(&model, MAX_RANGE_M).map_err(|e| ObserverError::Geometry(e.to_string()))?;
        Ok(Self { model, geometry, poses: LinkPoses::new(), stamp: None, obstacles: Vec::with_capacity(BODY_CAPSULE_NAMES.len()) })
    }

    /// The robot model.
    pub fn model(&self) -> &RobotModel {
        &self.model
    }

    /// Stamp of the joint state in use (s), `None` before the first.
    pub fn joint_stamp(&self) -> Option<f64> {
        self.stamp
    }

    /// Takes a joint state: positions matched to the model's joints by name (in model order
    /// when `names` is empty). Incomplete or non-finite states are rejected and the previous one
    /// stays in use.
    pub fn set_joint_state(&mut self, stamp: f64, names: &[String], positions: &[f64]) -> Result<()> {
        let mut q = JointVector::zeros();
        for (j, name) in self.model.joint_names().iter().enumerate() {
            let i = if names.is_empty() { Some(j) } else { names.iter().position(|n| n == name) };
            let Some(v) = i.and_then(|i| positions.get(i)) else {
                return Err(ObserverError::BadJointState { field: "name".into(), reason: format!("joint {name:?} missing") });
            };
            if !v.is_finite() {
                return Err(ObserverError::BadJointState { field: "position".into(), reason: format!("joint {name:?} = {v}") });
            }
            q[j] = *v;
        }
        debug_assert_eq!(q.len(), DOF);
        self.model.forward_kinematics(&q, &mut self.poses);
        self.stamp = Some(stamp);
        Ok(())
    }

    /// Link poses at the last joint state (empty before the first).
    pub fn link_poses(&self) -> &LinkPoses {
        &self.poses
    }

    /// Minimum distance between the capsule body of `pose` and the links; `None` before the
    /// first joint state. Cost: 16 capsules × moving links GJK queries (bounding-sphere culled).
    pub fn distance(&mut self, pose: &SkeletonPose) -> Option<BodyDistance> {
        self.stamp?;
        self.obstacles.clear();
        for (c, name) in body_capsules(pose).iter().zip(BODY_CAPSULE_NAMES) {
            self.obstacles.push(Obstacle::capsule(name, c.a, c.b, c.radius, Vector3::zeros(), Vector3::zeros()));
        }
        let (_, closest) = self.geometry.distances(&self.poses, &self.obstacles, pose.time);
        Some(match closest.link {
            Some(l) => BodyDistance { distance: closest.human_distance, link: self.model.link_names()[l].clone() },
            None => BodyDistance { distance: MAX_RANGE_M, link: String::new() },
        })
    }
}
