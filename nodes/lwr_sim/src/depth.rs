//! The simulated depth camera of `lwr_sim`: renders the scene camera's view of the floor, the
//! table, the objects, the robot at the current joints and the people seen on `/human/skeleton`
//! (capsule bodies, see [`People`]), as `/camera/depth/image_raw` and
//! `/camera/depth/camera_info`.
//!
//! Threading: the 1 kHz loop only copies a [`DepthSnapshot`] (stamp, joints, object poses: no
//! allocation once warm) into a one-slot mailbox when a frame is due; a worker thread renders
//! the newest snapshot and publishes it. If rendering falls behind (e.g. `--max` pacing), older
//! snapshots are overwritten, so frames are dropped rather than the loop slowed; the count of
//! dropped frames is logged.

use std::sync::{Arc, Condvar, Mutex};

use anyhow::{Context, Result, bail};
use cowork_depth::{Capsule, DepthImage, DepthRenderer, Encoding, Floor, Intrinsics, KinectNoise};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::sensor_msgs::{CameraInfo, Image};
use cowork_people::{BODY_CAPSULE_COUNT, SkeletonPose, body_capsules};
use cowork_robot::JointVector;
use cowork_sim::{Shape, Simulator};
use nalgebra::Isometry3;
use serde::{Deserialize, Serialize};

/// The `depth:` block of the `lwr_sim` parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DepthConfig {
    /// Render and publish the depth camera.
    pub enabled: bool,
    /// `sensor_msgs/Image` encoding: `32FC1` (m, NaN = no return) or `16UC1` (mm, 0 = no return).
    pub encoding: String,
    /// Add Kinect-like noise (depth-dependent error, disparity quantisation, dropouts).
    pub noise: bool,
    /// Seed of the noise sequence.
    pub noise_seed: u64,
    /// Rasterise on all cores (rayon) instead of the worker thread alone.
    pub parallel: bool,
    /// Draw the floor (people stand on it).
    pub floor: bool,
    /// Height of the floor in the base frame, m (the robot stands on the table, z = 0 on its
    /// top); the synthetic people's floor by default.
    pub floor_height_m: f64,
    /// A person whose last `/human/skeleton` message is older than this (s of simulated
    /// time) is no longer drawn.
    pub person_timeout_s: f64,
}

impl Default for DepthConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            encoding: "32FC1".into(),
            noise: true,
            noise_seed: 1,
            parallel: false,
            floor: true,
            floor_height_m: cowork_people::DEFAULT_FLOOR_Z,
            person_timeout_s: 0.5,
        }
    }
}

/// The floor is at most this far above or below the table top, m.
pub const MAX_FLOOR_DISTANCE_M: f64 = 10.0;
/// Longest `depth.person_timeout_s`, s (a person is drawn at most this long after their last
/// skeleton).
pub const MAX_PERSON_TIMEOUT_S: f64 = 3600.0;

impl DepthConfig {
    /// Rejects a bad encoding, a floor height beyond [`MAX_FLOOR_DISTANCE_M`] and a timeout
    /// outside (0, [`MAX_PERSON_TIMEOUT_S`]], naming the key.
    pub fn validate(&self, place: &str) -> Result<()> {
        self.encoding(place)?;
        let z = self.floor_height_m;
        if !(z.is_finite() && z.abs() <= MAX_FLOOR_DISTANCE_M) {
            bail!("{place}: `depth.floor_height_m` = {z} must be in [-{MAX_FLOOR_DISTANCE_M}, {MAX_FLOOR_DISTANCE_M}] m");
        }
        let t = self.person_timeout_s;
        if !(t.is_finite() && t > 0.0 && t <= MAX_PERSON_TIMEOUT_S) {
            bail!("{place}: `depth.person_timeout_s` = {t} must be in (0, {MAX_PERSON_TIMEOUT_S}] s");
        }
        Ok(())
    }

    /// The encoding, checked.
    pub fn encoding(&self, place: &str) -> Result<Encoding> {
        match self.encoding.parse::<Encoding>() {
            Ok(e) => Ok(e),
            Err(_) => bail!("{place}: `depth.encoding` = {:?} must be \"32FC1\" or \"16UC1\"", self.encoding),
        }
    }
}

/// The simulator state a depth frame shows.
#[derive(Debug, Clone, Default)]
pub struct DepthSnapshot {
    /// Simulated time of the state.
    pub stamp: Time,
    /// Each arm's base pose (scene frame) and joint positions (rad), scene order.
    pub arms: Vec<(Isometry3<f64>, JointVector)>,
    /// Object shapes and poses (scene frame).
    pub objects: Vec<(Shape, Isometry3<f64>)>,
    /// Capsule bodies of the people (scene frame).
    pub people: Vec<Capsule>,
}

impl DepthSnapshot {
    /// Copies the simulator's current state and the people's bodies (reusing the buffers).
    pub fn capture(&mut self, sim: &Simulator, people: &People) {
        self.stamp = Time::from_nanos(sim.time_ns());
        self.arms.clear();
        self.arms.extend(sim.arms().iter().map(|a| (*a.base(), *a.joint_positions())));
        self.objects.clear();
        self.objects.extend(sim.objects().iter().map(|o| (o.shape, o.pose)));
        self.people.clear();
        self.people.extend(people.capsules());
    }
}

/// The people the camera sees: the capsule body (see [`cowork_people::body_capsules`]) of the
/// newest `/human/skeleton` message of each `person_id`, its body size measured from the
/// message's arms, feet on the floor. A person not heard of for the timeout is dropped.
#[derive(Debug, Clone)]
pub struct People {
    floor_z: f64,
    timeout_ns: i64,
    tracks: Vec<Track>,
    rejected: u64,
}

#[derive(Debug, Clone)]
struct Track {
    person_id: u32,
    /// Simulated time of the last message, ns.
    seen_ns: i64,
    body: [Capsule; BODY_CAPSULE_COUNT],
}

impl People {
    /// Nobody yet; feet on the floor at `floor_z` (m, base frame); a person is dropped
    /// `timeout_s` (simulated) after its last message.
    pub fn new(floor_z: f64, timeout_s: f64) -> Self {
        Self { floor_z, timeout_ns: (timeout_s * 1e9) as i64, tracks: Vec::new(), rejected: 0 }
    }

    /// Takes a skeleton received at simulated time `now_ns`. A malformed one (missing segment,
    /// NaN, lengths that disagree) is an error naming the problem, and changes nothing.
    pub fn update(&mut self, msg: &Skeleton, now_ns: i64) -> Result<()> {
        let pose = match SkeletonPose::from_message_measured(msg, self.floor_z) {
            Ok(p) => p,
            Err(e) => {
                self.rejected += 1;
                bail!("{} of person {}: {e}", cowork_msgs::topics::SKELETON.name, msg.person_id);
            }
        };
        let body = body_capsules(&pose);
        match self.tracks.iter_mut().find(|t| t.person_id == msg.person_id) {
            Some(t) => {
                t.seen_ns = now_ns;
                t.body = body;
            }
            None => self.tracks.push(Track { person_id: msg.person_id, seen_ns: now_ns, body }),
        }
        Ok(())
    }

    /// Drops the people not heard of for the timeout at simulated time `now_ns`.
    pub fn expire(&mut self, now_ns: i64) {
        let timeout = self.timeout_ns;
        self.tracks.retain(|t| now_ns.saturating_sub(t.seen_ns) <= timeout);
    }

    /// Ids of the people drawn now.
    pub fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.tracks.iter().map(|t| t.person_id)
    }

    /// Every capsule of every person, base frame.
    pub fn capsules(&self) -> impl Iterator<Item = Capsule> + '_ {
        self.tracks.iter().flat_map(|t| t.body.iter().copied())
    }

    /// Messages refused so far.
    pub fn rejected(&self) -> u64 {
        self.rejected
    }
}

/// Renders snapshots into depth messages.
#[derive(Debug)]
pub struct DepthCamera {
    renderer: DepthRenderer,
    encoding: Encoding,
    frame_id: String,
    intrinsics: Intrinsics,
    depth: DepthImage,
}

impl DepthCamera {
    /// A camera for the simulator's scene camera (`scene.camera`: intrinsics, pose, frame id).
    pub fn new(sim: &Simulator, config: &DepthConfig) -> Result<Self> {
        let encoding = config.encoding("depth parameters")?;
        let mut renderer = DepthRenderer::new(sim.model(), sim.scene()).context("depth camera of the scene")?;
        renderer.set_parallel(config.parallel);
        if config.floor {
            renderer.set_floor(Some(Floor::at(config.floor_height_m)))?;
        }
        if config.noise {
            renderer.set_noise(Some(KinectNoise::with_seed(config.noise_seed)))?;
        }
        Ok(Self {
            intrinsics: *renderer.intrinsics(),
            renderer,
            encoding,
            frame_id: sim.scene().camera.frame_id.clone(),
            depth: DepthImage::default(),
        })
    }

    /// Renders `snap` into `image` and fills `info` (both stamped with the snapshot's time, in
    /// the camera's optical frame), reusing their buffers.
    pub fn render(&mut self, snap: &DepthSnapshot, image: &mut Image, info: &mut CameraInfo) -> Result<()> {
        self.renderer.render_arms(&snap.arms, &snap.objects, &snap.people, &mut self.depth)?;
        self.depth.write_image_msg(snap.stamp, &self.frame_id, self.encoding, image);
        *info = self.intrinsics.to_camera_info(snap.stamp, &self.frame_id);
        Ok(())
    }

    /// The renderer (e.g. for its labels).
    pub fn renderer(&self) -> &DepthRenderer {
        &self.renderer
    }
}

/// One-slot, newest-wins mailbox from the simulation loop to the depth worker.
#[derive(Debug, Default)]
pub struct Mailbox {
    slot: Mutex<Slot>,
    ready: Condvar,
}

#[derive(Debug, Default)]
struct Slot {
    /// The snapshot to render next, if any.
    next: Option<DepthSnapshot>,
    /// A buffer handed back by the worker for reuse.
    spare: Option<DepthSnapshot>,
    /// Snapshots overwritten before the worker took them.
    dropped: u64,
    closed: bool,
}

impl Mailbox {
    /// A shared mailbox.
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// Posts the simulator's current state and the people (replacing an untaken snapshot).
    /// Called from the loop.
    pub fn post(&self, sim: &Simulator, people: &People) {
        let Ok(mut slot) = self.slot.lock() else { return };
        let mut snap = match slot.next.take() {
            Some(old) => {
                slot.dropped += 1;
                old
            }
            None => slot.spare.take().unwrap_or_default(),
        };
        snap.capture(sim, people);
        slot.next = Some(snap);
        drop(slot);
        self.ready.notify_one();
    }

    /// Posts a snapshot captured by the loop (replacing an untaken one).
    pub fn post_snapshot(&self, snap: DepthSnapshot) {
        let Ok(mut slot) = self.slot.lock() else { return };
        if slot.next.replace(snap).is_some() {
            slot.dropped += 1;
        }
        drop(slot);
        self.ready.notify_one();
    }

    /// Waits for the next snapshot; `None` once closed. `done` is the previous snapshot, given
    /// back for reuse.
    pub fn take(&self, done: Option<DepthSnapshot>) -> Option<DepthSnapshot> {
        let mut slot = self.slot.lock().ok()?;
        if done.is_some() {
            slot.spare = done;
        }
        loop {
            if slot.closed {
                return None;
            }
            if let Some(s) = slot.next.take() {
                return Some(s);
            }
            slot = self.ready.wait(slot).ok()?;
        }
    }

    /// Frames dropped so far because the worker was busy.
    pub fn dropped(&self) -> u64 {
        self.slot.lock().map(|s| s.dropped).unwrap_or(0)
    }

    /// Wakes the worker for good.
    pub fn close(&self) {
        if let Ok(mut slot) = self.slot.lock() {
            slot.closed = true;
        }
        self.ready.notify_all();
    }
}

/// Simulated-time schedule of the camera: frame `k` is due at the first step at or after
/// `k / rate_hz`.
#[derive(Debug, Clone, Copy)]
pub struct FrameClock {
    period_ns: f64,
    next_frame: u64,
}

impl FrameClock {
    /// A clock at `rate_hz` (> 0), first frame at time 0.
    pub fn new(rate_hz: f64) -> Self {
        Self { period_ns: 1e9 / rate_hz, next_frame: 0 }
    }

    /// `true` (once per frame) when a frame is due at simulated time `time_ns`.
    pub fn due(&mut self, time_ns: i64) -> bool {
        let at = (self.next_frame as f64 * self.period_ns).round() as i64;
        if time_ns >= at {
            // Skip frames a jump in time passed over.
            self.next_frame = (time_ns as f64 / self.period_ns).floor() as u64 + 1;
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_clock_gives_30_frames_per_simulated_second() {
        let mut c = FrameClock::new(30.0);
        let due: Vec<i64> = (1..1000).map(|ms| ms * 1_000_000).filter(|t| c.due(*t)).collect();
        assert_eq!(due.len(), 30);
        assert_eq!(due[0], 1_000_000);
        assert_eq!(due[1], 34_000_000);
        assert_eq!(due[2], 67_000_000);
    }

    #[test]
    fn config_encoding_is_checked() {
        let c = DepthConfig { encoding: "16UC1".into(), ..Default::default() };
        assert_eq!(c.encoding("f").unwrap(), Encoding::U16Millimetres);
        let c = DepthConfig { encoding: "rgb8".into(), ..Default::default() };
        let err = c.encoding("config/lwr_sim.yaml").unwrap_err().to_string();
        assert!(err.contains("depth.encoding") && err.contains("rgb8"), "{err}");
    }
}
