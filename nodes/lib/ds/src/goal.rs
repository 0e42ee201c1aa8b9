//! Goal adaptation (thesis eq. 5.2): ẋ = f(x − g) with a goal g that may change at any time,
//! and the reach check that rejects goals the arm cannot attain.

use crate::error::Fault;
use crate::primitive::FirstOrderDs;
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::Vector3;

/// Velocity of DS `ds` at `x` for the current goal `goal` (eq. 5.2; m, m/s, base frame).
///
/// A stable DS stays stable for any g, so a goal change needs no reset: the next call simply
/// converges to the new goal.
pub fn adapted_velocity<F: FirstOrderDs + ?Sized>(
    ds: &F,
    x: &Vector3<f64>,
    goal: &Vector3<f64>,
) -> Vector3<f64> {
    ds.velocity(x, goal)
}

/// Conservative reach bound of a serial arm: the sum of the distances between consecutive link
/// frames from the first joint's link to the tip, at q = 0. No configuration puts the tip
/// farther than that from the first joint's origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// Origin of the first joint's link in the base frame (m); fixed, as joint 1 turns about it.
    pub shoulder: Vector3<f64>,
    /// Upper bound of the tip's distance from `shoulder` (m).
    pub radius: f64,
}

impl Reach {
    /// The bound for `model`. Allocation-free.
    pub fn of_model(model: &RobotModel) -> Self {
        let mut poses = LinkPoses::new();
        model.forward_kinematics(&JointVector::zeros(), &mut poses);
        let first = model.joint_link(0);
        let shoulder = poses.get(first).translation.vector;
        let mut radius = 0.0;
        for link in first..model.tip_link() {
            radius += (poses.get(link + 1).translation.vector - poses.get(link).translation.vector)
                .norm();
        }
        Self { shoulder, radius }
    }

    /// `Err(GoalOutOfReach)` when `goal` (m, base frame) is farther than the bound.
    pub fn check(&self, goal: &Vector3<f64>) -> Result<(), Fault> {
        let distance = (goal - self.shoulder).norm();
        if distance > self.radius {
            Err(Fault::GoalOutOfReach {
                distance_m: distance,
                reach_m: self.radius,
            })
        } else {
            Ok(())
        }
    }
}
