//! Inputs shared by the node's tests.
#![allow(dead_code)] // each test binary uses its own subset

use std::path::PathBuf;

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Header;
use cowork_people::{MessageMeta, Performer};

/// The arm's pose in every test (rad).
pub const READY: [f64; 7] = [0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0];

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `/joint_states` at `t` (s) with the arm at [`READY`].
pub fn joint_state(t: f64) -> JointState {
    JointState {
        header: Header { stamp: Time::from_secs_f64(t), frame_id: String::new() },
        name: (1..=7).map(|i| format!("lwr_joint_{i}")).collect(),
        position: READY.to_vec(),
        ..Default::default()
    }
}

/// `/human/skeleton` of performer `p` at `t` (s), as a depth tracker sends it.
pub fn skeleton(p: &Performer, t: f64) -> Skeleton {
    p.pose(t).to_message(&MessageMeta {
        stamp: Time::from_secs_f64(t),
        frame_id: "lwr_base_link",
        source: Skeleton::SOURCE_DEPTH_TRACKER,
        person_id: p.person_id(),
        with_velocities: true,
    })
}
