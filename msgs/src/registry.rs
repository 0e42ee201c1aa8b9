//! Run-time registry of the known message types, for tools that only have a type name
//! (bag info, topic echo, discovered DDS topics).

use crate::RosMessage;
use crate::cdr::{self, CdrError};

/// One known message type and type-erased functions to work with its payloads.
#[derive(Clone, Copy, Debug)]
pub struct MessageTypeInfo {
    /// ROS package, e.g. `"sensor_msgs"`.
    pub package: &'static str,
    /// Type name inside the package, e.g. `"JointState"`.
    pub name: &'static str,
    /// Full `ros2msg` schema text ([`RosMessage::ros2msg_definition`]).
    pub definition: fn() -> String,
    /// Decodes a CDR payload (with encapsulation header) into JSON.
    pub cdr_to_json: fn(&[u8]) -> Result<serde_json::Value, CdrError>,
    /// Encodes a JSON value (same shape as `cdr_to_json` gives) as a CDR payload.
    pub json_to_cdr: fn(&serde_json::Value) -> Result<Vec<u8>, CdrError>,
}

impl MessageTypeInfo {
    /// The entry for `T`.
    pub const fn of<T: RosMessage>() -> Self {
        Self {
            package: T::PACKAGE,
            name: T::NAME,
            definition: T::ros2msg_definition,
            cdr_to_json: cdr::cdr_to_json::<T>,
            json_to_cdr: cdr::json_to_cdr::<T>,
        }
    }

    /// ROS 2 type name, e.g. `"sensor_msgs/msg/JointState"`.
    pub fn type_name(&self) -> String {
        format!("{}/msg/{}", self.package, self.name)
    }

    /// Whether `type_name` names this type (see [`type_name_matches`]).
    pub fn matches(&self, type_name: &str) -> bool {
        type_name_matches(self.package, self.name, type_name)
    }
}

/// Whether `candidate` names `package/msg/name`, written as `package/msg/name`,
/// `package/name` or as the DDS name `package::msg::dds_::name_`. Does not allocate.
pub fn type_name_matches(package: &str, name: &str, candidate: &str) -> bool {
    let Some(rest) = candidate.strip_prefix(package) else {
        return false;
    };
    if let Some(n) = rest
        .strip_prefix("/msg/")
        .or_else(|| rest.strip_prefix('/'))
    {
        return n == name;
    }
    rest.strip_prefix("::msg::dds_::")
        .and_then(|n| n.strip_suffix('_'))
        .is_some_and(|n| n == name)
}

#[doc(hidden)]
#[macro_export]
macro_rules! __known_types_array {
    (() $($module:ident :: $ty:ident),* $(,)?) => {
        [$($crate::MessageTypeInfo::of::<$crate::$module::$ty>()),*]
    };
}

static KNOWN_TYPES: &[MessageTypeInfo] = &crate::__for_all_message_types!(__known_types_array!());

/// Every message type of this crate (standard and custom).
pub fn known_types() -> &'static [MessageTypeInfo] {
    KNOWN_TYPES
}

/// The known type named `type_name` (any form accepted by [`type_name_matches`]).
pub fn find_type(type_name: &str) -> Option<&'static MessageTypeInfo> {
    KNOWN_TYPES.iter().find(|t| t.matches(type_name))
}
