//! [`Observer`]: everything the human observer node computes, message by message, no I/O.

use std::collections::BTreeMap;

use cowork_msgs::msg::Skeleton;
use cowork_people::{Segment, SkeletonPose, Source};
use cowork_robot::RobotModel;
use nalgebra::{Point3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::distance::{BodyDistance, RobotBody};
use crate::error::{Result, check};
use crate::features::Sample;
use crate::gesture::{Classifier, Detection, GestureModel, GestureTracker};
use crate::kalman::{ConstantVelocityKf, Estimate, KalmanConfig};
use crate::mode::{Mode, ModeConfig, SpeedGovernor};
use crate::skeleton::check_skeleton;

/// Parameters of the observer (the `observer:` block of `config/human_observer.yaml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ObserverConfig {
    /// Frame the skeletons must be in (the robot base frame).
    pub base_frame: String,
    /// Floor height in the base frame, m (places the capsule body's feet).
    pub floor_z: f64,
    /// Hand filter; `measurement_noise_m` is replaced per source by the two values below.
    pub kalman: KalmanConfig,
    /// Hand position noise of an Xsens suit, m.
    pub xsens_measurement_noise_m: f64,
    /// Hand position noise of a depth-camera tracker, m.
    pub depth_measurement_noise_m: f64,
    /// Far / interaction and α_h.
    pub mode: ModeConfig,
    /// A person with no frame for longer than this is dropped, s (judged by when frames
    /// arrive on the node's clock, see [`Observer::on_skeleton_at`]).
    pub person_timeout_s: f64,
    /// A tracked person whose newest frame is stamped further than this behind the time a
    /// state is made for is stale: the state fails closed (interaction) until fresh frames
    /// arrive, s. Late frames are a person who is there, never "nobody".
    pub max_skeleton_age_s: f64,
    /// At most this many people are tracked; frames of further ids are ignored (and slow the
    /// robot: someone is there who cannot be tracked).
    pub max_people: usize,
    /// A joint state further than this from a skeleton's stamp is too old for the distance
    /// (which is then unknown: interaction), s.
    pub max_joint_state_age_s: f64,
}

impl Default for ObserverConfig {
    fn default() -> Self {
        Self {
            base_frame: "lwr_base_link".into(),
            floor_z: -0.75,
            kalman: KalmanConfig::default(),
            xsens_measurement_noise_m: 0.004,
            depth_measurement_noise_m: 0.015,
            mode: ModeConfig::default(),
            person_timeout_s: 0.5,
            max_skeleton_age_s: 0.3,
            max_people: 4,
            max_joint_state_age_s: 0.5,
        }
    }
}

impl ObserverConfig {
    /// Rejects NaN and out-of-range values; `place` prefixes the names.
    pub fn validate(&self, place: &str) -> Result<()> {
        check(&format!("{place}floor_z"), self.floor_z, -10.0, 10.0, "must be in [-10, 10] m")?;
        self.kalman.validate(&format!("{place}kalman."))?;
        check(&format!("{place}xsens_measurement_noise_m"), self.xsens_measurement_noise_m, 1e-6, 1.0, "must be in [1e-6, 1] m")?;
        check(&format!("{place}depth_measurement_noise_m"), self.depth_measurement_noise_m, 1e-6, 1.0, "must be in [1e-6, 1] m")?;
        self.mode.validate(&format!("{place}mode."))?;
        check(&format!("{place}person_timeout_s"), self.person_timeout_s, 1e-3, 60.0, "must be in [0.001, 60] s")?;
        check(&format!("{place}max_skeleton_age_s"), self.max_skeleton_age_s, 1e-3, 60.0, "must be in [0.001, 60] s")?;
        check(&format!("{place}max_people"), self.max_people as f64, 1.0, 64.0, "must be 1 to 64")?;
        check(&format!("{place}max_joint_state_age_s"), self.max_joint_state_age_s, 1e-3, 60.0, "must be in [0.001, 60] s")
    }
}

/// One `/human/state` as the library computes it.
#[derive(Clone, Debug, PartialEq)]
pub struct HumanOutput {
    /// Time, s (the skeleton's stamp, or the tick's time).
    pub stamp: f64,
    /// Somebody is tracked (or someone is there whose data is unusable).
    pub present: bool,
    /// Far / interaction.
    pub mode: Mode,
    /// Minimum body–robot distance, m (0 when unknown: fail closed).
    pub distance: f64,
    /// Closest robot link ("" when unknown).
    pub closest_link: String,
    /// The person the state is about (the closest).
    pub person_id: Option<u32>,
    /// Filtered right-hand position of that person, base frame, m (predicted to `stamp`).
    pub hand_position: Point3<f64>,
    /// Filtered right-hand velocity, m/s.
    pub hand_velocity: Vector3<f64>,
    /// α_h, m/s.
    pub speed_scale: f64,
    /// A stop is in force.
    pub stopped: bool,
    /// False while some person's data is unusable (bad frames, untrackable ids, no fresh joint
    /// state): the state is then the fail-closed one.
    pub usable: bool,
}

/// A recognised gesture with the gesturing hand's pose.
#[derive(Clone, Debug, PartialEq)]
pub struct GestureReport {
    /// Performer.
    pub person_id: u32,
    /// What was recognised.
    pub detection: Detection,
    /// Right-hand position at the end of the window, m.
    pub hand_position: Point3<f64>,
    /// Right-hand orientation.
    pub hand_orientation: UnitQuaternion<f64>,
}

/// What one skeleton frame produced.
#[derive(Clone, Debug)]
pub struct FrameOutcome {
    /// The state to publish.
    pub state: HumanOutput,
    /// A gesture recognised on this frame.
    pub gesture: Option<GestureReport>,
    /// Warnings about the frame (naming the field); the frame may still have been used.
    pub warnings: Vec<String>,
    /// The frame was used.
    pub accepted: bool,
}

/// A tracked person.
#[derive(Clone, Debug)]
pub struct Track {
    /// Tracker id.
    pub person_id: u32,
    /// Stamp of the last accepted frame, s.
    pub last_stamp: f64,
    /// When the last frame of this person (accepted or not) arrived, on the node's clock, s.
    pub heard_at: f64,
    /// Last accepted pose.
    pub pose: SkeletonPose,
    /// Right and left hand filters.
    pub hands: [ConstantVelocityKf; 2],
    /// Distance at the last accepted frame (`None`: no fresh joint state).
    pub distance: Option<BodyDistance>,
    /// Arrival time (node clock, s) of the first of the current run of rejected frames.
    pub bad_since: Option<f64>,
    gestures: Option<GestureTracker>,
}

/// The human observer (see the crate docs).
#[derive(Debug)]
pub struct Observer {
    config: ObserverConfig,
    robot: RobotBody,
    governor: SpeedGovernor,
    classifier: Option<Classifier>,
    tracks: BTreeMap<u32, Track>,
    /// Arrival time (node clock, s) of the last untracked person's frame that had to be
    /// ignored (bad, or no room).
    untracked_at: Option<f64>,
    last_gesture: Option<GestureReport>,
    rejected: u64,
    speed_cap: Option<f64>,
}

impl Observer {
    /// An observer of people near `model`; `gestures`: the learned model (none: no
    /// recognition).
    pub fn new(model: RobotModel, config: ObserverConfig, gestures: Option<GestureModel>) -> Result<Self> {
        config.validate("observer.")?;
        Ok(Self {
            robot: RobotBody::new(model)?,
            governor: SpeedGovernor::new(config.mode.clone())?,
            classifier: gestures.map(Classifier::new).transpose()?,
            tracks: BTreeMap::new(),
            untracked_at: None,
            last_gesture: None,
            rejected: 0,
            speed_cap: None,
            config,
        })
    }

    /// The parameters.
    pub fn config(&self) -> &ObserverConfig {
        &self.config
    }

    /// The gesture classifier, if a model was given.
    pub fn classifier(&self) -> Option<&Classifier> {
        self.classifier.as_ref()
    }

    /// The robot geometry.
    pub fn robot(&self) -> &RobotBody {
        &self.robot
    }

    /// Tracked people.
    pub fn tracks(&self) -> impl Iterator<Item = &Track> {
        self.tracks.values()
    }

    /// The last recognised gesture.
    pub fn last_gesture(&self) -> Option<&GestureReport> {
        self.last_gesture.as_ref()
    }

    /// Caps α_h at `cap` m/s whatever the mode (`None`: no cap), e.g. while the gesture model
    /// could not be loaded and a stop gesture would go unseen.
    pub fn set_speed_cap(&mut self, cap: Option<f64>) {
        self.speed_cap = cap.filter(|c| c.is_finite()).map(|c| c.max(0.0));
    }

    /// Frames rejected so far.
    pub fn rejected_frames(&self) -> u64 {
        self.rejected
    }

    /// A `/joint_states` message (positions by joint name).
    pub fn on_joint_state(&mut self, stamp: f64, names: &[String], positions: &[f64]) -> Result<()> {
        self.robot.set_joint_state(stamp, names, positions)
    }

    /// A `/speech_command`; returns true when it changed the stop latch.
    pub fn on_speech(&mut self, words: &str) -> bool {
        self.governor.on_speech(words)
    }

    fn drop_silent(&mut self, now: f64) {
        let timeout = self.config.person_timeout_s;
        self.tracks.retain(|_, t| now - t.heard_at <= timeout && t.bad_since.is_none_or(|b| now - b <= timeout));
        if self.untracked_at.is_some_and(|t| now - t > timeout) {
            self.untracked_at = None;
        }
        if self.tracks.is_empty() && self.untracked_at.is_none() {
            self.governor.on_nobody();
        }
    }

    /// A `/human/skeleton` frame that arrives when the node's clock reads its own stamp (a bag
    /// replayed offline, a test); see [`Self::on_skeleton_at`].
    pub fn on_skeleton(&mut self, msg: &Skeleton) -> FrameOutcome {
        self.on_skeleton_at(msg, None)
    }

    /// A `/human/skeleton` frame that arrived at `received` (s, the node's clock; `None`: at
    /// its stamp). Never fails: a frame that cannot be used is reported in `warnings` (naming
    /// the field) and makes the state fail closed until the person sends a good frame again
    /// or is dropped.
    ///
    /// Silence is judged by arrival, staleness by stamp: a person whose frames keep arriving,
    /// however late, is never dropped as gone (which would report nobody, far speed, while
    /// they stand beside the robot); their late frames make the state fail closed instead
    /// (`max_skeleton_age_s`, `max_joint_state_age_s`).
    pub fn on_skeleton_at(&mut self, msg: &Skeleton, received: Option<f64>) -> FrameOutcome {
        let stamp = msg.header.stamp.to_secs_f64();
        let arrival = received.filter(|r| r.is_finite()).unwrap_or(stamp);
        let mut warnings = Vec::new();
        let id = msg.person_id;
        if arrival.is_finite() {
            self.drop_silent(arrival);
        }
        if !self.tracks.contains_key(&id) && self.tracks.len() >= self.config.max_people {
            warnings.push(format!(
                "field `person_id`: person {id} ignored: already tracking {} people (max_people); robot slowed",
                self.tracks.len()
            ));
            self.untracked_at = Some(arrival);
            self.rejected += 1;
            return self.outcome(stamp, None, warnings, false);
        }
        let frame = match check_skeleton(msg, &self.config.base_frame, self.config.floor_z) {
            Ok(f) => f,
            Err(e) => {
                warnings.push(format!("{e}; robot slowed while the data is unusable"));
                self.mark_bad(id, arrival);
                return self.outcome(stamp, None, warnings, false);
            }
        };
        warnings.extend(frame.notices.iter().cloned());
        if let Some(t) = self.tracks.get(&id)
            && frame.stamp <= t.last_stamp
        {
            warnings.push(format!(
                "person {id}: field `header.stamp`: {:.6} s is not after the previous frame's {:.6} s; frame ignored",
                frame.stamp, t.last_stamp
            ));
            self.mark_bad(id, arrival);
            return self.outcome(stamp, None, warnings, false);
        }
        // Distance at the current joint state, if fresh enough.
        let distance = match self.robot.joint_stamp() {
            Some(js) if (js - frame.stamp).abs() <= self.config.max_joint_state_age_s => self.robot.distance(&frame.pose),
            Some(js) => {
                warnings.push(format!(
                    "/joint_states is {:.3} s away from the skeleton stamp (max_joint_state_age_s {}); distance unknown, robot slowed",
                    (js - frame.stamp).abs(),
                    self.config.max_joint_state_age_s
                ));
                None
            }
            None => {
                warnings.push("no /joint_states yet; distance unknown, robot slowed".into());
                None
            }
        };
        let track = match self.tracks.entry(id) {
            std::collections::btree_map::Entry::Occupied(o) => o.into_mut(),
            std::collections::btree_map::Entry::Vacant(v) => {
                let hands = [ConstantVelocityKf::new(self.config.kalman), ConstantVelocityKf::new(self.config.kalman)];
                let [Ok(r), Ok(l)] = hands else {
                    warnings.push("kalman: invalid configuration".into());
                    return self.outcome(stamp, None, warnings, false);
                };
                let gestures = match &self.classifier {
                    Some(c) => match GestureTracker::new(c.model().features.clone()) {
                        Ok(g) => Some(g),
                        Err(e) => {
                            warnings.push(format!("gesture model: {e}"));
                            None
                        }
                    },
                    None => None,
                };
                v.insert(Track { person_id: id, last_stamp: f64::NEG_INFINITY, heard_at: arrival, pose: frame.pose.clone(), hands: [r, l], distance: None, bad_since: None, gestures })
            }
        };
        let r = match frame.source {
            Source::Xsens => self.config.xsens_measurement_noise_m,
            Source::DepthTracker => self.config.depth_measurement_noise_m,
        };
        for (kf, seg) in track.hands.iter_mut().zip([Segment::RightHand, Segment::LeftHand]) {
            let _ = kf.set_measurement_noise(r);
            if let Err(e) = kf.update(frame.stamp, &frame.pose.position(seg)) {
                warnings.push(format!("person {id}: {}: hand filter: {e}", seg.name()));
            }
        }
        track.last_stamp = frame.stamp;
        track.heard_at = arrival;
        track.bad_since = None;
        track.distance = distance;
        track.pose = frame.pose;
        let mut report = None;
        if let (Some(g), Some(c)) = (track.gestures.as_mut(), self.classifier.as_ref()) {
            let has_velocity = !msg.velocities.is_empty();
            match g.push(Sample::from_pose(&track.pose, frame.stamp, has_velocity), c) {
                Ok(Some(det)) => {
                    let hand = track.pose.segment(Segment::RightHand);
                    report = Some(GestureReport { person_id: id, detection: det, hand_position: hand.position, hand_orientation: hand.orientation });
                }
                Ok(None) => {}
                Err(e) => warnings.push(format!("person {id}: gesture recognition: {e}")),
            }
        }
        if let Some(r) = &report {
            self.governor.on_gesture(&r.detection.label);
            self.last_gesture = Some(r.clone());
        }
        self.outcome(frame.stamp, report, warnings, true)
    }

    fn mark_bad(&mut self, id: u32, arrival: f64) {
        self.rejected += 1;
        match self.tracks.get_mut(&id) {
            Some(t) => {
                t.heard_at = arrival;
                t.bad_since.get_or_insert(arrival);
            }
            None => self.untracked_at = Some(arrival),
        }
    }

    fn outcome(&mut self, stamp: f64, gesture: Option<GestureReport>, warnings: Vec<String>, accepted: bool) -> FrameOutcome {
        FrameOutcome { state: self.state_at(stamp), gesture, warnings, accepted }
    }

    /// The state at `now` (s) for the steady-rate publication: people silent for longer than
    /// `person_timeout_s` are dropped first; hands are predicted to `now`.
    pub fn tick(&mut self, now: f64) -> HumanOutput {
        self.drop_silent(now);
        self.state_at(now)
    }

    fn state_at(&mut self, now: f64) -> HumanOutput {
        let max_age = self.config.max_skeleton_age_s;
        let unusable_person = self.untracked_at.is_some()
            || self.tracks.values().any(|t| t.bad_since.is_some() || now - t.last_stamp > max_age);
        let unknown_distance = self.tracks.values().any(|t| t.distance.is_none());
        let closest = self
            .tracks
            .values()
            .filter_map(|t| t.distance.as_ref().map(|d| (t, d)))
            .min_by(|a, b| a.1.distance.total_cmp(&b.1.distance));
        let present = !self.tracks.is_empty() || unusable_person;
        let usable = !unusable_person && !unknown_distance;
        if present {
            // Unusable data is an unknown distance: interaction at once, and far again only
            // after the governor's dwell with good data (no flicker on intermittent bad frames).
            let d = if usable { closest.map(|c| c.1.distance) } else { None };
            self.governor.on_distance(d, now);
        }
        let mode = if present { self.governor.mode() } else { Mode::Far };
        let (person, distance, link) = match closest {
            Some((t, d)) if usable => (Some(t.person_id), d.distance, d.link.clone()),
            _ => (self.tracks.keys().next().copied(), 0.0, String::new()),
        };
        let hand: Option<Estimate> = person.and_then(|p| self.tracks.get(&p)).and_then(|t| t.hands[0].predict_to(now));
        let mut speed = self.governor.speed(present);
        if present && mode == Mode::Interaction {
            speed = speed.min(self.config.mode.interaction_speed);
        }
        if let Some(cap) = self.speed_cap {
            speed = speed.min(cap);
        }
        HumanOutput {
            stamp: now,
            present,
            mode,
            distance,
            closest_link: link,
            person_id: person,
            hand_position: hand.map_or_else(Point3::origin, |e| e.position),
            hand_velocity: hand.map_or_else(Vector3::zeros, |e| e.velocity),
            speed_scale: speed,
            stopped: self.governor.stopped().is_some(),
            usable,
        }
    }
}
