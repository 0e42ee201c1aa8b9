//! [`ObserverNode`]: the node's state and one handler per message, no I/O.

use anyhow::Result;
use cowork_msgs::builtin_interfaces::{Duration, Time};
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Vector3 as MsgVector3};
use cowork_msgs::msg::{Gesture, HumanState, Skeleton};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::{ColorRGBA, Header, String as RosString};
use cowork_msgs::visualization_msgs::{Marker, MarkerArray};
use cowork_observer::{GestureModel, GestureReport, HumanOutput, Mode, Observer, Retargeter};
use cowork_people::body_capsules;
use cowork_robot::RobotModel;
use nalgebra::{Point3, UnitQuaternion, Vector3};

use crate::params::{Params, RetargetArm};
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
    model: RobotModel,
    /// One per `retarget.arms` entry.
    demonstration: Vec<ArmDemonstration>,
    /// The demonstrator (the first Xsens person seen) once one is.
    demonstrator: Option<u32>,
}

/// Imitation teaching state of one driven arm.
#[derive(Debug)]
struct ArmDemonstration {
    params: RetargetArm,
    /// The arm's latest `/joint_states` positions (model joint order), the IK's start.
    joints: Option<cowork_robot::JointVector>,
    /// Running since the demonstrator's last frame; restarted from the arm's joints after a gap.
    retargeter: Option<Retargeter>,
    /// Stamp of the last frame retargeted, s.
    last_stamp: f64,
    /// `/lwr/follow_joints`, reused.
    msg: JointState,
}

/// A demonstrator silent this long (by stamps) starts again from the arm's joints, s.
pub const DEMONSTRATION_GAP_S: f64 = 0.5;

/// What one demonstrator frame gave.
#[derive(Debug, Clone, Default)]
pub struct DemonstratorOutput {
    /// `(index in retarget.arms, /lwr/follow_joints)`.
    pub targets: Vec<(usize, JointState)>,
    /// Whether the frame is also a person near the robot, for the observer: the demonstrator's
    /// skeleton is in the robot base frame. (A suit worn away from the robot, in another frame,
    /// only drives it.)
    pub track_as_person: bool,
    /// Warnings about the frame.
    pub warnings: Vec<Warning>,
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
        let observer = Observer::new(model.clone(), params.observer.clone(), gestures)?;
        let names = model.joint_names().to_vec();
        let demonstration = params
            .retarget
            .arms
            .iter()
            .map(|a| ArmDemonstration {
                params: a.clone(),
                joints: None,
                retargeter: None,
                last_stamp: f64::NEG_INFINITY,
                msg: JointState { name: names.clone(), position: vec![0.0; names.len()], ..Default::default() },
            })
            .collect();
        Ok(Self {
            model,
            demonstration,
            demonstrator: None,
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

    /// The arms a demonstrator drives (`retarget.arms`), by index.
    pub fn retarget_arms(&self) -> impl Iterator<Item = &RetargetArm> {
        self.demonstration.iter().map(|d| &d.params)
    }

    /// `<arm>/joint_states` of driven arm `index`: where its retargeting starts.
    pub fn on_arm_joint_state(&mut self, index: usize, msg: &JointState) -> Result<(), Warning> {
        let names = self.model.joint_names();
        let d = &mut self.demonstration[index];
        let topic = JOINT_STATES.name_in(&format!("/{}", d.params.arm)).into_owned();
        let mut q = cowork_robot::JointVector::zeros();
        for (i, name) in names.iter().enumerate() {
            let Some(k) = msg.name.iter().position(|n| n == name) else {
                return Err(Warning { kind: format!("{topic}:name"), message: format!("{topic}: no joint {name:?}; message ignored") });
            };
            match msg.position.get(k) {
                Some(v) if v.is_finite() => q[i] = *v,
                _ => {
                    return Err(Warning {
                        kind: format!("{topic}:position"),
                        message: format!("{topic}: position of {name:?} missing or not finite; message ignored"),
                    });
                }
            }
        }
        d.joints = Some(q);
        Ok(())
    }

    /// Imitation teaching: an Xsens skeleton of the demonstrator (the first suit seen) is
    /// retargeted (eq. 4.7) onto every driven arm; each target is stamped with the frame's
    /// stamp. An arm whose joints are not known yet, or a frame that is refused, gives a
    /// warning and no target (the arm then stops within the simulator's command timeout).
    /// Frames of other sources or people, and every frame when no arm is driven, are only for
    /// the observer.
    pub fn on_demonstrator(&mut self, msg: &Skeleton) -> DemonstratorOutput {
        let mut out = DemonstratorOutput { track_as_person: true, ..Default::default() };
        if self.demonstration.is_empty() || msg.source != Skeleton::SOURCE_XSENS {
            return out;
        }
        if *self.demonstrator.get_or_insert(msg.person_id) != msg.person_id {
            return out;
        }
        let frame = msg.header.frame_id.trim_start_matches('/');
        out.track_as_person = frame.is_empty() || frame == self.base_frame;
        let stamp = msg.header.stamp.to_secs_f64();
        let frame_id = if frame.is_empty() { self.base_frame.clone() } else { frame.to_owned() };
        for (index, d) in self.demonstration.iter_mut().enumerate() {
            let topic = cowork_msgs::topics::FOLLOW_JOINTS.name_in(&format!("/{}", d.params.arm)).into_owned();
            if !(stamp - d.last_stamp <= DEMONSTRATION_GAP_S && stamp >= d.last_stamp) {
                d.retargeter = None;
            }
            if d.retargeter.is_none() {
                let Some(q0) = d.joints else {
                    out.warnings.push(Warning {
                        kind: format!("{topic}:joints"),
                        message: format!("{topic}: no joint states of arm {:?} yet: the demonstrator is not retargeted onto it", d.params.arm),
                    });
                    continue;
                };
                match Retargeter::new(self.model.clone(), d.params.config(), q0) {
                    Ok(r) => d.retargeter = Some(r),
                    Err(e) => {
                        out.warnings.push(Warning { kind: format!("{topic}:config"), message: format!("{topic}: {e}") });
                        continue;
                    }
                }
            }
            let Some(r) = d.retargeter.as_mut() else { continue };
            match r.retarget_message(msg, &frame_id) {
                Ok(t) => {
                    d.last_stamp = stamp;
                    d.msg.header = msg.header.clone();
                    d.msg.position.copy_from_slice(t.joints.as_slice());
                    out.targets.push((index, d.msg.clone()));
                }
                Err(e) => out.warnings.push(Warning {
                    kind: format!("{}:demonstrator", SKELETON.name),
                    message: format!("{}: demonstrator frame not retargeted onto arm {:?}: {e}", SKELETON.name, d.params.arm),
                }),
            }
        }
        out
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
