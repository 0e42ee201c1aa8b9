//! Per-link trace of a recorded trial: at every skeleton frame, each robot link's **true**
//! distance to the person (link hull against the body capsules, as the judge measures it)
//! beside what the distance node **reported** for that link (the newest `/fded/distances`
//! stamped at or before the frame: distance, robot and obstacle points, obstacle velocity,
//! age), and what the controller did (commanded joint speed, `/motion/status`). This is the
//! evidence for "why did link L hit the hand": a distance that was wrong, late, or right and
//! not acted on.

use std::path::Path;

use cowork_bag::BagReader;
use cowork_msgs::msg::{LinkDistances, MotionStatus, Skeleton};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Float64MultiArray;
use cowork_people::{SkeletonPose, body_capsules};
use cowork_robot::{DOF, JointVector, LinkPoses, RobotModel};
use cowork_scenario::distance::LinkGeometry;
use cowork_scenario::obstacle::Obstacle;
use nalgebra::Vector3;

use crate::error::Result;

/// What the distance node reported for one link.
#[derive(Debug, Clone, PartialEq)]
pub struct Reported {
    /// Stamp of the depth frame it came from (s).
    pub stamp: f64,
    /// Distance (m).
    pub distance: f64,
    /// Closest robot point (m, base frame).
    pub robot_point: [f64; 3],
    /// Closest obstacle point (m, base frame).
    pub obstacle_point: [f64; 3],
    /// Obstacle velocity (m/s).
    pub obstacle_velocity: [f64; 3],
}

/// One link at one skeleton frame.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkSample {
    /// Simulated time (s).
    pub t: f64,
    /// Link name.
    pub link: String,
    /// True link–person distance (m; negative: penetration depth).
    pub true_m: f64,
    /// Closest point of the link (true geometry, m, base frame).
    pub true_robot_point: [f64; 3],
    /// Closest point of the person (m, base frame).
    pub true_person_point: [f64; 3],
    /// The newest report for this link at `t`, if any (and valid).
    pub reported: Option<Reported>,
    /// Norm of the newest commanded joint velocity (rad/s).
    pub commanded_qdot: f64,
    /// Newest `/motion/status`: `id state reason`.
    pub status: String,
}

impl LinkSample {
    /// CSV header of [`csv_row`](Self::csv_row).
    pub const CSV_HEADER: &'static str = "t,link,true_m,fded_m,fded_age_s,true_robot_x,true_robot_y,true_robot_z,true_person_x,true_person_y,true_person_z,fded_robot_x,fded_robot_y,fded_robot_z,fded_obstacle_x,fded_obstacle_y,fded_obstacle_z,fded_vel_x,fded_vel_y,fded_vel_z,commanded_qdot,status";

    /// One CSV line (empty fields where nothing was reported).
    pub fn csv_row(&self) -> String {
        let f = |v: &[f64; 3]| format!("{:.4},{:.4},{:.4}", v[0], v[1], v[2]);
        let (fded, age, rp, op, vel) = match &self.reported {
            Some(r) => (
                format!("{:.4}", r.distance),
                format!("{:.4}", self.t - r.stamp),
                f(&r.robot_point),
                f(&r.obstacle_point),
                f(&r.obstacle_velocity),
            ),
            None => (String::new(), String::new(), ",,".into(), ",,".into(), ",,".into()),
        };
        format!(
            "{:.4},{},{:.4},{fded},{age},{},{},{rp},{op},{vel},{:.3},\"{}\"",
            self.t,
            self.link,
            self.true_m,
            f(&self.true_robot_point),
            f(&self.true_person_point),
            self.commanded_qdot,
            self.status.replace('"', "'")
        )
    }
}

/// The per-link trace of the bag at `path` for `model`, people standing on `floor_z`; only
/// samples whose true distance is below `below_m` (m) are kept.
pub fn link_trace(path: &Path, model: &RobotModel, floor_z: f64, below_m: f64) -> Result<Vec<LinkSample>> {
    let geometry = LinkGeometry::new(model, 6.0)?;
    let reader = BagReader::open_recoverable(path)?;
    let mut poses = LinkPoses::new();
    let mut q: Option<JointVector> = None;
    let mut index: Vec<Option<usize>> = Vec::new();
    let mut reported: Vec<Option<Reported>> = vec![None; model.link_count()];
    let mut commanded = 0.0;
    let mut status = String::new();
    let mut out = Vec::new();
    for m in reader.messages() {
        let Ok(m) = m else { continue };
        match &*m.topic {
            "/joint_states" => {
                let Ok(js) = m.decode::<JointState>() else { continue };
                if index.len() != js.name.len() {
                    index = js.name.iter().map(|n| model.joint_index(n)).collect();
                }
                let mut v = JointVector::zeros();
                let mut seen = 0;
                for (k, i) in index.iter().enumerate() {
                    if let (Some(i), Some(p)) = (i, js.position.get(k)) {
                        v[*i] = *p;
                        seen += 1;
                    }
                }
                if seen == DOF && v.iter().all(|x| x.is_finite()) {
                    q = Some(v);
                }
            }
            "/fded/distances" => {
                let Ok(d) = m.decode::<LinkDistances>() else { continue };
                let stamp = d.header.stamp.to_secs_f64();
                for (pos, l) in d.links.iter().enumerate() {
                    let i = if l.link_name.is_empty() {
                        Some(pos)
                    } else {
                        model.link_names().iter().position(|n| *n == l.link_name)
                    };
                    let Some(i) = i.filter(|i| *i < reported.len()) else { continue };
                    reported[i] = (l.valid && l.distance.is_finite()).then(|| Reported {
                        stamp,
                        distance: l.distance,
                        robot_point: [l.robot_point.x, l.robot_point.y, l.robot_point.z],
                        obstacle_point: [l.obstacle_point.x, l.obstacle_point.y, l.obstacle_point.z],
                        obstacle_velocity: [l.obstacle_velocity.x, l.obstacle_velocity.y, l.obstacle_velocity.z],
                    });
                }
            }
            "/lwr/joint_velocity_command" => {
                if let Ok(c) = m.decode::<Float64MultiArray>() {
                    commanded = c.data.iter().map(|v| v * v).sum::<f64>().sqrt();
                }
            }
            "/motion/status" => {
                if let Ok(s) = m.decode::<MotionStatus>() {
                    status = format!("{} {} {}", s.command_id, s.state, s.reason);
                }
            }
            "/human/skeleton" => {
                let Ok(sk) = m.decode::<Skeleton>() else { continue };
                let Some(qv) = q else { continue };
                let Ok(pose) = SkeletonPose::from_message_measured(&sk, floor_z) else { continue };
                let t = sk.header.stamp.to_secs_f64();
                let caps: Vec<Obstacle> = body_capsules(&pose)
                    .iter()
                    .map(|c| Obstacle::capsule("body", c.a, c.b, c.radius, Vector3::zeros(), Vector3::zeros()))
                    .collect();
                model.forward_kinematics(&qv, &mut poses);
                let (d, _) = geometry.distances(&poses, &caps, t);
                for l in 0..d.count.min(model.link_count()) {
                    let e = &d.links[l];
                    if !e.valid || e.distance >= below_m {
                        continue;
                    }
                    out.push(LinkSample {
                        t,
                        link: model.link_names()[l].clone(),
                        true_m: e.distance,
                        true_robot_point: [e.robot_point.x, e.robot_point.y, e.robot_point.z],
                        true_person_point: [e.obstacle_point.x, e.obstacle_point.y, e.obstacle_point.z],
                        reported: reported[l].clone(),
                        commanded_qdot: commanded,
                        status: status.clone(),
                    });
                }
            }
            _ => {}
        }
    }
    Ok(out)
}
