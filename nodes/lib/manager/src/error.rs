//! Errors of the robot manager library.

use std::path::PathBuf;

/// Everything that can go wrong learning primitives or reading and writing the database.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ManagerError {
    /// A configuration value is out of range.
    #[error("robot manager configuration: `{field}` = {value}: {reason}")]
    Config {
        /// Parameter name.
        field: String,
        /// Value found.
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A segment cannot be learned as a primitive.
    #[error("cannot learn {label}: {reason}")]
    Learn {
        /// Segment label.
        label: String,
        /// Why.
        reason: String,
    },
    /// The DMP fit of a segment failed.
    #[error("cannot learn {label}: {source}")]
    Motion {
        /// Segment label.
        label: String,
        /// The motion library's error.
        #[source]
        source: cowork_motion::MotionError,
    },
    /// Reading or writing the database file failed.
    #[error("primitive database {path}: {op}: {source}")]
    Io {
        /// What was being done.
        op: &'static str,
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The database file is not valid JSON of the expected shape.
    #[error("primitive database {path}: line {line}, column {column}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What the parser expected (names the field).
        message: String,
    },
    /// The database file parses but a value in it is invalid.
    #[error("primitive database {path}: primitive `{id}`, field `{field}`: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Primitive key.
        id: String,
        /// Field.
        field: String,
        /// Why.
        reason: String,
    },
    /// An HMM primitive cannot be added or refined (not an HMM, bad demonstration or contact
    /// time, unusable result); nothing was changed.
    #[error("cannot refine primitive `{id}`: {reason}; the database is unchanged")]
    Refine {
        /// Primitive key.
        id: String,
        /// Why.
        reason: String,
    },
    /// No primitive has this key.
    #[error("no primitive `{id}` in the database of robot `{robot}`")]
    NotFound {
        /// Key asked for.
        id: String,
        /// Database robot name.
        robot: String,
    },
}

/// Result alias of the library.
pub type Result<T, E = ManagerError> = std::result::Result<T, E>;
