//! Every topic of the graph, defined once: its name, its message type and how it is delivered
//! to writers and readers. Nodes open them with `cowork_ros::RosNode::{advertise, subscribe}`;
//! the bag tools and the synthesiser (which have no ROS dependency) take names and types from
//! here too, so a topic can never be spelt two ways.
//!
//! # Namespaces (one graph, several arms)
//!
//! A topic is either [`Scope::Robot`], one per arm (ROS 2 would write it as a *relative* name,
//! resolved in the node's namespace), or [`Scope::Graph`], one for the whole graph (an absolute
//! name: `/clock`, `/tf`, the camera, the person, speech, the supervisor). [`Topic::name`] is the
//! name in the root namespace `/`, so a single-arm graph is unchanged. An arm's nodes run in the
//! arm's namespace (`ds_controller --ros-args -r __ns:=/left`), where its per-arm topics live:
//! `/left/joint_states`, `/left/lwr/joint_velocity_command` ([`Topic::name_in`]). A node that
//! serves several arms (the simulator, the supervisor) opens each arm's topic in that arm's
//! namespace explicitly (`cowork_ros::RosNode::advertise_in`).
//!
//! TF frames of a namespaced arm are prefixed `<ns>/` ([`frame_prefix`]: `left/lwr_link_3`), as
//! robot_state_publisher's `frame_prefix` does in ROS 2 multi-robot setups, so both arms share
//! `/tf`; joint names in `<ns>/joint_states` are not prefixed (each arm's joints are named as in
//! its URDF). Do not call an arm `lwr`: its `/lwr/external_wrench` (EXTERNAL_WRENCH) would be
//! the root arm's [`LWR_EXTERNAL_WRENCH`].
//!
//! ```
//! use cowork_msgs::topics;
//! assert_eq!(topics::JOINT_STATES.name, "/joint_states");
//! assert_eq!(topics::JOINT_STATES.type_name(), "sensor_msgs/msg/JointState");
//! assert_eq!(topics::JOINT_STATES.name_in("/left"), "/left/joint_states");
//! assert_eq!(topics::CLOCK.name_in("/left"), "/clock");
//! ```

use std::borrow::Cow;
use std::marker::PhantomData;

use crate::RosMessage;
use crate::geometry_msgs::WrenchStamped;
use crate::msg::{
    ActionCommand, Gesture, HumanState, LinkDistances, MotionCommand, MotionStatus, ObjectStream, RobotStream, Skeleton,
    WorkingMemory, WorldObject, WorldState,
};
use crate::rosgraph_msgs::Clock;
use crate::sensor_msgs::{CameraInfo, Image, JointState};
use crate::std_msgs::{Float64MultiArray, String as RosString};
use crate::tf2_msgs::TFMessage;
use crate::visualization_msgs::MarkerArray;

/// How a topic is delivered (mapped to a DDS QoS profile by `cowork_ros::qos::of`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Delivery {
    /// Reliable, volatile, keep last `depth`; a writer never waits for a slow reader.
    Reliable {
        /// Queue depth (messages).
        depth: usize,
    },
    /// Best effort, volatile, keep last `depth`: only the newest samples matter.
    BestEffort {
        /// Queue depth (messages).
        depth: usize,
    },
    /// Reliable, transient local, keep last 1: a late reader gets the last message.
    Latched,
    /// `/clock`: best effort, keep last 1.
    Clock,
}

impl Delivery {
    /// ROS 2's default: reliable, keep last 10.
    pub const DEFAULT: Delivery = Delivery::Reliable { depth: 10 };
    /// Sensor streams (rclcpp's `SensorDataQoS`): best effort, keep last 5.
    pub const SENSOR_DATA: Delivery = Delivery::BestEffort { depth: 5 };
}

/// Whether a topic is one per arm or one for the whole graph (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// One per arm: ROS 2 would write it as a relative name, resolved in the namespace of the
    /// node that opens it (`/left/joint_states` in `/left`).
    Robot,
    /// One for the whole graph: an absolute name, the same in every namespace.
    Graph,
}

/// A topic of the graph: name, scope, message type `T`, and the delivery of its writers and
/// readers. The two may differ: `/joint_states` is written reliably but read best effort, so a
/// stalled reader never blocks the simulator's 1 kHz writes.
#[derive(Debug)]
pub struct Topic<T> {
    /// ROS name in the root namespace `/`, e.g. `/joint_states`; [`name_in`](Self::name_in)
    /// gives it in another namespace.
    pub name: &'static str,
    /// One per arm or one for the graph.
    pub scope: Scope,
    /// Delivery of the graph's writers.
    pub writer: Delivery,
    /// Delivery of the graph's readers.
    pub reader: Delivery,
    _type: PhantomData<fn() -> T>,
}

impl<T> Clone for Topic<T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for Topic<T> {}

impl<T: RosMessage> Topic<T> {
    /// A graph-scoped topic whose writers and readers share `delivery`.
    pub const fn new(name: &'static str, delivery: Delivery) -> Self {
        Self { name, scope: Scope::Graph, writer: delivery, reader: delivery, _type: PhantomData }
    }

    /// A graph-scoped topic written with `writer` and read with `reader`.
    pub const fn with_reader(name: &'static str, writer: Delivery, reader: Delivery) -> Self {
        Self { name, scope: Scope::Graph, writer, reader, _type: PhantomData }
    }

    /// The same topic, one per arm ([`Scope::Robot`]).
    pub const fn per_robot(self) -> Self {
        Self { scope: Scope::Robot, ..self }
    }

    /// The same topic read (or written, by the same token) with another delivery: a tool that
    /// wants a deeper queue than the graph's nodes.
    pub const fn reading(self, reader: Delivery) -> Self {
        Self { reader, ..self }
    }

    /// The same topic written with another delivery (a bag replay that would rather wait).
    pub const fn writing(self, writer: Delivery) -> Self {
        Self { writer, ..self }
    }

    /// ROS type name, e.g. `sensor_msgs/msg/JointState`.
    pub fn type_name(&self) -> String {
        T::type_name()
    }
}

impl<T> Topic<T> {
    /// The topic's name for a node in `namespace` (an absolute ROS namespace, `/` or `/left`;
    /// a trailing `/` is ignored): `namespace` + [`name`](Self::name) for a [`Scope::Robot`]
    /// topic outside the root namespace (`/left/lwr/joint_velocity_command`), else `name`.
    /// `namespace` is not checked here (`cowork_ros::RosNode` checks it); allocates only for a
    /// per-arm topic in a namespace.
    pub fn name_in(&self, namespace: &str) -> Cow<'static, str> {
        let ns = namespace.trim_end_matches('/');
        match self.scope {
            Scope::Robot if !ns.is_empty() => Cow::Owned(format!("{ns}{}", self.name)),
            _ => Cow::Borrowed(self.name),
        }
    }
}

/// The TF frame prefix of an arm in `namespace`: `""` in the root namespace, `left/` in `/left`
/// (nested namespaces keep their path: `a/b/`), as robot_state_publisher's `frame_prefix` in
/// ROS 2 multi-robot setups; a frame is `prefix + link` (`left/lwr_link_3`).
pub fn frame_prefix(namespace: &str) -> String {
    let ns = namespace.trim_matches('/');
    if ns.is_empty() { String::new() } else { format!("{ns}/") }
}

/// Simulated time, written by `lwr_sim`.
pub const CLOCK: Topic<Clock> = Topic::new("/clock", Delivery::Clock);
/// The arm's joint positions / velocities (1 kHz, `lwr_sim`); read best effort, newest first.
pub const JOINT_STATES: Topic<JointState> =
    Topic::with_reader("/joint_states", Delivery::DEFAULT, Delivery::BestEffort { depth: 100 }).per_robot();
/// Joint velocity command (rad/s) from `ds_controller` to `lwr_sim`.
pub const JOINT_VELOCITY_COMMAND: Topic<Float64MultiArray> = Topic::new("/lwr/joint_velocity_command", Delivery::DEFAULT).per_robot();
/// Imitation teaching (thesis Sec. 4.2): joint position targets (rad, `position`, the arm's
/// joint names) of the demonstrator's arm retargeted onto the robot arm by `human_observer`
/// (eq. 4.7), stamped with the skeleton frame's stamp; `lwr_sim` makes the arm follow them (the
/// visual feedback the thesis gives in V-Rep) and a real arm's driver may ignore them.
pub const FOLLOW_JOINTS: Topic<JointState> = Topic::new("/lwr/follow_joints", Delivery::Reliable { depth: 1000 }).per_robot();
/// Task transition control while a push is blended in (thesis Sec. 4.1.2, Fig. 4.7), from
/// `ds_controller` at most every 10 ms of node time: `[w1, w2, w3, f]`, the barycentric weights
/// of T¹ = T_ee, T² = [T_ee, T_ic], T³ = [T_ic, T_ee] and the push's norm (N); one `[1, 0, 0, 0]`
/// when the blend is back at T¹.
pub const TTC_WEIGHTS: Topic<Float64MultiArray> = Topic::new("/ds_controller/ttc", Delivery::DEFAULT).per_robot();
/// `open` / `close` for the gripper.
pub const GRIPPER_COMMAND: Topic<RosString> = Topic::new("/lwr/gripper_command", Delivery::DEFAULT).per_robot();
/// Pushes on the arm by a person or a test (base frame, N / N·m), in.
pub const EXTERNAL_WRENCH: Topic<WrenchStamped> = Topic::new("/external_wrench", Delivery::Reliable { depth: 1000 }).per_robot();
/// The wrench `lwr_sim` measures on the arm in execute mode, out, for the controller.
pub const LWR_EXTERNAL_WRENCH: Topic<WrenchStamped> =
    Topic::with_reader("/lwr/external_wrench", Delivery::Reliable { depth: 100 }, Delivery::BestEffort { depth: 100 }).per_robot();
/// Link transforms.
pub const TF: Topic<TFMessage> = Topic::new("/tf", Delivery::Reliable { depth: 100 });
/// Static transforms (camera, world), latched.
pub const TF_STATIC: Topic<TFMessage> = Topic::new("/tf_static", Delivery::Latched);
/// The arm's URDF, latched.
pub const ROBOT_DESCRIPTION: Topic<RosString> = Topic::new("/robot_description", Delivery::Latched).per_robot();
/// Simulated depth image (m, 32FC1).
pub const DEPTH_IMAGE: Topic<Image> = Topic::new("/camera/depth/image_raw", Delivery::SENSOR_DATA);
/// The depth camera's intrinsics.
pub const DEPTH_CAMERA_INFO: Topic<CameraInfo> = Topic::new("/camera/depth/camera_info", Delivery::SENSOR_DATA);
/// Ground truth of the simulated world: object poses, gripper, what is held.
pub const WORLD: Topic<WorldState> = Topic::new("/lwr/world", Delivery::Reliable { depth: 100 }).per_robot();
/// A person moves a scene object (name + pose).
pub const PLACE_OBJECT: Topic<WorldObject> = Topic::new("/lwr/place_object", Delivery::Reliable { depth: 100 });
/// The tracked person's skeleton (Xsens / Kinect / synthesised).
pub const SKELETON: Topic<Skeleton> = Topic::with_reader("/human/skeleton", Delivery::Reliable { depth: 50 }, Delivery::DEFAULT);
/// The human observer's state of the person (distance, speed, attention).
pub const HUMAN_STATE: Topic<HumanState> = Topic::new("/human/state", Delivery::DEFAULT);
/// Recognised gestures.
pub const GESTURE: Topic<Gesture> = Topic::new("/human/gesture", Delivery::DEFAULT);
/// Gesture labels of a training recording (JSON `label`, `start`, `end`), for learning the
/// gesture model from bags.
pub const GESTURE_LABEL: Topic<RosString> = Topic::new("/human/gesture_label", Delivery::DEFAULT);
/// The person's skeleton as markers, for RViz / Foxglove.
pub const HUMAN_MARKERS: Topic<MarkerArray> = Topic::new("/human/markers", Delivery::DEFAULT);
/// Speech commands (`teach`, `done`, `stop`, `repeat`, `human add(water)` …).
pub const SPEECH_COMMAND: Topic<RosString> = Topic::new("/speech_command", Delivery::DEFAULT);
/// fDED distances from each link to the obstacles (m).
pub const FDED_DISTANCES: Topic<LinkDistances> = Topic::new("/fded/distances", Delivery::DEFAULT).per_robot();
/// fDED's obstacle points and closest pairs as markers.
pub const FDED_MARKERS: Topic<MarkerArray> = Topic::new("/fded/markers", Delivery::DEFAULT).per_robot();
/// A motion for the controller (primitive, goal, gains).
pub const MOTION_COMMAND: Topic<MotionCommand> = Topic::new("/motion/command", Delivery::Reliable { depth: 10 }).per_robot();
/// The controller's progress on the current motion.
pub const MOTION_STATUS: Topic<MotionStatus> = Topic::new("/motion/status", Delivery::Reliable { depth: 10 }).per_robot();
/// The robot manager's action events and segments. A state stream (30 Hz of simulated time,
/// 120 Hz of wall time while teaching at `--rate 4`) that carries events which must not be
/// lost: with depth 100 a supervisor stalled for 0.8 s on a loaded machine lost a reliable
/// sample to the writer's KeepLast history (`noa5(cup)` of a pouring demonstration never
/// reached it, so pour(water) was learned without its pour). 2000 samples hold ≥ 16 s of wall
/// time at any rate the graph runs.
pub const ROBOT_STREAM: Topic<RobotStream> = Topic::new("/robot_stream", Delivery::Reliable { depth: 2000 }).per_robot();
/// Objects the robot manager sees (visible, pose).
pub const OBJECT_STREAM: Topic<ObjectStream> = Topic::new("/object_stream", Delivery::DEFAULT).per_robot();
/// Objects the robot holds or is about to hold (fDED leaves them out of the obstacles).
pub const MANIPULATED_OBJECTS: Topic<ObjectStream> = Topic::new("/manipulated_objects", Delivery::Reliable { depth: 100 }).per_robot();
/// The supervisor's action for the robot manager.
pub const SUPERVISOR_ACTION: Topic<ActionCommand> = Topic::new("/supervisor/action", Delivery::DEFAULT);
/// The supervisor's working memory (for tools and reports).
pub const WORKING_MEMORY: Topic<WorkingMemory> = Topic::new("/supervisor/working_memory", Delivery::DEFAULT);

/// Name (in the root namespace), ROS type and writer delivery of every topic above (bag tools,
/// the README's table). A per-arm topic is listed once, by its root name; [`find`] also knows
/// it under an arm's namespace.
pub fn all() -> Vec<(&'static str, String, Delivery)> {
    entries().into_iter().map(|(name, ty, writer, _)| (name, ty, writer)).collect()
}

/// [`all`] with each topic's scope.
fn entries() -> Vec<(&'static str, String, Delivery, Scope)> {
    fn e<T: RosMessage>(t: &Topic<T>) -> (&'static str, String, Delivery, Scope) {
        (t.name, t.type_name(), t.writer, t.scope)
    }
    vec![
        e(&CLOCK),
        e(&JOINT_STATES),
        e(&JOINT_VELOCITY_COMMAND),
        e(&FOLLOW_JOINTS),
        e(&TTC_WEIGHTS),
        e(&GRIPPER_COMMAND),
        e(&EXTERNAL_WRENCH),
        e(&LWR_EXTERNAL_WRENCH),
        e(&TF),
        e(&TF_STATIC),
        e(&ROBOT_DESCRIPTION),
        e(&DEPTH_IMAGE),
        e(&DEPTH_CAMERA_INFO),
        e(&WORLD),
        e(&PLACE_OBJECT),
        e(&SKELETON),
        e(&HUMAN_STATE),
        e(&GESTURE),
        e(&GESTURE_LABEL),
        e(&HUMAN_MARKERS),
        e(&SPEECH_COMMAND),
        e(&FDED_DISTANCES),
        e(&FDED_MARKERS),
        e(&MOTION_COMMAND),
        e(&MOTION_STATUS),
        e(&ROBOT_STREAM),
        e(&OBJECT_STREAM),
        e(&MANIPULATED_OBJECTS),
        e(&SUPERVISOR_ACTION),
        e(&WORKING_MEMORY),
    ]
}

/// The entry of [`all`] for the topic called `name`: a topic's root name (`/joint_states`), or
/// a per-arm topic under one namespace token (`/left/joint_states`,
/// `/right/lwr/joint_velocity_command`). A graph topic under a namespace (`/left/clock`) is
/// none of the graph's. The root name wins where both readings exist.
pub fn find(name: &str) -> Option<(&'static str, String, Delivery)> {
    let entries = entries();
    let exact = entries.iter().position(|(n, ..)| *n == name);
    let namespaced = || {
        let rest = &name[name.strip_prefix('/')?.find('/')? + 1..];
        entries.iter().position(|(n, _, _, scope)| *scope == Scope::Robot && *n == rest)
    };
    let i = exact.or_else(namespaced)?;
    let (n, ty, writer, _) = entries.into_iter().nth(i)?;
    Some((n, ty, writer))
}

/// The writer delivery of the graph topic called `name` ([`find`]: `/joint_states` or
/// `/left/joint_states`), if it is one.
pub fn writer_delivery(name: &str) -> Option<Delivery> {
    find(name).map(|(_, _, d)| d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_ros_names_and_types_are_known() {
        let all = all();
        let mut names: Vec<_> = all.iter().map(|(n, _, _)| *n).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), all.len(), "a topic is defined twice");
        for (name, ty, _) in &all {
            assert!(name.starts_with('/') && !name.ends_with('/') && !name.contains("//"), "{name}");
            assert!(crate::find_type(ty).is_some(), "{name}: type {ty} not in the registry");
        }
    }

    /// The README's "Topics and QoS" table is one table (no blank line splits it, which renders
    /// the rest as text) and lists every topic defined here, with its type.
    #[test]
    fn the_readme_topic_table_lists_every_topic_in_one_table() {
        let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md")).expect("README.md");
        let section = readme.split("## Topics and QoS").nth(1).expect("a Topics and QoS section");
        let section = section.split("\n## ").next().unwrap_or(section);
        let lines: Vec<&str> = section.lines().collect();
        let first = lines.iter().position(|l| l.starts_with("| topic |")).expect("the table header");
        let rows: Vec<&str> = lines[first..].iter().copied().take_while(|l| l.starts_with('|')).collect();
        let after = lines[first + rows.len()..].iter().find(|l| !l.trim().is_empty());
        assert!(!after.is_some_and(|l| l.starts_with('|')), "a blank line splits the topic table before {after:?}");
        for (name, ty, _) in all() {
            let short = ty.replace("/msg/", "/");
            let row = rows.iter().find(|r| r.starts_with(&format!("| `{name}` |")));
            let row = row.unwrap_or_else(|| panic!("README topic table: no row for {name}"));
            assert!(row.contains(&short), "README topic table: {name} is not shown as {short}: {row}");
        }
    }

    #[test]
    fn per_arm_topics_resolve_in_the_arms_namespace() {
        assert_eq!(JOINT_STATES.name_in("/"), "/joint_states");
        assert_eq!(JOINT_STATES.name_in("/left"), "/left/joint_states");
        assert_eq!(JOINT_STATES.name_in("/left/"), "/left/joint_states");
        assert_eq!(JOINT_VELOCITY_COMMAND.name_in("/right"), "/right/lwr/joint_velocity_command");
        assert_eq!(TTC_WEIGHTS.name_in("/left"), "/left/ds_controller/ttc");
        assert_eq!(JOINT_STATES.name_in("/a/b"), "/a/b/joint_states");
        // Graph topics are the same in every namespace.
        for name in [CLOCK.name_in("/left"), TF.name_in("/left"), SPEECH_COMMAND.name_in("/left"), PLACE_OBJECT.name_in("/left")] {
            assert!(!name.starts_with("/left"), "{name}");
        }
        assert_eq!(frame_prefix("/"), "");
        assert_eq!(frame_prefix("/left"), "left/");
        assert_eq!(frame_prefix("/a/b"), "a/b/");
    }

    #[test]
    fn the_scopes_are_as_documented() {
        let robot = [
            "/joint_states", "/lwr/joint_velocity_command", "/lwr/follow_joints", "/ds_controller/ttc", "/lwr/gripper_command",
            "/external_wrench", "/lwr/external_wrench", "/robot_description", "/lwr/world", "/fded/distances",
            "/fded/markers", "/motion/command", "/motion/status", "/robot_stream", "/object_stream",
            "/manipulated_objects",
        ];
        let entries = entries();
        for (name, _, _, scope) in &entries {
            let expected = if robot.contains(name) { Scope::Robot } else { Scope::Graph };
            assert_eq!(*scope, expected, "{name}");
        }
        assert_eq!(entries.iter().filter(|e| e.3 == Scope::Robot).count(), robot.len());
    }

    #[test]
    fn find_knows_per_arm_topics_under_a_namespace() {
        for (name, ty, writer, scope) in entries() {
            assert_eq!(find(name), Some((name, ty.clone(), writer)), "{name}");
            let left = format!("/left{name}");
            let expected = (scope == Scope::Robot).then_some((name, ty, writer));
            assert_eq!(find(&left), expected, "{left}");
        }
        assert_eq!(writer_delivery("/right/lwr/joint_velocity_command"), Some(Delivery::DEFAULT));
        assert_eq!(writer_delivery("/left/tf_static"), None);
        assert_eq!(writer_delivery("/a/b/joint_states"), None);
        assert_eq!(find("/joint_states/"), None);
        assert_eq!(find("left/joint_states"), None);
        assert_eq!(find(""), None);
    }
}
