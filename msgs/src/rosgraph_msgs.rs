//! `rosgraph_msgs`: the simulated clock.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::ros_message;

/// Simulated time, published on `/clock` when nodes run with `use_sim_time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Clock {
    /// Current simulated time.
    pub clock: Time,
}

ros_message!(Clock = "rosgraph_msgs" / "Clock" in "ros_std/rosgraph_msgs/msg", deps [Time]);
