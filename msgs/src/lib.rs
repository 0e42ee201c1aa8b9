//! ROS 2 message types of the cowork graph: Rust structs tied to their .msg definitions.
