//! The `lwr_sim` node: a thin ROS 2 adapter around [`cowork_sim::Simulator`].
//!
//! Files as every node: `params.rs` ([`LwrSimConfig`]), `node.rs` ([`LwrSim`]: turns messages
//! into simulator inputs and simulator state into [`Output`]s; no I/O, so tests drive it
//! directly), `run.rs` ([`run_loop`], generic over the [`InputSource`](cowork_ros::InputSource)
//! — DDS, or a scripted one in the golden tests — stepping simulated time at its [`Pacing`],
//! and [`run`], which wires it to DDS), `depth.rs` (the depth camera and its worker's mailbox).
//!
//! Inputs: `/lwr/joint_velocity_command` (std_msgs/Float64MultiArray, 7 values, rad/s),
//! `/lwr/gripper_command` (std_msgs/String `open` / `close`), `/external_wrench`
//! (geometry_msgs/WrenchStamped: expressed in `header.frame_id` and applied at its origin; an empty
//! frame or the base link means a base-frame wrench at the tool point). What a wrench does
//! depends on [`WrenchMode`]: in `teach` mode (the default) the arm yields to it by admittance
//! (zero-gravity kinesthetic teaching); in `execute` mode the arm does not move by itself: the
//! wrench is *reported* on `/lwr/external_wrench` (geometry_msgs/WrenchStamped, `header.frame_id`
//! = the contact link, force and torque in that link's frame, at `external_wrench.report_rate_hz`
//! while it acts) for the controller's task transition control (thesis Sec. 4.1.2), as the
//! LWR's joint torque sensors report a person's push while it runs a motion.
//! `/human/skeleton` (cowork_msgs/Skeleton, base frame): each person is drawn in the depth image
//! as a capsule body on the floor (see [`depth::People`]). `/lwr/place_object`
//! (cowork_msgs/WorldObject): a person moves a scene object (see [`LwrSim::on_place_object`]).
//! Outputs: `/clock`, `/joint_states`, `/tf` (link tree parent → child, objects), `/tf_static` (camera),
//! `/lwr/world` (cowork_msgs/WorldState: gripper, held object, tool pose, every object's pose,
//! tool distance and tilt, at `publish.world_rate_hz`; what the robot manager and the
//! experiments' success checks read),
//! `/camera/depth/image_raw` (sensor_msgs/Image, `32FC1` m or `16UC1` mm) and
//! `/camera/depth/camera_info` at the scene camera's `rate_hz` of simulated time (sensor-data
//! QoS), rendered by a worker thread from the newest state (see [`depth`]).

pub mod depth;
mod node;
mod params;
mod run;

pub use node::{Due, Input, LwrSim, MAX_PENDING_WRENCHES, MAX_STEP_WARNINGS, Output};
pub use params::{LwrSimConfig, PublishRates, WrenchConfig, WrenchMode};
pub use run::{HOLD_RECHECK_S, Pacing, RunSummary, WARNING_REPEAT_S, run, run_loop, run_with};
