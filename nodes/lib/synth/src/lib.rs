//! Deterministic scenario bags (thesis Sec. 5.1.3, 5.2.3, 4.2): MCAP files with the ROS 2
//! profile carrying what the graph would see in a scenario — `/clock`, `/joint_states`, `/tf`,
//! `/tf_static`, depth frames with camera info, Xsens-style skeletons, teaching wrenches and
//! speech, gesture labels — written from a seed so that the same seed gives the same bytes.
//!
//! The robot is the kinematic simulator of `lwr_sim` ([`cowork_sim::Simulator`], 1 kHz) in the
//! scene of `config/scenes/`, so joint states, tf and the motion that wrenches produce are what
//! `lwr_sim` would publish.
//!
//! ```no_run
//! use cowork_synth::{Scenario, SynthOptions, synthesize};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let options = SynthOptions { seed: 7, ..SynthOptions::default() };
//! let summary = synthesize(Scenario::KinestheticPour, &options, "pour.mcap".as_ref(), &mut |_| {})?;
//! println!("{} messages", summary.counts.values().sum::<u64>());
//! # Ok(()) }
//! ```

mod depth;
mod error;
pub mod gestures;
pub mod kitchen;
mod plan;
pub mod pizza;
pub mod pour;
mod replay;
mod runner;
mod scenario;
pub mod stacking;
pub mod static_scene;
pub mod streams;

pub use depth::DEPTH_ENCODING;
pub use error::{Result, SynthError};
pub use plan::{CartesianPath, PathSample, Teacher};
pub use replay::{Applied, ReplaySummary, TeachingInput, apply_input, replay_teaching};
pub use scenario::{Scenario, SynthOptions, SynthSummary, continue_from, load_simulator, synthesize};
