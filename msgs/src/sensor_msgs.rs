//! `sensor_msgs`: joint states, images (raw and compressed) and camera calibration.

use serde::{Deserialize, Serialize};

use crate::ros_message;
use crate::std_msgs::Header;

/// State of a set of joints. Each array is empty or as long as `name`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Time of the measurement.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions (rad for revolute, m for prismatic joints).
    pub position: Vec<f64>,
    /// Velocities (rad/s or m/s).
    pub velocity: Vec<f64>,
    /// Efforts (Nm or N).
    pub effort: Vec<f64>,
}

ros_message!(JointState = "sensor_msgs" / "JointState" in "ros_std/sensor_msgs/msg", deps [Header]);

/// An uncompressed image; `data` holds `step * height` bytes.
///
/// Depth images in cowork: encoding `32FC1` (m) or `16UC1` (mm), in the camera optical frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    /// Acquisition time and camera optical frame.
    pub header: Header,
    /// Number of rows (pixels).
    pub height: u32,
    /// Number of columns (pixels).
    pub width: u32,
    /// Pixel encoding, e.g. `"32FC1"`, `"16UC1"`, `"rgb8"`.
    pub encoding: String,
    /// 1 when multi-byte pixel values are big-endian.
    pub is_bigendian: u8,
    /// Row length (bytes).
    pub step: u32,
    /// Pixel data, row-major.
    #[serde(with = "crate::bytes")]
    pub data: Vec<u8>,
}

ros_message!(Image = "sensor_msgs" / "Image" in "ros_std/sensor_msgs/msg", deps [Header]);

/// A sub-window of an image (pixels).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Leftmost column (pixels).
    pub x_offset: u32,
    /// Topmost row (pixels).
    pub y_offset: u32,
    /// Height (pixels).
    pub height: u32,
    /// Width (pixels).
    pub width: u32,
    /// Whether a rectified ROI should be computed.
    pub do_rectify: bool,
}

ros_message!(RegionOfInterest = "sensor_msgs" / "RegionOfInterest" in "ros_std/sensor_msgs/msg", deps []);

/// Camera calibration (pin-hole model, thesis eq. 5.14).
///
/// `k`, `r`, `p` are fixed-size arrays: CDR writes them without a length prefix.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Acquisition time and camera optical frame.
    pub header: Header,
    /// Image rows (pixels).
    pub height: u32,
    /// Image columns (pixels).
    pub width: u32,
    /// Distortion model, e.g. `"plumb_bob"`.
    pub distortion_model: String,
    /// Distortion parameters of the model.
    pub d: Vec<f64>,
    /// Intrinsic matrix, 3x3 row-major: [fx 0 cx; 0 fy cy; 0 0 1] (pixels).
    pub k: [f64; 9],
    /// Rectification matrix, 3x3 row-major.
    pub r: [f64; 9],
    /// Projection matrix, 3x4 row-major (pixels).
    pub p: [f64; 12],
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}

ros_message!(CameraInfo = "sensor_msgs" / "CameraInfo" in "ros_std/sensor_msgs/msg", deps [Header, RegionOfInterest]);

/// A compressed image (`format` names the codec, e.g. `"png"`); a marker's embedded texture.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Acquisition time and camera optical frame.
    pub header: Header,
    /// Codec, e.g. `"jpeg"`, `"png"`.
    pub format: String,
    /// Compressed bytes.
    #[serde(with = "crate::bytes")]
    pub data: Vec<u8>,
}

ros_message!(CompressedImage = "sensor_msgs" / "CompressedImage" in "ros_std/sensor_msgs/msg", deps [Header]);
