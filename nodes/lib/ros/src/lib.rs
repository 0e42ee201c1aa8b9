//! The one adapter between cowork libraries and ROS 2 (ros2-client).
