//! Experiments in the whole cowork graph (thesis Sec. 5.1.3) — the ROS-free half of
//! `cowork experiment` and `cowork report`.
//!
//! An experiment is a plain description ([`plan::Experiment`]: scene, task script of motions
//! and gripper commands, scripted people, success test) that one shared runner (the `cowork`
//! CLI) executes in the graph of node processes. This crate has everything that needs no
//! DDS: the descriptions ([`plan`]), the task executor fed with `/motion/status` and
//! `/lwr/world` ([`sequencer`]), the judge that measures what the simulated world did — true
//! robot–person distance from the robot link hulls and the person's capsule body, collisions,
//! placements — ([`judge`]), the JSON ([`result`]), judging a recorded MCAP ([`bag`]) and the
//! report of PNG plots and a static `index.html` ([`report`]).
//!
//! Frames and units: robot base frame (table top z = 0), m, s, rad.

mod error;

pub mod bag;
pub mod cooperation;
pub mod judge;
pub mod plan;
pub mod report;
pub mod result;
pub mod sequencer;
pub mod trace;

pub use error::{Error, Result};
pub use judge::{Judge, Series, Stats, THESIS_MIN_DISTANCE_M};
pub use plan::{DistanceMethod, Experiment, NAMES, Options, Step, build};
pub use result::{RunResult, Summary, TrialResult};
pub use sequencer::{Output, Progress, Sequencer};
