//! Closed loop with the real LWR model: q += q̇ dt at 1 kHz reaches a Cartesian goal with a
//! sphere in the straight path, never penetrating it (analytic distance of the link mesh
//! vertices to the sphere), within the joint limits.
// Joint loops index q, q̇ and the limits together.
#![allow(clippy::needless_range_loop)]

mod common;

use cowork_ds::{ControlOutput, ControllerConfig, DsController, Status};
use cowork_robot::LinkPoses;
use nalgebra::{Point3, Vector3};

struct Outcome {
    reached_at: Option<f64>,
    min_distance: f64,
    final_error: f64,
    max_speed_ratio: f64,
    escape_steps: usize,
}

fn run(
    primitive: cowork_ds::Primitive,
    radius: f64,
    offset: Vector3<f64>,
    steps: usize,
) -> Outcome {
    let model = common::lwr();
    let points = common::link_points(&model, 1);
    let mut q = common::q_start();
    let x0 = common::tip_position(&model, &q);
    let goal = x0 + Vector3::new(0.0, 0.45, 0.0);
    // Sphere centred just off the straight path, half way.
    let centre = Point3::from((x0 + goal) / 2.0 + offset);
    let limits = *model.joint_limits();
    let mut ctl = DsController::new(model.clone(), ControllerConfig::default()).expect("config");
    let dt = ctl.config().period_s;
    let mut poses = LinkPoses::new();
    let mut out = ControlOutput::default();
    let cmd = common::command(primitive, goal);
    let mut o = Outcome {
        reached_at: None,
        min_distance: f64::INFINITY,
        final_error: f64::NAN,
        max_speed_ratio: 0.0,
        escape_steps: 0,
    };
    for k in 0..steps {
        let t = k as f64 * dt;
        model.forward_kinematics(&q, &mut poses);
        o.min_distance = o.min_distance.min(common::min_sphere_distance(
            &poses, &points, &centre, radius,
        ));
        let mut input = common::input(q, cmd, t);
        input.distances =
            common::sphere_distances(&poses, &points, &centre, radius, &Vector3::zeros(), t);
        ctl.step(&input, &mut out).expect("valid input");
        for i in 0..7 {
            o.max_speed_ratio = o
                .max_speed_ratio
                .max(out.qdot[i].abs() / limits[i].velocity);
        }
        q += out.qdot * dt;
        for i in 0..7 {
            assert!(
                limits[i].contains(q[i]),
                "joint {i} left its limits: {}",
                q[i]
            );
        }
        o.final_error = out.diagnostics.goal_error_m;
        o.escape_steps += usize::from(out.diagnostics.escaping);
        if out.status == Status::Converged && o.reached_at.is_none() {
            o.reached_at = Some(t);
        }
        if o.reached_at.is_some_and(|r| t > r + 0.5) {
            break;
        }
    }
    o
}

#[test]
fn reaches_goal_around_a_sphere_without_penetration() {
    let o = run(
        common::constant_speed(0.3),
        0.08,
        Vector3::new(0.0, 0.0, 0.03),
        10_000,
    );
    eprintln!(
        "constant speed: reached at {:?} s, min distance {:.4} m, final error {:.4} m, max |q̇|/limit {:.3}, escape steps {}",
        o.reached_at, o.min_distance, o.final_error, o.max_speed_ratio, o.escape_steps
    );
    assert!(
        o.reached_at.is_some(),
        "goal not reached, error {} m",
        o.final_error
    );
    assert!(o.final_error < 0.005);
    assert!(
        o.min_distance > 0.0,
        "penetrated the sphere: {} m",
        o.min_distance
    );
    assert!(o.max_speed_ratio <= 1.0 + 1e-9);
}

#[test]
fn linear_ds_with_a_sphere_on_the_path_arrives() {
    // Sphere exactly on the path. Convergence is slow near the goal: M still slows the motion
    // along the normal there (λ₁ ≈ 0.2 at 0.2 m), as eq. 5.6 prescribes at any distance.
    let o = run(common::linear(2.0), 0.06, Vector3::zeros(), 30_000);
    eprintln!(
        "linear head-on: reached at {:?} s, min distance {:.4} m, final error {:.4} m, max |q̇|/limit {:.3}, escape steps {}",
        o.reached_at, o.min_distance, o.final_error, o.max_speed_ratio, o.escape_steps
    );
    assert!(
        o.reached_at.is_some(),
        "goal not reached, error {} m",
        o.final_error
    );
    assert!(
        o.min_distance > 0.0,
        "penetrated the sphere: {} m",
        o.min_distance
    );
}
