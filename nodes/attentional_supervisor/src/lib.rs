//! The `attentional_supervisor` node: a thin ROS 2 adapter around
//! [`cowork_supervisor::Supervisor`] (thesis Sec. 4.3.2–4.3.4, 5.2.2–5.2.4).
//!
//! Files as every node: `params.rs` ([`Params`]), `node.rs` ([`SupervisorNode`]: turns
//! messages into library [`Event`](cowork_supervisor::Event)s and
//! [`Decision`](cowork_supervisor::Decision)s into [`Output`]s; no I/O, so tests drive it one
//! tick at a time on a mock clock), `run.rs` ([`run_loop`], generic over the
//! [`InputSource`](cowork_ros::InputSource) — DDS, or a scripted one in the golden tests — and
//! [`run`], which wires it to DDS and paces the decision loop at `tick_rate_hz` on the wall
//! clock or `/clock`).
//!
//! Inputs:
//! * `/object_stream` (cowork_msgs/ObjectStream): one `objects` event per message
//!   (name, end-effector distance in m, visibility);
//! * `/robot_stream` (cowork_msgs/RobotStream): per message, in this order, the action events
//!   (`done` → `action_done`, `failed` → `action_failed` with the reason; "started" events
//!   carry nothing new), the teaching segments
//!   (→ `segment`), then the gripper state *when it changed* (→ `gripper`): the events and
//!   segments happened before the state the message reports;
//! * `/speech_command` (std_msgs/String): `speech`.
//!
//! Not used: `RobotStream.mode` (the supervisor switches mode on `/speech_command` itself),
//! `RobotStream.ee_pose` and `ObjectState.pose` (the distance stimulus is
//! `ObjectState.robot_distance`), `ActionEvent.command_id` (events are matched by label).
//! The messages carry no arm, per-arm distance or area, so over ROS the node drives a single
//! arm; dual-arm runs go through the library's event scripts.
//!
//! Outputs: `/supervisor/action` (cowork_msgs/ActionCommand), when the decision changes —
//! a new action (`stop = false`) or an abort (`stop = true`, with the id and label of the
//! aborted command) — and again, with a warning, when no `/robot_stream` event of an action's
//! id came within `action_resend_s` (a command lost before the robot manager's reader matched;
//! at most 5 times); `/supervisor/working_memory` (cowork_msgs/WorkingMemory) at
//! `snapshot_rate_hz`. Every other decision (learned action, mode, accomplished behaviour,
//! waiting for a demonstration, warning) is logged.
//!
//! Bad input (unknown object or speech word, NaN distance, an action event for an action that is
//! not running, an unknown action kind) is logged as a warning and the loop goes on; repeated
//! warnings of one kind are logged at most once every [`WARNING_REPEAT_S`] seconds.
//!
//! ```
//! use attentional_supervisor::{Params, SupervisorNode};
//! use cowork_msgs::builtin_interfaces::Time;
//! use cowork_msgs::msg::{ObjectState, ObjectStream};
//! use cowork_supervisor::{Ltm, Supervisor};
//!
//! let ltm = Ltm::parse(
//!     "objects([water]).\n\
//!      schema(add(Obj), [(subtask(take,Obj), hand.free)], Obj.taken).\n\
//!      schema(subtask(take,Obj), [(foa1(Obj), true)], Obj.taken).\n\
//!      schema(foa1(Obj), [], foa1.done, foa).\n",
//! ).unwrap();
//! let params = Params::default();
//! let sup = Supervisor::new(ltm, "add(water)", params.attention.clone()).unwrap();
//! let mut node = SupervisorNode::new(sup, &params);
//! node.on_object_stream(&ObjectStream {
//!     objects: vec![ObjectState { name: "water".into(), robot_distance: 0.5, visible: true, ..Default::default() }],
//!     ..Default::default()
//! });
//! let mut commands = Vec::new();
//! node.tick(Time::from_secs_f64(0.01), &mut commands);
//! assert_eq!(commands[0].label, "foa1(water)");
//! assert!(!commands[0].stop);
//! ```

mod node;
mod params;
mod run;

pub use cowork_ros::RunOptions;
pub use node::{
    CommandTracker, Input, MAX_SPEECH_CHARS, MAX_WARNING_CHARS, Output, Pacer, RobotStreamDecoder, SupervisorNode,
    WARNING_REPEAT_S, action_kind, kind_code, objects_event, speech_event, warning_kind, working_memory,
};
pub use params::{MAX_TASK_DEPTH, Params};
pub use run::{RunSummary, run, run_loop};
