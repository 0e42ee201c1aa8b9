//! Errors of building a controller ([`Error`]) and faults of one control step ([`Fault`]).

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Why a controller could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration value is NaN, infinite or out of its range.
    #[error("DS controller config `{field}` = {value}: {reason}")]
    Config {
        /// Dotted path of the field, e.g. `modulation.epsilon`.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// The admissible range.
        reason: &'static str,
    },
    /// A sampled path ([`crate::tracker::PathTracker`]) is empty, ragged or not finite.
    #[error("learned path: {reason}")]
    Path {
        /// What is wrong, naming the sample.
        reason: String,
    },
}

/// Which input stream a fault is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stream {
    /// Robot–obstacle distances (`/fded/distances`).
    Distances,
    /// Human state (`/human/state`).
    Human,
    /// Joint positions (`/joint_states`).
    JointStates,
}

impl std::fmt::Display for Stream {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Stream::Distances => "/fded/distances",
            Stream::Human => "/human/state",
            Stream::JointStates => "/joint_states",
        })
    }
}

/// Why one control step did not run the motion. The step still fills its output with a
/// braking command (decelerate to zero, hold), which must be sent.
///
/// `Copy` and allocation-free: the real-time thread can hand it to the ROS side as is.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Fault {
    /// An input stream is older than the configured bound (or never arrived), or stamped in
    /// the future (negative age: the clock went back).
    #[error("stale {stream}: age {age_s:.3} s {}", if *age_s < 0.0 { "is negative (stamp in the future: the clock went back?)".to_owned() } else { format!("exceeds {bound_s} s") })]
    Stale {
        /// The stream.
        stream: Stream,
        /// Age of the newest sample (s); infinite when none ever arrived.
        age_s: f64,
        /// Configured bound (s).
        bound_s: f64,
    },
    /// A numeric input is NaN or infinite.
    #[error("non-finite {what} (link {link})")]
    NonFinite {
        /// Which field, e.g. `distance`, `normal`, `q`, `goal`.
        what: &'static str,
        /// Link index for per-link fields, `usize::MAX` otherwise.
        link: usize,
    },
    /// An obstacle normal has (near) zero length, so no avoidance direction exists.
    #[error("zero obstacle normal for link {link}")]
    ZeroNormal {
        /// Link index.
        link: usize,
    },
    /// The goal lies farther from the shoulder than the arm can reach.
    #[error("goal out of reach: {distance_m} m from the shoulder, reach {reach_m} m")]
    GoalOutOfReach {
        /// Distance of the goal from the first joint (m).
        distance_m: f64,
        /// Reach bound of the arm (m).
        reach_m: f64,
    },
    /// A primitive parameter is out of range (e.g. a negative gain or speed).
    #[error("bad primitive parameter `{what}` = {value}")]
    BadPrimitive {
        /// Parameter name.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// The adapter rejected the newest message of a stream (e.g. an unknown link name); the
    /// robot is held until a valid one arrives.
    #[error("rejected {stream} message: {reason}")]
    Rejected {
        /// The stream.
        stream: Stream,
        /// Why.
        reason: &'static str,
    },
    /// The distance array names more links than the robot has.
    #[error("distances for {given} links, robot has {links}")]
    TooManyLinks {
        /// Entries given.
        given: usize,
        /// Links of the model.
        links: usize,
    },
}
