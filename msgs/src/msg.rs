//! The custom `cowork_msgs` types (`msgs/msg/*.msg`).
//!
//! Unless a field says otherwise, frames are the robot base frame, lengths are in m,
//! velocities in m/s and times in s.

use serde::{Deserialize, Serialize};

use crate::builtin_interfaces::Time;
use crate::geometry_msgs::{Point, Pose, Twist, Vector3};
use crate::ros_message;
use crate::std_msgs::Header;

/// A tracked human skeleton: one pose per body segment (thesis Sec. 3.2.1, 4.2).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Skeleton {
    /// Time of the sample; frame of the poses.
    pub header: Header,
    /// `SOURCE_XSENS` or `SOURCE_DEPTH_TRACKER`.
    pub source: String,
    /// Tracker-assigned id of the person.
    pub person_id: u32,
    /// Segment names; `poses[i]` belongs to `segment_names[i]`.
    pub segment_names: Vec<String>,
    /// Segment poses in `header.frame_id` (m, unit quaternion).
    pub poses: Vec<Pose>,
    /// Segment velocities (m/s, rad/s); empty when not measured.
    pub velocities: Vec<Twist>,
}

ros_message!(
    Skeleton = "cowork_msgs" / "Skeleton" in "msg",
    deps [Header, Pose, Twist],
    consts {
        /// Xsens motion-capture suit, 11 segments at 120 Hz.
        SOURCE_XSENS: &'static str = "xsens",
        /// Depth-camera skeleton tracker.
        SOURCE_DEPTH_TRACKER: &'static str = "depth_tracker",
        SEGMENT_PELVIS: &'static str = "pelvis",
        SEGMENT_STERNUM: &'static str = "sternum",
        SEGMENT_HEAD: &'static str = "head",
        SEGMENT_RIGHT_SHOULDER: &'static str = "right_shoulder",
        SEGMENT_RIGHT_ELBOW: &'static str = "right_elbow",
        SEGMENT_RIGHT_WRIST: &'static str = "right_wrist",
        SEGMENT_RIGHT_HAND: &'static str = "right_hand",
        SEGMENT_LEFT_SHOULDER: &'static str = "left_shoulder",
        SEGMENT_LEFT_ELBOW: &'static str = "left_elbow",
        SEGMENT_LEFT_WRIST: &'static str = "left_wrist",
        SEGMENT_LEFT_HAND: &'static str = "left_hand",
    }
);

impl Skeleton {
    /// The 11 Xsens segments in the order the `.msg` lists them (thesis Sec. 4.2).
    pub const XSENS_SEGMENTS: [&'static str; 11] = [
        Self::SEGMENT_PELVIS,
        Self::SEGMENT_STERNUM,
        Self::SEGMENT_HEAD,
        Self::SEGMENT_RIGHT_SHOULDER,
        Self::SEGMENT_RIGHT_ELBOW,
        Self::SEGMENT_RIGHT_WRIST,
        Self::SEGMENT_RIGHT_HAND,
        Self::SEGMENT_LEFT_SHOULDER,
        Self::SEGMENT_LEFT_ELBOW,
        Self::SEGMENT_LEFT_WRIST,
        Self::SEGMENT_LEFT_HAND,
    ];

    /// Pose of the segment called `name`, if present.
    pub fn segment(&self, name: &str) -> Option<&Pose> {
        self.segment_names
            .iter()
            .position(|n| n == name)
            .and_then(|i| self.poses.get(i))
    }
}

/// The person near the robot as seen by `human_observer` (thesis Sec. 5.1.3).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HumanState {
    /// Time of the skeleton sample used; base frame.
    pub header: Header,
    /// `MODE_FAR` or `MODE_INTERACTION`.
    pub mode: u8,
    /// A person is tracked.
    pub present: bool,
    /// Minimum human-robot distance (m).
    pub distance: f64,
    /// Filtered hand position, base frame (m).
    pub hand_position: Point,
    /// Filtered hand velocity, base frame (m/s).
    pub hand_velocity: Vector3,
    /// alpha_h of eq. 5.3 (m/s); 0 after "stop".
    pub speed_scale: f64,
    /// Stopped by a gesture or the spoken "stop".
    pub stopped: bool,
}

ros_message!(
    HumanState = "cowork_msgs" / "HumanState" in "msg",
    deps [Header, Point, Vector3],
    consts {
        /// Person far: nominal speed.
        MODE_FAR: u8 = 0,
        /// Person close: reduced speed.
        MODE_INTERACTION: u8 = 1,
    }
);

/// A recognised gesture (thesis Sec. 3.2.1, 5.1.3).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Gesture {
    /// Time of the last frame of the window; base frame.
    pub header: Header,
    /// One of the `LABEL_*` values.
    pub label: String,
    /// Confidence in [0, 1].
    pub confidence: f64,
    /// DTW distance to the closest template (dimensionless).
    pub dtw_distance: f64,
    /// Gesturing hand pose at the end of the window, base frame.
    pub hand_pose: Pose,
}

ros_message!(
    Gesture = "cowork_msgs" / "Gesture" in "msg",
    deps [Header, Pose],
    consts {
        LABEL_COME: &'static str = "come",
        LABEL_STOP: &'static str = "stop",
        LABEL_HANDOVER_RIGHT: &'static str = "handover_right",
    }
);

/// Distance between one robot link and the closest obstacle (fDED, thesis Sec. 5.1.2).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkDistance {
    /// URDF link name.
    pub link_name: String,
    /// Link-obstacle distance (m); meaningless when `valid` is false.
    pub distance: f64,
    /// Closest point on the link, base frame (m).
    pub robot_point: Point,
    /// Closest obstacle point, base frame (m).
    pub obstacle_point: Point,
    /// Unit obstacle surface normal at `obstacle_point`, away from the obstacle.
    pub normal: Vector3,
    /// Obstacle point velocity, base frame (m/s).
    pub obstacle_velocity: Vector3,
    /// An obstacle was found for this link.
    pub valid: bool,
}

ros_message!(LinkDistance = "cowork_msgs" / "LinkDistance" in "msg", deps [Point, Vector3]);

/// Per-link distances of one depth frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LinkDistances {
    /// Stamp of the depth frame; base frame.
    pub header: Header,
    /// One entry per link, in chain order.
    pub links: Vec<LinkDistance>,
    /// Index of the smallest valid distance, -1 when none is valid.
    pub min_index: i32,
    /// Computation time (s).
    pub processing_time: f64,
    /// `"cpu"`, `"wgpu"`, `"brute_force"` or `"spheres"`.
    pub backend: String,
}

ros_message!(LinkDistances = "cowork_msgs" / "LinkDistances" in "msg", deps [Header, LinkDistance]);

impl LinkDistances {
    /// The entry at `min_index`, if it is valid.
    pub fn closest(&self) -> Option<&LinkDistance> {
        usize::try_from(self.min_index)
            .ok()
            .and_then(|i| self.links.get(i))
            .filter(|l| l.valid)
    }
}

/// A motion for the DS controller (thesis Ch. 3, Sec. 4.3.1, 5.1.1).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MotionCommand {
    /// Time of the command.
    pub header: Header,
    /// Command id, echoed in `MotionStatus::command_id`.
    pub id: u32,
    /// One of the `KIND_*` values.
    pub kind: u8,
    /// Action label, e.g. `"take(bottle)"`.
    pub label: String,
    /// Primitive parameters as JSON; empty when unused.
    pub parameters_json: String,
    /// Primitive parameters as a flat vector; empty when unused.
    pub parameters: Vec<f64>,
    /// Goal pose, base frame.
    pub goal: Pose,
    /// Nominal end-effector speed before human scaling (m/s).
    pub nominal_speed: f64,
    /// Keep the current end-effector orientation.
    pub hold_orientation: bool,
    /// Turn the end effector's obstacle avoidance off for this motion (handover, Sec. 5.1.3);
    /// `false` (the default) keeps it on. Null-space (link) avoidance stays on either way.
    pub end_effector_avoidance_off: bool,
}

ros_message!(
    MotionCommand = "cowork_msgs" / "MotionCommand" in "msg",
    deps [Header, Pose],
    consts {
        /// Linear DS (far-object action).
        KIND_LINEAR: u8 = 0,
        /// Constant-speed point-to-point DS.
        KIND_CONSTANT_SPEED: u8 = 1,
        /// Dynamic movement primitive (near-object action).
        KIND_DMP: u8 = 2,
        /// GMR-based DS.
        KIND_GMR: u8 = 3,
        /// Constrained GMR.
        KIND_CGMR: u8 = 4,
        /// Hold the current pose.
        KIND_HOLD: u8 = 5,
        /// HMM primitive: its generated path tracked (Algorithm 3, Sec. 4.1.3).
        KIND_HMM: u8 = 6,
        /// Joint-space move: parameters = [q_g (7, rad), gain (1/s), max_speed (rad/s)].
        KIND_JOINTS: u8 = 7,
    }
);

/// Progress of the current motion command.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MotionStatus {
    /// Time of the status.
    pub header: Header,
    /// `MotionCommand::id` this status belongs to.
    pub command_id: u32,
    /// One of the `STATE_*` values.
    pub state: u8,
    /// Why the state was entered (empty while running).
    pub reason: String,
    /// End-effector to goal distance (m).
    pub goal_error: f64,
}

ros_message!(
    MotionStatus = "cowork_msgs" / "MotionStatus" in "msg",
    deps [Header],
    consts {
        STATE_RUNNING: u8 = 0,
        STATE_CONVERGED: u8 = 1,
        STATE_ABORTED: u8 = 2,
        STATE_HELD: u8 = 3,
    }
);

impl MotionStatus {
    /// The name of a `STATE_*` value for logs: `running`, `converged`, `aborted`, `held`
    /// (`state 7` for a value outside them).
    pub fn state_name(state: u8) -> std::borrow::Cow<'static, str> {
        match state {
            Self::STATE_RUNNING => "running".into(),
            Self::STATE_CONVERGED => "converged".into(),
            Self::STATE_ABORTED => "aborted".into(),
            Self::STATE_HELD => "held".into(),
            other => format!("state {other}").into(),
        }
    }
}

/// An action started or finished by `robot_manager` (thesis Sec. 4.3.1, 5.2.1).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActionEvent {
    /// Action label, e.g. `"take(bottle)"`.
    pub label: String,
    /// One of the `KIND_*` values.
    pub kind: u8,
    /// `ActionCommand::id` that requested it; 0 while teaching.
    pub command_id: u32,
    /// The action is accomplished (`a.done`).
    pub done: bool,
    /// The action could not be accomplished (`done` is then false).
    pub failed: bool,
    /// Why it failed; empty otherwise.
    pub reason: String,
}

ros_message!(
    ActionEvent = "cowork_msgs" / "ActionEvent" in "msg",
    deps [],
    consts {
        /// Near-object action (DMP).
        KIND_NOA: u8 = 0,
        /// Far-object action (linear DS).
        KIND_FOA: u8 = 1,
        /// Gripper command.
        KIND_GRIPPER: u8 = 2,
    }
);

/// An action segmented online during teaching (thesis Sec. 4.3.1).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActionSegment {
    /// Generated label, e.g. `"reach(bottle)"`.
    pub label: String,
    /// One of the `KIND_*` values.
    pub kind: u8,
    /// Object whose proximity area bounds the segment; empty when none.
    pub object_name: String,
    /// Start of the segment.
    pub start_time: Time,
    /// End of the segment.
    pub end_time: Time,
    /// Goal (last) pose, base frame.
    pub goal: Pose,
    /// Key of the learned primitive; empty for gripper segments.
    pub primitive_id: String,
}

ros_message!(
    ActionSegment = "cowork_msgs" / "ActionSegment" in "msg",
    deps [Time, Pose],
    consts {
        KIND_NOA: u8 = 0,
        KIND_FOA: u8 = 1,
        KIND_GRIPPER: u8 = 2,
    }
);

/// Robot state stream for the attentional supervisor (thesis Fig. 4.10, Sec. 4.3.1).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RobotStream {
    /// Time of the state; base frame.
    pub header: Header,
    /// End-effector pose, base frame.
    pub ee_pose: Pose,
    /// `GRIPPER_OPEN` or `GRIPPER_CLOSED`.
    pub gripper_state: u8,
    /// Object in the gripper; empty when the hand is free.
    pub held_object: String,
    /// `MODE_EXECUTE` or `MODE_TEACH`.
    pub mode: u8,
    /// Action events since the previous message.
    pub events: Vec<ActionEvent>,
    /// Teaching segments since the previous message.
    pub segments: Vec<ActionSegment>,
}

ros_message!(
    RobotStream = "cowork_msgs" / "RobotStream" in "msg",
    deps [Header, Pose, ActionEvent, ActionSegment],
    consts {
        MODE_EXECUTE: u8 = 0,
        MODE_TEACH: u8 = 1,
        GRIPPER_OPEN: u8 = 0,
        GRIPPER_CLOSED: u8 = 1,
    }
);

/// One tracked object (thesis Sec. 4.3.1).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectState {
    /// Object name, e.g. `"bottle"`.
    pub name: String,
    /// Pose, base frame.
    pub pose: Pose,
    /// End-effector to object distance (m).
    pub robot_distance: f64,
    /// Currently seen (else `pose` is the last known one).
    pub visible: bool,
}

ros_message!(ObjectState = "cowork_msgs" / "ObjectState" in "msg", deps [Pose]);

/// All tracked objects.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectStream {
    /// Time; base frame.
    pub header: Header,
    /// The objects.
    pub objects: Vec<ObjectState>,
}

ros_message!(ObjectStream = "cowork_msgs" / "ObjectStream" in "msg", deps [Header, ObjectState]);

/// Action selected by the attentional supervisor (thesis Sec. 4.3.2, 5.2.2).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ActionCommand {
    /// Time of the decision.
    pub header: Header,
    /// Command id, echoed in `ActionEvent::command_id`.
    pub id: u32,
    /// Concrete action label, e.g. `"take(bottle)"`.
    pub label: String,
    /// `ARM_RIGHT`, `ARM_LEFT`, or empty for a single-arm robot.
    pub arm: String,
    /// Stop and abort the current action.
    pub stop: bool,
}

ros_message!(
    ActionCommand = "cowork_msgs" / "ActionCommand" in "msg",
    deps [Header],
    consts {
        ARM_RIGHT: &'static str = "right",
        ARM_LEFT: &'static str = "left",
    }
);

/// One working-memory behaviour, the 6-tuple (m, r, p, x, e, mu) (thesis Sec. 3.3, 4.3.2).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WmNode {
    /// Stable id while allocated.
    pub id: u32,
    /// Index of the parent in `WorkingMemory::nodes`; -1 for the root.
    pub parent: i32,
    /// m: behaviour name, e.g. `"take(bottle)"`.
    pub name: String,
    /// r: releaser text.
    pub releaser: String,
    /// Current value of the releaser.
    pub releaser_value: bool,
    /// p: post-condition text.
    pub postcondition: String,
    /// Concrete (atomic action) rather than abstract.
    pub concrete: bool,
    /// e = mu / lambda (1/s).
    pub emphasis: f64,
    /// mu: magnitude.
    pub magnitude: f64,
    /// lambda: activation period (s), eq. 4.8.
    pub period: f64,
    /// Post-condition satisfied.
    pub done: bool,
    /// Releaser and all ancestors' releasers hold.
    pub enabled: bool,
    /// `ASSIGNED_NONE`, `ASSIGNED_ROBOT` or `ASSIGNED_HUMAN`.
    pub assigned_to: u8,
    /// Robot arm: `"right"`, `"left"` or empty.
    pub arm: String,
}

ros_message!(
    WmNode = "cowork_msgs" / "WmNode" in "msg",
    deps [],
    consts {
        ASSIGNED_NONE: u8 = 0,
        ASSIGNED_ROBOT: u8 = 1,
        ASSIGNED_HUMAN: u8 = 2,
    }
);

/// Snapshot of the working memory (thesis Sec. 4.3.2).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorkingMemory {
    /// Time of the snapshot.
    pub header: Header,
    /// The tree in pre-order; `nodes[0]` is the root.
    pub nodes: Vec<WmNode>,
    /// State variables currently true, e.g. `"bottle.taken"`.
    pub true_variables: Vec<String>,
}

ros_message!(WorkingMemory = "cowork_msgs" / "WorkingMemory" in "msg", deps [Header, WmNode]);

/// One object of the simulated world, ground truth from `lwr_sim`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorldObject {
    /// Object name, as in the scene file.
    pub name: String,
    /// Pose of the shape centre, base frame.
    pub pose: Pose,
    /// Tool point to object surface distance (m); 0 inside.
    pub tool_distance: f64,
    /// Angle between the object's z axis and the base z axis (rad).
    pub tilt: f64,
    /// Held by the gripper.
    pub held: bool,
}

ros_message!(WorldObject = "cowork_msgs" / "WorldObject" in "msg", deps [Pose]);

/// State of the simulated world on `/lwr/world`: grasp state, tool pose, every object.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct WorldState {
    /// Simulated time; base frame.
    pub header: Header,
    /// `GRIPPER_OPEN` or `GRIPPER_CLOSED`.
    pub gripper_state: u8,
    /// Held object; empty when nothing is held.
    pub held_object: String,
    /// Tool (tip link) pose, base frame.
    pub tool_pose: Pose,
    /// Every scene object, in scene-file order.
    pub objects: Vec<WorldObject>,
}

ros_message!(
    WorldState = "cowork_msgs" / "WorldState" in "msg",
    deps [Header, Pose, WorldObject],
    consts {
        GRIPPER_OPEN: u8 = 0,
        GRIPPER_CLOSED: u8 = 1,
    }
);
