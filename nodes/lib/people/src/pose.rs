//! The 11 Xsens segments and a full-body pose in the robot base frame.

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion as MsgQuaternion, Twist, Vector3 as MsgVector3};
use cowork_msgs::msg::Skeleton;
use cowork_msgs::std_msgs::Header;
use nalgebra::{Point3, Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::body::BodySize;
use crate::error::{PeopleError, Result};

/// The 11 Xsens segments (thesis Sec. 4.2), in the order of [`Skeleton::XSENS_SEGMENTS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum Segment {
    Pelvis = 0,
    Sternum,
    Head,
    RightShoulder,
    RightElbow,
    RightWrist,
    RightHand,
    LeftShoulder,
    LeftElbow,
    LeftWrist,
    LeftHand,
}

/// Number of Xsens segments.
pub const SEGMENT_COUNT: usize = 11;

impl Segment {
    /// All segments in message order.
    pub const ALL: [Segment; SEGMENT_COUNT] = [
        Segment::Pelvis,
        Segment::Sternum,
        Segment::Head,
        Segment::RightShoulder,
        Segment::RightElbow,
        Segment::RightWrist,
        Segment::RightHand,
        Segment::LeftShoulder,
        Segment::LeftElbow,
        Segment::LeftWrist,
        Segment::LeftHand,
    ];

    /// Index in [`Segment::ALL`] and in the message arrays.
    pub fn index(self) -> usize {
        self as usize
    }

    /// The `cowork_msgs/Skeleton` segment name (`SEGMENT_*` constants).
    pub fn name(self) -> &'static str {
        Skeleton::XSENS_SEGMENTS[self.index()]
    }

    /// The arm segments of one side: shoulder, elbow, wrist, hand.
    pub fn arm(side: Side) -> [Segment; 4] {
        match side {
            Side::Right => [Segment::RightShoulder, Segment::RightElbow, Segment::RightWrist, Segment::RightHand],
            Side::Left => [Segment::LeftShoulder, Segment::LeftElbow, Segment::LeftWrist, Segment::LeftHand],
        }
    }
}

/// Body side.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// The person's right.
    Right,
    /// The person's left.
    Left,
}

impl Side {
    /// +1 for the right side, −1 for the left (the right side is at −y of the body frame).
    pub fn sign(self) -> f64 {
        match self {
            Side::Right => 1.0,
            Side::Left => -1.0,
        }
    }

    /// Index in per-side arrays: right 0, left 1.
    pub fn index(self) -> usize {
        match self {
            Side::Right => 0,
            Side::Left => 1,
        }
    }
}

/// State of one segment in the robot base frame.
///
/// Segment frames: trunk segments (pelvis, sternum, head) have x forward, y to the person's
/// left, z up. An arm point carries the frame of the segment that starts there (shoulder: upper
/// arm; elbow: forearm; wrist and hand: hand) with −z pointing down the limb towards the finger
/// tips and +x the palm normal when the forearm is supinated; with the arms hanging at rest every
/// frame is the body frame turned by the forearm pronation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentState {
    /// Position (m).
    pub position: Point3<f64>,
    /// Orientation (unit quaternion, segment frame to base frame).
    pub orientation: UnitQuaternion<f64>,
    /// Linear velocity of `position` (m/s).
    pub linear_velocity: Vector3<f64>,
    /// Angular velocity, base frame (rad/s).
    pub angular_velocity: Vector3<f64>,
}

impl Default for SegmentState {
    fn default() -> Self {
        Self {
            position: Point3::origin(),
            orientation: UnitQuaternion::identity(),
            linear_velocity: Vector3::zeros(),
            angular_velocity: Vector3::zeros(),
        }
    }
}

/// A foot on (or above) the floor: not an Xsens segment, kept for the depth renderer's legs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Foot {
    /// Ankle joint centre, base frame (m).
    pub ankle: Point3<f64>,
    /// Unit horizontal direction from heel to toe, base frame.
    pub heading: Vector3<f64>,
}

/// A full-body pose at one instant: the 11 segments plus the feet, base frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SkeletonPose {
    /// Time of the pose (s, performer time).
    pub time: f64,
    /// Body size the pose was built with.
    pub body: BodySize,
    /// Floor height, base frame z (m).
    pub floor_z: f64,
    /// Segment states indexed by [`Segment::index`].
    pub segments: [SegmentState; SEGMENT_COUNT],
    /// Right and left foot (index [`Side::index`]).
    pub feet: [Foot; 2],
}

/// Header, source and id written into a [`Skeleton`] message.
#[derive(Clone, Debug, PartialEq)]
pub struct MessageMeta<'a> {
    /// `header.stamp`.
    pub stamp: Time,
    /// `header.frame_id`, the robot base frame.
    pub frame_id: &'a str,
    /// `Skeleton::SOURCE_XSENS` or `Skeleton::SOURCE_DEPTH_TRACKER`.
    pub source: &'a str,
    /// Tracker id of the person.
    pub person_id: u32,
    /// Fill `velocities` (else left empty, as for a source that does not measure them).
    pub with_velocities: bool,
}

impl SkeletonPose {
    /// The state of segment `s`.
    pub fn segment(&self, s: Segment) -> &SegmentState {
        &self.segments[s.index()]
    }

    /// Position of segment `s` (m, base frame).
    pub fn position(&self, s: Segment) -> Point3<f64> {
        self.segments[s.index()].position
    }

    /// True when every number of the pose is finite.
    pub fn is_finite(&self) -> bool {
        let v3 = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
        self.segments.iter().all(|s| {
            v3(&s.position.coords)
                && s.orientation.coords.iter().all(|x| x.is_finite())
                && v3(&s.linear_velocity)
                && v3(&s.angular_velocity)
        }) && self.feet.iter().all(|f| v3(&f.ankle.coords) && v3(&f.heading))
    }

    /// The `cowork_msgs/Skeleton` message of this pose: the 11 segment names in message order,
    /// one pose each and (if asked) one twist each.
    pub fn to_message(&self, meta: &MessageMeta<'_>) -> Skeleton {
        let mut msg = Skeleton::default();
        self.write_message(meta, &mut msg);
        msg
    }

    /// Like [`Self::to_message`] but reusing `msg`'s buffers.
    pub fn write_message(&self, meta: &MessageMeta<'_>, msg: &mut Skeleton) {
        msg.header = Header { stamp: meta.stamp, frame_id: meta.frame_id.to_owned() };
        msg.source = meta.source.to_owned();
        msg.person_id = meta.person_id;
        msg.segment_names.clear();
        msg.segment_names.extend(Segment::ALL.iter().map(|s| s.name().to_owned()));
        msg.poses.clear();
        msg.poses.extend(self.segments.iter().map(|s| {
            let q = s.orientation.quaternion();
            Pose {
                position: Point { x: s.position.x, y: s.position.y, z: s.position.z },
                orientation: MsgQuaternion { x: q.i, y: q.j, z: q.k, w: q.w },
            }
        }));
        msg.velocities.clear();
        if meta.with_velocities {
            let v = |v: &Vector3<f64>| MsgVector3 { x: v.x, y: v.y, z: v.z };
            msg.velocities.extend(
                self.segments
                    .iter()
                    .map(|s| Twist { linear: v(&s.linear_velocity), angular: v(&s.angular_velocity) }),
            );
        }
    }

    /// A pose rebuilt from a message (any segment order, extra segments ignored), with the feet
    /// put on the floor below the hips. Fails when a segment is missing, a number is not finite
    /// or the arrays' lengths differ.
    pub fn from_message(msg: &Skeleton, body: BodySize, floor_z: f64) -> Result<Self> {
        if msg.poses.len() != msg.segment_names.len() {
            return Err(PeopleError::Malformed {
                reason: format!("{} segment names but {} poses", msg.segment_names.len(), msg.poses.len()),
            });
        }
        if !msg.velocities.is_empty() && msg.velocities.len() != msg.segment_names.len() {
            return Err(PeopleError::Malformed {
                reason: format!("{} segment names but {} velocities", msg.segment_names.len(), msg.velocities.len()),
            });
        }
        let mut segments = [SegmentState::default(); SEGMENT_COUNT];
        for s in Segment::ALL {
            let i = msg
                .segment_names
                .iter()
                .position(|n| n == s.name())
                .ok_or_else(|| PeopleError::MissingSegment { name: s.name().to_owned() })?;
            let p = &msg.poses[i];
            let o = &p.orientation;
            let q = Quaternion::new(o.w, o.x, o.y, o.z);
            let n = q.norm();
            let finite = [p.position.x, p.position.y, p.position.z, o.w, o.x, o.y, o.z].iter().all(|v| v.is_finite());
            if !finite || n < 1e-6 {
                return Err(PeopleError::Malformed {
                    reason: format!("segment {:?}: non-finite position or degenerate quaternion", s.name()),
                });
            }
            let (lin, ang) = match msg.velocities.get(i) {
                Some(t) => (
                    Vector3::new(t.linear.x, t.linear.y, t.linear.z),
                    Vector3::new(t.angular.x, t.angular.y, t.angular.z),
                ),
                None => (Vector3::zeros(), Vector3::zeros()),
            };
            segments[s.index()] = SegmentState {
                position: Point3::new(p.position.x, p.position.y, p.position.z),
                orientation: UnitQuaternion::from_quaternion(q),
                linear_velocity: lin,
                angular_velocity: ang,
            };
        }
        let pelvis = segments[Segment::Pelvis.index()];
        let l = body.lengths();
        let fwd = horizontal_forward(&pelvis.orientation);
        let left = Vector3::new(-fwd.y, fwd.x, 0.0);
        let feet = [Side::Right, Side::Left].map(|side| {
            let p = pelvis.position.coords - side.sign() * l.hip_half_width * left;
            Foot { ankle: Point3::new(p.x, p.y, floor_z + l.ankle_height), heading: fwd }
        });
        Ok(Self { time: msg.header.stamp.to_secs_f64(), body, floor_z, segments, feet })
    }
}

impl SkeletonPose {
    /// The body size that fits the arms of this pose: the standing height whose upper-arm and
    /// forearm lengths (0.186 H and 0.146 H, see [`BodySize::lengths`]) add up to the mean
    /// shoulder–elbow–wrist path of the two arms, clamped to
    /// [[`BodySize::MIN_HEIGHT`], [`BodySize::MAX_HEIGHT`]]. Arm segments are rigid in every
    /// motion, so a moving person measures the same; sensor noise of a few mm moves the height
    /// by about 1 %.
    pub fn measured_body(&self) -> BodySize {
        let unit = BodySize { height: 1.0 }.lengths();
        let path: f64 = [Side::Right, Side::Left]
            .into_iter()
            .map(|side| {
                let [sh, el, wr, _] = Segment::arm(side);
                (self.position(el) - self.position(sh)).norm() + (self.position(wr) - self.position(el)).norm()
            })
            .sum();
        let height = path / (2.0 * (unit.upper_arm + unit.forearm));
        let height = if height.is_finite() { height } else { BodySize::default().height };
        BodySize { height: height.clamp(BodySize::MIN_HEIGHT, BodySize::MAX_HEIGHT) }
    }

    /// Like [`Self::from_message`] for a receiver that does not know the person: the body size
    /// (which places the feet and sizes the capsule body) is [measured](Self::measured_body)
    /// from the message's arms.
    pub fn from_message_measured(msg: &Skeleton, floor_z: f64) -> Result<Self> {
        let body = Self::from_message(msg, BodySize::default(), floor_z)?.measured_body();
        Self::from_message(msg, body, floor_z)
    }
}

/// Unit horizontal projection of a frame's x axis (the facing direction); +x if it is vertical.
pub(crate) fn horizontal_forward(q: &UnitQuaternion<f64>) -> Vector3<f64> {
    let x = q * Vector3::x();
    let h = Vector3::new(x.x, x.y, 0.0);
    let n = h.norm();
    if n > 1e-9 { h / n } else { Vector3::x() }
}
