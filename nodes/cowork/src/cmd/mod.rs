//! One module per top-level subcommand.

pub mod bag;
pub mod bag_synth;
pub mod bench_control;
pub mod bench_lasa;
pub mod bridge;
pub mod bridge_stats;
pub mod domain;
pub mod experiment;
pub mod kitchen;
pub mod pizza;
pub mod fded;
pub mod keystore;
pub mod learn;
pub mod observe;
pub mod report;
pub mod primitives;
pub mod refine;
pub mod refine_elbow;
pub mod robot;
pub mod say;
pub mod scenario;
pub mod supervisor;
pub mod teach;
pub mod topic;
