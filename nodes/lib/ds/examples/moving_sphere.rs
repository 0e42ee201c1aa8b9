//! Fig. 5.5 in simulation (analytic sphere, no depth camera): the LWR holds its end effector at
//! g with ẋ = 3 (g − x) while a sphere (radius 0.1 m) starting 1 m away flies through g at
//! constant velocity [0, v, 0]. For v = 0.5, 0.6, … 4.0 m/s prints the smallest distance of the
//! hand links (and of the whole arm) to the sphere and the goal error 3 s after the pass.
//!
//! `cargo run --release -p cowork_ds --example moving_sphere`

use cowork_ds::primitive::Linear;
use cowork_ds::{
    ControlInput, ControlOutput, ControllerConfig, Distances, DsController, HumanInput, HumanState,
    LinkDistance, MotionCommand, Primitive,
};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::{Point3, Vector3};
use std::path::PathBuf;

/// Smallest distance of the hand links and of the whole arm, and the final goal error (m).
#[derive(Debug, Clone, Copy)]
pub struct Pass {
    pub hand_min: f64,
    pub arm_min: f64,
    pub final_error: f64,
}

pub fn pass(model: &RobotModel, speed: f64, radius: f64) -> Pass {
    let points: Vec<Vec<Point3<f64>>> = (0..model.link_count())
        .map(|l| {
            model
                .link_mesh(l)
                .map(|m| m.vertices.clone())
                .unwrap_or_default()
        })
        .collect();
    let mut q = JointVector::from_row_slice(&[0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0]);
    let goal = model.link_pose(&q, model.tip_link()).translation.vector;
    let v = Vector3::new(0.0, speed, 0.0);
    let start = Point3::from(goal - v.normalize() * 1.0);
    let mut ctl = DsController::new(model.clone(), ControllerConfig::default()).expect("config");
    let ee_first = ctl.end_effector_first_link();
    let dt = ctl.config().period_s;
    let mut poses = LinkPoses::new();
    let mut out = ControlOutput::default();
    let command = MotionCommand {
        id: 1,
        primitive: Primitive::Linear(Linear { gain: 3.0 }),
        goal,
        orientation: None,
        end_effector_avoidance: true,
    };
    let duration = 2.0 / speed + 3.0;
    let steps = (duration / dt) as usize;
    let mut r = Pass {
        hand_min: f64::INFINITY,
        arm_min: f64::INFINITY,
        final_error: 0.0,
    };
    for k in 0..steps {
        let t = k as f64 * dt;
        let c = start + v * t;
        model.forward_kinematics(&q, &mut poses);
        let mut d = Distances::clear(t);
        d.count = points.len();
        for (l, pts) in points.iter().enumerate() {
            let pose = poses.get(l);
            let mut best = (f64::INFINITY, Point3::origin());
            for p in pts {
                let w = pose * p;
                let dist = (w - c).norm() - radius;
                if dist < best.0 {
                    best = (dist, w);
                }
            }
            if best.0.is_finite() {
                let n = (best.1 - c).normalize();
                d.links[l] = LinkDistance {
                    valid: true,
                    distance: best.0,
                    robot_point: best.1,
                    obstacle_point: c + n * radius,
                    normal: n,
                    obstacle_velocity: v,
                };
                if l >= ee_first {
                    r.hand_min = r.hand_min.min(best.0);
                }
                r.arm_min = r.arm_min.min(best.0);
            }
        }
        let input = ControlInput {
            time: t,
            q,
            command,
            distances: d,
            human: HumanInput {
                stamp: t,
                state: HumanState::default(),
            },
        };
        ctl.step(&input, &mut out).expect("valid input");
        q += out.qdot * dt;
        r.final_error = out.diagnostics.goal_error_m;
    }
    r
}

fn main() {
    let urdf =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf).expect("LWR URDF loads");
    println!("speed_m_s  hand_min_m  arm_min_m  final_goal_error_m");
    let mut first_fail = None;
    for i in 0..=35 {
        let speed = 0.5 + 0.1 * i as f64;
        let r = pass(&model, speed, 0.1);
        println!(
            "{speed:9.1}  {:10.4}  {:9.4}  {:18.4}",
            r.hand_min, r.arm_min, r.final_error
        );
        if first_fail.is_none() && (r.hand_min <= 0.0 || r.final_error > 0.01) {
            first_fail = Some(speed);
        }
    }
    match first_fail {
        Some(s) => println!("first failing speed: {s:.1} m/s"),
        None => println!("no failure up to 4.0 m/s"),
    }
}
