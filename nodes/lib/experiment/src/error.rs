//! Errors of building, judging and reporting an experiment.

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Why an experiment could not be built, judged or reported.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// No experiment of that name.
    #[error("unknown experiment `{name}` (known: {known})")]
    UnknownExperiment {
        /// The name asked for.
        name: String,
        /// The names that exist.
        known: String,
    },
    /// An option does not apply or its value cannot be used.
    #[error("experiment `{experiment}`: {message}")]
    BadOption {
        /// The experiment.
        experiment: String,
        /// What is wrong.
        message: String,
    },
    /// The scene does not fit the experiment (missing object, object off the table, ...).
    #[error("scene {place}: {message}")]
    Scene {
        /// The scene file.
        place: String,
        /// What is wrong.
        message: String,
    },
    /// The scripted people could not be built.
    #[error("people script: {0}")]
    People(#[from] cowork_people::PeopleError),
    /// Robot geometry for judging.
    #[error("robot geometry: {0}")]
    Geometry(#[from] cowork_scenario::Error),
    /// Reading a recorded run.
    #[error("bag: {0}")]
    Bag(#[from] cowork_bag::BagError),
    /// Writing a report.
    #[error("report {path}: {message}")]
    Report {
        /// File or directory.
        path: String,
        /// What went wrong.
        message: String,
    },
}
