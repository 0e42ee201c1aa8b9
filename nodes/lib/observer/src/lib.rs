//! The human observer of cowork (thesis Fig. 5.1, Sec. 3.2.1, 4.2, 5.1.3), with no ROS
//! dependency: from `cowork_msgs/Skeleton` frames (an Xsens suit's 11 segments at 120 Hz or a
//! depth-camera tracker at 30 Hz, both with the message's segment names),
//!
//! - per tracked person (`person_id`), checked frames ([`skeleton`]: missing or duplicate
//!   segments, NaN, non-unit quaternions, other frames, stamps going backwards are rejected and
//!   named; extra segments ignored), a constant-velocity Kalman filter on each hand
//!   ([`kalman`]) that can be asked where the hand is at any later time;
//! - the minimum distance between the person's capsule body and the robot's links at the
//!   current joint state, with the closest link ([`distance`]);
//! - far / interaction with hysteresis and α_h (0.3 m/s far, 0.1 m/s interaction, 0 after a
//!   stop gesture or the spoken `stop` until `come` or `repeat`) ([`mode`]);
//! - gestures recognised from unidirectional invariants (eq. 3.16–3.17) and body-frame arm
//!   posture over a 50-frame 30 Hz sliding window with DTW and k-NN with a rejection threshold,
//!   templates and threshold learned from labelled streams ([`features`], [`gesture`]);
//! - retargeting of the demonstrator's arm to robot joint targets (eq. 4.7, [`retarget`]).
//!
//! [`Observer`] puts it together message by message (no I/O, no clock of its own): the
//! `human_observer` node and `cowork observe` both drive it. Anything the speed depends on that
//! is missing or unusable makes the state fail closed (interaction speed, never faster).
//!
//! ```no_run
//! use cowork_observer::{Observer, ObserverConfig, GestureModel};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = cowork_robot::RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let gestures = GestureModel::from_file("config/gestures.json".as_ref())?;
//! let mut obs = Observer::new(model, ObserverConfig::default(), Some(gestures))?;
//! obs.on_joint_state(0.0, &[], &[0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0])?;
//! # let skeleton = cowork_msgs::msg::Skeleton::default();
//! let out = obs.on_skeleton(&skeleton);
//! println!("{:?} at {:.2} m, alpha_h {} m/s", out.state.mode, out.state.distance, out.state.speed_scale);
//! # Ok(()) }
//! ```
//!
//! Frames and units: robot base frame, m, s, rad.

pub mod distance;
mod error;
pub mod eval;
pub mod features;
pub mod gesture;
pub mod kalman;
pub mod mode;
mod observer;
pub mod retarget;
pub mod skeleton;

pub use error::{ObserverError, Result};
pub use gesture::{Classifier, Detection, GestureModel, GestureTracker, Label, LearnConfig, Learner, RecognitionConfig};
pub use kalman::{ConstantVelocityKf, Estimate, KalmanConfig};
pub use mode::{Mode, ModeConfig, SpeedGovernor};
pub use observer::{FrameOutcome, GestureReport, HumanOutput, Observer, ObserverConfig, Track};
pub use retarget::{RetargetConfig, Retargeted, Retargeter};
