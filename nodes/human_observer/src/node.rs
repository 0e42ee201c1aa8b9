//! [`ObserverNode`]: the node's state and one handler per message, no I/O.

use anyhow::Result;
use cowork_msgs::builtin_interfaces::{Duration, Time};
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3 as MsgVector3};
use cowork_msgs::msg::{Gesture, HumanState, Skeleton};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::{ColorRGBA, Header, String as RosString};
use cowork_msgs::visualization_msgs::{Marker, MarkerArray};
use cowork_observer::{GestureModel, GestureReport, HumanOutput, Mode, Observer};
use cowork_people::body_capsules;
use cowork_robot::RobotModel;
use nalgebra::{Point3, UnitQuaternion, Vector3};

use crate::params::Params;
use cowork_msgs::topics::{JOINT_STATES, SKELETON, SPEECH_COMMAND};

pub use cowork_ros::Warning;

/// What one skeleton frame gives to publish.
#[derive(Debug, Clone)]
pub struct SkeletonOutput {
    /// `/human/state`.
    pub state: HumanState,
    /// `/human/gesture`, when one was recognised.
    pub gesture: Option<Gesture>,
    /// Warnings about the frame.
    pub warnings: Vec<Warning>,
}

/// The node's state: the observer, the publication schedule and the markers.
#[derive(Debug)]
pub struct ObserverNode {
    params: Params,
    observer: Observer,
    base_frame: String,
    /// Time of the last `/human/state`, s (node clock / message stamps).
    last_state: f64,
    last_markers: f64,
    last: Option<HumanOutput>,
    markers: MarkerArray,
    states: u64,
    gestures: u64,
    /// The node's clock at the last [`Self::set_clock`] / [`Self::on_tick`], s: when skeleton
    /// frames arrive (`None`: at their stamps).
    clock: Option<f64>,
}

/// Namespace of the capsule body markers (id = person index × 16 + capsule).
pub const NS_BODY: &str = "human/body";
/// Namespace of the filtered hand spheres.
pub const NS_HAND: &str = "human/hand";
/// Namespace of the hand velocity arrows.
pub const NS_HAND_VELOCITY: &str = "human/hand_velocity";
/// Namespace of the last gesture's text.
pub const NS_GESTURE: &str = "human/gesture";

const BODY: ColorRGBA = ColorRGBA::new(0.95, 0.75, 0.55, 0.6);
const HAND: ColorRGBA = ColorRGBA::new(0.1, 0.6, 1.0, 1.0);
const ARROW: ColorRGBA = ColorRGBA::new(0.1, 0.9, 0.3, 1.0);
const TEXT: ColorRGBA = ColorRGBA::new(1.0, 1.0, 1.0, 1.0);
const MARKER_LIFETIME_S: f64 = 0.5;

fn point(p: &Point3<f64>) -> Point {
    Point { x: p.x, y: p.y, z: p.z }
}

fn quaternion(q: &UnitQuaternion<f64>) -> Quaternion {
    Quaternion { x: q.i, y: q.j, z: q.k, w: q.w }
}

impl ObserverNode {
    /// The node for `model` with `params` (validated here) and the gesture model, if any.
    pub fn new(model: RobotModel, params: Params, gestures: Option<GestureModel>) -> Result<Self> {
        params.validate("human_observer parameters")?;
        let base_frame = params.observer.base_frame.clone();
        let observer = Observer::new(model, params.observer.clone(), gestures)?;
        Ok(Self {
            params,
            observer,
            base_frame,
            last_state: f64::NEG_INFINITY,
            last_markers: f64::NEG_INFINITY,
            last: None,
            markers: MarkerArray::default(),
            states: 0,
            gestures: 0,
            clock: None,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// No usable gesture model (the file named by `gestures` failed to load): recognition is
    /// off and α_h is capped at the interaction speed, since a stop gesture would go unseen.
    pub fn without_gestures_fail_closed(&mut self) {
        self.observer.set_speed_cap(Some(self.params.observer.mode.interaction_speed));
    }

    /// The library object.
    pub fn observer(&self) -> &Observer {
        &self.observer
    }

    /// `/human/state` messages made so far.
    pub fn states(&self) -> u64 {
        self.states
    }

    /// `/human/gesture` messages made so far.
    pub fn gestures(&self) -> u64 {
        self.gestures
    }

    /// The last state, as the library computed it.
    pub fn last_state(&self) -> Option<&HumanOutput> {
        self.last.as_ref()
    }

    /// `/joint_states`.
    pub fn on_joint_state(&mut self, msg: &JointState) -> Result<(), Warning> {
        self.observer
            .on_joint_state(msg.header.stamp.to_secs_f64(), &msg.name, &msg.position)
            .map_err(|e| Warning { kind: JOINT_STATES.name.to_string(), message: format!("{}: message ignored: {e}", JOINT_STATES.name) })
    }

    /// `/speech_command`: `stop` / `repeat` (the words of the parameters) move the stop latch;
    /// returns true when it changed (other words are for other nodes).
    pub fn on_speech(&mut self, msg: &RosString) -> bool {
        let changed = self.observer.on_speech(&msg.data);
        if changed {
            tracing::info!("{}: {:?}: {}", SPEECH_COMMAND.name, cowork_ros::quote(msg.data.trim()), if self.observer.tracks().count() == 0 && self.last.as_ref().is_some_and(|s| s.stopped) { "stopped" } else { "stop latch changed" });
        }
        changed
    }

    /// The node's clock now (s): frames handled from here on arrived at this time (a person
    /// is dropped when no frame has arrived for `person_timeout_s`, however the frames are
    /// stamped; late frames fail the state closed instead).
    pub fn set_clock(&mut self, now: f64) {
        if now.is_finite() {
            self.clock = Some(now);
        }
    }

    /// `/human/skeleton`, arrived at the last [`Self::set_clock`] (or tick) time: always gives
    /// a state to publish (fail closed on bad or late frames).
    pub fn on_skeleton(&mut self, msg: &Skeleton) -> SkeletonOutput {
        let out = self.observer.on_skeleton_at(msg, self.clock);
        let warnings = out
            .warnings
            .iter()
            .map(|w| {
                let field = w.split("field `").nth(1).and_then(|r| r.split('`').next()).unwrap_or("frame");
                Warning { kind: format!("{}:{field}", SKELETON.name), message: format!("{}: {w}", SKELETON.name) }
            })
            .collect();
        let gesture = out.gesture.as_ref().map(|g| self.gesture_msg(g));
        if let Some(g) = &gesture {
            self.gestures += 1;
            tracing::info!("gesture {:?} (person {}, confidence {:.2}, DTW {:.3})", g.label, out.gesture.as_ref().map_or(0, |g| g.person_id), g.confidence, g.dtw_distance);
        }
        let state = self.state_msg(&out.state);
        self.last_state = out.state.stamp;
        self.last = Some(out.state);
        SkeletonOutput { state, gesture, warnings }
    }

    /// The steady-rate publication at `now` (s): a state when none went out for a period
    /// (people silent too long are dropped first).
    pub fn on_tick(&mut self, now: f64) -> Option<HumanState> {
        self.set_clock(now);
        let period = 1.0 / self.params.state_rate_hz;
        if now - self.last_state < period && now >= self.last_state {
            return None;
        }
        let s = self.observer.tick(now);
        let msg = self.state_msg(&s);
        self.last_state = now;
        self.last = Some(s);
        Some(msg)
    }

    fn header(&self, stamp: f64) -> Header {
        Header { stamp: Time::from_secs_f64(stamp.max(0.0)), frame_id: self.base_frame.clone() }
    }

    fn state_msg(&mut self, s: &HumanOutput) -> HumanState {
        self.states += 1;
        HumanState {
            header: self.header(s.stamp),
            mode: match s.mode {
                Mode::Far => HumanState::MODE_FAR,
                Mode::Interaction => HumanState::MODE_INTERACTION,
            },
            present: s.present,
            distance: s.distance,
            hand_position: point(&s.hand_position),
            hand_velocity: MsgVector3 { x: s.hand_velocity.x, y: s.hand_velocity.y, z: s.hand_velocity.z },
            speed_scale: s.speed_scale,
            stopped: s.stopped,
        }
    }

    fn gesture_msg(&self, g: &GestureReport) -> Gesture {
        Gesture {
            header: self.header(g.detection.stamp),
            label: g.detection.label.clone(),
            confidence: g.detection.confidence,
            dtw_distance: g.detection.distance,
            hand_pose: Pose { position: point(&g.hand_position), orientation: quaternion(&g.hand_orientation) },
        }
    }

    /// `/human/markers` when due at `now` (s): every tracked person's capsule body (cylinders),
    /// filtered hands (spheres) with velocity arrows, the last gesture as text above the head;
    /// a `DELETEALL` first so people who left vanish.
    pub fn markers(&mut self, now: f64) -> Option<&MarkerArray> {
        if now - self.last_markers < 1.0 / self.params.markers_rate_hz && now >= self.last_markers {
            return None;
        }
        self.last_markers = now;
        let header = self.header(now);
        let lifetime = Duration::from_secs_f64(MARKER_LIFETIME_S);
        let base = Marker { header: header.clone(), lifetime, action: Marker::ADD, ..Default::default() };
        let mut markers = vec![Marker { action: Marker::DELETEALL, ..base.clone() }];
        let last_gesture = self.observer.last_gesture().cloned();
        for (k, t) in self.observer.tracks().enumerate() {
            let k = i32::try_from(k).unwrap_or(i32::MAX / 32);
            for (i, c) in body_capsules(&t.pose).iter().enumerate() {
                let axis = c.b - c.a;
                let len = axis.norm();
                let rot = UnitQuaternion::rotation_between(&Vector3::z(), &axis).unwrap_or_else(UnitQuaternion::identity);
                let mid = nalgebra::center(&c.a, &c.b);
                markers.push(Marker {
                    ns: NS_BODY.into(),
                    id: k * 32 + i as i32,
                    type_: Marker::CYLINDER,
                    pose: Pose { position: point(&mid), orientation: quaternion(&rot) },
                    scale: MsgVector3 { x: 2.0 * c.radius, y: 2.0 * c.radius, z: len + 2.0 * c.radius },
                    color: BODY,
                    ..base.clone()
                });
            }
            for (h, kf) in t.hands.iter().enumerate() {
                let Some(e) = kf.predict_to(now) else { continue };
                let id = k * 2 + h as i32;
                markers.push(Marker {
                    ns: NS_HAND.into(),
                    id,
                    type_: Marker::SPHERE,
                    pose: Pose { position: point(&e.position), orientation: Quaternion { w: 1.0, ..Default::default() } },
                    scale: MsgVector3 { x: 0.06, y: 0.06, z: 0.06 },
                    color: HAND,
                    ..base.clone()
                });
                markers.push(Marker {
                    ns: NS_HAND_VELOCITY.into(),
                    id,
                    type_: Marker::ARROW,
                    pose: Pose { orientation: Quaternion { w: 1.0, ..Default::default() }, ..Default::default() },
                    points: vec![point(&e.position), point(&(e.position + e.velocity * self.params.velocity_arrow_s))],
                    scale: MsgVector3 { x: 0.01, y: 0.02, z: 0.03 },
                    color: ARROW,
                    ..base.clone()
                });
            }
            if let Some(g) = last_gesture.as_ref().filter(|g| g.person_id == t.person_id) {
                let head = t.pose.position(cowork_people::Segment::Head) + Vector3::new(0.0, 0.0, 0.3);
                markers.push(Marker {
                    ns: NS_GESTURE.into(),
                    id: k,
                    type_: Marker::TEXT_VIEW_FACING,
                    pose: Pose { position: point(&head), orientation: Quaternion { w: 1.0, ..Default::default() } },
                    scale: MsgVector3 { x: 0.0, y: 0.0, z: 0.12 },
                    color: TEXT,
                    text: format!("{} ({:.2})", g.detection.label, g.detection.confidence),
                    ..base.clone()
                });
            }
        }
        self.markers.markers = markers;
        Some(&self.markers)
    }
}
