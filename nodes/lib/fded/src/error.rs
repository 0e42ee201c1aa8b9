//! Errors of the fDED pipeline.

/// What can go wrong when configuring fDED or processing one frame.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A parameter is NaN or out of range (checked once, in [`FdedParams::validate`](crate::FdedParams::validate)).
    #[error("parameter `{name}` = {value}: {reason}")]
    BadParameter {
        /// Field name in [`FdedParams`](crate::FdedParams).
        name: &'static str,
        /// The offending value, as text.
        value: String,
        /// What would be accepted.
        reason: &'static str,
    },
    /// The depth image does not have the size the intrinsics describe.
    #[error("depth image is {got_width}x{got_height} ({got_len} values) but the camera is {width}x{height}")]
    SizeMismatch {
        /// Image width, px.
        got_width: u32,
        /// Image height, px.
        got_height: u32,
        /// Number of values in the image buffer.
        got_len: usize,
        /// Width expected from the intrinsics, px.
        width: u32,
        /// Height expected from the intrinsics, px.
        height: u32,
    },
    /// The camera intrinsics are unusable (non-positive or non-finite focal length, empty image).
    #[error("camera intrinsics unusable: {reason}")]
    BadIntrinsics {
        /// What is wrong.
        reason: &'static str,
    },
    /// No joint state has been given for this frame.
    #[error("no joint state for the frame at t = {stamp} s")]
    MissingJointState {
        /// Frame stamp, s.
        stamp: f64,
    },
    /// The joint state has the wrong number of positions.
    #[error("joint state has {got} positions, the robot has {expected} joints")]
    JointCount {
        /// Positions given.
        got: usize,
        /// Actuated joints of the model.
        expected: usize,
    },
    /// A joint position or the camera pose is NaN or infinite.
    #[error("{what} is not finite")]
    NotFinite {
        /// Which input.
        what: &'static str,
    },
    /// The robot model has no link meshes, so there is nothing to measure distances from.
    #[error("robot model `{robot}` has no link meshes")]
    NoMeshes {
        /// Robot name.
        robot: String,
    },
    /// The model has more links than the fixed-size buffers hold, or more than a `u8` label.
    #[error("robot model has {links} links, at most {max} supported")]
    TooManyLinks {
        /// Links of the model.
        links: usize,
        /// Supported maximum.
        max: usize,
    },
    /// The requested backend is not available in this build or on this machine.
    #[error("backend {backend:?} is not available: {reason}")]
    BackendUnavailable {
        /// The backend asked for.
        backend: crate::Backend,
        /// Why not.
        reason: &'static str,
    },
    /// A benchmark scene could not be rendered.
    #[error("benchmark scene: {message}")]
    Scene {
        /// The renderer's message.
        message: String,
    },
    /// Benchmark output could not be written.
    #[error("writing benchmark output: {message}")]
    Output {
        /// The I/O error.
        message: String,
    },
    /// The worker thread pool could not be created.
    #[error("cannot start {threads} worker threads: {message}")]
    ThreadPool {
        /// Threads asked for.
        threads: usize,
        /// The pool builder's message.
        message: String,
    },
}

/// `Result` with the crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
