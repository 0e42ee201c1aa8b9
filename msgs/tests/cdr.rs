//! CDR encoding: hand-computed byte layouts, big-endian input, errors, JSON, round-trips.

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion, Transform, TransformStamped, Vector3};
use cowork_msgs::msg::{LinkDistance, LinkDistances, WmNode, WorkingMemory};
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState, RegionOfInterest};
use cowork_msgs::std_msgs::{Header, String as RosString};
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::{CdrError, RosMessage, find_type, from_cdr, to_cdr, to_cdr_into};
use proptest::prelude::*;

#[test]
fn string_hi_layout() {
    let bytes = to_cdr(&RosString::new("hi"));
    // header | u32 length including the NUL | 'h' 'i' NUL
    assert_eq!(bytes, [0x00, 0x01, 0x00, 0x00, 3, 0, 0, 0, b'h', b'i', 0]);
    assert_eq!(from_cdr::<RosString>(&bytes).unwrap().data, "hi");
}

#[test]
fn header_layout_little_and_big_endian() {
    let header = Header::new(Time { sec: 1, nanosec: 2 }, "base");
    let le = to_cdr(&header);
    #[rustfmt::skip]
    let expected_le = [
        0x00, 0x01, 0x00, 0x00,
        1, 0, 0, 0,          // stamp.sec
        2, 0, 0, 0,          // stamp.nanosec
        5, 0, 0, 0,          // frame_id length incl. NUL
        b'b', b'a', b's', b'e', 0,
    ];
    assert_eq!(le, expected_le);
    #[rustfmt::skip]
    let be = [
        0x00, 0x00, 0x00, 0x00,
        0, 0, 0, 1,
        0, 0, 0, 2,
        0, 0, 0, 5,
        b'b', b'a', b's', b'e', 0,
    ];
    assert_eq!(from_cdr::<Header>(&be).unwrap(), header);
    // Trailing alignment padding (as rmw writes it) is accepted.
    let mut padded = le.clone();
    padded.extend_from_slice(&[0, 0, 0]);
    assert_eq!(from_cdr::<Header>(&padded).unwrap(), header);
}

#[test]
fn camera_info_fixed_arrays_have_no_length_prefix() {
    let mut info = CameraInfo {
        header: Header::new(Time::default(), "cam"),
        height: 480,
        width: 640,
        distortion_model: "plumb_bob".into(),
        d: vec![0.0; 5],
        binning_x: 1,
        binning_y: 2,
        roi: RegionOfInterest {
            x_offset: 3,
            y_offset: 4,
            height: 5,
            width: 6,
            do_rectify: true,
        },
        ..Default::default()
    };
    info.k = [525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0];
    info.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    info.p = [
        525.0, 0.0, 319.5, 0.0, 0.0, 525.0, 239.5, 0.0, 0.0, 0.0, 1.0, 0.0,
    ];
    let bytes = to_cdr(&info);
    let body = &bytes[4..];
    // stamp 8 | frame_id 4+4 | height, width 8 | distortion_model 4+10 -> 38 | pad 2 |
    // d: len 4 -> 44, pad 4 -> 48, 5 x 8 -> 88 | k 72 -> 160 | r 72 -> 232 | p 96 -> 328 |
    // binning 8 -> 336 | roi 16 -> 352 | do_rectify 1 -> 353
    assert_eq!(body.len(), 353);
    let f64_at = |off: usize| f64::from_le_bytes(body[off..off + 8].try_into().unwrap());
    let u32_at = |off: usize| u32::from_le_bytes(body[off..off + 4].try_into().unwrap());
    assert_eq!(u32_at(40), 5, "d length prefix");
    assert_eq!(f64_at(88), 525.0, "k[0] directly after d, no length prefix");
    assert_eq!(f64_at(88 + 16), 319.5, "k[2]");
    assert_eq!(f64_at(160), 1.0, "r[0]");
    assert_eq!(f64_at(232), 525.0, "p[0]");
    assert_eq!(f64_at(232 + 88), 0.0, "p[11]");
    assert_eq!(u32_at(328), 1, "binning_x");
    assert_eq!(u32_at(332), 2, "binning_y");
    assert_eq!(u32_at(336), 3, "roi.x_offset");
    assert_eq!(body[352], 1, "roi.do_rectify");
    assert_eq!(from_cdr::<CameraInfo>(&bytes).unwrap(), info);
}

#[test]
fn image_data_is_a_length_prefixed_octet_sequence() {
    let img = Image {
        header: Header::default(),
        height: 1,
        width: 2,
        encoding: "16UC1".into(),
        is_bigendian: 0,
        step: 4,
        data: vec![1, 2, 3, 4],
    };
    let bytes = to_cdr(&img);
    // stamp 8 | frame_id "" 4+1 -> 13 | pad 3 -> 16 | height, width -> 24 |
    // encoding 4+6 -> 34 | is_bigendian -> 35 | pad 1 -> 36 | step -> 40 | len -> 44 | data -> 48
    let body = &bytes[4..];
    assert_eq!(body.len(), 48);
    assert_eq!(&body[40..48], &[4, 0, 0, 0, 1, 2, 3, 4]);
    assert_eq!(from_cdr::<Image>(&bytes).unwrap(), img);
}

#[test]
fn quaternion_default_is_identity_on_the_wire() {
    let bytes = to_cdr(&Quaternion::default());
    assert_eq!(&bytes[4 + 24..], &1.0f64.to_le_bytes());
}

#[test]
fn errors_name_the_type_and_the_problem() {
    let err = from_cdr::<JointState>(&[0, 1]).unwrap_err();
    assert!(matches!(err, CdrError::TooShort { len: 2, .. }));
    assert!(
        err.to_string().contains("sensor_msgs/msg/JointState"),
        "{err}"
    );

    let err = from_cdr::<Header>(&[0, 2, 0, 0, 1, 0, 0, 0]).unwrap_err();
    assert!(
        matches!(
            err,
            CdrError::UnsupportedEncapsulation { header: [0, 2], .. }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("std_msgs/msg/Header"), "{err}");

    let mut truncated = to_cdr(&Header::new(Time::default(), "base_link"));
    truncated.truncate(truncated.len() - 3);
    let err = from_cdr::<Header>(&truncated).unwrap_err();
    assert!(matches!(err, CdrError::Decode { .. }), "{err}");
    assert!(err.to_string().contains("std_msgs/msg/Header"), "{err}");

    // A bool that is neither 0 nor 1.
    let mut bad_bool = to_cdr(&RegionOfInterest::default());
    let last = bad_bool.len() - 1;
    bad_bool[last] = 7;
    assert!(from_cdr::<RegionOfInterest>(&bad_bool).is_err());
}

#[test]
fn registry_json_round_trip() {
    let js = JointState {
        header: Header::new(Time { sec: 3, nanosec: 4 }, "world"),
        name: vec!["lwr_joint_1".into(), "lwr_joint_2".into()],
        position: vec![0.1, -0.2],
        velocity: vec![],
        effort: vec![],
    };
    let info = find_type("sensor_msgs/JointState").expect("known");
    let json = (info.cdr_to_json)(&to_cdr(&js)).unwrap();
    assert_eq!(json["name"][1], "lwr_joint_2");
    assert_eq!(json["header"]["stamp"]["sec"], 3);
    assert_eq!(json["position"][1], -0.2);
    let back = (info.json_to_cdr)(&json).unwrap();
    assert_eq!(from_cdr::<JointState>(&back).unwrap(), js);

    let img_info = find_type("sensor_msgs::msg::dds_::Image_").expect("dds name");
    let img = Image {
        data: vec![9, 8, 7],
        ..Default::default()
    };
    let json = (img_info.cdr_to_json)(&to_cdr(&img)).unwrap();
    assert_eq!(json["data"], serde_json::json!([9, 8, 7]));
    assert_eq!(
        from_cdr::<Image>(&(img_info.json_to_cdr)(&json).unwrap()).unwrap(),
        img
    );

    let err = (info.cdr_to_json)(&[1, 2, 3, 4, 5]).unwrap_err();
    assert!(err.to_string().contains("JointState"), "{err}");
}

#[test]
fn to_cdr_into_reuses_the_buffer() {
    let mut buf = Vec::with_capacity(256);
    let ptr = buf.as_ptr();
    to_cdr_into(&RosString::new("first message"), &mut buf);
    to_cdr_into(&RosString::new("hi"), &mut buf);
    assert_eq!(buf, to_cdr(&RosString::new("hi")));
    assert_eq!(
        buf.as_ptr(),
        ptr,
        "no reallocation for a buffer that is large enough"
    );
}

// ---- property tests -------------------------------------------------------------------

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        -1e6..1e6f64,
        Just(0.0),
        Just(-0.0),
        Just(f64::MAX),
        Just(f64::MIN_POSITIVE)
    ]
}

fn text() -> impl Strategy<Value = String> {
    // Any Unicode except NUL (CDR strings are NUL-terminated).
    "[^\u{0}]{0,12}"
}

fn time() -> impl Strategy<Value = Time> {
    (any::<i32>(), 0u32..1_000_000_000).prop_map(|(sec, nanosec)| Time { sec, nanosec })
}

fn header() -> impl Strategy<Value = Header> {
    (time(), text()).prop_map(|(stamp, frame_id)| Header { stamp, frame_id })
}

fn point() -> impl Strategy<Value = Point> {
    (finite(), finite(), finite()).prop_map(|(x, y, z)| Point { x, y, z })
}

fn vector() -> impl Strategy<Value = Vector3> {
    (finite(), finite(), finite()).prop_map(|(x, y, z)| Vector3 { x, y, z })
}

fn quaternion() -> impl Strategy<Value = Quaternion> {
    (finite(), finite(), finite(), finite()).prop_map(|(x, y, z, w)| Quaternion { x, y, z, w })
}

fn link_distance() -> impl Strategy<Value = LinkDistance> {
    (
        text(),
        finite(),
        point(),
        point(),
        vector(),
        vector(),
        any::<bool>(),
    )
        .prop_map(
            |(
                link_name,
                distance,
                robot_point,
                obstacle_point,
                normal,
                obstacle_velocity,
                valid,
            )| {
                LinkDistance {
                    link_name,
                    distance,
                    robot_point,
                    obstacle_point,
                    normal,
                    obstacle_velocity,
                    valid,
                }
            },
        )
}

fn wm_node() -> impl Strategy<Value = WmNode> {
    (
        (
            any::<u32>(),
            any::<i32>(),
            text(),
            text(),
            any::<bool>(),
            text(),
            any::<bool>(),
        ),
        (
            finite(),
            finite(),
            finite(),
            any::<bool>(),
            any::<bool>(),
            any::<u8>(),
            text(),
        ),
    )
        .prop_map(
            |(
                (id, parent, name, releaser, releaser_value, postcondition, concrete),
                (emphasis, magnitude, period, done, enabled, assigned_to, arm),
            )| WmNode {
                id,
                parent,
                name,
                releaser,
                releaser_value,
                postcondition,
                concrete,
                emphasis,
                magnitude,
                period,
                done,
                enabled,
                assigned_to,
                arm,
            },
        )
}

fn round_trip<T: RosMessage>(msg: &T) -> Result<(), TestCaseError> {
    let bytes = to_cdr(msg);
    prop_assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
    let back: T = from_cdr(&bytes).map_err(|e| TestCaseError::fail(e.to_string()))?;
    prop_assert_eq!(&back, msg);
    Ok(())
}

proptest! {
    #[test]
    fn joint_state_round_trips(
        header in header(),
        name in proptest::collection::vec(text(), 0..8),
        position in proptest::collection::vec(finite(), 0..8),
        velocity in proptest::collection::vec(finite(), 0..8),
        effort in proptest::collection::vec(finite(), 0..3),
    ) {
        round_trip(&JointState { header, name, position, velocity, effort })?;
    }

    #[test]
    fn camera_info_round_trips(
        header in header(),
        size in (any::<u32>(), any::<u32>()),
        model in text(),
        d in proptest::collection::vec(finite(), 0..6),
        k in proptest::array::uniform9(finite()),
        r in proptest::array::uniform9(finite()),
        p in proptest::array::uniform12(finite()),
        roi in (any::<u32>(), any::<u32>(), any::<bool>()),
    ) {
        round_trip(&CameraInfo {
            header, height: size.0, width: size.1, distortion_model: model, d, k, r, p,
            binning_x: roi.0, binning_y: roi.1,
            roi: RegionOfInterest { x_offset: roi.1, y_offset: roi.0, height: 1, width: 2, do_rectify: roi.2 },
        })?;
    }

    #[test]
    fn image_round_trips(
        header in header(),
        encoding in text(),
        is_bigendian in any::<u8>(),
        data in proptest::collection::vec(any::<u8>(), 0..64),
    ) {
        let width = u32::try_from(data.len()).unwrap_or(0);
        round_trip(&Image { header, height: 1, width, encoding, is_bigendian, step: width, data })?;
    }

    #[test]
    fn link_distances_round_trip(
        header in header(),
        links in proptest::collection::vec(link_distance(), 0..8),
        min_index in -1i32..8,
        processing_time in finite(),
        backend in text(),
    ) {
        round_trip(&LinkDistances { header, links, min_index, processing_time, backend })?;
    }

    #[test]
    fn working_memory_round_trips(
        header in header(),
        nodes in proptest::collection::vec(wm_node(), 0..6),
        true_variables in proptest::collection::vec(text(), 0..4),
    ) {
        round_trip(&WorkingMemory { header, nodes, true_variables })?;
    }

    #[test]
    fn tf_message_round_trips(
        transforms in proptest::collection::vec((header(), text(), vector(), quaternion()), 0..6),
    ) {
        let transforms = transforms
            .into_iter()
            .map(|(header, child_frame_id, translation, rotation)| TransformStamped {
                header, child_frame_id, transform: Transform { translation, rotation },
            })
            .collect();
        round_trip(&TFMessage { transforms })?;
    }

    #[test]
    fn pose_round_trips(position in point(), orientation in quaternion()) {
        round_trip(&Pose { position, orientation })?;
    }
}
