//! Errors of the depth crate.

use std::path::PathBuf;

/// Result with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong when converting, validating or rendering depth images.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A `sensor_msgs/CameraInfo` field that does not describe a usable pin-hole camera.
    #[error("CameraInfo field `{field}` = {value}: {reason}")]
    BadCameraInfo {
        /// The field at fault, e.g. `k[0]` or `width`.
        field: &'static str,
        /// Its value as text.
        value: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// Camera intrinsics with a non-finite or out-of-range value.
    #[error("intrinsics `{field}` = {value}: {reason}")]
    BadIntrinsics {
        /// The field at fault, e.g. `fx`.
        field: &'static str,
        /// Its value as text.
        value: String,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// An image `encoding` this crate does not read as depth.
    #[error("Image field `encoding` = {encoding:?}: not a depth encoding (expected \"32FC1\" in m or \"16UC1\" in mm)")]
    UnknownEncoding {
        /// The encoding string of the message.
        encoding: String,
    },
    /// An image with no pixels.
    #[error("Image fields `width` x `height` = {width}x{height}: the image has no pixels")]
    ZeroSize {
        /// Columns, px.
        width: u32,
        /// Rows, px.
        height: u32,
    },
    /// An image `step` shorter than one row of pixels.
    #[error("Image field `step` = {step} bytes: shorter than a row of `width` = {width} px x {bytes_per_pixel} bytes = {min} bytes")]
    StepTooSmall {
        /// Row length in the message, bytes.
        step: u32,
        /// Columns, px.
        width: u32,
        /// Bytes per pixel of the encoding.
        bytes_per_pixel: u32,
        /// Smallest acceptable step, bytes.
        min: u64,
    },
    /// An image whose `data` length is not `step * height`.
    #[error("Image field `data` has {len} bytes but `step` x `height` = {step} x {height} = {expected} bytes")]
    DataLength {
        /// Length of `data`, bytes.
        len: usize,
        /// Row length, bytes.
        step: u32,
        /// Rows, px.
        height: u32,
        /// `step * height`, bytes.
        expected: u64,
    },
    /// An `is_bigendian` flag other than 0 or 1.
    #[error("Image field `is_bigendian` = {value}: must be 0 or 1")]
    BadEndianFlag {
        /// The flag in the message.
        value: u8,
    },
    /// A depth image buffer whose length does not match its size.
    #[error("depth image `data` has {len} values but `width` x `height` = {width} x {height}")]
    BufferSize {
        /// Length of `data`.
        len: usize,
        /// Columns, px.
        width: u32,
        /// Rows, px.
        height: u32,
    },
    /// A configuration or geometry value that is NaN or out of range.
    #[error("`{field}` = {value}: {reason}")]
    BadValue {
        /// The parameter at fault, e.g. `noise.dropout_probability` or `capsule.radius`.
        field: String,
        /// Its value as text.
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// Writing a PNG file failed.
    #[error("cannot write PNG {path}: {message}")]
    Png {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

impl Error {
    pub(crate) fn bad_value(
        field: impl Into<String>,
        value: impl std::fmt::Display,
        reason: impl Into<String>,
    ) -> Self {
        Error::BadValue { field: field.into(), value: value.to_string(), reason: reason.into() }
    }
}
