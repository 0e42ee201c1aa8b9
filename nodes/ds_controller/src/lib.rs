//! The `ds_controller` node: a thin ROS 2 adapter around [`cowork_ds::DsController`].
//!
//! The node's rooms (STYLE.md "Node shape"):
//! - [`params`]: the typed parameters, thesis defaults, `validate()` naming the key;
//! - [`node`]: the ROS side without I/O — [`Adapter`] (converts and validates messages),
//!   [`StatusTracker`] (`/motion/status`: abort, hold, resume, de-duplication, rejections) and
//!   [`DsNode`] with one pure handler per [`Input`];
//! - [`rt`]: the **real-time loop** ([`rt_loop`]), which steps the controller every period (1 ms
//!   of wall time, or of `/clock` time with `use_sim_time`) on the newest inputs from a
//!   [`Mailbox`] of `Copy` data and hands out `Copy` [`RtOutput`]s; it never allocates, logs,
//!   serialises or publishes;
//! - [`run`](mod@run): the wiring — a DDS input thread that blocks on the subscriptions, the
//!   real-time thread, and the ROS side's loop [`serve`] (generic over the input source, so
//!   `tests/golden.rs` drives it with a scripted source and a mock clock).
//!
//! Inputs carry their header stamps (when the data was measured): the watchdog ages them
//! against the node's clock, so a frame delivered late is as old as it is. Bad input never
//! stops the node: a bad command is aborted with its reason and the robot held; bad distances
//! (NaN, infinite, zero normal, unknown link) hold the robot with the reason until valid ones
//! arrive; warnings about inputs are logged at most once per kind per `warning_period_s`.

pub mod human;
pub mod learned;
pub mod node;
pub mod params;
pub mod rt;
pub mod run;
pub mod scene;

pub use cowork_ros::RunOptions;
pub use node::{
    Adapter, DsNode, HANDOVER_HAND_RADIUS_M, Input, LIMITED_SHOWN_S, Outputs, Rejection, StatusTracker, mark_handover_goal,
    state_of,
};
pub use params::Params;
pub use rt::{Clock, FieldChannels, Mailbox, RtInputs, RtOutput, rt_loop, rt_step};
pub use run::{Sink, TICK_S, run, serve};

/// The push lwr_sim reports in execute mode (geometry_msgs/WrenchStamped, `header.frame_id` =
/// the contact link, force in that link's frame).
pub const TOPIC_EXTERNAL_WRENCH: &str = cowork_msgs::topics::LWR_EXTERNAL_WRENCH.name;
