//! The gesture descriptor (thesis Sec. 3.2.1, 5.1.3): a 30 Hz window of 50 frames of the
//! torso (sternum), right shoulder, elbow and hand, each frame described by
//!
//! - the unidirectional invariants of eq. 3.16–3.17, `γ = ‖v × v̇‖/‖v‖²` and
//!   `ξ = ‖ω × ω̇‖/‖ω‖²`, of the four segments ([`cowork_motion::invariants::unidirectional`]),
//!   bounded by `(2/π) atan(·/invariant_scale)` and weighted by the segment's speed saliency
//!   `s/(s + saliency_speed)`: a still segment's velocity is sensor noise and its curvature is
//!   meaningless, so it must not dominate the distance;
//! - the hand and elbow positions in the sternum frame divided by the person's arm length
//!   (upper arm + forearm) and the hand's finger and palm directions in the sternum frame: also
//!   invariant to where the person stands, which way they face and their size, and they tell
//!   apart the two held postures (stop: arm up, palm out; handover: forearm forward, palm up)
//!   whose invariants are both "nothing moves".
//!
//! Sources at other rates (Xsens 120 Hz, a tracker that drops frames or jitters) are resampled
//! onto the 30 Hz grid `t_k = k / rate_hz` by linear interpolation (positions, velocities) and
//! normalised linear interpolation (orientations) between the two neighbouring frames; a gap
//! longer than `max_gap_s` restarts the window.

use std::collections::VecDeque;

use cowork_motion::invariants::unidirectional;
use cowork_people::{Segment, SkeletonPose};
use nalgebra::{Point3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{Result, check};

/// Segments whose invariants are used: torso (sternum), right shoulder, elbow, hand.
pub const INVARIANT_SEGMENTS: [Segment; 4] = [Segment::Sternum, Segment::RightShoulder, Segment::RightElbow, Segment::RightHand];

/// Columns per frame: 8 invariants, hand and elbow position, finger and palm directions.
pub const FEATURE_DIM: usize = 20;

/// How windows are cut and described.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FeatureConfig {
    /// Rate of the window's grid, Hz (the thesis's 30 Hz tracker).
    pub rate_hz: f64,
    /// Frames per window (thesis: 50).
    pub window: usize,
    /// A gap between two frames of a person longer than this restarts the window, s.
    pub max_gap_s: f64,
    /// Scale of the invariants before bounding, 1/s.
    pub invariant_scale: f64,
    /// Speed at which a segment's invariants count half, m/s (angular: this × 10 rad/s).
    pub saliency_speed: f64,
    /// Weight of the 8 invariant columns.
    pub invariant_weight: f64,
    /// Weight of the 6 position columns.
    pub position_weight: f64,
    /// Weight of the 6 direction columns.
    pub direction_weight: f64,
}

impl Default for FeatureConfig {
    fn default() -> Self {
        Self {
            rate_hz: 30.0,
            window: 50,
            max_gap_s: 0.25,
            invariant_scale: 4.0,
            saliency_speed: 0.15,
            invariant_weight: 0.5,
            position_weight: 1.0,
            direction_weight: 0.5,
        }
    }
}

impl FeatureConfig {
    /// Rejects NaN and out-of-range values.
    pub fn validate(&self, place: &str) -> Result<()> {
        check(&format!("{place}rate_hz"), self.rate_hz, 1.0, 1000.0, "must be in [1, 1000] Hz")?;
        check(&format!("{place}window"), self.window as f64, 5.0, 1000.0, "must be 5 to 1000 frames")?;
        check(&format!("{place}max_gap_s"), self.max_gap_s, 1e-3, 10.0, "must be in [0.001, 10] s")?;
        check(&format!("{place}invariant_scale"), self.invariant_scale, 1e-6, 1e6, "must be > 0")?;
        check(&format!("{place}saliency_speed"), self.saliency_speed, 1e-6, 100.0, "must be > 0 m/s")?;
        check(&format!("{place}invariant_weight"), self.invariant_weight, 0.0, 1e3, "must be in [0, 1000]")?;
        check(&format!("{place}position_weight"), self.position_weight, 0.0, 1e3, "must be in [0, 1000]")?;
        check(&format!("{place}direction_weight"), self.direction_weight, 0.0, 1e3, "must be in [0, 1000]")
    }

    /// Grid period, s.
    pub fn period(&self) -> f64 {
        1.0 / self.rate_hz
    }

    /// Window length, s.
    pub fn duration(&self) -> f64 {
        (self.window - 1) as f64 * self.period()
    }
}

/// What a frame contributes to a window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Stamp, s.
    pub stamp: f64,
    /// Positions of [`INVARIANT_SEGMENTS`], m.
    pub position: [Point3<f64>; 4],
    /// Orientations of [`INVARIANT_SEGMENTS`].
    pub orientation: [UnitQuaternion<f64>; 4],
    /// Linear velocities, m/s (zero when not measured).
    pub linear: [Vector3<f64>; 4],
    /// Angular velocities, rad/s (zero when not measured).
    pub angular: [Vector3<f64>; 4],
    /// The source measured velocities.
    pub has_velocity: bool,
    /// Upper arm + forearm of the person, m.
    pub arm: f64,
}

impl Sample {
    /// The sample of `pose` at `stamp`; `has_velocity` when the message carried velocities.
    pub fn from_pose(pose: &SkeletonPose, stamp: f64, has_velocity: bool) -> Self {
        let l = pose.body.lengths();
        let seg = |i: usize| pose.segment(INVARIANT_SEGMENTS[i]);
        Self {
            stamp,
            position: std::array::from_fn(|i| seg(i).position),
            orientation: std::array::from_fn(|i| seg(i).orientation),
            linear: std::array::from_fn(|i| seg(i).linear_velocity),
            angular: std::array::from_fn(|i| seg(i).angular_velocity),
            has_velocity,
            arm: l.upper_arm + l.forearm,
        }
    }

    fn lerp(&self, other: &Sample, t: f64, stamp: f64) -> Sample {
        Sample {
            stamp,
            position: std::array::from_fn(|i| self.position[i] + (other.position[i] - self.position[i]) * t),
            orientation: std::array::from_fn(|i| {
                let b = if self.orientation[i].coords.dot(&other.orientation[i].coords) < 0.0 {
                    UnitQuaternion::new_unchecked(-other.orientation[i].into_inner())
                } else {
                    other.orientation[i]
                };
                self.orientation[i].nlerp(&b, t)
            }),
            linear: std::array::from_fn(|i| self.linear[i].lerp(&other.linear[i], t)),
            angular: std::array::from_fn(|i| self.angular[i].lerp(&other.angular[i], t)),
            has_velocity: self.has_velocity && other.has_velocity,
            arm: self.arm + (other.arm - self.arm) * t,
        }
    }
}

/// The last `window` samples of one person on the grid.
#[derive(Clone, Debug)]
pub struct Window {
    config: FeatureConfig,
    last: Option<Sample>,
    next_tick: i64,
    grid: VecDeque<Sample>,
    generation: u64,
}

impl Window {
    /// An empty window.
    pub fn new(config: FeatureConfig) -> Result<Self> {
        config.validate("features.")?;
        let n = config.window;
        Ok(Self { config, last: None, next_tick: i64::MIN, grid: VecDeque::with_capacity(n + 1), generation: 0 })
    }

    /// The configuration.
    pub fn config(&self) -> &FeatureConfig {
        &self.config
    }

    /// Empties the window.
    pub fn clear(&mut self) {
        self.last = None;
        self.grid.clear();
        self.next_tick = i64::MIN;
        self.generation += 1;
    }

    /// Incremented every time the window restarts (a gap, a clear): grid samples of different
    /// generations are not contiguous.
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// The newest `n` grid samples, oldest first (fewer if the window holds fewer).
    pub fn latest(&self, n: usize) -> impl Iterator<Item = &Sample> {
        self.grid.iter().skip(self.grid.len().saturating_sub(n))
    }

    /// Adds a frame (stamps must increase; the caller checks); returns how many grid samples it
    /// completed (0 to many: a 120 Hz source completes one every fourth frame).
    pub fn push(&mut self, s: Sample) -> usize {
        let period = self.config.period();
        let Some(prev) = self.last else {
            self.last = Some(s);
            self.next_tick = (s.stamp / period).ceil() as i64;
            return 0;
        };
        if s.stamp - prev.stamp > self.config.max_gap_s || s.stamp <= prev.stamp {
            self.clear();
            self.last = Some(s);
            self.next_tick = (s.stamp / period).ceil() as i64;
            return 0;
        }
        let mut added = 0;
        loop {
            let t = self.next_tick as f64 * period;
            if t > s.stamp {
                break;
            }
            if t >= prev.stamp {
                let f = (t - prev.stamp) / (s.stamp - prev.stamp);
                if self.grid.len() == self.config.window {
                    self.grid.pop_front();
                }
                self.grid.push_back(prev.lerp(&s, f, t));
                added += 1;
            }
            self.next_tick += 1;
        }
        self.last = Some(s);
        added
    }

    /// Whether the window holds `window` grid samples.
    pub fn is_full(&self) -> bool {
        self.grid.len() == self.config.window
    }

    /// Stamp of the newest grid sample, s.
    pub fn end_stamp(&self) -> Option<f64> {
        self.grid.back().map(|s| s.stamp)
    }

    /// The descriptor of the full window (`window × FEATURE_DIM`, row-major), `None` until full.
    pub fn descriptor(&self) -> Option<Vec<f64>> {
        if !self.is_full() {
            return None;
        }
        let samples: Vec<Sample> = self.grid.iter().copied().collect();
        describe(&samples, &self.config)
    }
}

fn smooth(u: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let n = u.len();
    (0..n).map(|i| (u[i.saturating_sub(1)] + 2.0 * u[i] + u[(i + 1).min(n - 1)]) / 4.0).collect()
}

/// Velocities of segment `k` over `s`: the measured ones, or central differences of the grid.
fn velocities(s: &[Sample], k: usize, dt: f64) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    if s.iter().all(|x| x.has_velocity) {
        return (s.iter().map(|x| x.linear[k]).collect(), s.iter().map(|x| x.angular[k]).collect());
    }
    let n = s.len();
    let idx = |i: usize| (i.saturating_sub(1), (i + 1).min(n - 1));
    let lin = (0..n)
        .map(|i| {
            let (a, b) = idx(i);
            (s[b].position[k] - s[a].position[k]) / (dt * (b - a).max(1) as f64)
        })
        .collect();
    let ang = (0..n)
        .map(|i| {
            let (a, b) = idx(i);
            (s[b].orientation[k] * s[a].orientation[k].inverse()).scaled_axis() / (dt * (b - a).max(1) as f64)
        })
        .collect();
    (lin, ang)
}

/// The descriptor of grid samples `s` (rows × [`FEATURE_DIM`], row-major); `None` when a value
/// is not finite or there are fewer than 3 samples.
pub fn describe(s: &[Sample], c: &FeatureConfig) -> Option<Vec<f64>> {
    let n = s.len();
    if n < 3 {
        return None;
    }
    let dt = c.period();
    let bound = |x: f64| std::f64::consts::FRAC_2_PI * (x / c.invariant_scale).atan();
    let mut inv = vec![[0.0; 8]; n];
    for k in 0..4 {
        let (v, w) = velocities(s, k, dt);
        let (v, w) = (smooth(&v), smooth(&w));
        let rows = unidirectional(&v, &w, dt).ok()?;
        for i in 0..n {
            let sv = v[i].norm();
            let sw = w[i].norm();
            inv[i][2 * k] = bound(rows[i][0]) * sv / (sv + c.saliency_speed);
            inv[i][2 * k + 1] = bound(rows[i][1]) * sw / (sw + 10.0 * c.saliency_speed);
        }
    }
    let mut out = Vec::with_capacity(n * FEATURE_DIM);
    for (i, x) in s.iter().enumerate() {
        let arm = if x.arm > 1e-3 { x.arm } else { return None };
        let body = x.orientation[0].inverse();
        let hand = body * (x.position[3] - x.position[0]) / arm;
        let elbow = body * (x.position[2] - x.position[0]) / arm;
        let fingers = body * (x.orientation[3] * -Vector3::z());
        let palm = body * (x.orientation[3] * Vector3::x());
        out.extend(inv[i].iter().map(|v| v * c.invariant_weight));
        out.extend(hand.iter().chain(elbow.iter()).map(|v| v * c.position_weight));
        out.extend(fingers.iter().chain(palm.iter()).map(|v| v * c.direction_weight));
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_people::{BodySize, Performer, Stance};

    #[test]
    fn a_120_hz_and_a_30_hz_source_give_the_same_grid() {
        let p = Performer::new(1, BodySize::MEDIUM, Stance::new(0.0, -1.0, 1.2), 3).expect("p");
        let c = FeatureConfig::default();
        let mut fast = Window::new(c.clone()).expect("w");
        let mut slow = Window::new(c).expect("w");
        for i in 0..(120 * 3) {
            let t = i as f64 / 120.0;
            fast.push(Sample::from_pose(&p.pose(t), t, true));
            if i % 4 == 0 {
                slow.push(Sample::from_pose(&p.pose(t), t, true));
            }
        }
        let (a, b) = (fast.descriptor().expect("full"), slow.descriptor().expect("full"));
        assert_eq!(a.len(), 50 * FEATURE_DIM);
        let err = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        assert!(err < 1e-6, "{err}");
        assert_eq!(fast.end_stamp(), slow.end_stamp());
    }

    #[test]
    fn a_gap_restarts_the_window() {
        let p = Performer::new(1, BodySize::MEDIUM, Stance::new(0.0, -1.0, 1.2), 3).expect("p");
        let mut w = Window::new(FeatureConfig::default()).expect("w");
        for i in 0..60 {
            w.push(Sample::from_pose(&p.pose(i as f64 / 30.0), i as f64 / 30.0, true));
        }
        assert!(w.is_full());
        w.push(Sample::from_pose(&p.pose(5.0), 5.0, true));
        assert!(!w.is_full());
    }
}
