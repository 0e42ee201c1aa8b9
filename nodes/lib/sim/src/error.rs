use std::path::PathBuf;

/// Errors raised while building a simulator from its configuration.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SimError {
    /// The scene or parameter file could not be read.
    #[error("cannot read {path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    /// The YAML text does not match the expected structure.
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    /// A value is NaN, infinite or out of its valid range.
    #[error("{place}: field `{field}` = {value}: {reason}")]
    BadValue { place: String, field: String, value: String, reason: String },
}

/// Rejected inputs. The simulator keeps running and holds the robot still.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CommandError {
    /// A joint velocity command with the wrong number of entries.
    #[error("joint velocity command has {got} entries, the robot has {expected} joints")]
    WrongLength { got: usize, expected: usize },
    /// A joint position target outside joint `index`'s limits.
    #[error("joint target[{index}] = {value} rad is outside the joint's limits [{lower}, {upper}] rad")]
    OutsideLimits { index: usize, value: f64, lower: f64, upper: f64 },
    /// A command or wrench entry that is NaN or infinite.
    #[error("{what}[{index}] is not finite ({value})")]
    NotFinite { what: &'static str, index: usize, value: f64 },
    /// A wrench applied to a link the robot does not have.
    #[error("wrench applied to unknown link `{link}`")]
    UnknownLink { link: String },
    /// A person placing an object the scene does not have.
    #[error("no object `{name}` in the scene")]
    UnknownObject { name: String },
    /// A person placing the object the gripper holds.
    #[error("object `{name}` is held by the gripper")]
    HeldByGripper { name: String },
    /// An object pose that is not finite or whose quaternion has no length.
    #[error("pose of object `{name}` is not finite or not a rotation")]
    BadPose { name: String },
}

/// Result alias of this crate.
pub type Result<T, E = SimError> = std::result::Result<T, E>;
