//! Reactive motion generation with dynamical systems (thesis Sec. 5.1.1, 5.1.3, A.2.2).
//!
//! The end effector follows ẋ = α_h M(x) f(x − g) + (I − M) ẋ_O: a stable first-order DS `f`
//! ([`primitive`]) towards a goal that may change at any time ([`goal`], eq. 5.2), scaled by the
//! human state ([`scaling`], eq. 5.3), modulated around the closest obstacle point
//! ([`modulation`], eq. 5.5–5.8, Algorithm 5). Multi-priority IK ([`ik`], eq. 5.13) turns it
//! into joint rates, avoiding the closest link point in the null space, and saturates joint
//! positions and speeds. [`DsController`] runs it all at 1 kHz with a stale-input watchdog and
//! never allocates in [`DsController::step`]. [`ttc`] is the task transition control of Sec.
//! 4.1.2 (a person's physical guidance blended with the primitive by force); [`tracker`] runs a
//! generated path (an HMM's, Sec. 4.1.3) as a learned field. No ROS dependency.
//!
//! Frames and units: robot base frame, m, rad, s.
//!
//! ```no_run
//! use cowork_ds::{ControlInput, ControlOutput, ControllerConfig, Distances, DsController,
//!     HumanInput, HumanState, MotionCommand, Primitive, primitive::ConstantSpeed};
//! use cowork_robot::{JointVector, RobotModel};
//! use nalgebra::Vector3;
//!
//! let model = RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let mut ctl = DsController::new(model, ControllerConfig::default())?;
//! let input = ControlInput {
//!     time: 0.0,
//!     q: JointVector::from_row_slice(&[0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0]),
//!     command: MotionCommand {
//!         id: 1,
//!         primitive: Primitive::ConstantSpeed(ConstantSpeed::new(0.3)),
//!         goal: Vector3::new(0.5, 0.2, 0.4),
//!         orientation: None,
//!         end_effector_avoidance: true,
//!     },
//!     distances: Distances::clear(0.0),
//!     human: HumanInput { stamp: 0.0, state: HumanState::default() },
//! };
//! let mut out = ControlOutput::default();
//! ctl.step(&input, &mut out)?; // send out.qdot (rad/s)
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod controller;
mod error;
pub mod goal;
pub mod ik;
pub mod modulation;
pub mod primitive;
pub mod safety;
pub mod scaling;
pub mod tracker;
pub mod ttc;

pub use controller::{
    ContactReport, ControlInput, ControlOutput, ControllerConfig, Diagnostics, Distances,
    DsController, ExternalWrench, HoldReason, HumanInput, LinkDistance, ModulationConfig,
    MotionCommand, Status, WrenchIgnored,
};
pub use error::{Error, Fault, Result, Stream};
pub use primitive::{FirstOrderDs, JointMove, LearnedField, Primitive};
pub use safety::{SafetyConfig, SafetyReport};
pub use scaling::{HumanMode, HumanState};
pub use tracker::PathTracker;
pub use ttc::{Contact, Stack, Ttc, TtcConfig, TtcReport};
