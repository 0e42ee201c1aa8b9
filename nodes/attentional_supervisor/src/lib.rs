//! The `attentional_supervisor` node: a thin ROS 2 adapter around
//! [`cowork_supervisor::Supervisor`] (thesis Sec. 4.3.2–4.3.4, 5.2.2–5.2.4).
//!
//! Files as every node: `params.rs` ([`Params`]), `node.rs` ([`SupervisorNode`]: turns
//! messages into library [`Event`](cowork_supervisor::Event)s and
//! [`Decision`](cowork_supervisor::Decision)s into [`Output`]s; no I/O, so tests drive it one
//! tick at a time on a mock clock), `areas.rs` ([`Areas`]: the dual-arm object merge and
//! areas) with `bases.rs` ([`ArmBases`], the arm bases from `/tf_static`), `run.rs` ([`run_loop`], generic over the
//! [`InputSource`](cowork_ros::InputSource) — DDS, or a scripted one in the golden tests — and
//! [`run`], which wires it to DDS and paces the decision loop at `tick_rate_hz` on the wall
//! clock or `/clock`).
//!
//! Inputs, single-arm LTM (no `arms([...])`; the topics and behaviour of a single-arm graph):
//! * `/object_stream` (cowork_msgs/ObjectStream): one `objects` event per message
//!   (name, end-effector distance in m, visibility);
//! * `/robot_stream` (cowork_msgs/RobotStream): per message, in this order, the action events
//!   (`done` → `action_done`, `failed` → `action_failed` with the reason; "started" events
//!   carry nothing new), the teaching segments
//!   (→ `segment`), then the gripper state *when it changed* (→ `gripper`): the events and
//!   segments happened before the state the message reports;
//! * `/speech_command` (std_msgs/String): `speech`.
//!
//! Inputs, dual-arm LTM (`arms([left, right])`, thesis Sec. 4.3.4, 5.2.4), one robot_manager
//! per arm in the arm's namespace:
//! * `/<arm>/robot_stream` for every declared arm (`/left/robot_stream`,
//!   `/right/robot_stream`): as `/robot_stream`, every event tagged with the arm
//!   (`action_done`, `action_failed`, `segment`, `gripper` with `arm: left`), each arm with its
//!   own last gripper state;
//! * `/<arm>/object_stream` for every declared arm: each arm's newest report merged into one
//!   `objects` event ([`Areas`]): `arm_distances` = each arm's `robot_distance` (m; no common
//!   `distance`), visible when any arm sees the object, and the object's area — the
//!   `ObjectState.pose` (that arm's base frame) taken into the world frame by the arm's base
//!   on `/tf_static` and classified by the `areas:` parameters: inside the central box
//!   (`areas.central`, world x-y, bounds included) → the central area
//!   (`attention.central_area`, one arm at a time); y above the box → `areas.left_arm`'s own
//!   area, below it → `areas.right_arm`'s; between the two but beside the box along x →
//!   central too (both arms reach it; a warning). An object seen only by arms whose base is not
//!   known yet has no area and is reported as *not seen* (the library would take an object with
//!   no area as reachable by every arm and needing no central grant): fail closed, with a
//!   rate-limited `supervisor:area_unknown` warning;
//! * `/tf_static` (tf2_msgs/TFMessage): the newest `<areas.frame> -> <arm>/<areas.base_link>`
//!   (`world -> left/lwr_base_link`) of every arm;
//! * `/speech_command`: as above. The root `/robot_stream` and `/object_stream` are not read
//!   (a scripted one is dropped with a warning).
//!
//! With `wait_for_object_stream`, a dual-arm node decides nothing until every arm's first
//! `/<arm>/object_stream` arrived.
//!
//! Not used: `RobotStream.mode` (the supervisor switches mode on `/speech_command` itself),
//! `RobotStream.ee_pose`, `ObjectState.pose` of a single arm (the distance stimulus is
//! `ObjectState.robot_distance`), `ActionEvent.command_id` (events are matched by label).
//!
//! Outputs: `/supervisor/action` (cowork_msgs/ActionCommand; `arm` empty for a single arm,
//! `left` / `right` with arms — one topic, each robot_manager executes its arm's commands),
//! when the decision changes — a new action (`stop = false`) or an abort (`stop = true`, with
//! the id and label of the aborted command) — and again, with a warning, when no event of an
//! action's id came on its arm's robot stream (`/robot_stream`, `/left/robot_stream`) within
//! `action_resend_s` (a command lost before the robot manager's reader matched; at most 5
//! times; tracked per arm), and once more when an arm's robot stream comes back after a
//! silence longer than `action_resend_s` while its action ran (its robot_manager was killed and
//! restarted, or stopped and continued, and may have started over without the action; one that
//! still runs it ignores the repeat). A command for an arm the LTM does not declare is never sent (the
//! library only decides for declared arms; the node checks again, [`CommandTracker`]).
//! `/supervisor/working_memory` (cowork_msgs/WorkingMemory) at `snapshot_rate_hz`. Every
//! other decision (learned action, mode, accomplished behaviour, waiting for a demonstration,
//! warning) is logged, with its arm.
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

mod areas;
mod bases;
mod node;
mod params;
mod run;

pub use areas::Areas;
pub use bases::{ArmBases, Placement};
pub use cowork_ros::RunOptions;
pub use node::{
    CommandTracker, Input, MAX_SPEECH_CHARS, MAX_WARNING_CHARS, Output, Pacer, RobotStreamDecoder, SupervisorNode,
    WARNING_REPEAT_S, action_kind, kind_code, objects_event, speech_event, warning_kind, working_memory,
};
pub use params::{AreaParams, CentralBox, MAX_TASK_DEPTH, Params, Side};
pub use run::{RunSummary, run, run_loop, run_with};
