//! Shared helpers of the crate tests.
#![allow(dead_code)]

use cowork_robot::{JointVector, RobotModel};
use rand::{Rng, SeedableRng};
use std::path::PathBuf;

/// `config/robot/lwr4plus.urdf` of this repository.
pub fn lwr_urdf() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf")
}

/// The hand-written non-LWR 7-DoF arm.
pub fn other_urdf() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/other_7dof/urdf/other_7dof.urdf")
}

pub fn lwr() -> RobotModel {
    RobotModel::from_urdf_file(lwr_urdf()).expect("LWR URDF loads")
}

pub fn other() -> RobotModel {
    RobotModel::from_urdf_file(other_urdf()).expect("other URDF loads")
}

pub fn rng(seed: u64) -> rand_chacha::ChaCha8Rng {
    rand_chacha::ChaCha8Rng::seed_from_u64(seed)
}

/// A configuration drawn uniformly within the limits (±π for continuous joints).
pub fn random_q(model: &RobotModel, rng: &mut impl Rng) -> JointVector {
    JointVector::from_fn(|i, _| {
        let l = model.joint_limits()[i];
        rng.random_range(l.lower.max(-std::f64::consts::PI)..l.upper.min(std::f64::consts::PI))
    })
}
