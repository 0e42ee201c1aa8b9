//! The observer message by message: a person walking in and out, bad input of every kind,
//! id floods, silent people, missing joint states (fail closed, never faster).

use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::Skeleton;
use cowork_observer::{GestureModel, Mode, Observer, ObserverConfig, ObserverError};
use cowork_people::{BodySize, MessageMeta, Performer, Room, Sampler, SensorConfig, Stance, Timeline};
use cowork_robot::RobotModel;
use nalgebra::Point3;

const READY: [f64; 7] = [0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0];

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn observer(config: ObserverConfig) -> Observer {
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("model");
    let mut o = Observer::new(model, config, None).expect("observer");
    o.on_joint_state(0.0, &[], &READY).expect("joints");
    o
}

fn standing(id: u32, x: f64, y: f64) -> Performer {
    Performer::new(id, BodySize::MEDIUM, Stance::new(x, y, 1.57), 5).expect("performer")
}

fn frame(p: &Performer, t: f64) -> Skeleton {
    p.pose(t).to_message(&MessageMeta {
        stamp: Time::from_secs_f64(t),
        frame_id: "lwr_base_link",
        source: Skeleton::SOURCE_XSENS,
        person_id: p.person_id(),
        with_velocities: true,
    })
}

#[test]
fn a_visit_switches_far_interaction_far() {
    let mut o = observer(ObserverConfig::default());
    let room = Room::default();
    let p = room.visit(7, BodySize::MEDIUM, 3, Point3::new(0.3, -0.3, 0.4), (Point3::new(0.0, -0.6, 0.2), Point3::new(0.4, -0.5, 0.2))).expect("visit");
    let mut timeline = Timeline::new();
    timeline.add(0.0, p).expect("timeline");
    let mut modes = Vec::new();
    let mut min_distance = f64::INFINITY;
    for m in Sampler::new(&timeline, SensorConfig::xsens(), 1).expect("sampler") {
        let t = m.header.stamp.to_secs_f64();
        o.on_joint_state(t, &[], &READY).expect("joints");
        let out = o.on_skeleton(&m);
        assert!(out.accepted, "{:?}", out.warnings);
        assert!(out.state.present && out.state.usable);
        min_distance = min_distance.min(out.state.distance);
        let expected = if out.state.mode == Mode::Interaction { 0.1 } else { 0.3 };
        assert_eq!(out.state.speed_scale, expected);
        if modes.last() != Some(&out.state.mode) {
            modes.push(out.state.mode);
        }
        if out.state.mode == Mode::Interaction {
            assert!(out.state.distance < 0.9 && out.state.closest_link.starts_with("lwr_"), "{:?}", out.state);
        }
    }
    assert_eq!(modes, vec![Mode::Far, Mode::Interaction, Mode::Far], "min distance {min_distance}");
    assert!(min_distance < 0.5, "the reach comes close to the arm: {min_distance}");
    let end = timeline.duration();
    assert!(o.tick(end + 0.1).present);
    let gone = o.tick(end + 1.0);
    assert!(!gone.present && gone.mode == Mode::Far && gone.speed_scale == 0.3, "{gone:?}");
}

#[test]
fn bad_frames_fail_closed_name_the_field_and_the_observer_recovers() {
    let mut o = observer(ObserverConfig::default());
    // Far from the robot: far speed.
    let p = standing(1, -0.5, -2.5);
    let mut t = 0.0;
    for _ in 0..10 {
        o.on_joint_state(t, &[], &READY).expect("joints");
        let out = o.on_skeleton(&frame(&p, t));
        assert_eq!(out.state.speed_scale, 0.3, "{:?}", out.warnings);
        t += 1.0 / 120.0;
    }
    let check_bad = |o: &mut Observer, m: Skeleton, field: &str| {
        let out = o.on_skeleton(&m);
        assert!(!out.accepted);
        assert!(out.warnings.iter().any(|w| w.contains(field)), "{field}: {:?}", out.warnings);
        assert!(!out.state.usable && out.state.present && out.state.mode == Mode::Interaction);
        assert!(out.state.speed_scale <= 0.1, "slowed, never faster: {:?}", out.state);
    };
    let good = |t: f64| frame(&p, t);
    let mut m = good(t);
    m.poses[3].position.x = f64::NAN;
    check_bad(&mut o, m, "poses[3].position");
    let mut m = good(t);
    let q = &mut m.poses[6].orientation;
    (q.x, q.y, q.z, q.w) = (0.5 * q.x, 0.5 * q.y, 0.5 * q.z, 0.5 * q.w);
    check_bad(&mut o, m, "poses[6].orientation");
    let mut m = good(t);
    m.segment_names.truncate(9);
    m.poses.truncate(9);
    m.velocities.truncate(9);
    check_bad(&mut o, m, "segment_names");
    check_bad(&mut o, good(t - 0.5), "header.stamp");
    // A good frame again: back to normal.
    let mut m = good(t);
    m.segment_names.push("right_toe".into());
    m.poses.push(Default::default());
    m.velocities.push(Default::default());
    let out = o.on_skeleton(&m);
    assert!(out.accepted && out.state.usable && out.state.speed_scale == 0.3, "{:?} {:?}", out.state, out.warnings);
    assert!(out.warnings.iter().any(|w| w.contains("extra segments")));
    assert_eq!(o.rejected_frames(), 4);
}

#[test]
fn an_id_flood_is_bounded_and_slows_the_robot_until_it_stops() {
    let mut o = observer(ObserverConfig { max_people: 3, ..Default::default() });
    let p = standing(1, -0.5, -2.5);
    // 500 ids within 0.25 s (less than person_timeout_s: none of them is dropped as silent).
    for k in 0..500u32 {
        let t = k as f64 / 2000.0;
        let mut m = frame(&p, t);
        m.person_id = 1000 + k;
        let out = o.on_skeleton(&m);
        if k >= 3 {
            assert!(!out.accepted && out.warnings.iter().any(|w| w.contains("person_id")));
            assert_eq!(out.state.mode, Mode::Interaction);
        }
    }
    assert_eq!(o.tracks().count(), 3);
    let later = o.tick(0.25 + 1.0);
    assert_eq!(o.tracks().count(), 0);
    assert!(!later.present && later.speed_scale == 0.3, "{later:?}");
}

#[test]
fn missing_or_stale_joint_states_fail_closed() {
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("model");
    let mut o = Observer::new(model, ObserverConfig::default(), None).expect("observer");
    let p = standing(1, -0.5, -2.5);
    let out = o.on_skeleton(&frame(&p, 0.0));
    assert!(!out.state.usable && out.state.mode == Mode::Interaction && out.state.speed_scale == 0.1);
    assert!(out.warnings.iter().any(|w| w.contains("/joint_states")));
    o.on_joint_state(0.01, &[], &READY).expect("joints");
    assert!(o.on_skeleton(&frame(&p, 0.02)).state.usable);
    let out = o.on_skeleton(&frame(&p, 2.0));
    assert!(!out.state.usable && out.state.speed_scale == 0.1, "stale joint state");
    assert!(matches!(o.on_joint_state(2.0, &["a".into()], &[0.0]), Err(ObserverError::BadJointState { .. })));
    let mut q = READY;
    q[2] = f64::NAN;
    assert!(o.on_joint_state(2.0, &[], &q).is_err());
}

#[test]
fn speech_stops_and_repeat_resumes() {
    let mut o = observer(ObserverConfig::default());
    let p = standing(1, -0.5, -2.5);
    assert_eq!(o.on_skeleton(&frame(&p, 0.0)).state.speed_scale, 0.3);
    assert!(o.on_speech("stop"));
    let s = o.on_skeleton(&frame(&p, 0.01)).state;
    assert!(s.stopped && s.speed_scale == 0.0);
    assert!(!o.on_speech("teach"));
    // Nobody there any more: still stopped.
    let s = o.tick(5.0);
    assert!(!s.present && s.stopped && s.speed_scale == 0.0);
    assert!(o.on_speech("repeat"));
    assert_eq!(o.tick(5.1).speed_scale, 0.3);
}

#[test]
fn malformed_model_files_name_the_field() {
    let dir = std::env::temp_dir().join(format!("cowork_observer_model_{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let path = dir.join("bad.json");
    std::fs::write(&path, "{\"format\": \"cowork-gestures/1\", \"threshold\": 1}").expect("write");
    let e = GestureModel::from_file(&path).expect_err("incomplete");
    assert!(e.to_string().contains("bad.json") && e.to_string().contains("line"), "{e}");
    std::fs::write(&path, "{}").expect("write");
    assert!(GestureModel::from_file(&path).is_err());
    assert!(GestureModel::from_file(&dir.join("missing.json")).is_err());
    let _ = std::fs::remove_dir_all(&dir);
}
