//! `std_msgs`: header, string, float64 multi-array and RGBA colour.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::ros_message;

/// Standard metadata of stamped messages.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Acquisition time of the data.
    pub stamp: Time,
    /// Frame the data is expressed in.
    pub frame_id: std::string::String,
}

impl Header {
    /// A header with the given stamp and frame.
    pub fn new(stamp: Time, frame_id: impl Into<std::string::String>) -> Self {
        Self {
            stamp,
            frame_id: frame_id.into(),
        }
    }
}

ros_message!(Header = "std_msgs" / "Header" in "ros_std/std_msgs/msg", deps [Time]);

/// A single string.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct String {
    /// The text.
    pub data: std::string::String,
}

impl String {
    /// A message carrying `data`.
    pub fn new(data: impl Into<std::string::String>) -> Self {
        Self { data: data.into() }
    }
}

ros_message!(String = "std_msgs" / "String" in "ros_std/std_msgs/msg", deps []);

/// One dimension of a multi-array.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// Label of the dimension.
    pub label: std::string::String,
    /// Size of the dimension (elements).
    pub size: u32,
    /// Stride of the dimension (elements).
    pub stride: u32,
}

ros_message!(MultiArrayDimension = "std_msgs" / "MultiArrayDimension" in "ros_std/std_msgs/msg", deps []);

/// Layout of a multi-array; `dim[0]` is the outermost dimension.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// Dimensions, outermost first.
    pub dim: Vec<MultiArrayDimension>,
    /// Elements of padding at the front of the data.
    pub data_offset: u32,
}

ros_message!(MultiArrayLayout = "std_msgs" / "MultiArrayLayout" in "ros_std/std_msgs/msg", deps [MultiArrayDimension]);

/// A multi-dimensional array of f64 (e.g. the 7 joint velocities in rad/s).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// Layout of `data`; an empty layout means a flat vector.
    pub layout: MultiArrayLayout,
    /// The values.
    pub data: Vec<f64>,
}

impl Float64MultiArray {
    /// A flat vector with an empty layout.
    pub fn from_vec(data: Vec<f64>) -> Self {
        Self {
            layout: MultiArrayLayout::default(),
            data,
        }
    }
}

ros_message!(Float64MultiArray = "std_msgs" / "Float64MultiArray" in "ros_std/std_msgs/msg", deps [MultiArrayLayout]);

/// An RGBA colour, each component in [0, 1] (viewers' markers).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Alpha (0 transparent, 1 opaque).
    pub a: f32,
}

impl ColorRGBA {
    /// The colour `(r, g, b, a)`.
    pub const fn new(r: f32, g: f32, b: f32, a: f32) -> Self {
        Self { r, g, b, a }
    }
}

ros_message!(ColorRGBA = "std_msgs" / "ColorRGBA" in "ros_std/std_msgs/msg", deps []);
