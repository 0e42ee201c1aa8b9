//! Joint limits in the IK: a joint on its limit leaves the end-effector task, and joints near
//! their limits are pushed back in the null space.
//! With the plain eq. 5.13 IK and per-joint clamping, a joint that reaches its limit leaves the
//! end-effector task short and the arm stalls off its goal (coffee seed 6's pour: joints 2, 3
//! and 6 on their limits, 5.7 cm off for 120 s).

mod common;

use cowork_robot::JointVector;

#[test]
fn a_joint_on_its_limit_leaves_the_task_and_the_others_make_up_for_it() {
    use cowork_ds::ik::{Ik, IkConfig, IkReport, Twist};
    use cowork_robot::{Jacobian, LinkPoses};
    use nalgebra::Point3;
    let model = common::lwr();
    let limits = *model.joint_limits();
    // The pour start of coffee seed 6 with joint 2 moved onto its upper limit.
    let mut q = JointVector::from_row_slice(&[43.81f64, 86.51, -86.75, 63.98, 32.61, 91.67, -20.17].map(f64::to_radians));
    q[1] = limits[1].upper;
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let mut jac = Jacobian::zeros();
    model.jacobian(&poses, model.tip_link(), &Point3::origin(), &mut jac);
    // A twist that the plain solution makes with joint 2 pushing further out.
    let twist = Twist::from_row_slice(&[0.0, 0.0, -0.1, 0.0, -0.4, 0.0]);
    let dt = 1e-3;
    let mut report = IkReport::default();
    let solve = |cfg: IkConfig, report: &mut IkReport| {
        Ik::new(cfg).solve_with_posture(&model, &poses, model.tip_link(), &twist, None, &JointVector::zeros(), Some((&q, dt)), report)
    };
    let plain = solve(IkConfig::default(), &mut report);
    assert!(plain[1] > 0.0, "the case must drive joint 2 out: {plain}");
    assert_eq!(report.released_joints, 0);
    // What the plain IK leaves after the clamp (saturate zeroes the outward part).
    let mut clamped = plain;
    clamped[1] = 0.0;
    let released = solve(IkConfig { release_limited_joints: true, ..IkConfig::default() }, &mut report);
    assert_eq!(report.released_joints, 1);
    assert_eq!(released[1], 0.0, "the released joint gets no task velocity");
    let miss = |qd: &JointVector| (jac * qd - twist).norm();
    eprintln!("twist error with joint 2 clamped: plain {:.4}, released {:.4}", miss(&clamped), miss(&released));
    assert!(miss(&released) < 0.2 * miss(&clamped), "{} vs {}", miss(&released), miss(&clamped));
}

#[test]
fn limit_avoidance_pushes_only_inside_the_zone() {
    let model = common::lwr();
    let limits = *model.joint_limits();
    let cfg = cowork_ds::ik::IkConfig { limit_zone: 0.3, limit_gain: 2.0, ..Default::default() };
    let mut q = JointVector::zeros();
    assert_eq!(cowork_ds::ik::limit_avoidance(&cfg, &limits, &q), JointVector::zeros());
    q[1] = limits[1].upper - 0.1;
    q[2] = limits[2].lower + 0.05;
    let v = cowork_ds::ik::limit_avoidance(&cfg, &limits, &q);
    assert!((v[1] + 2.0 * 0.2).abs() < 1e-12, "{v}");
    assert!((v[2] - 2.0 * 0.25).abs() < 1e-12, "{v}");
    assert_eq!(v[0], 0.0);
    // Joint 6 kept off its wrist singularity at 0.
    let wrist = cowork_ds::ik::IkConfig { keep_off_zero: [false, false, false, false, false, true, false], ..cfg };
    q[5] = -0.1;
    let v = cowork_ds::ik::limit_avoidance(&wrist, &limits, &q);
    assert!((v[5] + 2.0 * 0.2).abs() < 1e-12, "{v}");
    q[5] = 0.5;
    assert_eq!(cowork_ds::ik::limit_avoidance(&wrist, &limits, &q)[5], 0.0);
    let off = cowork_ds::ik::IkConfig::default();
    assert_eq!(cowork_ds::ik::limit_avoidance(&off, &limits, &q), JointVector::zeros());
}
