//! ROS 2 message types of the cowork graph: Rust structs tied to their `.msg` definitions.
//!
//! Every message is a plain serde struct whose field order equals its `.msg` file (CDR is
//! positional). The [`RosMessage`] trait ties the struct to its ROS package, type name and
//! `.msg` text, and lists its direct dependencies, so the ROS type string, the DDS type string
//! and the full MCAP `ros2msg` schema are all derived from one place and cannot drift.
//!
//! * standard types the graph uses live in modules named after their ROS package
//!   ([`std_msgs`], [`builtin_interfaces`], [`sensor_msgs`], [`geometry_msgs`], [`tf2_msgs`],
//!   [`rosgraph_msgs`], [`visualization_msgs`]); their `.msg` texts are in `msgs/ros_std/` (field lines as upstream);
//! * the custom `cowork_msgs` types live in [`msg`]; their `.msg` files in `msgs/msg/` form a
//!   real ROS 2 interface package (`package.xml`, `CMakeLists.txt`).
//!
//! ```
//! use cowork_msgs::{RosMessage, from_cdr, to_cdr, sensor_msgs::JointState};
//!
//! assert_eq!(JointState::type_name(), "sensor_msgs/msg/JointState");
//! assert_eq!(JointState::dds_type_name(), "sensor_msgs::msg::dds_::JointState_");
//! assert!(JointState::ros2msg_definition().contains("MSG: builtin_interfaces/Time"));
//!
//! let js = JointState { name: vec!["joint_1".into()], position: vec![0.5], ..Default::default() };
//! let bytes = to_cdr(&js);
//! assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
//! let back: JointState = from_cdr(&bytes).unwrap();
//! assert_eq!(back, js);
//! ```

use std::fmt::Debug;

use serde::Serialize;
use serde::de::DeserializeOwned;

mod bytes;
mod cdr;
mod registry;

pub mod builtin_interfaces;
pub mod geometry_msgs;
pub mod msg;
pub mod rosgraph_msgs;
pub mod sensor_msgs;
pub mod std_msgs;
pub mod tf2_msgs;
pub mod topics;
pub mod visualization_msgs;

pub use cdr::{CdrError, from_cdr, to_cdr, to_cdr_into};
pub use registry::{MessageTypeInfo, find_type, known_types, type_name_matches};

/// The 80-character line that precedes every dependency section of a `ros2msg` schema.
pub const DEFINITION_SEPARATOR: &str =
    "================================================================================";

/// Static description of one message type: enough to write its full `ros2msg` schema.
#[derive(Clone, Copy, Debug)]
pub struct TypeDescription {
    /// ROS package, e.g. `"sensor_msgs"`.
    pub package: &'static str,
    /// Type name inside the package, e.g. `"JointState"`.
    pub name: &'static str,
    /// The type's own `.msg` text.
    pub msg: &'static str,
    /// Direct dependencies: the non-primitive field types of `msg`.
    pub dependencies: &'static [TypeDescription],
}

impl TypeDescription {
    /// ROS 2 type name, e.g. `"sensor_msgs/msg/JointState"`.
    pub fn type_name(&self) -> String {
        format!("{}/msg/{}", self.package, self.name)
    }

    /// DDS type name, e.g. `"sensor_msgs::msg::dds_::JointState_"`.
    pub fn dds_type_name(&self) -> String {
        format!("{}::msg::dds_::{}_", self.package, self.name)
    }

    /// `package/Name` as written in `.msg` files and in `MSG:` section headers.
    pub fn short_name(&self) -> String {
        format!("{}/{}", self.package, self.name)
    }

    /// Full `ros2msg` schema: this type's `.msg` text followed, for every transitive
    /// dependency (each once), by a separator line, `MSG: package/Name` and its text.
    ///
    /// The order is the one rosbag2 writes (`LocalMessageDefinitionSource::get_full_text`):
    /// depth-first, the direct dependencies of each type visited in byte order of their
    /// `package/Name`, every type emitted the first time it is reached.
    pub fn ros2msg_definition(&self) -> String {
        let mut seen: Vec<(&'static str, &'static str)> = Vec::new();
        let mut out = String::new();
        self.append_definition(&mut seen, &mut out);
        out
    }

    fn append_definition(&self, seen: &mut Vec<(&'static str, &'static str)>, out: &mut String) {
        out.push_str(self.msg);
        let mut deps: Vec<&TypeDescription> = self.dependencies.iter().collect();
        // rosbag2 keeps the dependencies of one .msg in a std::set<std::string>.
        deps.sort_by(|a, b| (a.package, '/', a.name).cmp(&(b.package, '/', b.name)));
        for dep in deps {
            let key = (dep.package, dep.name);
            if seen.contains(&key) {
                continue;
            }
            seen.push(key);
            out.push('\n');
            out.push_str(DEFINITION_SEPARATOR);
            out.push_str("\nMSG: ");
            out.push_str(dep.package);
            out.push('/');
            out.push_str(dep.name);
            out.push('\n');
            dep.append_definition(seen, out);
        }
    }
}

/// One constant of a `.msg` file, as the Rust side declares it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Constant {
    /// Constant name, e.g. `"MODE_FAR"`.
    pub name: &'static str,
    /// Rust type of the associated constant, e.g. `"u8"`.
    pub rust_type: &'static str,
    /// Value as written, e.g. `"0"` or `"\"xsens\""`.
    pub value: &'static str,
}

/// A Rust struct that is the ROS 2 message `PACKAGE/msg/NAME`.
///
/// Implemented (through an internal macro) for every message of this crate; the macro reads
/// `MSG` from the `.msg` file, and the crate's tests check that `DEPENDENCIES` lists every
/// non-primitive field type of `MSG`, that the struct's fields equal the `.msg` fields in
/// name, order and kind, and that `CONSTANTS` equals the `.msg` constants.
pub trait RosMessage:
    Serialize + DeserializeOwned + Clone + Debug + Default + PartialEq + Send + Sync + 'static
{
    /// ROS package, e.g. `"sensor_msgs"`.
    const PACKAGE: &'static str;
    /// Type name inside the package, e.g. `"JointState"`.
    const NAME: &'static str;
    /// This type's own `.msg` text (the `.msg` file, included at compile time).
    const MSG: &'static str;
    /// Direct dependencies: one entry per distinct non-primitive field type of `MSG`.
    const DEPENDENCIES: &'static [TypeDescription];
    /// The `.msg` constants; each is also an associated constant of the struct.
    const CONSTANTS: &'static [Constant] = &[];
    /// Everything above in one value (used for dependency lists).
    const DESCRIPTION: TypeDescription = TypeDescription {
        package: Self::PACKAGE,
        name: Self::NAME,
        msg: Self::MSG,
        dependencies: Self::DEPENDENCIES,
    };

    /// Full MCAP `ros2msg` schema text, see [`TypeDescription::ros2msg_definition`].
    fn ros2msg_definition() -> String {
        Self::DESCRIPTION.ros2msg_definition()
    }

    /// ROS 2 type name, e.g. `"sensor_msgs/msg/JointState"`.
    fn type_name() -> String {
        Self::DESCRIPTION.type_name()
    }

    /// DDS type name, e.g. `"sensor_msgs::msg::dds_::JointState_"`.
    fn dds_type_name() -> String {
        Self::DESCRIPTION.dds_type_name()
    }
}

/// Implements [`RosMessage`] for a struct and defines its `.msg` constants.
///
/// `ros_message!(Type = "pkg"/"Name" in "dir", deps [A, B], consts { C: u8 = 0 });` reads
/// `$CARGO_MANIFEST_DIR/dir/Name.msg`.
macro_rules! ros_message {
    (
        $ty:ident = $pkg:literal / $name:literal in $dir:literal,
        deps [$($dep:ty),* $(,)?]
        $(, consts { $($(#[$cmeta:meta])* $cname:ident : $cty:ty = $cval:expr),* $(,)? })?
        $(,)?
    ) => {
        impl $crate::RosMessage for $ty {
            const PACKAGE: &'static str = $pkg;
            const NAME: &'static str = $name;
            const MSG: &'static str =
                include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/", $dir, "/", $name, ".msg"));
            const DEPENDENCIES: &'static [$crate::TypeDescription] =
                &[$(<$dep as $crate::RosMessage>::DESCRIPTION),*];
            $(
                const CONSTANTS: &'static [$crate::Constant] = &[$(
                    $crate::Constant {
                        name: stringify!($cname),
                        rust_type: stringify!($cty),
                        value: stringify!($cval),
                    }
                ),*];
            )?
        }
        $(
            impl $ty {
                $(
                    $(#[$cmeta])*
                    pub const $cname: $cty = $cval;
                )*
            }
        )?
    };
}
pub(crate) use ros_message;

/// Lists every message type of the crate as `module::Type` and passes the list to the macro
/// named first. Single source for [`known_types`] and [`with_message_type!`].
#[doc(hidden)]
#[macro_export]
macro_rules! __for_all_message_types {
    ($callback:ident ! ($($args:tt)*)) => {
        $crate::$callback! { ($($args)*)
            builtin_interfaces::Time,
            builtin_interfaces::Duration,
            std_msgs::Header,
            std_msgs::String,
            std_msgs::MultiArrayDimension,
            std_msgs::MultiArrayLayout,
            std_msgs::Float64MultiArray,
            std_msgs::ColorRGBA,
            geometry_msgs::Point,
            geometry_msgs::Point32,
            geometry_msgs::Vector3,
            geometry_msgs::Quaternion,
            geometry_msgs::Pose,
            geometry_msgs::PoseStamped,
            geometry_msgs::Twist,
            geometry_msgs::Wrench,
            geometry_msgs::WrenchStamped,
            geometry_msgs::Transform,
            geometry_msgs::TransformStamped,
            sensor_msgs::JointState,
            sensor_msgs::Image,
            sensor_msgs::RegionOfInterest,
            sensor_msgs::CameraInfo,
            sensor_msgs::CompressedImage,
            tf2_msgs::TFMessage,
            visualization_msgs::UVCoordinate,
            visualization_msgs::MeshFile,
            visualization_msgs::Marker,
            visualization_msgs::MarkerArray,
            rosgraph_msgs::Clock,
            msg::Skeleton,
            msg::HumanState,
            msg::Gesture,
            msg::LinkDistance,
            msg::LinkDistances,
            msg::MotionCommand,
            msg::MotionStatus,
            msg::ActionEvent,
            msg::ActionSegment,
            msg::RobotStream,
            msg::ObjectState,
            msg::ObjectStream,
            msg::ActionCommand,
            msg::WmNode,
            msg::WorkingMemory,
            msg::WorldObject,
            msg::WorldState,
        }
    };
}

#[doc(hidden)]
#[macro_export]
macro_rules! __with_message_type_impl {
    (($name:expr, $t:ident, $body:expr) $($module:ident :: $ty:ident),* $(,)?) => {{
        let __cowork_type_name: &str = $name;
        $(
            if $crate::type_name_matches(
                <$crate::$module::$ty as $crate::RosMessage>::PACKAGE,
                <$crate::$module::$ty as $crate::RosMessage>::NAME,
                __cowork_type_name,
            ) {
                #[allow(dead_code)]
                type $t = $crate::$module::$ty;
                ::core::option::Option::Some($body)
            } else
        )*
        {
            ::core::option::Option::None
        }
    }};
}

/// Runs `expr` with the type parameter `T` bound to the known message type named by
/// `type_name` and returns `Some(expr)`, or `None` when no known type has that name.
///
/// The name may be written `pkg/msg/Name`, `pkg/Name` or as the DDS name
/// `pkg::msg::dds_::Name_`. Used to create typed subscriptions for discovered topics.
///
/// ```
/// use cowork_msgs::{RosMessage, with_message_type};
///
/// let def = with_message_type!("sensor_msgs/msg/JointState", T => T::ros2msg_definition());
/// assert!(def.unwrap().starts_with("# State of a set of joints"));
/// assert!(with_message_type!("no_msgs/msg/Nothing", T => T::type_name()).is_none());
/// ```
#[macro_export]
macro_rules! with_message_type {
    ($type_name:expr, $t:ident => $body:expr) => {
        $crate::__for_all_message_types!(__with_message_type_impl!($type_name, $t, $body))
    };
}
