//! The `fded_distance` node: a thin ROS 2 adapter around fDED (thesis Sec. 5.1.2,
//! [`cowork_fded`]), on the wgpu path when a hardware Vulkan adapter exists and the CPU
//! otherwise (a software adapter is used only when `backend: gpu` asks for it).
//!
//! Inputs: `/camera/depth/image_raw` (sensor_msgs/Image, `32FC1` m or `16UC1` mm; sensor-data
//! QoS), `/camera/depth/camera_info` (sensor_msgs/CameraInfo), `/joint_states`
//! (sensor_msgs/JointState, matched by joint name, and to the frame by stamp), `/tf_static`
//! (tf2_msgs/TFMessage: the transform from the robot base to the image's `frame_id`; until one
//! arrives the configured `camera_pose` is used), `/manipulated_objects` (cowork_msgs/ObjectStream
//! from robot_manager: the held object and the object the running action goes to, whose
//! pixels are removed before fDED so they do not repel the arm — fail closed, see
//! [`manipulated`]). Only a direct base → camera transform is read; chains are not composed.
//!
//! Outputs, for every processed frame, stamped with the image's stamp, in the base frame:
//! `/fded/distances` (cowork_msgs/LinkDistances, with `processing_time`, s, of the fDED call
//! and `backend`, `"wgpu"` or `"cpu"`) and `/fded/markers` (visualization_msgs/MarkerArray:
//! per link the closest robot and obstacle points, the segment between them and the obstacle
//! normal; see [`markers`]).
//!
//! Frames are never queued: the DDS thread posts every image into a latest-frame slot
//! ([`inbox::Inbox`]) and a worker thread takes the newest one when it is free; older ones are
//! dropped and counted. A frame that cannot be processed (unknown encoding, size different
//! from the camera info, data length ≠ step × height, no camera info or joint state yet) is
//! skipped with a warning naming the topic and the reason, repeated warnings at most once per
//! `warning_period_s`; NaN and zero pixels are no return. The node keeps running.
//!
//! [`FdedNode`] does no I/O, so tests drive it message by message; [`run`] wires it to DDS.
//!
//! ```no_run
//! use cowork_robot::RobotModel;
//! use cowork_ros::{NodeConfig, RosNode};
//! use fded_distance::{FdedNode, Params, RunOptions};
//!
//! let model = RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let fded = FdedNode::new(model, Params::default())?;
//! let node = RosNode::new("fded_distance", &NodeConfig::default())?;
//! let summary = fded_distance::run(node, fded, &RunOptions { duration_s: Some(10.0), stop: None })?;
//! println!("{} frames", summary.frames);
//! # Ok::<(), anyhow::Error>(())
//! ```

pub mod inbox;
pub mod manipulated;
pub mod markers;
mod node;
mod params;
mod run;

pub use cowork_ros::RunOptions;
pub use node::{FdedNode, MAX_CAMERA_FRAMES, Skip, isometry};
pub use params::{ManipulatedParams, Params};
pub use run::{Input, Output, RunSummary, run, run_scripted};

// Topic names for the node's warnings, from the one definition in `cowork_msgs::topics`.
const TOPIC_DEPTH: &str = cowork_msgs::topics::DEPTH_IMAGE.name;
const TOPIC_CAMERA_INFO: &str = cowork_msgs::topics::DEPTH_CAMERA_INFO.name;
const TOPIC_JOINT_STATES: &str = cowork_msgs::topics::JOINT_STATES.name;
const TOPIC_TF_STATIC: &str = cowork_msgs::topics::TF_STATIC.name;
const TOPIC_MANIPULATED: &str = cowork_msgs::topics::MANIPULATED_OBJECTS.name;
