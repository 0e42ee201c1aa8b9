//! The `robot_manager` node: a thin ROS 2 adapter around [`cowork_manager::Manager`]
//! (thesis Sec. 4.3.1, 5.2.1, Fig. 4.10).
//!
//! | topic | type | direction |
//! |---|---|---|
//! | `/lwr/world` | cowork_msgs/WorldState (tool pose, gripper, held object, object poses) | in |
//! | `/speech_command` | std_msgs/String (`teach`, `done`, `stop`, `repeat`, `gripper open\|close`, `human <subtask>`) | in |
//! | `/supervisor/action` | cowork_msgs/ActionCommand | in |
//! | `/motion/status` | cowork_msgs/MotionStatus | in |
//! | `/human/gesture` | cowork_msgs/Gesture (`stop` = stop, `come` = repeat) | in |
//! | `/motion/command` | cowork_msgs/MotionCommand (FOA `KIND_LINEAR`, NOA `KIND_DMP`, `KIND_HOLD`) | out |
//! | `/lwr/gripper_command` | std_msgs/String `open` / `close` | out |
//! | `/robot_stream` | cowork_msgs/RobotStream (EE pose, gripper, held object, mode, events, segments) | out |
//! | `/object_stream` | cowork_msgs/ObjectStream (task names, pose, tool distance, visible) | out |
//! | `/manipulated_objects` | cowork_msgs/ObjectStream (scene names: the held object and the running action's target object; stamp and frame of the `/lwr/world` report) | out, to fded_distance, which does not count them as obstacles |
//!
//! [`node`] holds the handlers (no I/O), [`run`] the DDS loop, [`params`] the parameters.

pub mod node;
pub mod params;
pub mod preview;
pub mod run;

pub use node::{Outbox, RobotManagerNode, addressed};
pub use params::Params;
pub use cowork_ros::RunOptions;
pub use run::{Input, run, run_loop};

