//! Kinematic simulator of a 7-DoF arm in a table-top scene.
//!
//! The simulator integrates joint velocity commands at a fixed step (1 ms by default) of
//! simulated time, saturates joint positions and velocities at the URDF limits, moves a
//! gripper that grasps the nearest graspable object within reach, carries held objects with
//! the hand, and turns external wrenches into admittance motion for kinesthetic teaching
//! (thesis eq. 4.6, `ẋ = c f`, with `c = 0.005 m/(N s)`).
//!
//! A scene names its one arm `robot:` (everything in that arm's base frame), or several arms
//! `arms:` (each a name, a base pose in the `world` frame and start joints; one model for all):
//! each arm then has its own command, wrench and gripper (`*_arm*` methods, by arm index; the
//! plain methods are the first arm's), a gripper never takes what another holds, and
//! [`Simulator::arm_clearance`] / [`ArmHulls`] give the closest pair of links of two arms.
//! Scenes whose arm bases overlap or whose arms intersect at their start joints are refused.
//!
//! It is deterministic: the same model, scene and input sequence give bit-identical states.
//! Time is kept in integer nanoseconds so that long runs do not drift.
//!
//! ```no_run
//! use cowork_robot::RobotModel;
//! use cowork_sim::{Scene, SimParams, Simulator};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let scene = Scene::from_file(std::path::Path::new("config/scenes/kitchen.yaml"))?;
//! let mut sim = Simulator::new(model, scene, SimParams::default())?;
//! sim.set_velocity_command(&[0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])?;
//! for _ in 0..1000 {
//!     sim.step();
//! }
//! println!("q1 after 1 s: {:.3} rad", sim.joint_positions()[0]);
//! # Ok(()) }
//! ```

mod error;
mod params;
mod scene;
mod simulator;

pub use error::{CommandError, Result, SimError};
pub use params::SimParams;
pub use scene::{ArmSetup, Camera, MIN_BASE_SEPARATION_M, Pose, RobotSetup, Scene, SceneObject, Shape};
pub use simulator::{Arm, ArmClearance, ArmHulls, FrameEdge, GripperState, ObjectState, Simulator, WORLD_FRAME, Wrench};
