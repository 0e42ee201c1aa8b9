//! Sampling a timeline into `cowork_msgs/Skeleton` messages as an Xsens suit (120 Hz) or a
//! depth-camera tracker (30 Hz, dropped frames, jittery capture times) would deliver them.

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::Skeleton;
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::error::{Result, check_range};
use crate::performer::Timeline;
use crate::pose::{MessageMeta, SkeletonPose};

/// The robot base frame of `config/robot/lwr4plus.urdf` (the frame `lwr_sim` publishes in).
pub const BASE_FRAME: &str = "lwr_base_link";

/// Kind of skeleton source.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Xsens motion-capture suit (thesis Sec. 4.2).
    Xsens,
    /// Depth-camera skeleton tracker (thesis Sec. 5.1.3, Kinect at 30 Hz).
    DepthTracker,
}

impl Source {
    /// The `Skeleton.source` string.
    pub fn as_str(self) -> &'static str {
        match self {
            Source::Xsens => Skeleton::SOURCE_XSENS,
            Source::DepthTracker => Skeleton::SOURCE_DEPTH_TRACKER,
        }
    }
}

/// How the skeleton is measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorConfig {
    /// Source written in the messages.
    pub source: Source,
    /// Sample rate (Hz, 1 to 1000).
    pub rate_hz: f64,
    /// Standard deviation of the additive Gaussian position noise, per axis and segment (m).
    pub position_noise_m: f64,
    /// Standard deviation of the orientation noise, per rotation-vector axis (rad).
    pub orientation_noise_rad: f64,
    /// Standard deviation of the linear-velocity noise, per axis (m/s).
    pub linear_velocity_noise: f64,
    /// Standard deviation of the angular-velocity noise, per axis (rad/s).
    pub angular_velocity_noise: f64,
    /// Probability that a frame is lost (0 to 0.9).
    pub drop_probability: f64,
    /// Standard deviation of the capture-time jitter (s, clipped to ±0.45 sample periods); the
    /// stamp is the capture time.
    pub stamp_jitter_s: f64,
    /// `header.frame_id`.
    pub frame_id: String,
    /// Fill `velocities`.
    pub with_velocities: bool,
    /// Added to every stamp (s): the timeline's zero on the message clock.
    pub time_offset_s: f64,
}

impl SensorConfig {
    /// Xsens suit: 120 Hz, 4 mm and 0.6° noise, no lost frames, velocities filled.
    pub fn xsens() -> Self {
        Self {
            source: Source::Xsens,
            rate_hz: 120.0,
            position_noise_m: 0.004,
            orientation_noise_rad: 0.01,
            linear_velocity_noise: 0.02,
            angular_velocity_noise: 0.05,
            drop_probability: 0.0,
            stamp_jitter_s: 0.0,
            frame_id: BASE_FRAME.to_owned(),
            with_velocities: true,
            time_offset_s: 0.0,
        }
    }

    /// Depth tracker: 30 Hz, 15 mm and 3° noise, 3 % lost frames, 4 ms capture jitter,
    /// velocities filled (from the tracker's filter).
    pub fn depth_tracker() -> Self {
        Self {
            source: Source::DepthTracker,
            rate_hz: 30.0,
            position_noise_m: 0.015,
            orientation_noise_rad: 0.05,
            linear_velocity_noise: 0.05,
            angular_velocity_noise: 0.2,
            drop_probability: 0.03,
            stamp_jitter_s: 0.004,
            ..Self::xsens()
        }
    }

    /// The same sensor without noise, lost frames or jitter.
    pub fn noiseless(mut self) -> Self {
        self.position_noise_m = 0.0;
        self.orientation_noise_rad = 0.0;
        self.linear_velocity_noise = 0.0;
        self.angular_velocity_noise = 0.0;
        self.drop_probability = 0.0;
        self.stamp_jitter_s = 0.0;
        self
    }

    /// Rejects NaN and out-of-range values.
    pub fn validate(&self) -> Result<()> {
        check_range("sensor rate_hz", self.rate_hz, 1.0, 1000.0, "1 to 1000 Hz")?;
        check_range("sensor position_noise_m", self.position_noise_m, 0.0, 1.0, "0 to 1 m")?;
        check_range("sensor orientation_noise_rad", self.orientation_noise_rad, 0.0, 1.0, "0 to 1 rad")?;
        check_range("sensor linear_velocity_noise", self.linear_velocity_noise, 0.0, 10.0, "0 to 10 m/s")?;
        check_range("sensor angular_velocity_noise", self.angular_velocity_noise, 0.0, 10.0, "0 to 10 rad/s")?;
        check_range("sensor drop_probability", self.drop_probability, 0.0, 0.9, "0 to 0.9")?;
        check_range("sensor stamp_jitter_s", self.stamp_jitter_s, 0.0, 1.0, "0 to 1 s")?;
        check_range("sensor time_offset_s", self.time_offset_s, 0.0, 4e9, "0 to 4e9 s")
    }
}

/// SplitMix64 finaliser: decorrelates seeds built from (seed, tick, person).
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Iterator over the skeleton messages of a timeline, in stamp order (one per present person
/// per kept frame). Frame `k` is captured at `k / rate_hz` (plus jitter); its noise and
/// drop decision come from a generator seeded by (seed, k, person), so a given seed always
/// gives the same messages.
#[derive(Debug)]
pub struct Sampler<'a> {
    timeline: &'a Timeline,
    config: SensorConfig,
    seed: u64,
    tick: u64,
    ticks: u64,
    pending: std::collections::VecDeque<Skeleton>,
}

impl<'a> Sampler<'a> {
    /// Samples `timeline` from 0 to its duration with `config`, noise drawn from `seed`.
    pub fn new(timeline: &'a Timeline, config: SensorConfig, seed: u64) -> Result<Self> {
        config.validate()?;
        let ticks = (timeline.duration() * config.rate_hz + 1e-9).floor() as u64 + 1;
        Ok(Self { timeline, config, seed, tick: 0, ticks, pending: Default::default() })
    }

    /// Number of frames (kept or dropped) the sampler walks through.
    pub fn frame_count(&self) -> u64 {
        self.ticks
    }

    fn frame(&mut self, k: u64) {
        let c = &self.config;
        let mut rng = ChaCha8Rng::seed_from_u64(mix(self.seed ^ mix(k)));
        if c.drop_probability > 0.0 && rng.random::<f64>() < c.drop_probability {
            return;
        }
        let period = 1.0 / c.rate_hz;
        let mut t = k as f64 * period;
        if c.stamp_jitter_s > 0.0 {
            let j = gauss(&mut rng, c.stamp_jitter_s).clamp(-0.45 * period, 0.45 * period);
            t = (t + j).max(0.0);
        }
        let stamp = Time::from_secs_f64(c.time_offset_s + t);
        for (person_id, mut pose) in self.timeline.poses_at(t) {
            let mut rng = ChaCha8Rng::seed_from_u64(mix(self.seed ^ mix(k) ^ mix(u64::from(person_id) << 40)));
            add_noise(&mut pose, c, &mut rng);
            let meta = MessageMeta {
                stamp,
                frame_id: &c.frame_id,
                source: c.source.as_str(),
                person_id,
                with_velocities: c.with_velocities,
            };
            self.pending.push_back(pose.to_message(&meta));
        }
    }
}

impl Iterator for Sampler<'_> {
    type Item = Skeleton;

    fn next(&mut self) -> Option<Skeleton> {
        while self.pending.is_empty() && self.tick < self.ticks {
            let k = self.tick;
            self.tick += 1;
            self.frame(k);
        }
        self.pending.pop_front()
    }
}

fn gauss(rng: &mut ChaCha8Rng, sigma: f64) -> f64 {
    match Normal::new(0.0, sigma) {
        Ok(n) => n.sample(rng),
        Err(_) => 0.0,
    }
}

fn gauss3(rng: &mut ChaCha8Rng, sigma: f64) -> Vector3<f64> {
    if sigma > 0.0 { Vector3::new(gauss(rng, sigma), gauss(rng, sigma), gauss(rng, sigma)) } else { Vector3::zeros() }
}

/// Adds the sensor's Gaussian noise to every segment of `pose`.
pub fn add_noise(pose: &mut SkeletonPose, c: &SensorConfig, rng: &mut ChaCha8Rng) {
    for s in pose.segments.iter_mut() {
        s.position += gauss3(rng, c.position_noise_m);
        s.orientation = UnitQuaternion::from_scaled_axis(gauss3(rng, c.orientation_noise_rad)) * s.orientation;
        s.linear_velocity += gauss3(rng, c.linear_velocity_noise);
        s.angular_velocity += gauss3(rng, c.angular_velocity_noise);
    }
}

/// All messages of `timeline` (see [`Sampler`]).
pub fn sample_timeline(timeline: &Timeline, config: SensorConfig, seed: u64) -> Result<Vec<Skeleton>> {
    Ok(Sampler::new(timeline, config, seed)?.collect())
}
