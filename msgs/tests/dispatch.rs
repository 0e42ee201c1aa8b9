//! `with_message_type!` and the registry resolve type names in every accepted spelling.

use cowork_msgs::{RosMessage, find_type, known_types, type_name_matches, with_message_type};

#[test]
fn dispatch_binds_the_named_type() {
    for info in known_types() {
        let full = info.type_name();
        let short = format!("{}/{}", info.package, info.name);
        let dds = format!("{}::msg::dds_::{}_", info.package, info.name);
        for name in [&full, &short, &dds] {
            let bound = with_message_type!(name.as_str(), T => T::type_name());
            assert_eq!(bound.as_deref(), Some(full.as_str()), "{name}");
            assert_eq!(
                find_type(name).map(|t| t.type_name()),
                Some(full.clone()),
                "{name}"
            );
        }
    }
}

#[test]
fn dispatch_can_build_typed_values() {
    let bytes =
        with_message_type!("cowork_msgs/msg/HumanState", T => cowork_msgs::to_cdr(&T::default()))
            .expect("known type");
    let back: cowork_msgs::msg::HumanState = cowork_msgs::from_cdr(&bytes).unwrap();
    assert_eq!(back, cowork_msgs::msg::HumanState::default());
}

#[test]
fn unknown_and_near_miss_names_are_none() {
    for name in [
        "",
        "sensor_msgs",
        "sensor_msgs/msg/JointStates",
        "sensor_msgs/srv/JointState",
        "sensor_msgs/msg/",
        "sensor_msgs::msg::dds_::JointState",
        "Sensor_msgs/msg/JointState",
        "nav_msgs/msg/Odometry",
        "std_msgs/msg/String/extra",
    ] {
        assert!(
            with_message_type!(name, T => T::type_name()).is_none(),
            "{name:?}"
        );
        assert!(find_type(name).is_none(), "{name:?}");
    }
}

#[test]
fn type_name_matching_forms() {
    assert!(type_name_matches(
        "geometry_msgs",
        "Pose",
        "geometry_msgs/msg/Pose"
    ));
    assert!(type_name_matches(
        "geometry_msgs",
        "Pose",
        "geometry_msgs/Pose"
    ));
    assert!(type_name_matches(
        "geometry_msgs",
        "Pose",
        "geometry_msgs::msg::dds_::Pose_"
    ));
    assert!(!type_name_matches(
        "geometry_msgs",
        "Pose",
        "geometry_msgs/msg/PoseStamped"
    ));
    assert!(!type_name_matches(
        "geometry_msgs",
        "Pose",
        "geometry_msgs::msg::dds_::Pose"
    ));
}
