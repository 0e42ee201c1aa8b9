//! Error type of the motion library.

use std::path::PathBuf;

/// Everything that can go wrong when learning, evaluating or loading motion models.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MotionError {
    /// Two inputs that must agree in size do not.
    #[error("{what}: expected dimension {expected}, got {got}")]
    DimensionMismatch {
        /// What was being checked.
        what: String,
        /// Required size.
        expected: usize,
        /// Size found.
        got: usize,
    },
    /// A NaN or infinite value in the input.
    #[error("{what}: value at index {index} is not finite")]
    NotFinite {
        /// What contained the value.
        what: String,
        /// Flat index of the offending value.
        index: usize,
    },
    /// Not enough samples (or demonstrations) to learn from.
    #[error("{what}: need at least {needed} samples, got {got}")]
    TooFewSamples {
        /// What was short.
        what: String,
        /// Minimum required.
        needed: usize,
        /// Number found.
        got: usize,
    },
    /// A covariance matrix is not positive definite (after regularisation).
    #[error("covariance of component {component} is singular or not positive definite ({context})")]
    SingularCovariance {
        /// Index of the component.
        component: usize,
        /// Where it was found (fit, GMR conditioning, ...).
        context: String,
    },
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name}: {reason}")]
    InvalidParameter {
        /// Name of the parameter.
        name: String,
        /// Why it is rejected.
        reason: String,
    },
    /// A malformed demonstration / pose / point CSV file.
    #[error("{file}: row {row}, column {column}: {reason}")]
    Csv {
        /// File name.
        file: PathBuf,
        /// 1-based line number in the file (the header is row 1).
        row: usize,
        /// Column name or 1-based index.
        column: String,
        /// What is wrong.
        reason: String,
    },
    /// I/O failure reading or writing a file.
    #[error("{file}: {source}")]
    Io {
        /// File name.
        file: PathBuf,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The operation is not defined for this kind of model.
    #[error("model kind {kind} does not support {operation}")]
    Unsupported {
        /// Model kind.
        kind: &'static str,
        /// Requested operation.
        operation: &'static str,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, MotionError>;

/// Fails with [`MotionError::NotFinite`] if any value is NaN or infinite.
pub(crate) fn check_finite(what: &str, v: &[f64]) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(MotionError::NotFinite {
            what: what.to_string(),
            index,
        }),
        None => Ok(()),
    }
}

/// Fails with [`MotionError::DimensionMismatch`] if `got != expected`.
pub(crate) fn check_dim(what: &str, expected: usize, got: usize) -> Result<()> {
    if expected == got {
        Ok(())
    } else {
        Err(MotionError::DimensionMismatch {
            what: what.to_string(),
            expected,
            got,
        })
    }
}

/// Shorthand for [`MotionError::InvalidParameter`].
pub(crate) fn invalid(name: &str, reason: impl Into<String>) -> MotionError {
    MotionError::InvalidParameter {
        name: name.to_string(),
        reason: reason.into(),
    }
}
