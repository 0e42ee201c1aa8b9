//! Errors of the human observer library.

use std::path::PathBuf;

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, ObserverError>;

/// What can go wrong when observing people or learning gestures.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ObserverError {
    /// A parameter is NaN, infinite or out of range.
    #[error("parameter `{name}` = {value}: {expected}")]
    InvalidParameter {
        /// Parameter name (dotted path as in the parameter file).
        name: String,
        /// Rejected value.
        value: f64,
        /// The valid range, in words.
        expected: &'static str,
    },
    /// A skeleton message cannot be used; `field` names the message field.
    #[error("skeleton of person {person_id}: field `{field}`: {reason}")]
    BadSkeleton {
        /// Tracker id of the person.
        person_id: u32,
        /// The offending field (`segment_names`, `poses[3].orientation`, `header.stamp`, ...).
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// A joint state cannot be used.
    #[error("joint state: field `{field}`: {reason}")]
    BadJointState {
        /// The offending field.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// The gesture model is malformed.
    #[error("gesture model{}: field `{field}`: {reason}", path.as_ref().map(|p| format!(" {}", p.display())).unwrap_or_default())]
    BadModel {
        /// File, when read from one.
        path: Option<PathBuf>,
        /// The offending field.
        field: String,
        /// What is wrong.
        reason: String,
    },
    /// Not enough training data.
    #[error("training data: {reason}")]
    Training {
        /// What is missing.
        reason: String,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The robot geometry could not be built.
    #[error("robot geometry: {0}")]
    Geometry(String),
    /// A motion-library call failed (DTW, invariants).
    #[error("motion library: {0}")]
    Motion(#[from] cowork_motion::MotionError),
}

pub(crate) fn check(name: &str, value: f64, lo: f64, hi: f64, expected: &'static str) -> Result<()> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(ObserverError::InvalidParameter { name: name.to_owned(), value, expected })
    }
}
