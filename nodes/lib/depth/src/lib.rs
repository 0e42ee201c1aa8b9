//! Depth camera renderer (thesis Sec. 5.1.2, eq. 5.14): robot meshes, scene objects and people.
//!
//! * [`Intrinsics`]: the pin-hole model of eq. 5.14 (optical frame z forward, x right, y down;
//!   depth = optical-frame z in m), to and from `sensor_msgs/CameraInfo`.
//! * [`DepthImage`]: row-major `f32` depths in m, `0.0` = no return; to and from
//!   `sensor_msgs/Image` (`32FC1` m, `16UC1` mm) and to a colour-mapped PNG.
//! * [`Capsule`]: a body segment of a person (base frame), as the synthetic-people crate
//!   produces them.
//! * [`DepthRenderer`]: renders the table, scene objects, the robot's URDF link meshes at joint
//!   positions `q`, people capsules and optionally a [`Floor`], with a per-pixel [`Label`] (which link / object /
//!   person), optionally with [`KinectNoise`].
//!
//! ```no_run
//! use cowork_depth::{Capsule, DepthImage, DepthRenderer, KinectNoise};
//! use cowork_robot::{JointVector, RobotModel};
//! use cowork_sim::{Scene, Simulator, SimParams};
//! use nalgebra::Point3;
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let model = RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let scene = Scene::from_file(std::path::Path::new("config/scenes/stacking.yaml"))?;
//! let mut renderer = DepthRenderer::new(&model, &scene)?;
//! renderer.set_noise(Some(KinectNoise::with_seed(7)))?;
//! let sim = Simulator::new(model, scene, SimParams::default())?;
//! let person = [Capsule::new(Point3::new(0.6, 0.8, 0.0), Point3::new(0.6, 0.8, 1.4), 0.15)];
//! let mut depth = DepthImage::default();
//! renderer.render(sim.joint_positions(), sim.objects(), &person, &mut depth)?;
//! depth.write_png("out/depth.png")?;
//! # Ok(()) }
//! ```

mod capsule;
mod error;
mod image;
mod intrinsics;
mod noise;
mod raster;
mod render;

pub use capsule::Capsule;
pub use error::{Error, Result};
pub use image::{DepthImage, Encoding};
pub use intrinsics::Intrinsics;
pub use noise::KinectNoise;
pub use render::{DepthRenderer, Floor, Label, Layers, ObjectView, Table};
