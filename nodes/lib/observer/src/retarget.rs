//! Motion retargeting of the demonstrator's arm to the robot (thesis Sec. 4.2, eq. 4.7):
//!
//! ```text
//! x_h = x_s + R_s ( l_a (x_e − x_s)/‖x_e − x_s‖ + l_fa (x_w − x_e)/‖x_w − x_e‖ )
//! ```
//!
//! The human upper-arm and forearm directions (shoulder → elbow → wrist from the skeleton) are
//! expressed in the sternum frame (so the trunk's motion does not move the robot), turned into
//! the robot base frame by `mount` (the robot's base stands for the demonstrator's trunk: x
//! forward, y left, z up) and scaled to the robot's own upper arm `l_a` and forearm `l_fa`
//! (shoulder, elbow and wrist are the origins of the links of joints 2, 4 and 6 — for the
//! LWR 0.40 m and 0.39 m), starting at the robot's shoulder `x_s`. The robot joint targets are
//! the damped-least-squares inverse kinematics of the elbow and wrist points (stacked 6 × 7
//! position Jacobian), started from the previous solution so a stream of frames gives a smooth
//! joint trajectory.

use cowork_msgs::msg::Skeleton;
use cowork_people::{Segment, Side, SkeletonPose};
use cowork_robot::{Jacobian, JointVector, LinkPoses, PositionJacobian, RobotModel, damped_pseudo_inverse};
use nalgebra::{Point3, UnitQuaternion, Vector3, Vector6};
use serde::{Deserialize, Serialize};

use crate::error::{ObserverError, Result, check};

/// Retargeting parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RetargetConfig {
    /// Which arm of the demonstrator drives the robot.
    pub side: Side,
    /// Roll, pitch, yaw (rad) of the demonstrator's sternum frame in the robot base frame.
    pub mount_rpy: [f64; 3],
    /// Damping of the least-squares IK.
    pub damping: f64,
    /// IK iterations per frame at most.
    pub iterations: usize,
    /// IK stops when the stacked elbow + wrist error is below this, m.
    pub tolerance_m: f64,
    /// Joint targets move at most this fraction of each joint's URDF speed limit between two
    /// frames (by their pose times), so a robot following them live can (0: unlimited). A human
    /// reach of 1.2 s asked up to 2.7× the LWR's limits in 11 % of frames.
    pub speed_limit_fraction: f64,
}

impl Default for RetargetConfig {
    fn default() -> Self {
        Self { side: Side::Right, mount_rpy: [0.0; 3], damping: 0.05, iterations: 50, tolerance_m: 1e-4, speed_limit_fraction: 1.0 }
    }
}

/// One retargeted frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Retargeted {
    /// Robot joint targets, rad (within the joint limits).
    pub joints: JointVector,
    /// Eq. 4.7 elbow target, base frame, m.
    pub elbow_target: Point3<f64>,
    /// Eq. 4.7 wrist (hand) target x_h, base frame, m.
    pub wrist_target: Point3<f64>,
    /// Remaining ‖elbow error‖ + ‖wrist error‖ at `joints`, m (the robot cannot always
    /// follow: joint limits, table, speed limits).
    pub residual_m: f64,
    /// The joint speed limit held `joints` back from the IK's solution this frame.
    pub speed_limited: bool,
}

/// Retargets a stream of skeletons of one demonstrator to robot joint targets.
#[derive(Debug)]
pub struct Retargeter {
    config: RetargetConfig,
    model: RobotModel,
    links: [usize; 3],
    lengths: (f64, f64),
    mount: UnitQuaternion<f64>,
    q: JointVector,
    /// Pose time (s) and joint targets of the last frame.
    last: Option<(f64, JointVector)>,
    poses: LinkPoses,
}

impl Retargeter {
    /// A retargeter for `model` starting the IK at `q0` (rad).
    pub fn new(model: RobotModel, config: RetargetConfig, q0: JointVector) -> Result<Self> {
        check("retarget.damping", config.damping, 1e-6, 10.0, "must be in [1e-6, 10]")?;
        check("retarget.iterations", config.iterations as f64, 1.0, 10_000.0, "must be 1 to 10000")?;
        check("retarget.tolerance_m", config.tolerance_m, 1e-9, 1.0, "must be in [1e-9, 1] m")?;
        check("retarget.speed_limit_fraction", config.speed_limit_fraction, 0.0, 1.0, "must be in [0, 1] (0: unlimited)")?;
        if !config.mount_rpy.iter().all(|v| v.is_finite()) || !q0.iter().all(|v| v.is_finite()) {
            return Err(ObserverError::InvalidParameter { name: "retarget.mount_rpy / q0".into(), value: f64::NAN, expected: "finite" });
        }
        let links = [model.joint_link(1), model.joint_link(3), model.joint_link(5)];
        let zero = JointVector::zeros();
        let at = |l: usize| model.link_pose(&zero, l).translation.vector;
        let lengths = ((at(links[1]) - at(links[0])).norm(), (at(links[2]) - at(links[1])).norm());
        if lengths.0 < 1e-3 || lengths.1 < 1e-3 {
            return Err(ObserverError::Geometry("robot upper arm or forearm (joints 2-4-6) has zero length".into()));
        }
        let [r, p, y] = config.mount_rpy;
        let q = model.clamp_to_limits(&q0);
        Ok(Self { mount: UnitQuaternion::from_euler_angles(r, p, y), config, model, links, lengths, q, last: None, poses: LinkPoses::new() })
    }

    /// Robot upper arm and forearm lengths (m): l_a, l_fa of eq. 4.7.
    pub fn robot_lengths(&self) -> (f64, f64) {
        self.lengths
    }

    /// Retargets one skeleton message (checked first; see [`crate::skeleton::check_skeleton`]).
    pub fn retarget_message(&mut self, msg: &Skeleton, base_frame: &str) -> Result<Retargeted> {
        let frame = crate::skeleton::check_skeleton(msg, base_frame, -0.75)?;
        self.retarget(&frame.pose)
    }

    /// Retargets one pose.
    pub fn retarget(&mut self, pose: &SkeletonPose) -> Result<Retargeted> {
        let [sh, el, wr, _] = Segment::arm(self.config.side);
        let (xs, xe, xw) = (pose.position(sh), pose.position(el), pose.position(wr));
        let dir = |a: &Point3<f64>, b: &Point3<f64>| (b - a).try_normalize(1e-6);
        let (Some(ua), Some(uf)) = (dir(&xs, &xe), dir(&xe, &xw)) else {
            return Err(ObserverError::BadSkeleton { person_id: 0, field: "poses".into(), reason: "arm segments of zero length".into() });
        };
        let body = self.mount * pose.segment(Segment::Sternum).orientation.inverse();
        self.model.forward_kinematics(&JointVector::zeros(), &mut self.poses);
        let shoulder = Point3::from(self.poses.get(self.links[0]).translation.vector);
        let (la, lfa) = self.lengths;
        let elbow_target = shoulder + la * (body * ua);
        let wrist_target = elbow_target + lfa * (body * uf);
        let mut jac = Jacobian::zeros();
        let mut pj = PositionJacobian::zeros();
        for _ in 0..self.config.iterations {
            let (ee, ew) = self.errors(&elbow_target, &wrist_target);
            if ee.norm() + ew.norm() < self.config.tolerance_m {
                break;
            }
            self.model.position_jacobian(&self.poses, self.links[1], &Point3::origin(), &mut pj);
            jac.fixed_view_mut::<3, 7>(0, 0).copy_from(&pj);
            self.model.position_jacobian(&self.poses, self.links[2], &Point3::origin(), &mut pj);
            jac.fixed_view_mut::<3, 7>(3, 0).copy_from(&pj);
            let e = Vector6::new(ee.x, ee.y, ee.z, ew.x, ew.y, ew.z);
            let dq = damped_pseudo_inverse(&jac, self.config.damping) * e;
            self.q = self.model.clamp_to_limits(&(self.q + dq));
        }
        let speed_limited = self.limit_speed(pose.time);
        let (ee, ew) = self.errors(&elbow_target, &wrist_target);
        Ok(Retargeted { joints: self.q, elbow_target, wrist_target, residual_m: ee.norm() + ew.norm(), speed_limited })
    }

    /// Elbow and wrist errors (target − actual, m, base frame) at the current joints.
    fn errors(&mut self, elbow_target: &Point3<f64>, wrist_target: &Point3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        self.model.forward_kinematics(&self.q, &mut self.poses);
        let at = |l: usize| Point3::from(self.poses.get(l).translation.vector);
        (elbow_target - at(self.links[1]), wrist_target - at(self.links[2]))
    }

    /// Holds the joints' step since the last frame (pose time `t`, s) within
    /// `speed_limit_fraction` of the URDF speed limits; a frame not later than the last one
    /// keeps the last targets. Returns whether the step was cut.
    fn limit_speed(&mut self, t: f64) -> bool {
        let fraction = self.config.speed_limit_fraction;
        let Some((t_last, q_last)) = self.last.filter(|_| fraction > 0.0) else {
            self.last = Some((t, self.q));
            return false;
        };
        let dt = t - t_last;
        if !(dt > 0.0) {
            self.q = q_last;
            return true;
        }
        let mut cut = false;
        for (i, l) in self.model.joint_limits().iter().enumerate() {
            let max = l.velocity * fraction * dt;
            let step = self.q[i] - q_last[i];
            if step.abs() > max {
                self.q[i] = q_last[i] + max.copysign(step);
                cut = true;
            }
        }
        self.last = Some((t, self.q));
        cut
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_people::{Action, BodySize, Performer, Stance};

    fn model() -> RobotModel {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
        RobotModel::from_urdf_file(root).expect("model")
    }

    #[test]
    fn the_robot_arm_follows_the_direction_of_the_human_arm() {
        let model = model();
        let q0 = JointVector::from_row_slice(&[0.0, 0.3, 0.0, -0.6, 0.0, 0.3, 0.0]);
        let mut r = Retargeter::new(model.clone(), RetargetConfig::default(), q0).expect("retargeter");
        assert!((r.robot_lengths().0 - 0.4).abs() < 1e-9 && (r.robot_lengths().1 - 0.39).abs() < 1e-9);
        // A person facing +x reaching forward at shoulder height: the robot arm points forward.
        let p = Performer::new(1, BodySize::MEDIUM, Stance::new(-1.0, 0.0, 0.0), 1)
            .expect("p")
            .then(Action::Reach { side: Side::Right, target: Point3::new(-0.2, -0.2, 0.65), duration: 1.0, hold: 1.0 })
            .expect("reach");
        let pose = p.pose(1.5);
        let out = r.retarget(&pose).expect("retarget");
        let [sh, el, wr, _] = Segment::arm(Side::Right);
        let human = (pose.position(wr) - pose.position(sh)).normalize();
        let robot = (out.wrist_target - Point3::new(0.0, 0.0, 0.31)).normalize();
        let body = pose.segment(Segment::Sternum).orientation.inverse();
        assert!((body * human - robot).norm() < 0.2, "human {human} robot {robot}");
        assert!(out.residual_m < 0.05, "residual {}", out.residual_m);
        let _ = el;
        let mut poses = LinkPoses::new();
        model.forward_kinematics(&out.joints, &mut poses);
        let wrist = poses.get(model.joint_link(5)).translation.vector;
        assert!((wrist - out.wrist_target.coords).norm() < 0.03);
    }

    #[test]
    fn joint_targets_keep_to_the_speed_limits_and_hold_on_a_frame_that_is_not_later() {
        let model = model();
        let q0 = JointVector::from_row_slice(&[0.0, 0.3, 0.0, -0.6, 0.0, 0.3, 0.0]);
        let mut r = Retargeter::new(model.clone(), RetargetConfig::default(), q0).expect("retargeter");
        let p = Performer::new(1, BodySize::MEDIUM, Stance::new(-1.0, 0.0, 0.0), 1)
            .expect("p")
            .then(Action::Reach { side: Side::Right, target: Point3::new(-0.2, -0.2, 0.65), duration: 1.0, hold: 1.0 })
            .expect("reach");
        let first = r.retarget(&p.pose(0.0)).expect("first");
        // 10 ms later the arm is far away: the targets move at the speed limits, no faster.
        let mut far = p.pose(1.5);
        far.time = 0.01;
        let later = r.retarget(&far).expect("later");
        assert!(later.speed_limited && later.residual_m > 0.05, "{later:?}");
        for ((a, b), l) in first.joints.iter().zip(later.joints.iter()).zip(model.joint_limits()) {
            assert!((b - a).abs() <= l.velocity * 0.01 + 1e-12);
        }
        let again = far.clone();
        let held = r.retarget(&again).expect("same time");
        assert_eq!(held.joints, later.joints, "a frame not later than the last moves nothing");
        assert!(Retargeter::new(model, RetargetConfig { speed_limit_fraction: 1.5, ..RetargetConfig::default() }, q0).is_err());
    }
}
