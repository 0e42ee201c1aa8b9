//! Shared helpers of the crate tests: the LWR model, analytic sphere distances, inputs.
#![allow(dead_code)]

use cowork_ds::primitive::{ConstantSpeed, Linear};
use cowork_ds::{
    ControlInput, Distances, HumanInput, HumanState, LinkDistance, MotionCommand, Primitive,
};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::{Point3, Vector3};
use std::path::PathBuf;

pub fn lwr() -> RobotModel {
    let urdf =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    RobotModel::from_urdf_file(urdf).expect("LWR URDF loads")
}

/// A comfortable start configuration of the LWR (elbow bent, hand in front of the base).
pub fn q_start() -> JointVector {
    JointVector::from_row_slice(&[0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0])
}

pub fn tip_position(model: &RobotModel, q: &JointVector) -> Vector3<f64> {
    model.link_pose(q, model.tip_link()).translation.vector
}

/// Mesh vertices of every link, in the link frames, every `stride`-th one.
pub fn link_points(model: &RobotModel, stride: usize) -> Vec<Vec<Point3<f64>>> {
    (0..model.link_count())
        .map(|l| {
            model
                .link_mesh(l)
                .map(|m| m.vertices.iter().step_by(stride).copied().collect())
                .unwrap_or_default()
        })
        .collect()
}

/// Per-link closest point to a sphere (centre `c`, radius `r`, velocity `v`), from the link
/// points `points` at link `poses`: the analytic distance of each point to the sphere surface.
pub fn sphere_distances(
    poses: &LinkPoses,
    points: &[Vec<Point3<f64>>],
    c: &Point3<f64>,
    r: f64,
    v: &Vector3<f64>,
    stamp: f64,
) -> Distances {
    let mut d = Distances::clear(stamp);
    d.count = points.len();
    for (l, pts) in points.iter().enumerate() {
        let pose = poses.get(l);
        let mut best: Option<(f64, Point3<f64>)> = None;
        for p in pts {
            let w = pose * p;
            let dist = (w - c).norm() - r;
            if best.is_none_or(|(b, _)| dist < b) {
                best = Some((dist, w));
            }
        }
        if let Some((dist, p)) = best {
            let n = (p - c).normalize();
            d.links[l] = LinkDistance {
                valid: true,
                distance: dist,
                robot_point: p,
                obstacle_point: c + n * r,
                normal: n,
                obstacle_velocity: *v,
            };
        }
    }
    d
}

/// Smallest distance of any link point to the sphere surface (m).
pub fn min_sphere_distance(
    poses: &LinkPoses,
    points: &[Vec<Point3<f64>>],
    c: &Point3<f64>,
    r: f64,
) -> f64 {
    let mut m = f64::INFINITY;
    for (l, pts) in points.iter().enumerate() {
        let pose = poses.get(l);
        for p in pts {
            m = m.min((pose * p - c).norm() - r);
        }
    }
    m
}

pub fn command(primitive: Primitive, goal: Vector3<f64>) -> MotionCommand {
    MotionCommand {
        id: 1,
        primitive,
        goal,
        orientation: None,
        end_effector_avoidance: true,
    }
}

pub fn linear(gain: f64) -> Primitive {
    Primitive::Linear(Linear { gain })
}

pub fn constant_speed(speed: f64) -> Primitive {
    Primitive::ConstantSpeed(ConstantSpeed::new(speed))
}

pub fn input(q: JointVector, command: MotionCommand, time: f64) -> ControlInput {
    ControlInput {
        time,
        q,
        command,
        distances: Distances::clear(time),
        human: HumanInput {
            stamp: time,
            state: HumanState::default(),
        },
    }
}
