//! `tf2_msgs`: the transform tree message published on `/tf`.

use serde::{Deserialize, Serialize};

use crate::geometry_msgs::TransformStamped;
use crate::ros_message;

/// A batch of transforms (each from `header.frame_id` to `child_frame_id`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

ros_message!(TFMessage = "tf2_msgs" / "TFMessage" in "ros_std/tf2_msgs/msg", deps [TransformStamped]);
