//! Errors of the synthetic-people library.

use thiserror::Error;

/// What can go wrong when building or sampling a synthetic person.
#[derive(Debug, Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum PeopleError {
    /// A parameter is NaN, infinite or outside its valid range.
    #[error("invalid {what}: {value} ({expected})")]
    InvalidParameter {
        /// Name of the parameter.
        what: String,
        /// The rejected value.
        value: f64,
        /// The valid range, in words.
        expected: &'static str,
    },
    /// A skeleton message lacks a segment the operation needs.
    #[error("skeleton message has no segment {name:?}")]
    MissingSegment {
        /// The missing segment name.
        name: String,
    },
    /// A skeleton message is malformed (lengths differ, non-unit quaternion...).
    #[error("malformed skeleton message: {reason}")]
    Malformed {
        /// What is wrong.
        reason: String,
    },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, PeopleError>;

/// Checks that `value` is finite and within `[lo, hi]`.
pub(crate) fn check_range(what: &str, value: f64, lo: f64, hi: f64, expected: &'static str) -> Result<()> {
    if value.is_finite() && value >= lo && value <= hi {
        Ok(())
    } else {
        Err(PeopleError::InvalidParameter { what: what.to_owned(), value, expected })
    }
}

/// Checks that `value` is finite.
pub(crate) fn check_finite(what: &str, value: f64) -> Result<()> {
    check_range(what, value, f64::NEG_INFINITY, f64::INFINITY, "a finite number")
}
