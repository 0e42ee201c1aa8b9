//! The topics every scenario bag carries, written through one [`Streams`] object.

use std::collections::BTreeMap;
use std::path::Path;

use cowork_bag::{BagWriter, ChannelId};
use cowork_msgs::RosMessage;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Quaternion, Transform, TransformStamped, Vector3};
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Header;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_sim::Simulator;
use nalgebra::Isometry3;

use crate::Result;

/// Topic names written by the synthesiser: the graph's names, from their one definition in
/// [`cowork_msgs::topics`].
pub mod topics {
    use cowork_msgs::topics as graph;
    /// rosgraph_msgs/Clock.
    pub const CLOCK: &str = graph::CLOCK.name;
    /// sensor_msgs/JointState.
    pub const JOINT_STATES: &str = graph::JOINT_STATES.name;
    /// tf2_msgs/TFMessage: links and objects.
    pub const TF: &str = graph::TF.name;
    /// tf2_msgs/TFMessage: the camera's optical frame, once at the start.
    pub const TF_STATIC: &str = graph::TF_STATIC.name;
    /// sensor_msgs/Image.
    pub const DEPTH_IMAGE: &str = graph::DEPTH_IMAGE.name;
    /// sensor_msgs/CameraInfo.
    pub const CAMERA_INFO: &str = graph::DEPTH_CAMERA_INFO.name;
    /// cowork_msgs/Skeleton.
    pub const SKELETON: &str = graph::SKELETON.name;
    /// geometry_msgs/WrenchStamped.
    pub const EXTERNAL_WRENCH: &str = graph::EXTERNAL_WRENCH.name;
    /// std_msgs/String.
    pub const SPEECH: &str = graph::SPEECH_COMMAND.name;
    /// std_msgs/String with a JSON gesture label (see the crate docs).
    pub const GESTURE_LABEL: &str = graph::GESTURE_LABEL.name;
}

/// Publication rates of the common streams, Hz of simulated time.
pub mod rates {
    /// `/clock` (bag replay drives the clock from the log times anyway).
    pub const CLOCK_HZ: f64 = 100.0;
    /// `/joint_states`.
    pub const JOINT_STATES_HZ: f64 = 100.0;
    /// `/tf` (as `lwr_sim`).
    pub const TF_HZ: f64 = 50.0;
    /// Depth camera (Kinect, Sec. 5.1.2).
    pub const DEPTH_HZ: f64 = 30.0;
    /// Xsens suit (Sec. 4.2).
    pub const XSENS_HZ: f64 = 120.0;
    /// `/external_wrench` during kinesthetic teaching.
    pub const WRENCH_HZ: f64 = 100.0;
}

/// Time of tick `k` of a `rate_hz` stream, ns (exact for integer rates, no drift).
pub fn tick_ns(k: u64, rate_hz: f64) -> i64 {
    (k as f64 * 1e9 / rate_hz).round() as i64
}

/// Yields the ticks of a fixed-rate stream that have become due.
#[derive(Debug, Clone)]
pub struct Ticker {
    rate_hz: f64,
    next: u64,
}

impl Ticker {
    /// A stream at `rate_hz` whose first tick is at t = 0.
    pub fn new(rate_hz: f64) -> Self {
        Self { rate_hz, next: 0 }
    }

    /// The next tick time if it is at or before `now_ns` (call repeatedly to drain).
    pub fn due(&mut self, now_ns: i64) -> Option<i64> {
        let t = tick_ns(self.next, self.rate_hz);
        (t <= now_ns).then(|| {
            self.next += 1;
            t
        })
    }
}

/// A bag being written: typed channels by topic, message counts, common conversions.
#[derive(Debug)]
pub struct Streams {
    bag: BagWriter,
    channels: BTreeMap<&'static str, ChannelId>,
    counts: BTreeMap<String, u64>,
    base_frame: String,
    joint_state: JointState,
}

impl Streams {
    /// Creates the bag at `path`; `sim` gives the joint names and the base frame.
    pub fn create(path: &Path, sim: &Simulator) -> Result<Self> {
        let model = sim.model();
        let names = model.joint_names().to_vec();
        let n = names.len();
        // Synthesised bags are written whole (no recorder to kill): size-bounded chunks only,
        // so the bundled bags keep their bytes.
        let mut bag = BagWriter::create(path)?;
        bag.set_chunk_span(None)?;
        Ok(Self {
            bag,
            channels: BTreeMap::new(),
            counts: BTreeMap::new(),
            base_frame: model.link_names()[0].clone(),
            joint_state: JointState {
                name: names,
                position: vec![0.0; n],
                velocity: vec![0.0; n],
                ..Default::default()
            },
        })
    }

    /// The robot base frame (frame of `/tf`, skeletons and wrenches).
    pub fn base_frame(&self) -> &str {
        &self.base_frame
    }

    /// Writes `msg` on `topic` with log and publish time `t_ns` (sim time).
    pub fn write<T: RosMessage>(&mut self, topic: &'static str, t_ns: i64, msg: &T) -> Result<()> {
        let channel = match self.channels.get(topic) {
            Some(c) => *c,
            None => {
                let c = self.bag.add_channel::<T>(topic)?;
                self.channels.insert(topic, c);
                c
            }
        };
        let t = u64::try_from(t_ns).unwrap_or(0);
        self.bag.write(channel, t, t, msg)?;
        *self.counts.entry(topic.to_owned()).or_default() += 1;
        Ok(())
    }

    /// `/clock` at `t_ns`.
    pub fn clock(&mut self, t_ns: i64) -> Result<()> {
        self.write(topics::CLOCK, t_ns, &Clock { clock: Time::from_nanos(t_ns) })
    }

    /// `/joint_states` from the simulator state, stamped `t_ns`.
    pub fn joint_states(&mut self, t_ns: i64, sim: &Simulator) -> Result<()> {
        self.joint_state.header.stamp = Time::from_nanos(t_ns);
        self.joint_state.position.copy_from_slice(sim.joint_positions().as_slice());
        self.joint_state.velocity.copy_from_slice(sim.joint_velocities().as_slice());
        let msg = self.joint_state.clone();
        self.write(topics::JOINT_STATES, t_ns, &msg)
    }

    /// `/tf`: the link tree (each link in its parent's frame) and every object in the base
    /// frame (as `lwr_sim`).
    pub fn tf(&mut self, t_ns: i64, sim: &Simulator) -> Result<()> {
        let stamp = Time::from_nanos(t_ns);
        let base = &self.base_frame;
        let transforms = sim.frame_tree().map(|e| transform(e.parent.unwrap_or(base), e.child, stamp, &e.pose)).collect();
        let msg = TFMessage { transforms };
        self.write(topics::TF, t_ns, &msg)
    }

    /// `/tf_static`: the camera's optical frame in the base frame.
    pub fn tf_static(&mut self, t_ns: i64, sim: &Simulator) -> Result<()> {
        let camera = &sim.scene().camera;
        let msg = TFMessage {
            transforms: vec![transform(
                &self.base_frame,
                &camera.frame_id,
                Time::from_nanos(t_ns),
                &camera.pose.isometry(),
            )],
        };
        self.write(topics::TF_STATIC, t_ns, &msg)
    }

    /// Finishes the file; returns the message count per topic.
    pub fn finish(self) -> Result<BTreeMap<String, u64>> {
        self.bag.finish()?;
        Ok(self.counts)
    }
}

/// A `TransformStamped` `parent ← child` from a pose of `child` in `parent`.
pub fn transform(parent: &str, child: &str, stamp: Time, pose: &Isometry3<f64>) -> TransformStamped {
    let t = &pose.translation.vector;
    let q = pose.rotation.quaternion();
    TransformStamped {
        header: Header { stamp, frame_id: parent.to_owned() },
        child_frame_id: child.to_owned(),
        transform: Transform {
            translation: Vector3 { x: t.x, y: t.y, z: t.z },
            rotation: Quaternion { x: q.i, y: q.j, z: q.k, w: q.w },
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticker_yields_each_tick_once_in_order() {
        let mut t = Ticker::new(30.0);
        let mut got = Vec::new();
        for now in (0..=1_000_000_000).step_by(1_000_000) {
            while let Some(s) = t.due(now) {
                got.push(s);
            }
        }
        assert_eq!(got.len(), 31);
        assert_eq!(got[1], 33_333_333);
        assert_eq!(got[30], 1_000_000_000);
    }
}
