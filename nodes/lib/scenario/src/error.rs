//! Errors of building or running a scenario.

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Why a scenario could not be built or run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// No scenario of that name.
    #[error("unknown scenario `{name}` (known: {known})")]
    UnknownScenario {
        /// The name asked for.
        name: String,
        /// The names that exist.
        known: String,
    },
    /// An option is unknown or its value cannot be used.
    #[error("scenario `{scenario}`: option `--{key}` = {value:?}: {reason}")]
    BadOption {
        /// Scenario name.
        scenario: String,
        /// Option key (without `--`).
        key: String,
        /// The value given.
        value: String,
        /// What is wrong.
        reason: String,
    },
    /// The robot description could not be loaded.
    #[error("robot model: {0}")]
    Robot(#[from] cowork_robot::Error),
    /// The simulator rejected the set-up.
    #[error("simulator: {0}")]
    Sim(#[from] cowork_sim::SimError),
    /// The controller rejected its configuration.
    #[error("DS controller: {0}")]
    Controller(#[from] cowork_ds::Error),
    /// The simulated scene could not be built.
    #[error("scenario scene: {message}")]
    Scene {
        /// Cause.
        message: String,
    },
    /// A link mesh has no convex hull (degenerate).
    #[error("link {link} ({name}): mesh has no convex hull")]
    DegenerateLink {
        /// Link index.
        link: usize,
        /// URDF link name.
        name: String,
    },
    /// The robot could not be brought to the scenario's start position.
    #[error("start position {target:?} not reached: {error_m} m away after {time_s} s")]
    StartNotReached {
        /// Wanted TCP position (m, base frame).
        target: [f64; 3],
        /// Remaining distance (m).
        error_m: f64,
        /// Time spent (s).
        time_s: f64,
    },
    /// Writing the trajectory failed.
    #[error("cannot write trajectory {path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        source: std::io::Error,
    },
}
