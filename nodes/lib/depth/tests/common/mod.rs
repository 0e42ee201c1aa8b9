//! Shared fixtures of the renderer tests.
#![allow(dead_code)]

use std::path::PathBuf;

use cowork_robot::RobotModel;
use cowork_sim::Scene;

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

pub fn model() -> RobotModel {
    RobotModel::from_urdf_file(repo().join("config/robot/lwr4plus.urdf")).expect("bundled URDF loads")
}

pub fn scene(name: &str) -> Scene {
    Scene::from_file(&repo().join("config/scenes").join(name)).expect("bundled scene loads")
}
