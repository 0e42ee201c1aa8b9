//! The dual-arm pizza setup shared by the two-arm tests: the arm bases and object positions of
//! `config/scenes/pizza.yaml`, poses in each arm's base frame, `/tf_static`, and the pizza LTM
//! taught with the library's event scripts.
#![allow(dead_code)]

use std::f64::consts::FRAC_PI_2;
use std::path::PathBuf;

use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Transform, TransformStamped, Vector3};
use cowork_msgs::msg::{ObjectState, ObjectStream};
use cowork_msgs::std_msgs::Header;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_supervisor::{Ltm, RunConfig, Supervisor, SupervisorConfig, parse_jsonl, runner};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// An arm base in the world frame.
#[derive(Debug, Clone, Copy)]
pub struct Base {
    pub arm: &'static str,
    /// m, world.
    pub position: [f64; 3],
    /// roll, pitch, yaw (rad), fixed axes x, y, z (URDF / the scene's `rpy`).
    pub rpy: [f64; 3],
}

// The bases of config/scenes/pizza.yaml (`arms:`), written out (two_arms.rs checks them
// against the file).
pub const LEFT: Base = Base { arm: "left", position: [-0.15, 0.12, 0.55], rpy: [-FRAC_PI_2, 0.0, 0.0] };
pub const RIGHT: Base = Base { arm: "right", position: [-0.15, -0.12, 0.55], rpy: [FRAC_PI_2, 0.0, 0.0] };
pub const BASES: [Base; 2] = [LEFT, RIGHT];

/// The objects of config/scenes/pizza.yaml (`objects:`, world positions, m), written out as the
/// bases (two_arms.rs checks them against the file): the pizza in the middle of the table,
/// tomato and oil at y = +0.50 (left), cheese and basil at y = -0.50 (right).
pub const OBJECTS: [(&str, [f64; 3]); 5] = [
    ("pizza", [0.45, 0.0, 0.01]),
    ("tomato", [0.30, 0.50, 0.08]),
    ("oil", [0.50, 0.50, 0.08]),
    ("cheese", [0.30, -0.50, 0.08]),
    ("basil", [0.50, -0.50, 0.08]),
];

/// R = Rz(yaw) Ry(pitch) Rx(roll), row-major: written out here, apart from the node's
/// quaternion arithmetic, so the two check each other.
pub fn rotation(rpy: [f64; 3]) -> [[f64; 3]; 3] {
    let (sr, cr) = rpy[0].sin_cos();
    let (sp, cp) = rpy[1].sin_cos();
    let (sy, cy) = rpy[2].sin_cos();
    [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]
}

/// The same rotation as a unit quaternion (what lwr_sim puts on `/tf_static`).
pub fn quaternion(rpy: [f64; 3]) -> Quaternion {
    let (sr, cr) = (rpy[0] / 2.0).sin_cos();
    let (sp, cp) = (rpy[1] / 2.0).sin_cos();
    let (sy, cy) = (rpy[2] / 2.0).sin_cos();
    Quaternion::new(sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)
}

/// A world point in `base`'s frame: Rᵀ (p − t).
pub fn in_base(base: &Base, world: [f64; 3]) -> Point {
    let r = rotation(base.rpy);
    let d = [world[0] - base.position[0], world[1] - base.position[1], world[2] - base.position[2]];
    let c = |j: usize| r[0][j] * d[0] + r[1][j] * d[1] + r[2][j] * d[2];
    Point::new(c(0), c(1), c(2))
}

/// `world -> <arm>/lwr_base_link` for `bases`, and the camera (which the node must skip), as
/// lwr_sim publishes them.
pub fn tf_static(bases: &[Base]) -> TFMessage {
    let t = |parent: &str, child: String, position: [f64; 3], rotation: Quaternion| TransformStamped {
        header: Header { frame_id: parent.into(), ..Default::default() },
        child_frame_id: child,
        transform: Transform { translation: Vector3::new(position[0], position[1], position[2]), rotation },
    };
    let mut transforms = vec![t("world", "camera_depth_optical_frame".into(), [1.7, 0.0, 1.0], quaternion([0.3, 0.2, 0.1]))];
    transforms.extend(bases.iter().map(|b| t("world", format!("{}/lwr_base_link", b.arm), b.position, quaternion(b.rpy))));
    TFMessage { transforms }
}

/// Distance from `base` to a world point (m): the stimulus the fake robot managers report.
pub fn reach(base: &Base, world: [f64; 3]) -> f64 {
    (0..3).map(|k| (world[k] - base.position[k]).powi(2)).sum::<f64>().sqrt()
}

/// `base`'s `/<arm>/object_stream` of `objects` (world positions), every one visible.
pub fn object_stream(base: &Base, objects: &[(&str, [f64; 3])]) -> ObjectStream {
    ObjectStream {
        header: Header { frame_id: format!("{}/lwr_base_link", base.arm), ..Default::default() },
        objects: objects
            .iter()
            .map(|(name, p)| ObjectState {
                name: (*name).into(),
                pose: Pose { position: in_base(base, *p), orientation: Quaternion::IDENTITY },
                robot_distance: reach(base, *p),
                visible: true,
            })
            .collect(),
    }
}

pub fn pizza_ltm() -> Ltm {
    Ltm::load(&root().join("config/tasks/pizza.schema")).expect("pizza LTM")
}

/// The pizza LTM taught arm by arm with the library's scripts (as its dual-arm scenario test).
pub fn taught_pizza() -> Ltm {
    let mut ltm = pizza_ltm();
    for script in ["pizza_teach_left.jsonl", "pizza_teach_right.jsonl"] {
        let text = std::fs::read_to_string(root().join("nodes/lib/supervisor/tests/data").join(script)).expect("script");
        let mut teacher = Supervisor::new(ltm, "pizza", SupervisorConfig::default()).expect("task");
        runner::run(&mut teacher, &parse_jsonl(&text).expect("script"), &RunConfig::default(), |_, _, _, _| {});
        ltm = teacher.ltm().clone();
    }
    ltm
}
