//! Evaluation of gesture recognition on synthetic people the templates never saw (the
//! "Must show" of the observer): labelled gesture streams and non-gesture streams (walking in
//! and out, standing, reaching towards the robot, sweeping a hand) drawn from seeds, at the
//! depth tracker's 30 Hz or the Xsens suit's 120 Hz, a confusion matrix with a `none` class,
//! precision and recall per label, false reports per 10 minutes of non-gesture motion.

use std::collections::BTreeMap;

use cowork_msgs::msg::Skeleton;
use cowork_people::{
    Action, BodySize, GestureSet, GestureSetConfig, GestureStyle, Performer, Room, Sampler, SensorConfig, Side, Stance, Timeline,
};
use nalgebra::{Point2, Point3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{ObserverError, Result};
use crate::features::Sample;
use crate::gesture::{Classifier, GestureModel, GestureTracker, Label, LearnConfig, Learner};
use crate::skeleton::check_skeleton;

/// The label that means "no gesture" in the confusion matrix.
pub const NONE: &str = "none";

/// Label of the extra class taught from labels only (a right hand raised above the head).
pub const RAISE_HAND: &str = "raise_hand";

/// A labelled skeleton stream.
#[derive(Clone, Debug, Default)]
pub struct Stream {
    /// Frames in stamp order.
    pub frames: Vec<Skeleton>,
    /// Labelled performances.
    pub labels: Vec<Label>,
    /// Length, s.
    pub duration_s: f64,
}

fn people(e: cowork_people::PeopleError) -> ObserverError {
    ObserverError::Training { reason: format!("synthetic people: {e}") }
}

/// `count` gestures (come / stop / handover right, evenly) by people drawn from `seed`
/// (sizes, speeds, amplitudes, positions, viewing angles of [`GestureSetConfig::default`]),
/// sampled by `sensor` with noise from `seed`. With `raise_hand`, `count / 3` performances
/// of the extra class [`RAISE_HAND`] follow.
pub fn gesture_stream(seed: u64, count: usize, sensor: &SensorConfig, raise_hand: bool) -> Result<Stream> {
    let room = Room::default();
    let config = GestureSetConfig { count, ..GestureSetConfig::default() };
    let set = GestureSet::generate(seed, &config, &room).map_err(people)?;
    let mut labels: Vec<Label> = set
        .instances
        .iter()
        .map(|g| Label { label: g.label().to_owned(), start: g.start, end: g.end, person_id: Some(g.person_id) })
        .collect();
    let mut timeline: Timeline = set.timeline().clone();
    if raise_hand {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_4a15e);
        let mut t = timeline.duration() + config.gap;
        for i in 0..(count / 3).max(1) {
            let id = 10_000 + i as u32;
            let body = BodySize::new(rng.random_range(config.height_range.0..=config.height_range.1)).map_err(people)?;
            let at = Point2::new(rng.random_range(config.area_min.0..=config.area_max.0), rng.random_range(config.area_min.1..=config.area_max.1));
            let yaw = room.yaw_for_view_angle(&at, rng.random_range(config.view_angle_range.0..=config.view_angle_range.1));
            let stance = Stance { position: at, yaw };
            let l = body.lengths();
            let top = room.floor_z + body.height;
            // Above the head, slightly forward and to the right.
            let (c, s) = (yaw.cos(), yaw.sin());
            let (fwd, right) = (0.15 * l.upper_arm / 0.32, l.shoulder_half_width);
            let target = Point3::new(at.x + fwd * c + right * s, at.y + fwd * s - right * c, top + rng.random_range(0.05..0.2));
            let mut p = Performer::new(id, body, stance, rng.random()).map_err(people)?.with_floor_z(room.floor_z).map_err(people)?;
            p.push(Action::Stand { duration: rng.random_range(0.6..1.2) }).map_err(people)?;
            let scale = rng.random_range(config.duration_scale_range.0..=config.duration_scale_range.1);
            let span = p
                .push(Action::Reach { side: Side::Right, target, duration: 0.8 * scale, hold: 0.6 * scale })
                .map_err(people)?;
            p.push(Action::Stand { duration: rng.random_range(0.5..1.0) }).map_err(people)?;
            labels.push(Label { label: RAISE_HAND.into(), start: t + span.start, end: t + span.end, person_id: Some(id) });
            let d = p.duration();
            timeline.add(t, p).map_err(people)?;
            t += d + config.gap;
        }
    }
    let _ = GestureStyle::default();
    let frames: Vec<Skeleton> = Sampler::new(&timeline, sensor.clone(), seed.wrapping_mul(31).wrapping_add(7)).map_err(people)?.collect();
    Ok(Stream { frames, labels, duration_s: timeline.duration() })
}

/// About `duration_s` of non-gesture motion by people drawn from `seed`: each walks in to the
/// table, stands, reaches towards a point of the robot's workspace, stands, sweeps the right
/// hand across the workspace, stands and walks out (the stacking scenario's visit), one after
/// the other; no labels.
pub fn non_gesture_stream(seed: u64, duration_s: f64, sensor: &SensorConfig) -> Result<Stream> {
    let room = Room::default();
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0dd_ba11);
    let mut timeline = Timeline::new();
    let mut t = 0.0;
    let mut id = 20_000u32;
    while t < duration_s {
        let body = BodySize::new(rng.random_range(1.5..1.95)).map_err(people)?;
        let reach = Point3::new(rng.random_range(-0.1..0.5), rng.random_range(-0.6..-0.2), rng.random_range(0.1..0.6));
        let from = Point3::new(rng.random_range(-0.1..0.2), rng.random_range(-0.7..-0.5), rng.random_range(0.05..0.3));
        let to = Point3::new(rng.random_range(0.3..0.6), rng.random_range(-0.6..-0.4), rng.random_range(0.05..0.3));
        let p = room.visit(id, body, rng.random(), reach, (from, to)).map_err(people)?;
        let d = p.duration();
        timeline.add(t, p).map_err(people)?;
        t += d + 0.5;
        id += 1;
    }
    let frames: Vec<Skeleton> = Sampler::new(&timeline, sensor.clone(), seed.wrapping_mul(17).wrapping_add(3)).map_err(people)?.collect();
    Ok(Stream { frames, labels: Vec::new(), duration_s: timeline.duration() })
}

/// Learns a model from streams (frames checked as the observer checks them; bad frames are
/// skipped).
pub fn learn(streams: &[&Stream], config: LearnConfig) -> Result<GestureModel> {
    let mut learner = Learner::new(config)?;
    let mut labels = Vec::new();
    let mut end = 0.0f64;
    for (k, s) in streams.iter().enumerate() {
        // Streams are laid one after the other on one clock (10 s apart) and their person ids
        // kept apart, so that labels and windows of different streams never mix.
        let first = s.frames.iter().map(|m| m.header.stamp.to_secs_f64()).fold(f64::INFINITY, f64::min);
        let offset = if first.is_finite() { end + 10.0 - first } else { end + 10.0 };
        let person = |p: u32| p.wrapping_add((k as u32).wrapping_mul(1_000_003));
        for m in &s.frames {
            let Ok(f) = check_skeleton(m, "lwr_base_link", -0.75) else { continue };
            learner.push(person(m.person_id), Sample::from_pose(&f.pose, f.stamp + offset, !m.velocities.is_empty()))?;
            end = end.max(f.stamp + offset);
        }
        for l in &s.labels {
            labels.push(Label { start: l.start + offset, end: l.end + offset, person_id: l.person_id.map(person), ..l.clone() });
        }
    }
    learner.finish(&labels)
}

/// One frame of a hand track: the measurement, the truth and the filter's estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackRow {
    /// Stamp, s.
    pub stamp: f64,
    /// Measured right-hand position, m.
    pub measured: Point3<f64>,
    /// Noise-free position, m.
    pub truth: Point3<f64>,
    /// Noise-free velocity, m/s.
    pub truth_velocity: nalgebra::Vector3<f64>,
    /// Filtered position, m.
    pub filtered: Point3<f64>,
    /// Filtered velocity, m/s.
    pub filtered_velocity: nalgebra::Vector3<f64>,
}

/// The right hand of the first performer of the gesture set of `seed` measured by `sensor`,
/// filtered by a [`ConstantVelocityKf`] with `config` (its `measurement_noise_m` as given).
pub fn kalman_track(seed: u64, sensor: &SensorConfig, config: crate::KalmanConfig) -> Result<Vec<TrackRow>> {
    let set = GestureSet::generate(seed, &GestureSetConfig { count: 3, ..Default::default() }, &Room::default()).map_err(people)?;
    let timeline = set.timeline();
    let id = set.instances.first().map_or(1, |i| i.person_id);
    let mut kf = crate::ConstantVelocityKf::new(config)?;
    let mut rows = Vec::new();
    for m in Sampler::new(timeline, sensor.clone(), seed).map_err(people)? {
        if m.person_id != id {
            continue;
        }
        let t = m.header.stamp.to_secs_f64() - sensor.time_offset_s;
        let Some((_, truth)) = timeline.poses_at(t).into_iter().find(|(p, _)| *p == id) else { continue };
        let Some(z) = m.segment(Skeleton::SEGMENT_RIGHT_HAND) else { continue };
        let z = Point3::new(z.position.x, z.position.y, z.position.z);
        let e = kf.update(m.header.stamp.to_secs_f64(), &z)?;
        let h = truth.segment(cowork_people::Segment::RightHand);
        rows.push(TrackRow { stamp: e.stamp, measured: z, truth: h.position, truth_velocity: h.linear_velocity, filtered: e.position, filtered_velocity: e.velocity });
    }
    Ok(rows)
}

/// RMSE of a track (m, m/s): raw position, filtered position, raw velocity (central
/// differences of the measurements), filtered velocity. The first `skip` rows (filter
/// start-up) are left out.
pub fn track_rmse(rows: &[TrackRow], skip: usize) -> [f64; 4] {
    let mut sums = [0.0; 4];
    let mut n = 0.0f64;
    for i in skip.max(1)..rows.len().saturating_sub(1) {
        let r = &rows[i];
        let raw_v = (rows[i + 1].measured - rows[i - 1].measured) / (rows[i + 1].stamp - rows[i - 1].stamp);
        sums[0] += (r.measured - r.truth).norm_squared();
        sums[1] += (r.filtered - r.truth).norm_squared();
        sums[2] += (raw_v - r.truth_velocity).norm_squared();
        sums[3] += (r.filtered_velocity - r.truth_velocity).norm_squared();
        n += 1.0;
    }
    sums.map(|s| (s / n.max(1.0)).sqrt())
}

/// A recognised gesture in an evaluation.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Performer.
    pub person_id: u32,
    /// Label.
    pub label: String,
    /// End of the window, s.
    pub stamp: f64,
    /// DTW distance.
    pub distance: f64,
    /// Confidence.
    pub confidence: f64,
}

/// Runs recognition over a stream as the observer does (one tracker per person).
pub fn recognise(model: &GestureModel, stream: &Stream) -> Result<(Vec<Report>, u64)> {
    let classifier = Classifier::new(model.clone())?;
    let mut trackers: BTreeMap<u32, (GestureTracker, f64)> = BTreeMap::new();
    let mut out = Vec::new();
    for m in &stream.frames {
        let Ok(f) = check_skeleton(m, "lwr_base_link", -0.75) else { continue };
        let (tr, last) = match trackers.entry(m.person_id) {
            std::collections::btree_map::Entry::Occupied(o) => o.into_mut(),
            std::collections::btree_map::Entry::Vacant(v) => v.insert((GestureTracker::new(model.features.clone())?, f64::NEG_INFINITY)),
        };
        if f.stamp <= *last {
            continue;
        }
        *last = f.stamp;
        if let Some(d) = tr.push(Sample::from_pose(&f.pose, f.stamp, !m.velocities.is_empty()), &classifier)? {
            out.push(Report { person_id: m.person_id, label: d.label, stamp: d.stamp, distance: d.distance, confidence: d.confidence });
        }
    }
    let evals = trackers.values().map(|t| t.0.evaluations()).sum();
    Ok((out, evals))
}

/// Confusion matrix and counts of one evaluation.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Evaluation {
    /// Labels in row / column order; the last is [`NONE`].
    pub labels: Vec<String>,
    /// `matrix[truth][predicted]`.
    pub matrix: Vec<Vec<usize>>,
    /// Further reports inside an already matched performance (same person).
    pub duplicates: usize,
    /// Seconds of stream evaluated.
    pub duration_s: f64,
    /// Windows classified.
    pub evaluations: u64,
}

impl Evaluation {
    fn index(&self, label: &str) -> usize {
        self.labels.iter().position(|l| l == label).unwrap_or(self.labels.len() - 1)
    }

    /// Matches reports to labels: a report of the performer within `[start, end + tolerance_s]`
    /// of a performance is its answer (the first one; later ones are duplicates); reports
    /// elsewhere are false (truth `none`); performances without a report are missed
    /// (predicted `none`).
    pub fn score(labels: &[String], stream: &Stream, reports: &[Report], tolerance_s: f64, evaluations: u64) -> Self {
        let mut names: Vec<String> = labels.to_vec();
        for l in &stream.labels {
            if !names.contains(&l.label) {
                names.push(l.label.clone());
            }
        }
        names.retain(|l| l != NONE);
        names.push(NONE.into());
        let n = names.len();
        let mut e = Evaluation { labels: names, matrix: vec![vec![0; n]; n], duplicates: 0, duration_s: stream.duration_s, evaluations };
        let mut answered: Vec<Option<String>> = vec![None; stream.labels.len()];
        for r in reports {
            let hit = stream.labels.iter().position(|l| l.person_id.is_none_or(|p| p == r.person_id) && r.stamp >= l.start && r.stamp <= l.end + tolerance_s);
            match hit {
                Some(i) if answered[i].is_some() => e.duplicates += 1,
                Some(i) => answered[i] = Some(r.label.clone()),
                None => {
                    let (t, p) = (e.index(NONE), e.index(&r.label));
                    e.matrix[t][p] += 1;
                }
            }
        }
        for (l, a) in stream.labels.iter().zip(&answered) {
            let (t, p) = (e.index(&l.label), e.index(a.as_deref().unwrap_or(NONE)));
            e.matrix[t][p] += 1;
        }
        e
    }

    /// Adds another evaluation's counts (same labels).
    pub fn add(&mut self, other: &Evaluation) {
        if self.labels.is_empty() {
            *self = other.clone();
            return;
        }
        for (i, l) in other.labels.iter().enumerate() {
            for (j, m) in other.labels.iter().enumerate() {
                let (a, b) = (self.index(l), self.index(m));
                self.matrix[a][b] += other.matrix[i][j];
            }
        }
        self.duplicates += other.duplicates;
        self.duration_s += other.duration_s;
        self.evaluations += other.evaluations;
    }

    /// Recall of `label`: recognised correctly / performed.
    pub fn recall(&self, label: &str) -> f64 {
        let i = self.index(label);
        let row: usize = self.matrix[i].iter().sum();
        if row == 0 { f64::NAN } else { self.matrix[i][i] as f64 / row as f64 }
    }

    /// Precision of `label`: correct reports / reports of it.
    pub fn precision(&self, label: &str) -> f64 {
        let j = self.index(label);
        let col: usize = self.matrix.iter().map(|r| r[j]).sum();
        if col == 0 { f64::NAN } else { self.matrix[j][j] as f64 / col as f64 }
    }

    /// Reports where no gesture was performed.
    pub fn false_reports(&self) -> usize {
        let none = self.labels.len() - 1;
        self.matrix[none].iter().sum()
    }

    /// False reports per 10 minutes of stream.
    pub fn false_per_10_min(&self) -> f64 {
        self.false_reports() as f64 / (self.duration_s / 600.0).max(1e-9)
    }

    /// The matrix as a text table with recall and precision.
    pub fn table(&self) -> String {
        let w = self.labels.iter().map(String::len).max().unwrap_or(4).max(9);
        let mut s = format!("{:>w$} |", "truth \\ got");
        for l in &self.labels {
            s += &format!(" {l:>w$}");
        }
        s += &format!(" | {:>7} {:>9}\n", "recall", "precision");
        for (i, l) in self.labels.iter().enumerate() {
            s += &format!("{l:>w$} |");
            for v in &self.matrix[i] {
                s += &format!(" {v:>w$}");
            }
            if l == NONE {
                s += " |\n";
            } else {
                s += &format!(" | {:>7.3} {:>9.3}\n", self.recall(l), self.precision(l));
            }
        }
        s
    }
}
