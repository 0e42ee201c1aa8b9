//! Null-space link avoidance (eq. 5.13): a sphere placed on the path that the elbow sweeps in
//! an obstacle-free run. Without link avoidance the arm hits it; with it (same end-effector
//! task, orientation held, 1 redundant DoF as in Sec. 5.1.3) the arm passes and the goal is
//! reached.

mod common;

use cowork_ds::{ControlOutput, ControllerConfig, DsController, Status};
use cowork_robot::{JointVector, LinkPoses};
use nalgebra::{Point3, Vector3};

struct Run {
    min_distance: f64,
    reached: bool,
    link_task_steps: usize,
    elbow_path: Vec<Vector3<f64>>,
}

fn run(links: bool, sphere: Option<(Point3<f64>, f64)>) -> Run {
    let model = common::lwr();
    let points = common::link_points(&model, 1);
    let q0 = JointVector::from_row_slice(&[0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0]);
    let x0 = common::tip_position(&model, &q0);
    let goal = x0 + Vector3::new(0.0, 0.35, 0.0);
    let mut cfg = ControllerConfig::default();
    cfg.modulation.links = links;
    // Eq. 5.13 on its own: the link-distance damper above it is tested in tests/safety.rs.
    cfg.safety.enabled = false;
    // The sphere is for the links; keep the end-effector DS unmodulated so both runs command
    // the same hand motion.
    cfg.modulation.end_effector = false;
    let mut ctl = DsController::new(model.clone(), cfg).unwrap();
    let elbow = model.joint_link(3);
    let mut cmd = common::command(common::linear(2.0), goal);
    // Orientation held at the start orientation.
    cmd.orientation = Some(model.link_pose(&q0, model.tip_link()).rotation);
    let mut q = q0;
    let mut poses = LinkPoses::new();
    let mut out = ControlOutput::default();
    let mut r = Run {
        min_distance: f64::INFINITY,
        reached: false,
        link_task_steps: 0,
        elbow_path: Vec::new(),
    };
    for k in 0..4000 {
        let t = k as f64 * 1e-3;
        model.forward_kinematics(&q, &mut poses);
        r.elbow_path.push(poses.get(elbow).translation.vector);
        let mut input = common::input(q, cmd, t);
        if let Some((c, rad)) = sphere {
            r.min_distance = r
                .min_distance
                .min(common::min_sphere_distance(&poses, &points, &c, rad));
            input.distances =
                common::sphere_distances(&poses, &points, &c, rad, &Vector3::zeros(), t);
        }
        ctl.step(&input, &mut out).unwrap();
        r.link_task_steps += usize::from(out.diagnostics.avoid_link.is_some());
        r.reached |= out.status == Status::Converged;
        q += out.qdot * 1e-3;
    }
    r
}

#[test]
fn elbow_avoids_a_sphere_on_its_path() {
    let free = run(false, None);
    // Sphere centred on the elbow's free path, half way, a bit off to the outside.
    let mid = free.elbow_path[free.elbow_path.len() / 4];
    let radius = 0.06;
    let sphere = (Point3::from(mid + Vector3::new(0.0, 0.0, 0.11)), radius);
    let blind = run(false, Some(sphere));
    let avoid = run(true, Some(sphere));
    eprintln!(
        "elbow sphere: without link avoidance min {:.4} m, with {:.4} m (link task {} steps, goal reached {})",
        blind.min_distance, avoid.min_distance, avoid.link_task_steps, avoid.reached
    );
    assert!(
        blind.min_distance < 0.0,
        "the scene must collide without avoidance"
    );
    assert!(
        avoid.min_distance > 0.0,
        "link avoidance failed: {} m",
        avoid.min_distance
    );
    assert!(avoid.reached, "goal reached with link avoidance");
    assert!(avoid.link_task_steps > 0);
}

/// The posture task with a fixed reference (`ik.posture_reference`) turns the redundant elbow
/// back to it while the tool holds its pose; with the default (the command's start) the elbow
/// stays where the arm is.
#[test]
fn posture_reference_turns_the_elbow_and_the_tool_stays() {
    let model = common::lwr();
    let reference = [0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0];
    let q_ref = JointVector::from_row_slice(&reference);
    let x0 = common::tip_position(&model, &q_ref);
    let hand = model.link_pose(&q_ref, model.tip_link()).rotation;
    // Holds the tool's pose from `q` for 5 s; returns the joints and the largest tool error.
    let hold = |q: JointVector, posture_reference: Option<[Option<f64>; 7]>| {
        let mut cfg = ControllerConfig::default();
        cfg.ik.posture_gain = 2.0;
        cfg.ik.posture_reference = posture_reference;
        let mut ctl = DsController::new(model.clone(), cfg).unwrap();
        let mut cmd = common::command(common::linear(2.0), x0);
        cmd.orientation = Some(hand);
        let mut q = q;
        let mut out = ControlOutput::default();
        let mut tool_off = 0.0f64;
        for k in 0..5000 {
            ctl.step(&common::input(q, cmd, k as f64 * 1e-3), &mut out).unwrap();
            q += out.qdot * 1e-3;
            tool_off = tool_off.max((common::tip_position(&model, &q) - x0).norm());
        }
        (q, tool_off)
    };
    // The same tool pose with the elbow swivelled: pulled towards joints 3 and 7 at 1.5 rad.
    let (swivelled, _) = hold(q_ref, Some([Some(0.0), Some(0.6), Some(1.5), Some(-1.3), Some(0.0), Some(0.7), Some(1.5)]));
    let dist = |q: &JointVector| (q - q_ref).norm();
    let (kept, kept_off) = hold(swivelled, None);
    let (back, back_off) = hold(swivelled, Some(reference.map(Some)));
    // Only the swivel joints pulled (1, 3, 5, 7; 2, 4, 6 free): back as well.
    let (swivel_only, _) = hold(swivelled, Some([Some(0.0), None, Some(0.0), None, Some(0.0), None, Some(0.0)]));
    eprintln!(
        "posture: {:.3} rad from the reference after the swivel, {:.3} held without a reference, {:.3} with, {:.3} with joints 1, 3, 5, 7 only; tool off at most {:.4} / {:.4} m",
        dist(&swivelled), dist(&kept), dist(&back), dist(&swivel_only), kept_off, back_off
    );
    assert!(dist(&swivel_only) < 0.1 * dist(&swivelled), "joints 1, 3, 5, 7 did not turn the elbow back: {}", dist(&swivel_only));
    assert!(dist(&swivelled) > 0.5, "the swivel did not move the elbow: {}", dist(&swivelled));
    assert!((dist(&kept) - dist(&swivelled)).abs() < 0.02, "without a reference the elbow moved: {}", dist(&kept));
    assert!(dist(&back) < 0.1 * dist(&swivelled), "the reference did not turn the elbow back: {}", dist(&back));
    assert!(kept_off < 0.005 && back_off < 0.005, "the tool left its pose: {kept_off} / {back_off} m");
}
