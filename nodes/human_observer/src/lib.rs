//! The `human_observer` node: a thin ROS 2 adapter around [`cowork_observer`] (thesis Fig. 5.1,
//! Sec. 5.1.3).
//!
//! Inputs: `/human/skeleton` (cowork_msgs/Skeleton, Xsens 120 Hz or depth tracker 30 Hz, any
//! number of `person_id`s up to `observer.max_people`), `/joint_states` (sensor_msgs/JointState,
//! by joint name: the robot's link geometry for the distance), `/speech_command`
//! (std_msgs/String: `stop` holds the robot, `repeat` releases it), `/clock` with
//! `use_sim_time`.
//!
//! Outputs: `/human/state` (cowork_msgs/HumanState) with every skeleton frame and at least at
//! `state_rate_hz` (`present: false` when nobody is tracked; a person silent for longer than
//! `observer.person_timeout_s` is dropped); `/human/gesture` (cowork_msgs/Gesture) per
//! recognised gesture; `/human/markers` (visualization_msgs/MarkerArray): capsule bodies,
//! filtered hands with velocity arrows, the last gesture as text.
//!
//! A message that cannot be used is skipped with a warning naming the topic and the field
//! (rate-limited per kind); the state then fails closed (interaction speed, never faster) until
//! the person's data is usable again or the person is dropped. The node keeps running.
//!
//! [`ObserverNode`] does no I/O, so tests drive it message by message; [`run`] wires it to DDS.

mod node;
mod params;
mod run;

pub use cowork_ros::{RunOptions, Warnings};
pub use node::{NS_BODY, NS_GESTURE, NS_HAND, NS_HAND_VELOCITY, ObserverNode, SkeletonOutput, Warning};
pub use params::Params;
pub use run::{Input, Output, RunSummary, run, run_loop};

