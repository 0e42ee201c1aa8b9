//! Robot description (URDF + link meshes) and allocation-free kinematics for 7-DoF serial arms.
//!
//! [`RobotModel`] loads the serial chain from a URDF's root link to its tip (the deepest link,
//! or one named) with exactly [`DOF`] revolute/continuous joints; fixed joints become constant
//! link offsets and their child links stay in the chain (tool frames). Nothing about a
//! particular arm is built in: the bundled KUKA LWR IV+ description lives in
//! `config/robot/lwr4plus.urdf` and any other 7-DoF serial URDF loads the same way.
//!
//! Frames and units: the base frame is the URDF root link frame; link frames are the URDF link
//! frames; lengths in m, angles in rad, rates in rad/s. [`Jacobian`] rows are linear velocity
//! (0..3) then angular velocity (3..6), both in the base frame.
//!
//! Meshes: each chain link's `<collision>` geometry (its `<visual>` when there is no collision
//! element) is merged into one [`TriMesh`] in the link frame. Mesh files must be STL. A
//! relative `filename` resolves against the URDF's directory; `package://PKG/REST` resolves to
//! `<URDF dir>/REST` if that exists, else to `<URDF dir>/../REST` (URDF in `PKG/urdf/`).
//! Box, cylinder, capsule and sphere primitives are tessellated.
//!
//! ```no_run
//! use cowork_robot::{damped_pseudo_inverse, Jacobian, JointVector, LinkPoses, RobotModel};
//! use nalgebra::Point3;
//!
//! let model = RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let q = JointVector::from_row_slice(&[0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0]);
//! let mut poses = LinkPoses::new();
//! model.forward_kinematics(&q, &mut poses);
//! let tip = model.tip_link();
//! let mut jac = Jacobian::zeros();
//! model.jacobian(&poses, tip, &Point3::origin(), &mut jac);
//! let pinv = damped_pseudo_inverse(&jac, 0.01);
//! println!("tip at {} m; J† is {}×{}", poses.get(tip).translation.vector, pinv.nrows(), pinv.ncols());
//! # Ok::<(), cowork_robot::Error>(())
//! ```

mod error;
mod linalg;
mod mesh;
mod model;
mod urdf;

pub use error::{Error, Result};
pub use linalg::{damped_pseudo_inverse, damped_pseudo_inverse_3, null_space_projector};
pub use mesh::TriMesh;
pub use model::{
    DOF, Jacobian, JacobianPinv, JointLimit, JointMatrix, JointVector, LinkPoses, MAX_LINKS,
    PositionJacobian, PositionJacobianPinv, RobotModel,
};
