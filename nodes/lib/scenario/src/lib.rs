//! Simulated experiments of the reactive DS controller (thesis Sec. 5.1.1 Fig. 5.3–5.7,
//! Sec. 5.1.3), run in-process on the simulated clock: `cowork_sim::Simulator` at 1 kHz, the
//! [`cowork_ds::DsController`] in the loop, and analytic obstacles (spheres, boxes, an open box,
//! a scripted person as capsules) whose per-link distances, closest points, normals and point
//! velocities are computed exactly with parry3d ([`distance`]) — the same
//! [`cowork_ds::Distances`] the controller gets from fDED. No ROS.
//!
//! ```no_run
//! use cowork_scenario::{Options, build, run};
//! let model = cowork_robot::RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let opts = Options::new("moving-sphere-hold", [("obstacle-velocity", "0,1.4,0")]);
//! let setup = build(&model, "moving-sphere-hold", &opts)?;
//! let summary = run(&model, setup, None)?;
//! println!("{}", serde_json::to_string_pretty(&summary)?);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Frames and units: robot base frame (table top z = 0), m, s, rad.

pub mod distance;
mod error;
pub mod obstacle;
pub mod person;
pub mod runner;
pub mod scenarios;

pub use error::{Error, Result};
pub use runner::{Goal, Setup, Start, Summary, World, run};
pub use scenarios::{NAMES, Options, build};
