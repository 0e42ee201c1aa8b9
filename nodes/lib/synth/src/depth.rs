//! The depth camera of a scenario bag: `/camera/depth/image_raw` (16UC1 mm) and
//! `/camera/depth/camera_info` at 30 Hz, rendered by [`cowork_depth::DepthRenderer`] from the
//! simulator's joints and objects, the people's capsule bodies and the floor they stand on.

use cowork_depth::{Capsule, DepthImage, DepthRenderer, Encoding, Floor, Intrinsics, KinectNoise};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::sensor_msgs::{CameraInfo, Image};
use cowork_sim::Simulator;

use crate::Result;
use crate::streams::{Streams, Ticker, rates, topics};

/// Encoding of the depth frames in synthesised bags: the Kinect's native 16-bit millimetres
/// (half the size of `32FC1`, and it compresses better).
pub const DEPTH_ENCODING: Encoding = Encoding::U16Millimetres;

/// Renderer, buffers and ticker of the depth stream.
#[derive(Debug)]
pub(crate) struct DepthRig {
    renderer: DepthRenderer,
    image: DepthImage,
    msg: Image,
    info: CameraInfo,
    frame_id: String,
    ticker: Ticker,
}

impl DepthRig {
    /// A camera as configured in the simulator's scene; Kinect noise drawn from `seed` if `noise`.
    pub fn new(sim: &Simulator, seed: u64, noise: bool) -> Result<Self> {
        let mut renderer = DepthRenderer::new(sim.model(), sim.scene())?;
        renderer.set_noise(noise.then(|| KinectNoise::with_seed(seed)))?;
        renderer.set_floor(Some(Floor::at(cowork_people::DEFAULT_FLOOR_Z)))?;
        let c = &sim.scene().camera;
        let intrinsics = Intrinsics { width: c.width, height: c.height, fx: c.fx, fy: c.fy, cx: c.cx, cy: c.cy };
        Ok(Self {
            renderer,
            image: DepthImage::default(),
            msg: Image::default(),
            info: intrinsics.to_camera_info(Time::default(), &c.frame_id),
            frame_id: c.frame_id.clone(),
            ticker: Ticker::new(rates::DEPTH_HZ),
        })
    }

    /// Next frame time due at or before `now_ns`.
    pub fn due(&mut self, now_ns: i64) -> Option<i64> {
        self.ticker.due(now_ns)
    }

    /// Renders the simulator's robot and objects with `people` and writes image + camera info
    /// stamped `t_ns`.
    pub fn write_frame(&mut self, streams: &mut Streams, t_ns: i64, sim: &Simulator, people: &[Capsule]) -> Result<()> {
        self.renderer.render(sim.joint_positions(), sim.objects(), people, &mut self.image)?;
        let stamp = Time::from_nanos(t_ns);
        self.image.write_image_msg(stamp, &self.frame_id, DEPTH_ENCODING, &mut self.msg);
        streams.write(topics::DEPTH_IMAGE, t_ns, &self.msg)?;
        self.info.header.stamp = stamp;
        streams.write(topics::CAMERA_INFO, t_ns, &self.info)
    }
}

/// The capsule body of every person of `timeline` present at `t` s, for the renderer.
pub(crate) fn people_capsules(timeline: &cowork_people::Timeline, t: f64, out: &mut Vec<Capsule>) {
    out.clear();
    for (_, pose) in timeline.poses_at(t) {
        out.extend(
            cowork_people::body_capsules(&pose)
                .iter()
                .map(|c| Capsule::new(c.a, c.b, c.radius)),
        );
    }
}
