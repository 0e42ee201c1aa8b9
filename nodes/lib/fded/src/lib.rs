//! fDED: fast robot–obstacle distance evaluation in the depth space (thesis Sec. 5.1.2).
//!
//! Per depth frame, [`Fded::process`] does work proportional to the robot points and the
//! lattice samples, never to the image's pixels:
//! 1. moves the **robot points** (every mesh vertex, plus points on long triangles so that no
//!    two neighbours are more than `robot_point_spacing` apart) to the camera frame and
//!    projects them (eq. 5.14), each labelled with its link;
//! 2. **removes the robot** at the object lattice samples only: a sample whose real depth is
//!    within δ = 5 cm of a link triangle covering it (grown by `robot_margin` px) is the robot;
//!    triangles come in chunks culled as a whole by facing, pixel box and depth;
//! 3. builds the **robot lattice** (per T_s × T_s tile and link, the robot point closest to the
//!    tile centre) and 4. the **object lattice** (every S_x-th column of every S_y-th row that
//!    is valid, not the table and not the robot);
//! 5. finds, per link, the closest lattice pair under the depth-space distance (eq. 5.15–5.16)
//!    with the gray area (eq. 5.17, ending at the table top); 6. **refines** it over every
//!    robot point of the winning tile (and, our addition, over the real depth around the
//!    winning object point, classifying only the pixels closer than the pair found);
//! 7. fits the obstacle **normal** by weighted least squares over L = 1 % of the image's points
//!    around the closest obstacle point (classifying only those with a weight), and the
//!    obstacle **velocity** from consecutive frames.
//!
//! The output ([`FdedOutput`]) is per link — distance, robot point, obstacle point, normal,
//! obstacle velocity, valid — plus the global minimum, all in the robot base frame. Buffers
//! ([`Buffers`]) are flat, `bytemuck`-friendly and sized once; with `threads = 1` a frame
//! allocates nothing after the first. The GPU path ([`gpu`]) shares stages 1–4, the
//! obstacle-side refinement and 7 with the CPU (host side) and runs 5–6 as compute shaders. The [`baseline`] module holds the brute force and
//! Flacco et al.'s sphere method for the benchmark.
//!
//! ```no_run
//! use cowork_depth::{DepthImage, Intrinsics};
//! use cowork_fded::{Fded, FdedParams, Frame};
//! use cowork_robot::RobotModel;
//! use nalgebra::{Isometry3, Vector3};
//!
//! let model = RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
//! let k = Intrinsics::kinect();
//! let mut fded = Fded::new(&model, &k, FdedParams::default())?;
//! let mut out = fded.new_output();
//! let depth = DepthImage::new(k.width, k.height);
//! let camera = Isometry3::face_towards(
//!     &[1.9, 0.0, 0.9].into(), &[0.45, 0.0, 0.2].into(), &-Vector3::z()); // optical y down
//! let q = [0.0; 7];
//! fded.process(&Frame { stamp: 0.0, depth: &depth, camera_pose: &camera, joints: Some(&q) }, &mut out)?;
//! if let Some(m) = out.minimum() {
//!     println!("closest: link {} at {:.3} m", m.link, m.distance);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod baseline;
#[cfg(feature = "bench")]
pub mod bench;
mod cam;
mod error;
pub mod gpu;
pub mod layout;
mod params;
mod pipeline;
mod raster;
mod stages;

pub use cam::Cam;
pub use error::{Error, Result};
pub use layout::{Buffers, LinkBest, NO_LINK, PixelBox, RobotPoint};
pub use params::{Backend, FdedParams};
pub use pipeline::{Fded, FdedOutput, Frame, FrameCounts, LinkDistance, StageTimes};
