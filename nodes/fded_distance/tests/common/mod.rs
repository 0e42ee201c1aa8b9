//! One noise-free frame of a scene as lwr_sim renders it, for the node-handler tests.

use std::path::PathBuf;

use cowork_msgs::sensor_msgs::{CameraInfo, Image};
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use lwr_sim::depth::{DepthCamera, DepthConfig, DepthSnapshot, People};
use lwr_sim::{LwrSim, LwrSimConfig};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn model() -> RobotModel {
    RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF")
}

/// The bundled lwr_sim on `scene` (camera noise off) after 50 steps (0.05 s), and its depth
/// frame and camera info at that time.
pub fn rendered(scene: Scene) -> (LwrSim, Image, CameraInfo) {
    let mut config: LwrSimConfig = cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("params");
    config.depth = DepthConfig { noise: false, ..config.depth };
    let sim = Simulator::new(model(), scene, config.simulation.clone()).expect("sim");
    let mut camera = DepthCamera::new(&sim, &config.depth).expect("camera");
    let mut lwr = LwrSim::new(sim, config);
    for _ in 0..50 {
        lwr.step();
    }
    let mut snap = DepthSnapshot::default();
    snap.capture(lwr.simulator(), &People::new(-0.8, 0.5));
    let (mut image, mut info) = (Image::default(), CameraInfo::default());
    camera.render(&snap, &mut image, &mut info).expect("render");
    (lwr, image, info)
}
