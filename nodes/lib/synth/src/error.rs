//! Errors of scenario synthesis.

/// `Result` with [`SynthError`].
pub type Result<T, E = SynthError> = std::result::Result<T, E>;

/// Why a scenario bag could not be written or replayed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SynthError {
    /// The scenario name is not one of [`Scenario::ALL`](crate::Scenario::ALL).
    #[error("unknown scenario `{name}` (known: {known})")]
    UnknownScenario {
        /// The name given.
        name: String,
        /// The known names, comma separated.
        known: String,
    },
    /// An option is NaN or out of its range.
    #[error("option `{option}` = {value}: {reason}")]
    BadOption {
        /// The option (`--duration`, ...).
        option: &'static str,
        /// The value given.
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The robot description could not be loaded.
    #[error("robot model: {source}")]
    Robot {
        /// The model loader's error.
        #[from]
        source: cowork_robot::Error,
    },
    /// The scene or simulator parameters are invalid.
    #[error("simulator: {source}")]
    Sim {
        /// The simulator's error.
        #[from]
        source: cowork_sim::SimError,
    },
    /// The simulator rejected an input the synthesiser produced.
    #[error("simulator rejected {what}: {source}")]
    Command {
        /// What was sent.
        what: &'static str,
        /// The simulator's complaint.
        source: cowork_sim::CommandError,
    },
    /// Writing or reading the bag failed.
    #[error("bag: {source}")]
    Bag {
        /// The bag library's error.
        #[from]
        source: cowork_bag::BagError,
    },
    /// The depth renderer failed.
    #[error("depth camera: {source}")]
    Depth {
        /// The renderer's error.
        source: cowork_depth::Error,
    },
    /// A synthetic person could not be built.
    #[error("synthetic people: {source}")]
    People {
        /// The people library's error.
        source: cowork_people::PeopleError,
    },
    /// A planned motion cannot be executed (joint limits, unreachable pose).
    #[error("scenario {scenario}: {reason}")]
    Plan {
        /// The scenario.
        scenario: &'static str,
        /// What went wrong.
        reason: String,
    },
}

impl From<cowork_depth::Error> for SynthError {
    fn from(source: cowork_depth::Error) -> Self {
        SynthError::Depth { source }
    }
}

impl From<cowork_people::PeopleError> for SynthError {
    fn from(source: cowork_people::PeopleError) -> Self {
        SynthError::People { source }
    }
}
