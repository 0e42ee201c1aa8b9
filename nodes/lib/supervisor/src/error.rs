//! Errors of the supervisor library, and run-time warnings (which never stop the loop).

use std::path::PathBuf;

/// Errors: bad schema files, bad tasks, bad configuration, file I/O.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The schema text does not follow the grammar.
    #[error("schema syntax error at line {line}, column {column}: {message}")]
    Syntax { line: usize, column: usize, message: String },
    /// A variable in a releaser or post-condition is not bound by the schema head.
    #[error("unbound variable {variable} in schema {schema} at line {line}, column {column}{hint}")]
    UnboundVariable { schema: String, variable: String, line: usize, column: usize, hint: String },
    /// Schemas that expand into each other (the task tree would be infinite).
    #[error("cyclic schemas: {}", cycle.join(" -> "))]
    CyclicSchema { cycle: Vec<String> },
    /// A literal names an object that `objects([...])` does not declare.
    #[error("unknown object '{name}' at line {line}, column {column} (declared objects: {declared})")]
    UnknownObject { name: String, line: usize, column: usize, declared: String },
    /// A sub-behaviour that no schema head matches.
    #[error("no schema for behaviour {behaviour} at line {line}, column {column}")]
    UnknownBehaviour { behaviour: String, line: usize, column: usize },
    /// Two schemas with the same head.
    #[error("duplicate schema {head} at line {line} (first at line {first_line})")]
    DuplicateSchema { head: String, line: usize, first_line: usize },
    /// A schema declared as an action (4th argument) that has sub-behaviours.
    #[error("action schema {head} at line {line} must have an empty sub-behaviour list")]
    ActionWithChildren { head: String, line: usize },
    /// `--task` names nothing in the LTM, or is not ground.
    #[error("unknown task '{task}': {reason}")]
    UnknownTask { task: String, reason: String },
    /// A configuration value is out of range or not finite.
    #[error("invalid supervisor parameter {name} = {value}: {reason}")]
    InvalidParameter { name: &'static str, value: f64, reason: &'static str },
    /// A line of an event script is malformed.
    #[error("event script line {line}: {message}")]
    Event { line: usize, message: String },
    /// Reading or writing a file failed.
    #[error("{op} {path}: {source}")]
    Io { op: &'static str, path: PathBuf, source: std::io::Error },
}

/// Result alias of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Something wrong with an input event; reported as a decision, the loop continues.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "warning", rename_all = "snake_case")]
pub enum Warning {
    /// A speech command outside the vocabulary (Sec. 5.2.3).
    UnknownSpeech { text: String },
    /// An event names an object the LTM does not declare.
    UnknownObject { name: String },
    /// An arm that the LTM does not declare.
    UnknownArm { arm: String },
    /// `human <subtask>` names no allocated, unfinished behaviour.
    UnknownSubtask { text: String },
    /// `action_done`/`action_failed` for an action that is not the commanded one.
    UnexpectedActionEvent { label: String },
    /// The commanded action failed in the robot manager.
    ActionFailed { label: String, reason: String },
    /// A segmented action arrived, but no open subtask is enabled to take it.
    NoOpenSubtask { label: String },
    /// A segment arrived while not teaching.
    SegmentOutsideTeaching { label: String },
    /// A segment label that is not a valid behaviour term.
    BadLabel { label: String, reason: String },
    /// A non-finite number in an event.
    NonFinite { field: String },
    /// A speech command that does not apply in the current mode.
    IgnoredSpeech { text: String, reason: String },
    /// A demonstrated subtask did not reach its post-condition (the hand closed on nothing,
    /// or `done` came first): it stays open, and at `done` its actions are forgotten.
    UnfinishedDemonstration { subtask: String, reason: String },
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::UnknownSpeech { text } => write!(f, "unknown speech command '{text}' ignored"),
            Self::UnknownObject { name } => write!(f, "unknown object '{name}' ignored"),
            Self::UnknownArm { arm } => write!(f, "unknown arm '{arm}' ignored"),
            Self::UnknownSubtask { text } => write!(f, "no allocated subtask '{text}'"),
            Self::UnexpectedActionEvent { label } => write!(f, "event for action '{label}' that is not running"),
            Self::ActionFailed { label, reason } => write!(f, "action '{label}' failed: {reason}"),
            Self::NoOpenSubtask { label } => write!(f, "segment '{label}' dropped: no enabled open subtask"),
            Self::SegmentOutsideTeaching { label } => write!(f, "segment '{label}' ignored: not teaching"),
            Self::BadLabel { label, reason } => write!(f, "bad action label '{label}': {reason}"),
            Self::NonFinite { field } => write!(f, "non-finite value in {field} ignored"),
            Self::IgnoredSpeech { text, reason } => write!(f, "speech '{text}' ignored: {reason}"),
            Self::UnfinishedDemonstration { subtask, reason } => write!(f, "demonstration of {subtask} unfinished: {reason}"),
        }
    }
}
