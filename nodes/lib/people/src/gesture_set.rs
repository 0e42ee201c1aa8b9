//! A labelled set of gesture performances, deterministic from a seed: different body sizes,
//! speeds, amplitudes, positions in the room and viewing angles (thesis Sec. 5.1.3).

use nalgebra::Point2;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::body::BodySize;
use crate::error::{Result, check_range};
use crate::motion::{Action, GestureKind, GestureStyle, Stance};
use crate::performer::{Performer, Room, Timeline};

/// Ranges the gesture instances are drawn from (uniformly).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GestureSetConfig {
    /// Number of instances, split evenly over the three gestures (order shuffled).
    pub count: usize,
    /// Body heights (m).
    pub height_range: (f64, f64),
    /// Gesture duration scale (1 = nominal).
    pub duration_scale_range: (f64, f64),
    /// Joint excursion scale.
    pub amplitude_range: (f64, f64),
    /// Arm-height variation (rad).
    pub tilt_range: (f64, f64),
    /// Beckoning repetitions of `come` (inclusive).
    pub come_repetitions: (u32, u32),
    /// Facing relative to the direction towards the camera (rad; 0 = facing the camera).
    pub view_angle_range: (f64, f64),
    /// Corner of the floor area people stand in (m, base frame, smallest x and y).
    pub area_min: (f64, f64),
    /// Opposite corner (largest x and y).
    pub area_max: (f64, f64),
    /// Standing time before the gesture (s).
    pub idle_before: (f64, f64),
    /// Standing time after the gesture (s).
    pub idle_after: (f64, f64),
    /// Time between one performer leaving and the next appearing (s).
    pub gap: f64,
}

impl Default for GestureSetConfig {
    fn default() -> Self {
        Self {
            count: 30,
            height_range: (1.50, 1.95),
            duration_scale_range: (0.7, 1.5),
            amplitude_range: (0.85, 1.15),
            tilt_range: (-0.12, 0.12),
            come_repetitions: (2, 4),
            view_angle_range: (-1.05, 1.05),
            area_min: (-0.8, -1.5),
            area_max: (0.1, -1.0),
            idle_before: (0.6, 1.2),
            idle_after: (0.5, 1.0),
            gap: 0.5,
        }
    }
}

impl GestureSetConfig {
    /// Rejects empty, reversed, NaN or out-of-range ranges.
    pub fn validate(&self) -> Result<()> {
        check_range("gesture count", self.count as f64, 1.0, 100_000.0, "1 to 100000")?;
        let range = |what: &str, (lo, hi): (f64, f64), min: f64, max: f64, expected: &'static str| -> Result<()> {
            check_range(&format!("{what} low"), lo, min, max, expected)?;
            check_range(&format!("{what} high"), hi, lo, max, expected)
        };
        range("height_range (m)", self.height_range, BodySize::MIN_HEIGHT, BodySize::MAX_HEIGHT, "1.0 to 2.3 m, low ≤ high")?;
        range("duration_scale_range", self.duration_scale_range, 0.3, 3.0, "0.3 to 3, low ≤ high")?;
        range("amplitude_range", self.amplitude_range, 0.5, 1.5, "0.5 to 1.5, low ≤ high")?;
        range("tilt_range (rad)", self.tilt_range, -0.4, 0.4, "-0.4 to 0.4 rad, low ≤ high")?;
        range(
            "come_repetitions",
            (f64::from(self.come_repetitions.0), f64::from(self.come_repetitions.1)),
            1.0,
            8.0,
            "1 to 8, low ≤ high",
        )?;
        range("view_angle_range (rad)", self.view_angle_range, -3.2, 3.2, "-π to π, low ≤ high")?;
        range("area x (m)", (self.area_min.0, self.area_max.0), -20.0, 20.0, "-20 to 20 m, min ≤ max")?;
        range("area y (m)", (self.area_min.1, self.area_max.1), -20.0, 20.0, "-20 to 20 m, min ≤ max")?;
        range("idle_before (s)", self.idle_before, 0.0, 60.0, "0 to 60 s, low ≤ high")?;
        range("idle_after (s)", self.idle_after, 0.0, 60.0, "0 to 60 s, low ≤ high")?;
        check_range("gap (s)", self.gap, 0.0, 60.0, "0 to 60 s")
    }
}

/// One labelled performance.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GestureInstance {
    /// Position in the set.
    pub index: usize,
    /// The gesture performed.
    pub kind: GestureKind,
    /// Tracker id of the performer (index + 1).
    pub person_id: u32,
    /// Body size.
    pub body: BodySize,
    /// Where the performer stands and faces.
    pub stance: Stance,
    /// Facing relative to the direction towards the camera (rad).
    pub view_angle: f64,
    /// Speed, amplitude, repetitions.
    pub style: GestureStyle,
    /// Seed of the performer's sway.
    pub seed: u64,
    /// Gesture start, timeline time (s).
    pub start: f64,
    /// Gesture end, timeline time (s).
    pub end: f64,
    /// The performer appears (timeline time, s).
    pub present_from: f64,
    /// The performer disappears (timeline time, s).
    pub present_until: f64,
}

impl GestureInstance {
    /// The label written to bags and published on `/human/gesture`.
    pub fn label(&self) -> &'static str {
        self.kind.label()
    }
}

/// A labelled gesture set and the timeline that performs it: one performer after the other,
/// each standing, gesturing once, standing, then leaving.
#[derive(Clone, Debug)]
pub struct GestureSet {
    /// The instances in timeline order.
    pub instances: Vec<GestureInstance>,
    timeline: Timeline,
}

impl GestureSet {
    /// Draws `config.count` instances from `seed` in `room`.
    pub fn generate(seed: u64, config: &GestureSetConfig, room: &Room) -> Result<Self> {
        config.validate()?;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut kinds: Vec<GestureKind> = (0..config.count).map(|i| GestureKind::ALL[i % 3]).collect();
        kinds.shuffle(&mut rng);
        let uniform = |(lo, hi): (f64, f64), rng: &mut ChaCha8Rng| if hi > lo { rng.random_range(lo..=hi) } else { lo };
        let mut timeline = Timeline::new();
        let mut instances = Vec::with_capacity(config.count);
        let mut t = 0.0;
        for (index, kind) in kinds.into_iter().enumerate() {
            let body = BodySize::new(uniform(config.height_range, &mut rng))?;
            let at = Point2::new(
                uniform((config.area_min.0, config.area_max.0), &mut rng),
                uniform((config.area_min.1, config.area_max.1), &mut rng),
            );
            let view_angle = uniform(config.view_angle_range, &mut rng);
            let stance = Stance { position: at, yaw: room.yaw_for_view_angle(&at, view_angle) };
            let (r0, r1) = config.come_repetitions;
            let style = GestureStyle {
                duration_scale: uniform(config.duration_scale_range, &mut rng),
                amplitude: uniform(config.amplitude_range, &mut rng),
                repetitions: rng.random_range(r0..=r1.max(r0)),
                tilt: uniform(config.tilt_range, &mut rng),
            };
            let before = uniform(config.idle_before, &mut rng);
            let after = uniform(config.idle_after, &mut rng);
            let person_seed: u64 = rng.random();
            let person_id = u32::try_from(index + 1).unwrap_or(u32::MAX);
            let mut p = Performer::new(person_id, body, stance, person_seed)?.with_floor_z(room.floor_z)?;
            if before > 0.0 {
                p.push(Action::Stand { duration: before })?;
            }
            let span = p.push(Action::Gesture { kind, style })?;
            if after > 0.0 {
                p.push(Action::Stand { duration: after })?;
            }
            let duration = p.duration();
            instances.push(GestureInstance {
                index,
                kind,
                person_id,
                body,
                stance,
                view_angle,
                style,
                seed: person_seed,
                start: t + span.start,
                end: t + span.end,
                present_from: t,
                present_until: t + duration,
            });
            timeline.add(t, p)?;
            t += duration + config.gap;
        }
        Ok(Self { instances, timeline })
    }

    /// The timeline performing the whole set.
    pub fn timeline(&self) -> &Timeline {
        &self.timeline
    }

    /// The performer of instance `index` (its own time starts at `present_from`).
    pub fn performer(&self, index: usize) -> Option<&Performer> {
        self.timeline.entries().get(index).map(|e| &e.performer)
    }
}
