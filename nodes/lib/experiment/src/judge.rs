//! Judging a trial from what the simulated world did: the true robot–person distance (robot
//! link geometry against the capsule body lwr_sim draws from the same `/human/skeleton`),
//! collisions, object placements from `/lwr/world`, and the time series of the report. Fed
//! with typed messages — live by the runner, or from a recorded MCAP by [`crate::bag`] — so a
//! recorded run is judged exactly as it was live.

use std::collections::BTreeMap;

use cowork_msgs::msg::{Gesture, HumanState, LinkDistances, MotionStatus, Skeleton, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::Float64MultiArray;
use cowork_people::{BODY_CAPSULE_NAMES, SkeletonPose, body_capsules};
use cowork_robot::{DOF, JointVector, LinkPoses, RobotModel};
use cowork_scenario::distance::LinkGeometry;
use cowork_scenario::obstacle::Obstacle;
use nalgebra::{Point3, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::plan::{Anchor, Placement};

/// The thesis's minimum robot–person distance with fDED (Sec. 5.1.3, Fig. 5.14), m.
pub const THESIS_MIN_DISTANCE_M: f64 = 0.067;

/// A person whose last skeleton is older than this is gone (s; lwr_sim's default timeout).
const PERSON_TIMEOUT_S: f64 = 0.5;
/// Distances beyond this are not computed exactly (m).
const RANGE_M: f64 = 6.0;

/// The human observer's reach: a person whose body comes closer to the robot than this is in
/// the interaction area (human_observer's default `interaction_enter_m`, thesis Sec. 5.1.3), m.
pub const INTERACTION_AREA_M: f64 = 0.8;

/// One `/human/state` as the report draws it: the message's own fields, its own numbering.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ObservedState {
    /// `HumanState.mode`: `MODE_FAR` (0) or `MODE_INTERACTION` (1).
    pub mode: u8,
    /// Someone is tracked (when false the message's other fields keep their last values).
    pub present: bool,
    /// Stopped by a gesture or the spoken `stop`.
    pub stopped: bool,
}

/// The tool's fastest moment while a person was in the interaction area.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NearPersonPeak {
    /// Simulated time (s).
    pub t_s: f64,
    /// Tool speed from `/lwr/world` (m/s, over ≥ 50 ms).
    pub speed_m_s: f64,
    /// Speed α_h allowed then (m/s; `None` before any `/human/state`).
    pub allowed_m_s: Option<f64>,
    /// True robot–person distance then (m; negative: penetration depth).
    pub person_distance_m: f64,
}

/// Time series of one trial (s of simulated time, SI units).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Series {
    /// True minimum robot–person distance (m), one sample per skeleton frame with a person.
    pub distance: Vec<(f64, f64)>,
    /// Smallest valid distance of each `/fded/distances` message (m; frames with no valid
    /// link are left out).
    pub measured_distance: Vec<(f64, f64)>,
    /// Processing time of each `/fded/distances` message (ms).
    pub processing_ms: Vec<(f64, f64)>,
    /// Tool speed from `/lwr/world` (m/s).
    pub tool_speed: Vec<(f64, f64)>,
    /// α_h of `/human/state` (m/s).
    pub alpha: Vec<(f64, f64)>,
    /// Mode and flags of `/human/state`.
    pub human_state: Vec<(f64, ObservedState)>,
    /// Gestures recognised (`/human/gesture`).
    pub gestures: Vec<(f64, String)>,
    /// Norm of the commanded joint velocity (rad/s).
    pub commanded_qdot: Vec<(f64, f64)>,
    /// Norm of the executed joint velocity of `/joint_states` (rad/s).
    pub executed_qdot: Vec<(f64, f64)>,
    /// Backend that computed the distances (`cpu`, `wgpu`, `spheres`).
    pub backend: String,
}

impl Series {
    /// The true robot–person distance at `t` (s): the skeleton frame nearest in time within
    /// 0.1 s, `None` when nobody was there. `distance` is in time order (frames as they came).
    pub fn person_distance_at(&self, t: f64) -> Option<f64> {
        let d = &self.distance;
        let i = d.partition_point(|s| s.0 < t);
        [i.checked_sub(1), Some(i)]
            .into_iter()
            .flatten()
            .filter_map(|k| d.get(k))
            .filter(|s| (s.0 - t).abs() <= 0.1)
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
            .map(|s| s.1)
    }

    /// α_h of the newest `/human/state` at or before `t` (m/s).
    pub fn allowed_at(&self, t: f64) -> Option<f64> {
        let a = &self.alpha;
        a.partition_point(|s| s.0 <= t).checked_sub(1).map(|i| a[i].1)
    }

    /// The largest tool speed (`/lwr/world`) while the true robot–person distance was below
    /// `area_m` (m; [`INTERACTION_AREA_M`] for the observer's interaction area), with the speed
    /// α_h allowed then and that distance. All from the simulated world but α_h, which is what
    /// the robot was told. `None` when the person never came that close while the tool moved.
    pub fn fastest_near_person(&self, area_m: f64) -> Option<NearPersonPeak> {
        self.tool_speed
            .iter()
            .filter(|s| s.1.is_finite())
            .filter_map(|&(t, speed)| {
                let d = self.person_distance_at(t).filter(|d| *d < area_m)?;
                Some(NearPersonPeak {
                    t_s: t,
                    speed_m_s: speed,
                    allowed_m_s: self.allowed_at(t),
                    person_distance_m: d,
                })
            })
            // The first of equal speeds.
            .fold(None, |best: Option<NearPersonPeak>, p| match best {
                Some(b) if b.speed_m_s >= p.speed_m_s => Some(b),
                _ => Some(p),
            })
    }
}

/// Statistics of a sample set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Samples.
    pub n: usize,
    /// Median.
    pub median: f64,
    /// 99th percentile.
    pub p99: f64,
    /// Mean.
    pub mean: f64,
    /// Largest.
    pub max: f64,
}

impl Stats {
    /// Of `values` (`None` when empty).
    pub fn of(values: impl Iterator<Item = f64>) -> Option<Stats> {
        let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let q = |p: f64| v[((p * (n - 1) as f64).round() as usize).min(n - 1)];
        Some(Stats {
            n,
            median: q(0.5),
            p99: q(0.99),
            mean: v.iter().sum::<f64>() / n as f64,
            max: v[n - 1],
        })
    }
}

/// Result of one placement check.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacementResult {
    /// Object judged.
    pub object: String,
    /// Distance of its centre from where it must be (m); `None` when it is missing.
    pub error_m: Option<f64>,
    /// Within tolerance.
    pub success: bool,
}

/// One subtask's outcome.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Subtask {
    /// Simulated time it took (s); `None` when it never finished.
    pub time_s: Option<f64>,
    /// Finished and placed within tolerance.
    pub success: bool,
}

/// Where the robot and the person came closest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Approach {
    /// Simulated time (s).
    pub t_s: f64,
    /// Distance (m; negative: penetration depth).
    pub distance_m: f64,
    /// Robot link.
    pub link: String,
    /// Body capsule of the person (`right_hand`, `right_forearm`, ...).
    pub body_part: String,
}

/// One contact between the robot and the person (clear → touching), and who was moving into
/// whom then: under speed and separation monitoring (ISO/TS 15066) the robot must be standing,
/// or here moving away, when a person touches it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Contact {
    /// Simulated time (s).
    pub t_s: f64,
    /// Robot link.
    pub link: String,
    /// Body capsule of the person.
    pub body_part: String,
    /// The robot's speed at the contact point towards the person (m/s, from the executed
    /// joint speeds of `/joint_states`; negative: moving away).
    pub robot_closing_m_s: f64,
    /// The person's speed towards the robot there (m/s): the distance's rate over the last
    /// skeleton frame less the robot's part.
    pub person_closing_m_s: f64,
}

/// [`Judge::nearest_pair`]'s answer: distance (m), body capsule, link name, and the link's index
/// with its closest point and the body's outward normal there (base frame).
type NearestPair = (f64, &'static str, String, Option<(usize, Point3<f64>, Vector3<f64>)>);

/// Contacts kept per trial (every one is counted).
const CONTACTS_KEPT: usize = 32;

/// The tool's speed against the speed α_h allowed (the newest `/human/state` at that time).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpeedPeak {
    /// Simulated time (s).
    pub t_s: f64,
    /// Tool speed from `/lwr/world` (m/s, over ≥ 50 ms).
    pub speed_m_s: f64,
    /// Speed α_h allowed then (m/s).
    pub allowed_m_s: f64,
}

/// Accumulates one trial.
#[derive(Debug)]
pub struct Judge {
    model: RobotModel,
    geometry: LinkGeometry,
    poses: LinkPoses,
    floor_z: f64,
    q: Option<(f64, JointVector)>,
    joint_index: Vec<Option<usize>>,
    /// person id → (stamp, capsules).
    people: BTreeMap<u32, (f64, Vec<Obstacle>)>,
    in_contact: bool,
    /// clear → touching transitions.
    pub collisions: u32,
    /// The first [`CONTACTS_KEPT`] of them.
    pub contacts: Vec<Contact>,
    /// Executed joint speeds of the newest joint state (rad/s), when it had them.
    qdot: Option<JointVector>,
    /// Newest simulated time seen (s).
    pub now: f64,
    first_world: Option<WorldState>,
    last_world: Option<WorldState>,
    last_tool: Option<(f64, Vector3<f64>)>,
    /// Closest approach so far.
    pub closest: Option<Approach>,
    /// Simulated time ds_controller reported its link-distance damper holding a link back
    /// (`/motion/status` reason `approach limited: LINK`), s.
    pub approach_limited_s: f64,
    /// The links it held back, by name, with the time each (s).
    pub approach_limited_links: BTreeMap<String, f64>,
    limited_since: Option<(f64, String)>,
    /// The series.
    pub series: Series,
    /// Newest true right hand of the person last seen (simulated time s, middle of the hand,
    /// base frame m).
    pub right_hand: Option<(f64, Point3<f64>)>,
}

impl Judge {
    /// A judge for `model`; people stand on `floor_z` (base frame, m).
    pub fn new(model: RobotModel, floor_z: f64) -> Result<Self> {
        let geometry = LinkGeometry::new(&model, RANGE_M)?;
        Ok(Self {
            geometry,
            poses: LinkPoses::new(),
            floor_z,
            q: None,
            joint_index: Vec::new(),
            people: BTreeMap::new(),
            in_contact: false,
            collisions: 0,
            contacts: Vec::new(),
            qdot: None,
            now: 0.0,
            first_world: None,
            last_world: None,
            last_tool: None,
            closest: None,
            approach_limited_s: 0.0,
            approach_limited_links: BTreeMap::new(),
            limited_since: None,
            series: Series::default(),
            right_hand: None,
            model,
        })
    }

    /// `/joint_states`.
    pub fn on_joint_state(&mut self, msg: &JointState) {
        let t = msg.header.stamp.to_secs_f64();
        if self.joint_index.len() != msg.name.len() {
            self.joint_index = msg.name.iter().map(|n| self.model.joint_index(n)).collect();
        }
        let mut q = JointVector::zeros();
        let mut seen = 0;
        for (k, i) in self.joint_index.iter().enumerate() {
            if let (Some(i), Some(p)) = (i, msg.position.get(k)) {
                q[*i] = *p;
                seen += 1;
            }
        }
        if seen != DOF || !q.iter().all(|v| v.is_finite()) {
            return;
        }
        self.now = self.now.max(t);
        // Executed joint speed at 100 Hz is plenty for a plot.
        if self
            .series
            .executed_qdot
            .last()
            .is_none_or(|(s, _)| t - s >= 0.01)
            && msg.velocity.len() == DOF
        {
            let n = msg.velocity.iter().map(|v| v * v).sum::<f64>().sqrt();
            self.series.executed_qdot.push((t, n));
        }
        self.q = Some((t, q));
        self.qdot = (msg.velocity.len() == msg.name.len()).then(|| {
            let mut v = JointVector::zeros();
            for (k, i) in self.joint_index.iter().enumerate() {
                if let Some(i) = i {
                    v[*i] = msg.velocity[k];
                }
            }
            v
        }).filter(|v| v.iter().all(|x| x.is_finite()));
    }

    /// `/human/skeleton`: the true body; the distance is evaluated at every frame.
    pub fn on_skeleton(&mut self, msg: &Skeleton) {
        let t = msg.header.stamp.to_secs_f64();
        let Ok(pose) = SkeletonPose::from_message_measured(msg, self.floor_z) else {
            return;
        };
        let caps = body_capsules(&pose)
            .iter()
            .zip(BODY_CAPSULE_NAMES)
            .map(|(c, name)| {
                Obstacle::capsule(name, c.a, c.b, c.radius, Vector3::zeros(), Vector3::zeros())
            })
            .collect();
        self.right_hand = Some((t, pose.position(cowork_people::Segment::RightHand)));
        self.people.insert(msg.person_id, (t, caps));
        self.now = self.now.max(t);
        self.evaluate(t);
    }

    fn evaluate(&mut self, t: f64) {
        self.people.retain(|_, (s, _)| t - *s <= PERSON_TIMEOUT_S);
        let Some((_, q)) = self.q else { return };
        if self.people.is_empty() {
            return;
        }
        self.model.forward_kinematics(&q, &mut self.poses);
        let obstacles: Vec<Obstacle> = self
            .people
            .values()
            .flat_map(|(_, c)| c.iter().cloned())
            .collect();
        let (_, closest) = self.geometry.distances(&self.poses, &obstacles, t);
        let d = closest.human_distance;
        if !d.is_finite() {
            return;
        }
        let touching = d <= 0.0;
        let previous = self.series.distance.last().copied();
        self.series.distance.push((t, d));
        if touching && !self.in_contact {
            self.collisions += 1;
            if self.contacts.len() < CONTACTS_KEPT {
                let contact = self.contact(&obstacles, t, previous.map(|(s, p)| (t - s, d - p)));
                self.contacts.push(contact);
            }
        }
        self.in_contact = touching;
        if self.closest.as_ref().is_none_or(|c| d < c.distance_m) {
            let (_, body_part, link, _) = self.nearest_pair(&obstacles, t);
            self.closest = Some(Approach { t_s: t, distance_m: d, link, body_part: body_part.to_owned() });
        }
    }

    /// The body capsule and the link closest to each other (each capsule on its own): the
    /// distance (m), the capsule's name, the link's name, and the link's index with its closest
    /// point and the body's outward normal there (base frame).
    fn nearest_pair(&self, obstacles: &[Obstacle], t: f64) -> NearestPair {
        let mut best = (f64::INFINITY, "", String::new(), None);
        for o in obstacles {
            let (d, c) = self.geometry.distances(&self.poses, std::slice::from_ref(o), t);
            if c.human_distance < best.0 {
                let link = c.link.and_then(|l| self.model.link_names().get(l).cloned()).unwrap_or_default();
                let at = c.link.and_then(|l| d.links.get(l).filter(|x| x.valid).map(|x| (l, x.robot_point, x.normal)));
                best = (c.human_distance, o.name, link, at);
            }
        }
        best
    }

    /// The contact starting now (the poses are at the current joints); `rate` is the time and
    /// the change of the distance since the previous skeleton frame (s, m).
    fn contact(&self, obstacles: &[Obstacle], t: f64, rate: Option<(f64, f64)>) -> Contact {
        let (_, body_part, link, closest) = self.nearest_pair(obstacles, t);
        let robot_closing = (|| {
            let ((l, robot_point, normal), qdot) = (closest?, self.qdot?);
            let mut pj = cowork_robot::PositionJacobian::zeros();
            let in_link = self.poses.get(l).inverse_transform_point(&robot_point);
            self.model.position_jacobian(&self.poses, l, &in_link, &mut pj);
            // The normal points out of the body, towards the robot.
            Some(-(pj * qdot).dot(&normal))
        })()
        .unwrap_or(f64::NAN);
        let closing = rate.filter(|(dt, _)| *dt > 1e-6 && *dt <= 0.05).map_or(f64::NAN, |(dt, dd)| -dd / dt);
        Contact { t_s: t, link, body_part: body_part.to_owned(), robot_closing_m_s: robot_closing, person_closing_m_s: closing - robot_closing }
    }

    /// `/fded/distances`.
    pub fn on_distances(&mut self, msg: &LinkDistances) {
        let t = msg.header.stamp.to_secs_f64();
        self.series
            .processing_ms
            .push((t, msg.processing_time * 1e3));
        if self.series.backend != msg.backend {
            self.series.backend = msg.backend.clone();
        }
        let min = msg
            .links
            .iter()
            .filter(|l| l.valid && l.distance.is_finite())
            .map(|l| l.distance)
            .fold(f64::INFINITY, f64::min);
        if min.is_finite() {
            self.series.measured_distance.push((t, min));
        }
    }

    /// `/motion/status`: times the link-distance damper's `approach limited: LINK` reports
    /// (from one status to the next).
    pub fn on_status(&mut self, msg: &MotionStatus) {
        let t = msg.header.stamp.to_secs_f64();
        if let Some((since, link)) = self.limited_since.take() {
            let dt = (t - since).max(0.0);
            self.approach_limited_s += dt;
            *self.approach_limited_links.entry(link).or_insert(0.0) += dt;
        }
        if let Some(link) = msg.reason.strip_prefix("approach limited: ") {
            self.limited_since = Some((t, link.to_owned()));
        }
    }

    /// `/human/state`.
    pub fn on_human_state(&mut self, msg: &HumanState) {
        let t = msg.header.stamp.to_secs_f64();
        self.series.alpha.push((t, msg.speed_scale));
        self.series.human_state.push((
            t,
            ObservedState { mode: msg.mode, present: msg.present, stopped: msg.stopped },
        ));
    }

    /// `/human/gesture`.
    pub fn on_gesture(&mut self, msg: &Gesture) {
        self.series
            .gestures
            .push((msg.header.stamp.to_secs_f64(), msg.label.clone()));
    }

    /// `/lwr/joint_velocity_command` (unstamped: taken at the newest simulated time).
    pub fn on_command(&mut self, msg: &Float64MultiArray) {
        let t = self.now;
        if self
            .series
            .commanded_qdot
            .last()
            .is_none_or(|(s, _)| t - s >= 0.01)
        {
            let n = msg.data.iter().map(|v| v * v).sum::<f64>().sqrt();
            self.series.commanded_qdot.push((t, n));
        }
    }

    /// `/lwr/world`.
    pub fn on_world(&mut self, msg: &WorldState) {
        let t = msg.header.stamp.to_secs_f64();
        let p = &msg.tool_pose.position;
        let x = Vector3::new(p.x, p.y, p.z);
        match self.last_tool {
            Some((s, y)) if t - s >= 0.05 => {
                self.series
                    .tool_speed
                    .push((0.5 * (s + t), (x - y).norm() / (t - s)));
                self.last_tool = Some((t, x));
            }
            Some(_) => {}
            None => self.last_tool = Some((t, x)),
        }
        if self.first_world.is_none() {
            self.first_world = Some(msg.clone());
        }
        self.last_world = Some(msg.clone());
        self.now = self.now.max(t);
    }

    /// The newest `/lwr/world`.
    pub fn world(&self) -> Option<&WorldState> {
        self.last_world.as_ref()
    }

    /// Smallest true robot–person distance so far (m).
    pub fn min_distance(&self) -> Option<f64> {
        self.series.distance.iter().map(|d| d.1).reduce(f64::min)
    }

    /// Checks `placements` against the first and the newest `/lwr/world`.
    pub fn placements(&self, placements: &[Placement]) -> Vec<PlacementResult> {
        let centre = |w: &WorldState, name: &str| {
            w.objects.iter().find(|o| o.name == name).map(|o| {
                let p = &o.pose.position;
                Point3::new(p.x, p.y, p.z)
            })
        };
        placements
            .iter()
            .map(|pl| {
                let error_m = (|| {
                    let last = self.last_world.as_ref()?;
                    let here = centre(last, &pl.object)?;
                    let anchor = match &pl.anchor {
                        Anchor::Object(other) => centre(last, other)?,
                        Anchor::Initial => centre(self.first_world.as_ref()?, &pl.object)?,
                        Anchor::Point(p) => Point3::from(*p),
                    };
                    Some((here - (anchor + Vector3::from(pl.offset))).norm())
                })();
                PlacementResult {
                    object: pl.object.clone(),
                    success: error_m.is_some_and(|e| e <= pl.tolerance_m),
                    error_m,
                }
            })
            .collect()
    }

    /// Speeds the tool actually moved at while the task ran: the median tool speed over the
    /// samples with α_h at `alpha` (±1 cm/s) and the tool faster than 2 cm/s.
    pub fn speed_at(&self, alpha: f64) -> Option<f64> {
        let a = &self.series.alpha;
        let at = |t: f64| {
            a.partition_point(|s| s.0 <= t)
                .checked_sub(1)
                .map(|i| a[i].1)
        };
        Stats::of(
            self.series
                .tool_speed
                .iter()
                .filter(|(t, v)| *v > 0.02 && at(*t).is_some_and(|x| (x - alpha).abs() < 0.01))
                .map(|s| s.1),
        )
        .map(|s| s.median)
    }

    /// The sample where the tool moved fastest above the speed α_h allowed at that time (the
    /// largest speed − allowed, which can be negative); `None` before any `/human/state`. With
    /// `nobody_close`, only samples where α_h was at its largest value of the trial (the far
    /// speed): the robot's own pace, not its evasion of a hand coming at it (eq. 5.4's
    /// (I − M) ẋ_O moves the arm with the obstacle, at the obstacle's speed).
    pub fn fastest_over_allowed(&self, nobody_close: bool) -> Option<SpeedPeak> {
        let a = &self.series.alpha;
        let far = a.iter().map(|s| s.1).fold(f64::NEG_INFINITY, f64::max);
        self.series
            .tool_speed
            .iter()
            .filter_map(|&(t, speed)| {
                let i = a.partition_point(|s| s.0 <= t).checked_sub(1)?;
                Some(SpeedPeak { t_s: t, speed_m_s: speed, allowed_m_s: a[i].1 })
            })
            .filter(|p| !nobody_close || p.allowed_m_s >= far - 1e-3)
            .max_by(|x, y| (x.speed_m_s - x.allowed_m_s).total_cmp(&(y.speed_m_s - y.allowed_m_s)))
    }

    /// Number of α_h changes between two different non-zero values.
    pub fn speed_switches(&self) -> usize {
        let mut last = None;
        let mut n = 0;
        for &(_, a) in &self.series.alpha {
            if a <= 0.0 {
                continue;
            }
            if last.is_some_and(|l: f64| (l - a).abs() > 1e-6) {
                n += 1;
            }
            last = Some(a);
        }
        n
    }
}
