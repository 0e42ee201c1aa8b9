//! Multi-priority inverse kinematics (thesis eq. 5.12–5.13, A.2.2) with null-space avoidance
//! of the closest link point, and joint position / velocity saturation.
//!
//! Frames: base frame for every Cartesian quantity; rates in m/s, rad/s. Allocation-free.

use cowork_robot::{
    DOF, Jacobian, JointLimit, JointMatrix, JointVector, LinkPoses, PositionJacobian, RobotModel,
    damped_pseudo_inverse, damped_pseudo_inverse_3, null_space_projector,
};
use nalgebra::{Matrix3, Point3, SVector, UnitQuaternion, Vector3};

/// Parameters of the IK and the saturation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IkConfig {
    /// Damping λ of the end-effector task's pseudo-inverse (mixed m/rad units).
    pub damping: f64,
    /// Damping λ of the link-point task's pseudo-inverse (m/rad).
    pub link_damping: f64,
    /// Gain of the angular-error feedback that holds or drives the orientation (1/s).
    pub orientation_gain: f64,
    /// Largest commanded end-effector angular speed (rad/s).
    pub max_angular_speed: f64,
    /// Fraction of each joint's URDF speed limit that may be commanded, in (0, 1].
    pub velocity_limit_fraction: f64,
    /// Joints stop this far inside their URDF position limits (rad), ≥ 0.
    pub position_margin: f64,
    /// Gain (1/s) of a lowest-priority posture task that pulls the joints back towards the
    /// configuration the current command started from, in what is left of the null space.
    /// 0 (default) is the thesis's eq. 5.13 as is; > 0 stops the redundant elbow from drifting
    /// (the damped pseudo-inverse and saturation otherwise let it wander over long motions).
    #[serde(default)]
    pub posture_gain: f64,
    /// Joint positions the posture task pulls towards (rad; `None` entries: that joint is not
    /// pulled), instead of the configuration the current command started from. A task
    /// streamed as many short commands (the manager's learned primitives) restarts that
    /// reference at every command, so it only damps drift; a fixed reference for the joints
    /// that turn the elbow about the shoulder–wrist line (1, 3, 5, 7 on the LWR) keeps it where
    /// the wrist keeps its range. Leave free the joints the hand's pose dictates (2, 4, 6): a
    /// pull on joint 6 across its keep-off-zero zone fought that push and held the spoon 7.6 mm
    /// off its goal, where the damped projector's leak balanced the DS (coffee seed 2). `None`
    /// (default): the command's start, every joint.
    pub posture_reference: Option<[Option<f64>; DOF]>,
    /// Largest joint-velocity norm of the posture task and the limit avoidance together
    /// (rad/s, > 0). The null-space projector of the damped pseudo-inverse leaks a little of
    /// that motion into the end-effector task; near the goal, where the DS asks for mm/s, an
    /// unbounded pull (2.7 rad/s with joints 5 and 7 far from the reference) balanced the DS
    /// 5.5 mm off the goal for 120 s (coffee seed 2's spoon over the cup).
    pub posture_max_speed: f64,
    /// Joint-limit avoidance (ours, beyond eq. 5.13): inside this distance of a position limit
    /// (after `position_margin`) a joint is pushed back at `limit_gain` per rad of intrusion,
    /// in the null space of the higher-priority tasks, rad. 0 (default): off.
    #[serde(default)]
    pub limit_zone: f64,
    /// Gain of the joint-limit avoidance, 1/s.
    #[serde(default)]
    pub limit_gain: f64,
    /// Joints kept off zero the same way (within `limit_zone` of 0 they are pushed away from
    /// it at `limit_gain`): on the LWR joint 6 at 0 is the wrist singularity, where joints 5
    /// and 7 turn about one axis and wind up against their limits (coffee seed 5's spoon:
    /// joint 6 at 4.8° above the cup, then joints 5 and 7 at ±170° for the rest of the trial).
    #[serde(default)]
    pub keep_off_zero: [bool; DOF],
    /// A joint that sits on its position limit while the end-effector task drives it further
    /// out is taken out of that task (its Jacobian column zeroed) and the task re-solved with
    /// the others, so they make up for it instead of leaving the task short by the clamped
    /// part (saturation in the null space, as Flacco et al.'s SNS; ours, beyond eq. 5.13).
    #[serde(default)]
    pub release_limited_joints: bool,
}

impl Default for IkConfig {
    fn default() -> Self {
        Self {
            damping: 0.01,
            link_damping: 0.02,
            orientation_gain: 5.0,
            max_angular_speed: 1.5,
            velocity_limit_fraction: 1.0,
            position_margin: 0.0,
            posture_gain: 0.0,
            posture_reference: None,
            posture_max_speed: 0.5,
            limit_zone: 0.0,
            limit_gain: 0.0,
            keep_off_zero: [false; DOF],
            release_limited_joints: false,
        }
    }
}

/// The secondary task: the closest point of a (non end-effector) link to an obstacle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkTask {
    /// Link index in the model.
    pub link: usize,
    /// The closest point on the link (m, base frame).
    pub point: Point3<f64>,
    /// Modulation matrix M(x_l) of that point (eq. 5.7).
    pub modulation: Matrix3<f64>,
    /// Velocity of the closest obstacle point (m/s).
    pub obstacle_velocity: Vector3<f64>,
}

/// A null-space motion primitive's step (thesis Sec. 4.1.1, Fig. 4.1): the origin of link
/// `link` (the elbow) should move with `velocity`, at the lowest priority, in what the
/// end-effector task (and an active link task) leave of the redundancy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointTask {
    /// Link index in the model; the task acts on its origin.
    pub link: usize,
    /// Desired velocity of that origin (m/s, base frame).
    pub velocity: Vector3<f64>,
}

/// End-effector twist [v; w]: linear (m/s) then angular (rad/s) velocity, base frame.
pub type Twist = SVector<f64, 6>;

/// Angular error (rad, base frame) that rotates `current` onto `desired`: the rotation vector
/// of `desired · current⁻¹`, shortest way round.
pub fn orientation_error(
    current: &UnitQuaternion<f64>,
    desired: &UnitQuaternion<f64>,
) -> Vector3<f64> {
    (desired * current.inverse()).scaled_axis()
}

/// Solves eq. 5.13 (in the task-priority form of Nakamura, see [`solve`]).
///
/// Scratch buffers sized at compile time; one instance per controller.
#[derive(Debug, Clone)]
pub struct Ik {
    cfg: IkConfig,
    jac: Jacobian,
    pj: PositionJacobian,
    /// Linear rows of the tip's Jacobian at the last solve, before any joint was released.
    tool: PositionJacobian,
    /// Projector onto the end-effector task's null space at the last solve (released joints
    /// included), I − J†J.
    null_space: JointMatrix,
}

/// What [`Ik::solve`] reports besides q̇.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct IkReport {
    /// Link-point velocity the secondary task asked for (m/s); zero without a link task.
    pub link_velocity_desired: Vector3<f64>,
    /// Link-point velocity achieved by the final (unsaturated) q̇ (m/s).
    pub link_velocity: Vector3<f64>,
    /// Velocity of the null-space primitive's link origin under the final (unsaturated) q̇
    /// (m/s); zero without a [`PointTask`].
    pub point_velocity: Vector3<f64>,
    /// Joints taken out of the end-effector task on their position limit (see
    /// [`IkConfig::release_limited_joints`]).
    pub released_joints: u8,
}

/// Joint-limit avoidance velocity (rad/s) at `q` (rad): each joint within `cfg.limit_zone` of
/// its limit (inside `cfg.position_margin`), or of 0 for the `keep_off_zero` joints, is pushed
/// back at `cfg.limit_gain` per rad of intrusion; zero when the zone or the gain is 0.
/// Allocation-free.
pub fn limit_avoidance(cfg: &IkConfig, limits: &[JointLimit; DOF], q: &JointVector) -> JointVector {
    let mut v = JointVector::zeros();
    if cfg.limit_zone <= 0.0 || cfg.limit_gain <= 0.0 {
        return v;
    }
    for i in 0..DOF {
        let low = q[i] - (limits[i].lower + cfg.position_margin);
        let high = (limits[i].upper - cfg.position_margin) - q[i];
        if low < cfg.limit_zone {
            v[i] += cfg.limit_gain * (cfg.limit_zone - low);
        }
        if high < cfg.limit_zone {
            v[i] -= cfg.limit_gain * (cfg.limit_zone - high);
        }
        if cfg.keep_off_zero[i] && q[i].abs() < cfg.limit_zone {
            // Away from 0 on the side the joint is on.
            v[i] += cfg.limit_gain * (cfg.limit_zone - q[i].abs()) * q[i].signum();
        }
    }
    v
}

impl Ik {
    /// An IK with parameters `cfg` (validated by the controller config).
    pub fn new(cfg: IkConfig) -> Self {
        Self {
            cfg,
            jac: Jacobian::zeros(),
            pj: PositionJacobian::zeros(),
            tool: PositionJacobian::zeros(),
            null_space: JointMatrix::identity(),
        }
    }

    /// Parameters.
    pub fn config(&self) -> &IkConfig {
        &self.cfg
    }

    /// Joint velocity (rad/s, unsaturated) for the end-effector twist `twist` = [v; w] (linear
    /// m/s, then angular rad/s) of link `tip` at its frame origin, with the optional
    /// null-space link task; `poses` from forward kinematics at the current q.
    ///
    /// Primary: q̇₁ = J† [v; w] (damped). Secondary (eq. 5.13): the closest link point x_l
    /// should move with the modulated velocity ẋ_l* = M(x_l)(ẋ_l − ẋ_O) + ẋ_O, ẋ_l = J_l q̇₁
    /// being what the primary task alone would give it. It is realised as far as the null space
    /// allows: q̇ = q̇₁ + N (J_l N)† (ẋ_l* − J_l q̇₁), N = I − J†J. Why not the literal
    /// N J_l† M ẋ_l of 5.13: there the null-space motion adds to the primary-induced link motion
    /// instead of replacing it, so an approach along n̂ is not cancelled; the task-priority form
    /// gives exactly M's reduction of the approach where the redundancy permits and leaves the
    /// end-effector task untouched, as 5.13 intends.
    pub fn solve(
        &mut self,
        model: &RobotModel,
        poses: &LinkPoses,
        tip: usize,
        twist: &Twist,
        link_task: Option<&LinkTask>,
        report: &mut IkReport,
    ) -> JointVector {
        self.solve_with_posture(model, poses, tip, twist, link_task, &JointVector::zeros(), None, report)
    }

    /// [`solve`](Self::solve) plus the posture task: `posture` is the desired joint velocity
    /// (rad/s) of the lowest priority, projected into the null space of the end-effector task
    /// and, when a link task is active, of the link task too.
    ///
    /// `at` (joint positions, rad, and the step, s): with `release_limited_joints` on, a joint
    /// on its position limit that the solution drives further out leaves the end-effector task
    /// (see [`IkConfig::release_limited_joints`]); `None` solves with every joint.
    #[allow(clippy::too_many_arguments)]
    pub fn solve_with_posture(
        &mut self,
        model: &RobotModel,
        poses: &LinkPoses,
        tip: usize,
        twist: &Twist,
        link_task: Option<&LinkTask>,
        posture: &JointVector,
        at: Option<(&JointVector, f64)>,
        report: &mut IkReport,
    ) -> JointVector {
        self.solve_with_null_space(model, poses, tip, twist, link_task, posture, None, at, report)
    }

    /// [`solve_with_posture`](Self::solve_with_posture) with a null-space motion primitive:
    /// with `point` the lowest priority is that [`PointTask`] instead of `posture`, in the
    /// task-priority form q̇ += N_k (J_p N_k)† (ẋ_p − J_p q̇_k), N_k the null space of the tasks
    /// above it and q̇_k their solution, so the point gets the best velocity the redundancy
    /// allows without touching them (Sec. 4.1.1).
    #[allow(clippy::too_many_arguments)]
    pub fn solve_with_null_space(
        &mut self,
        model: &RobotModel,
        poses: &LinkPoses,
        tip: usize,
        twist: &Twist,
        link_task: Option<&LinkTask>,
        posture: &JointVector,
        point: Option<&PointTask>,
        at: Option<(&JointVector, f64)>,
        report: &mut IkReport,
    ) -> JointVector {
        model.jacobian(poses, tip, &Point3::origin(), &mut self.jac);
        self.tool = self.jac.fixed_rows::<3>(0).into_owned();
        let mut pinv = damped_pseudo_inverse(&self.jac, self.cfg.damping);
        let mut q1 = pinv * twist;
        *report = IkReport::default();
        if let (true, Some((q, dt))) = (self.cfg.release_limited_joints, at) {
            // At most one pass per joint: each pass releases at least one more.
            for _ in 0..DOF {
                let mut released = false;
                for (i, l) in model.joint_limits().iter().enumerate() {
                    let next = q[i] + q1[i] * dt;
                    let out_low = q1[i] < 0.0 && next < l.lower + self.cfg.position_margin;
                    let out_high = q1[i] > 0.0 && next > l.upper - self.cfg.position_margin;
                    if (out_low || out_high) && self.jac.column(i).iter().any(|v| *v != 0.0) {
                        self.jac.column_mut(i).fill(0.0);
                        released = true;
                        report.released_joints += 1;
                    }
                }
                if !released {
                    break;
                }
                pinv = damped_pseudo_inverse(&self.jac, self.cfg.damping);
                q1 = pinv * twist;
            }
        }
        let n = null_space_projector(&self.jac, &pinv);
        self.null_space = n;
        let lowest_off = point.is_none() && posture.iter().all(|v| *v == 0.0);
        if link_task.is_none() && lowest_off {
            return q1;
        }
        // The link task (eq. 5.13) above the lowest one, and the null space it leaves.
        let (mut secondary, n_low) = match link_task {
            Some(task) => {
                let in_link = poses.get(task.link).inverse_transform_point(&task.point);
                model.position_jacobian(poses, task.link, &in_link, &mut self.pj);
                let x_l = self.pj * q1;
                let desired = task.modulation * (x_l - task.obstacle_velocity) + task.obstacle_velocity;
                let jn: PositionJacobian = self.pj * n;
                let jn_pinv = damped_pseudo_inverse_3(&jn, self.cfg.link_damping);
                report.link_velocity_desired = desired;
                // Null space of both tasks: N (I − (J_l N)† (J_l N)).
                (n * (jn_pinv * (desired - x_l)), n * (cowork_robot::JointMatrix::identity() - jn_pinv * jn))
            }
            None => (JointVector::zeros(), n),
        };
        match point {
            Some(p) => {
                let mut jp = PositionJacobian::zeros();
                model.position_jacobian(poses, p.link, &Point3::origin(), &mut jp);
                let jn: PositionJacobian = jp * n_low;
                let jn_pinv = damped_pseudo_inverse_3(&jn, self.cfg.link_damping);
                secondary += n_low * (jn_pinv * (p.velocity - jp * (q1 + secondary)));
                let q = q1 + self.secondary_scale(model, &q1, &secondary) * secondary;
                report.point_velocity = jp * q;
                if link_task.is_some() {
                    report.link_velocity = self.pj * q;
                }
                q
            }
            None => {
                secondary += n_low * posture;
                let q = q1 + self.secondary_scale(model, &q1, &secondary) * secondary;
                if link_task.is_some() {
                    report.link_velocity = self.pj * q;
                }
                q
            }
        }
    }
}

impl Ik {
    /// Takes the tip's position Jacobian at `poses` without solving (a step that moves the
    /// joints directly, [`crate::JointMove`]); the null space becomes the whole joint space.
    pub fn update_tool_jacobian(&mut self, model: &RobotModel, poses: &LinkPoses, tip: usize) {
        model.jacobian(poses, tip, &Point3::origin(), &mut self.jac);
        self.tool = self.jac.fixed_rows::<3>(0).into_owned();
        self.null_space = JointMatrix::identity();
    }

    /// The tip's position Jacobian (m/rad, base frame) at the configuration of the last solve
    /// (or update), every joint included: the tool's actual linear velocity is this times q̇.
    pub fn tool_position_jacobian(&self) -> &PositionJacobian {
        &self.tool
    }

    /// Projector onto the end-effector task's null space at the configuration of the last
    /// solve (I − J†J, J† damped; joints released on their limits count as free): a joint
    /// velocity times it leaves the tool's twist (almost) alone.
    pub fn null_space(&self) -> &JointMatrix {
        &self.null_space
    }

    /// Largest s ∈ [0, 1] with |q̇₁ + s q̇₂| within the speed limits (times the configured
    /// fraction) wherever q̇₁ alone is: the lower-priority tasks use only the speed the
    /// end-effector task leaves, so they never slow it through the uniform velocity scaling.
    fn secondary_scale(&self, model: &RobotModel, q1: &JointVector, q2: &JointVector) -> f64 {
        let mut s: f64 = 1.0;
        for (i, l) in model.joint_limits().iter().enumerate() {
            let vmax = l.velocity * self.cfg.velocity_limit_fraction;
            let (a, b) = (q1[i], q2[i]);
            if b == 0.0 || a.abs() >= vmax {
                continue;
            }
            // |a + s b| ≤ vmax  ⇔  s ≤ (vmax − a sign(b)) / |b|.
            let room = (vmax - a * b.signum()) / b.abs();
            s = s.min(room.max(0.0));
        }
        s
    }
}

/// Which limits [`saturate`] had to enforce.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Saturation {
    /// Some joint exceeded its speed limit: the whole q̇ was scaled down (direction kept).
    pub velocity: bool,
    /// Some joint would have crossed a position limit within `dt`: that joint was clamped.
    pub position: bool,
}

/// Saturates `qdot` (rad/s) in place so that |q̇ᵢ| ≤ fraction · limitᵢ.velocity and
/// q + q̇ dt stays within [lower + margin, upper − margin] (a joint already outside is only
/// allowed to move back in, at most at its speed limit).
///
/// Velocity first scales the whole vector (keeps the Cartesian direction, as a uniform time
/// scaling does); the position clamp then acts per joint.
pub fn saturate(
    limits: &[JointLimit; DOF],
    q: &JointVector,
    qdot: &mut JointVector,
    dt: f64,
    fraction: f64,
    margin: f64,
) -> Saturation {
    let mut sat = Saturation::default();
    let mut scale: f64 = 1.0;
    for i in 0..DOF {
        let vmax = limits[i].velocity * fraction;
        if qdot[i].abs() > vmax {
            scale = scale.min(vmax / qdot[i].abs());
        }
    }
    if scale < 1.0 {
        *qdot *= scale;
        sat.velocity = true;
    }
    for i in 0..DOF {
        let l = &limits[i];
        let vmax = l.velocity * fraction;
        let lo = ((l.lower + margin - q[i]) / dt).min(0.0).max(-vmax);
        let hi = ((l.upper - margin - q[i]) / dt).max(0.0).min(vmax);
        // Outside the range: only motion back in is allowed.
        let (lo, hi) = if q[i] < l.lower + margin {
            (0.0, ((l.lower + margin - q[i]) / dt).min(vmax))
        } else if q[i] > l.upper - margin {
            ((((l.upper - margin) - q[i]) / dt).max(-vmax), 0.0)
        } else {
            (lo, hi)
        };
        let c = qdot[i].clamp(lo, hi);
        if c != qdot[i] {
            qdot[i] = c;
            sat.position = true;
        }
    }
    sat
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> [JointLimit; DOF] {
        [JointLimit {
            lower: -1.0,
            upper: 1.0,
            velocity: 2.0,
        }; DOF]
    }

    #[test]
    fn velocity_scaling_keeps_direction() {
        let mut qd = JointVector::from_element(1.0);
        qd[2] = 4.0;
        let before = qd;
        let s = saturate(&limits(), &JointVector::zeros(), &mut qd, 0.001, 1.0, 0.0);
        assert!(s.velocity && !s.position);
        assert!((qd[2] - 2.0).abs() < 1e-12);
        assert!((qd.normalize() - before.normalize()).norm() < 1e-12);
    }

    #[test]
    fn position_limit_is_never_crossed() {
        let mut q = JointVector::from_element(0.9995);
        let mut qd = JointVector::from_element(1.5);
        let s = saturate(&limits(), &q, &mut qd, 0.001, 1.0, 0.0);
        assert!(s.position);
        q += qd * 0.001;
        assert!(q.iter().all(|&x| x <= 1.0 + 1e-15));
        // Already outside: may only come back.
        let q = JointVector::from_element(1.2);
        let mut qd = JointVector::from_element(1.0);
        saturate(&limits(), &q, &mut qd, 0.001, 1.0, 0.0);
        assert!(qd.iter().all(|&x| x == 0.0));
        let mut qd = JointVector::from_element(-3.0);
        saturate(&limits(), &q, &mut qd, 0.001, 1.0, 0.0);
        assert!(qd.iter().all(|&x| (x + 2.0).abs() < 1e-12));
    }

    #[test]
    fn orientation_error_is_the_rotation_vector() {
        let a = UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3);
        let d = UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 0.0, 0.4)) * a;
        let e = orientation_error(&a, &d);
        assert!((e - Vector3::new(0.0, 0.0, 0.4)).norm() < 1e-12);
    }
}
