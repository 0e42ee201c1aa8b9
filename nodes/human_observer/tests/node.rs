//! The node message by message (no network), then its wiring over DDS on a private domain.

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::{Gesture, HumanState, Skeleton};
use cowork_msgs::rosgraph_msgs::Clock;
use cowork_msgs::sensor_msgs::JointState;
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::visualization_msgs::{Marker, MarkerArray};
use cowork_observer::LearnConfig;
use cowork_observer::eval::{gesture_stream, learn};
use common::{joint_state, root, skeleton};
use cowork_people::{BodySize, Performer, SensorConfig, Stance};
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, qos};
use human_observer::{ObserverNode, Params, RunOptions};

fn model() -> RobotModel {
    RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF")
}

fn params() -> Params {
    let mut p: Params = cowork_ros::params::load(&root().join("config/human_observer.yaml"), "human_observer").expect("params");
    p.urdf = root().join("config/robot/lwr4plus.urdf").display().to_string();
    p.gestures = String::new();
    p
}

#[test]
fn bundled_parameters_are_valid_and_typos_fail() {
    params().validate("config/human_observer.yaml").expect("valid");
    let typo = "human_observer:\n  ros__parameters:\n    observer: { person_timeout: 1.0 }\n";
    assert!(cowork_ros::params::from_str::<Params>(typo, "human_observer", "t.yaml").is_err());
    let bad = "human_observer:\n  ros__parameters:\n    observer: { mode: { interaction_enter_m: 1.0, interaction_leave_m: 0.5 } }\n";
    let p: Params = cowork_ros::params::from_str(bad, "human_observer", "t.yaml").expect("parses");
    assert!(p.validate("t.yaml").is_err());
    let nan = "human_observer:\n  ros__parameters:\n    state_rate_hz: .nan\n";
    let p: Params = cowork_ros::params::from_str(nan, "human_observer", "t.yaml").expect("parses");
    assert!(p.validate("t.yaml").is_err());
}

#[test]
fn handlers_publish_every_frame_tick_when_nobody_and_fail_closed() {
    let mut node = ObserverNode::new(model(), params(), None).expect("node");
    // Nobody yet: the tick says so at the steady rate.
    let s = node.on_tick(0.0).expect("first tick");
    assert!(!s.present && s.mode == HumanState::MODE_FAR && s.speed_scale == 0.3);
    assert!(node.on_tick(0.01).is_none(), "not yet due at 30 Hz");
    assert!(node.on_tick(0.04).is_some());
    node.on_joint_state(&joint_state(0.0)).expect("joints");
    let bad = JointState { name: vec!["x".into()], position: vec![1.0], ..Default::default() };
    let w = node.on_joint_state(&bad).expect_err("incomplete");
    assert!(w.message.contains("/joint_states"), "{}", w.message);
    // A person right beside the robot: interaction at every frame.
    let p = Performer::new(4, BodySize::MEDIUM, Stance::new(0.1, -0.75, 1.57), 1).expect("p");
    for k in 0..30 {
        let t = 0.05 + k as f64 / 30.0;
        node.on_joint_state(&joint_state(t)).expect("joints");
        let out = node.on_skeleton(&skeleton(&p, t));
        assert!(out.warnings.is_empty(), "{:?}", out.warnings);
        assert!(out.state.present && out.state.mode == HumanState::MODE_INTERACTION && out.state.speed_scale == 0.1, "{:?}", out.state);
        assert_eq!(out.state.header.stamp, Time::from_secs_f64(t));
        assert_eq!(out.state.header.frame_id, "lwr_base_link");
    }
    // NaN frame: warning naming topic and field; the state stays slow.
    let mut m = skeleton(&p, 1.2);
    m.poses[5].position.z = f64::NAN;
    let out = node.on_skeleton(&m);
    assert!(out.warnings[0].message.starts_with("/human/skeleton") && out.warnings[0].message.contains("poses[5].position"), "{:?}", out.warnings);
    assert!(out.state.mode == HumanState::MODE_INTERACTION && out.state.speed_scale <= 0.1);
    // Markers: DELETEALL, 16 capsules, two hands with arrows.
    let ma = node.markers(1.2).expect("markers due").clone();
    assert_eq!(ma.markers[0].action, Marker::DELETEALL);
    assert_eq!(ma.markers.iter().filter(|m| m.ns == human_observer::NS_BODY).count(), 16);
    assert_eq!(ma.markers.iter().filter(|m| m.ns == human_observer::NS_HAND_VELOCITY && m.type_ == Marker::ARROW).count(), 2);
    // Spoken stop holds, repeat releases.
    assert!(node.on_speech(&RosString::new("stop")));
    let s = node.on_skeleton(&skeleton(&p, 1.3)).state;
    assert!(s.stopped && s.speed_scale == 0.0);
    assert!(node.on_speech(&RosString::new("repeat")));
    // Silent for longer than the timeout: dropped, present false.
    let s = node.on_tick(2.5).expect("tick");
    assert!(!s.present && s.speed_scale == 0.3 && !s.stopped, "{s:?}");
    // A gesture model that failed to load: never faster than the interaction speed.
    node.without_gestures_fail_closed();
    let s = node.on_tick(2.6).expect("tick");
    assert!(!s.present && s.speed_scale == 0.1, "{s:?}");
}

fn private_domain() -> u16 {
    cowork_ros::domain::test_domain("human_observer node test")
}

#[test]
fn over_dds_state_gesture_markers_and_bad_input() {
    let domain = private_domain();
    let config = |_: ()| NodeConfig { domain_id: Some(domain), use_sim_time: false, ..Default::default() };
    // A small model from three labelled gestures; the same stream is replayed below.
    let stream = gesture_stream(5, 3, &SensorConfig::depth_tracker(), false).expect("stream");
    let gestures = learn(&[&stream], LearnConfig::default()).expect("model");
    let stop = Arc::new(AtomicBool::new(false));
    let observer = ObserverNode::new(model(), params(), Some(gestures)).expect("observer");
    let node = RosNode::new("human_observer", &NodeConfig { use_sim_time: true, ..config(()) }).expect("node");
    let options = RunOptions { duration_s: Some(120.0), stop: Some(Arc::clone(&stop)) };
    let handle = std::thread::spawn(move || human_observer::run(node, observer, &options));

    let mut client = RosNode::new("test_client", &config(())).expect("client");
    let clock = client.publisher::<Clock>("/clock", &qos::clock()).expect("pub");
    let joints = client.publisher::<JointState>("/joint_states", &qos::reliable()).expect("pub");
    let skeletons = client.publisher::<Skeleton>("/human/skeleton", &qos::reliable()).expect("pub");
    let speech = client.publisher::<RosString>("/speech_command", &qos::reliable()).expect("pub");
    let states = client.subscription::<HumanState>("/human/state", &qos::reliable()).expect("sub");
    let gesture = client.subscription::<Gesture>("/human/gesture", &qos::reliable()).expect("sub");
    let markers = client.subscription::<MarkerArray>("/human/markers", &qos::reliable()).expect("sub");
    // Discovery: the node's subscriptions and publications matched.
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(30)
        && (skeletons.subscription_count(&client) == 0 || joints.subscription_count(&client) == 0 || states.publisher_count(&client) == 0)
    {
        clock.publish(Clock { clock: Time::from_secs_f64(0.0) }).expect("clock");
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(skeletons.subscription_count(&client) > 0, "human_observer not discovered");

    let mut got_states: Vec<HumanState> = Vec::new();
    let mut got_gestures: Vec<Gesture> = Vec::new();
    let mut marker_arrays = 0;
    let drain = |states_: &mut Vec<HumanState>, gestures_: &mut Vec<Gesture>, markers_: &mut usize| {
        while let Some(s) = states.take() {
            states_.push(s);
        }
        while let Some(g) = gesture.take() {
            gestures_.push(g);
        }
        while markers.take().is_some() {
            *markers_ += 1;
        }
    };
    // Nobody: steady present = false.
    for k in 0..20 {
        clock.publish(Clock { clock: Time::from_secs_f64(k as f64 * 0.01) }).expect("clock");
        std::thread::sleep(Duration::from_millis(20));
    }
    let t_end = stream.frames.last().map_or(0.0, |m| m.header.stamp.to_secs_f64());
    // The labelled stream, about 5x faster than real time, with the sim clock and joints.
    let mut bad_sent = false;
    for (i, m) in stream.frames.iter().enumerate() {
        let t = m.header.stamp.to_secs_f64() + 1.0;
        let mut m = m.clone();
        m.header.stamp = Time::from_secs_f64(t);
        clock.publish(Clock { clock: Time::from_secs_f64(t) }).expect("clock");
        joints.publish(joint_state(t)).expect("joints");
        skeletons.publish(m.clone()).expect("skeleton");
        if i == 60 && !bad_sent {
            let mut bad = m.clone();
            bad.poses[1].orientation.w = 5.0;
            skeletons.publish(bad).expect("bad");
            speech.publish(RosString::new("stop")).expect("speech");
            bad_sent = true;
        }
        if i == 90 {
            speech.publish(RosString::new("repeat")).expect("speech");
        }
        std::thread::sleep(Duration::from_millis(6));
        drain(&mut got_states, &mut got_gestures, &mut marker_arrays);
    }
    // Silence: the person is dropped and present = false comes at the steady rate.
    for k in 0..40 {
        clock.publish(Clock { clock: Time::from_secs_f64(t_end + 1.0 + 0.05 * k as f64) }).expect("clock");
        std::thread::sleep(Duration::from_millis(25));
        drain(&mut got_states, &mut got_gestures, &mut marker_arrays);
    }
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline && got_states.last().is_none_or(|s| s.present) {
        std::thread::sleep(Duration::from_millis(50));
        drain(&mut got_states, &mut got_gestures, &mut marker_arrays);
    }
    stop.store(true, Ordering::SeqCst);
    let summary = handle.join().expect("join").expect("run");
    println!("{summary:?}, {} states, {} gestures {:?}, {marker_arrays} marker arrays", got_states.len(), got_gestures.len(), got_gestures.iter().map(|g| &g.label).collect::<Vec<_>>());
    assert!(summary.skeletons as usize >= stream.frames.len(), "{summary:?}");
    assert!(got_states.len() >= stream.frames.len(), "a state per frame: {} < {}", got_states.len(), stream.frames.len());
    assert!(got_states.iter().any(|s| !s.present), "present = false while nobody is tracked");
    assert!(got_states.iter().any(|s| s.present && s.mode == HumanState::MODE_FAR));
    assert!(got_states.iter().any(|s| s.stopped && s.speed_scale == 0.0), "spoken stop");
    assert!(!got_states.last().expect("states").present, "dropped after the timeout");
    assert!(got_states.iter().all(|s| s.speed_scale <= 0.3 && s.distance.is_finite()));
    assert!(!got_gestures.is_empty(), "no gesture over DDS");
    assert!(got_gestures.iter().all(|g| stream.labels.iter().any(|l| l.label == g.label) && g.confidence > 0.0 && g.dtw_distance >= 0.0));
    assert!(marker_arrays > 0);
}

/// The pizza arms driven by an Xsens demonstrator (config/human_observer.yaml's `/left` block).
fn two_arm_params() -> Params {
    let text = std::fs::read_to_string(root().join("config/human_observer.yaml")).expect("file");
    let mut p: Params = cowork_ros::params::from_str_in(&text, "human_observer", Some("/left"), "config/human_observer.yaml").expect("params");
    p.urdf = root().join("config/robot/lwr4plus.urdf").display().to_string();
    p.gestures = String::new();
    p
}

fn suit(p: &Performer, t: f64, frame_id: &str) -> Skeleton {
    p.pose(t).to_message(&cowork_people::MessageMeta {
        stamp: Time::from_secs_f64(t),
        frame_id,
        source: Skeleton::SOURCE_XSENS,
        person_id: p.person_id(),
        with_velocities: false,
    })
}

#[test]
fn an_xsens_demonstrator_drives_each_arm_with_its_own_arm_and_a_bystander_does_not() {
    let params = two_arm_params();
    let arms: Vec<_> = params.retarget.arms.iter().map(|a| (a.arm.clone(), a.side)).collect();
    assert_eq!(arms, [("left".to_owned(), cowork_people::Side::Left), ("right".to_owned(), cowork_people::Side::Right)]);
    let mut node = ObserverNode::new(model(), params, None).expect("node");
    // The demonstrator raises the left arm forward; the right hangs.
    let demonstrator = Performer::new(1, BodySize::MEDIUM, Stance::new(-0.15, 0.0, 0.0), 1)
        .expect("p")
        .then(cowork_people::Action::Reach {
            side: cowork_people::Side::Left,
            target: nalgebra::Point3::new(0.4, 0.3, 0.6),
            duration: 1.0,
            hold: 1.0,
        })
        .expect("reach");
    // No joint states yet: nothing to start from, a warning per arm, no target.
    let first = node.on_demonstrator(&suit(&demonstrator, 0.0, "world"));
    assert!(first.targets.is_empty() && first.warnings.len() == 2, "{:?}", first.warnings);
    assert!(first.warnings[0].message.contains("/left/lwr/follow_joints"), "{}", first.warnings[0].message);
    assert!(!first.track_as_person, "a suit in the world frame only drives the arms");
    node.on_arm_joint_state(0, &joint_state(0.0)).expect("left joints");
    node.on_arm_joint_state(1, &joint_state(0.0)).expect("right joints");
    let mut last = Vec::new();
    for k in 0..240 {
        let t = k as f64 / 120.0;
        let out = node.on_demonstrator(&suit(&demonstrator, t, "world"));
        assert!(out.warnings.is_empty(), "{:?}", out.warnings);
        assert_eq!(out.targets.iter().map(|t| t.0).collect::<Vec<_>>(), [0, 1]);
        assert_eq!(out.targets[0].1.header.stamp, Time::from_secs_f64(t), "stamped with the frame");
        last = out.targets;
    }
    // The left robot arm's hand went forward (base x = world x for the pizza mount) and up
    // from the hanging start; the right arm, driven by the hanging arm, stayed low.
    let m = model();
    let mut poses = cowork_robot::LinkPoses::new();
    let wrist = |q: &[f64], poses: &mut cowork_robot::LinkPoses| {
        m.forward_kinematics(&cowork_robot::JointVector::from_column_slice(q), poses);
        poses.get(m.joint_link(5)).translation.vector
    };
    let left = wrist(&last[0].1.position, &mut poses);
    let right = wrist(&last[1].1.position, &mut poses);
    assert!(left.x > 0.3, "left wrist {left}");
    assert!(left.x > right.x + 0.2, "left {left} right {right}");
    // A suit frame missing the left arm's segments: refused naming the field, no target for
    // any arm (the arms stop within the simulator's command timeout).
    let mut broken = suit(&demonstrator, 2.01, "world");
    let keep: Vec<usize> = (0..broken.segment_names.len()).filter(|&i| !broken.segment_names[i].starts_with("left_")).collect();
    broken.segment_names = keep.iter().map(|&i| broken.segment_names[i].clone()).collect();
    broken.poses = keep.iter().map(|&i| broken.poses[i].clone()).collect();
    broken.velocities.clear();
    let out = node.on_demonstrator(&broken);
    assert!(out.targets.is_empty(), "{:?}", out.targets);
    assert_eq!(out.warnings.len(), 2, "{:?}", out.warnings);
    assert!(out.warnings[0].message.contains("not retargeted onto arm \"left\""), "{}", out.warnings[0].message);
    // A bystander seen by the depth camera, and a second suit, drive nothing.
    let bystander = Performer::new(2, BodySize::MEDIUM, Stance::new(1.0, 0.0, 3.14), 2).expect("p");
    let out = node.on_demonstrator(&skeleton(&bystander, 2.0));
    assert!(out.targets.is_empty() && out.track_as_person);
    let out = node.on_demonstrator(&suit(&bystander, 2.0, "world"));
    assert!(out.targets.is_empty() && out.track_as_person);
    // Bad parameters are refused naming the field.
    let mut bad = two_arm_params();
    bad.retarget.arms[1].arm = "left".into();
    let e = ObserverNode::new(model(), bad, None).expect_err("twice");
    assert!(format!("{e:#}").contains("retarget.arms[1].arm"), "{e:#}");
}
