//! A move in joint space (`Primitive::Joints`): the arm a turned pour left wound up (joint 7 on
//! its limit, coffee-closed-bottle seed 2) goes back to the ready pose, no joint faster than the
//! move allows, the tool within the allowed speed, held while the person says stop, and kept
//! off an obstacle by the link damper.

mod common;

use cowork_ds::{ControlOutput, ControllerConfig, DsController, HumanState, JointMove, Primitive, Status};
use cowork_robot::JointVector;
use nalgebra::{Point3, Vector3};

fn deg(d: [f64; 7]) -> JointVector {
    JointVector::from_iterator(d.iter().map(|v| v.to_radians()))
}

/// Where seed 2's approach to the water bottle stood for 120 s.
fn wound_up() -> JointVector {
    deg([75.6, 87.4, -111.8, 83.0, -90.0, -111.9, 170.0])
}

/// The kitchen's ready pose (config/scenes/kitchen.yaml).
fn ready() -> [f64; 7] {
    let q = deg([0.0, 30.0, 0.0, 90.0, 0.0, 60.0, 0.0]);
    [q[0], q[1], q[2], q[3], q[4], q[5], q[6]]
}

struct Run {
    converged_at: Option<f64>,
    /// Smallest link–sphere distance along the run, m (∞ without a sphere).
    closest: f64,
    fastest_joint: f64,
    fastest_tool: f64,
    q: JointVector,
}

/// Runs the move from `q0` for `seconds` (1 kHz, q += q̇ dt) with the human state `human` and,
/// with a sphere (centre, radius), its distance to every link measured and, with `feed`, given
/// to the controller.
fn run(q0: JointVector, seconds: f64, human: impl Fn(f64) -> HumanState, sphere: Option<(Point3<f64>, f64)>, feed: bool) -> Run {
    let model = common::lwr();
    let points = common::link_points(&model, 4);
    let mut ctl = DsController::new(model.clone(), ControllerConfig::default()).expect("config");
    let dt = ctl.config().period_s;
    let m = JointMove { joints: ready(), gain: 2.0, max_speed: 0.6 };
    let goal = common::tip_position(&model, &JointVector::from_row_slice(&m.joints));
    let cmd = common::command(Primitive::Joints(m), goal);
    let mut out = ControlOutput::default();
    let mut poses = cowork_robot::LinkPoses::new();
    let mut q = q0;
    let mut r = Run { converged_at: None, closest: f64::INFINITY, fastest_joint: 0.0, fastest_tool: 0.0, q };
    let steps = (seconds / dt) as usize;
    for k in 0..steps {
        let t = k as f64 * dt;
        let mut input = common::input(q, cmd, t);
        input.human.state = human(t);
        if let Some((c, radius)) = sphere {
            model.forward_kinematics(&q, &mut poses);
            r.closest = r.closest.min(common::min_sphere_distance(&poses, &points, &c, radius));
            if feed {
                input.distances = common::sphere_distances(&poses, &points, &c, radius, &Vector3::zeros(), t);
            }
        }
        let before = common::tip_position(&model, &q);
        ctl.step(&input, &mut out).expect("valid input");
        q += out.qdot * dt;
        r.fastest_joint = r.fastest_joint.max(out.qdot.amax());
        r.fastest_tool = r.fastest_tool.max((common::tip_position(&model, &q) - before).norm() / dt);
        if out.status == Status::Converged && r.converged_at.is_none() {
            r.converged_at = Some(t);
        }
    }
    r.q = q;
    r
}

#[test]
fn a_wound_up_arm_goes_back_to_the_ready_pose_in_joint_space() {
    let r = run(wound_up(), 30.0, |_| HumanState::default(), None, false);
    let goal = JointVector::from_row_slice(&ready());
    let left = (r.q - goal).amax();
    let at = r.converged_at.expect("converged");
    eprintln!(
        "unwound in {at:.2} s, {:.4} rad left, fastest joint {:.3} rad/s, fastest tool {:.3} m/s",
        left, r.fastest_joint, r.fastest_tool
    );
    assert!(left <= JointMove::TOLERANCE_RAD, "{left} rad from the ready pose");
    // Joint 7 turns 170°: at most 0.6 rad/s, at least ~5 s.
    assert!(at > 4.5, "converged at {at} s");
    assert!(r.fastest_joint <= 0.6 + 1e-9, "{}", r.fastest_joint);
    // The robot's own motion keeps the far speed at the tool (0.3 m/s by default), within a step.
    let far = ControllerConfig::default().scaling.far_speed;
    assert!(r.fastest_tool <= far * 1.05, "tool at {} m/s (far speed {far})", r.fastest_tool);
}

#[test]
fn a_joint_move_is_held_while_the_person_says_stop() {
    let stopped = HumanState { stopped: true, ..HumanState::default() };
    let r = run(wound_up(), 3.0, |_| stopped, None, false);
    assert!((r.q - wound_up()).amax() < 1e-3, "moved {} rad while stopped", (r.q - wound_up()).amax());
}

#[test]
fn the_link_damper_keeps_a_joint_move_off_an_obstacle() {
    let model = common::lwr();
    // A ball where the wrist passes half-way back.
    let half = wound_up() + (JointVector::from_row_slice(&ready()) - wound_up()) * 0.5;
    let centre = Point3::from(model.link_pose(&half, 5).translation.vector);
    let ball = Some((centre, 0.05));
    let free = run(wound_up(), 30.0, |_| HumanState::default(), ball, false);
    let damped = run(wound_up(), 30.0, |_| HumanState::default(), ball, true);
    eprintln!(
        "closest to the ball: {:.3} m blind (converged {:?}), {:.3} m with its distances (converged {:?})",
        free.closest, free.converged_at, damped.closest, damped.converged_at
    );
    assert!(free.closest < 0.0, "the case must run through the ball: {}", free.closest);
    assert!(damped.closest > 0.0, "the damper let a link into the ball: {}", damped.closest);
}
