//! One module per top-level subcommand.

pub mod robot;
pub mod say;
pub mod supervisor;
pub mod topic;
