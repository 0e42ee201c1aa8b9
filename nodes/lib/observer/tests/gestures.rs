//! Recognition generalises: templates from the gesture set of one seed, tested on people of
//! another seed (other sizes, speeds, amplitudes, positions, viewing angles, noise), at the
//! depth tracker's 30 Hz and the Xsens suit's 120 Hz; non-gesture motion (walking, standing,
//! reaching, sweeping) is not reported. Small sets so the debug profile stays fast; the full
//! table is `cowork bench gestures`.

use cowork_observer::eval::{Evaluation, gesture_stream, learn, non_gesture_stream, recognise};
use cowork_observer::{GestureModel, LearnConfig, Mode, Observer, ObserverConfig};
use cowork_people::SensorConfig;

fn model() -> GestureModel {
    let depth = SensorConfig::depth_tracker();
    let train = gesture_stream(11, 12, &depth, false).expect("train");
    let negatives = non_gesture_stream(11, 40.0, &depth).expect("negatives");
    learn(&[&train, &negatives], LearnConfig::default()).expect("learn")
}

#[test]
fn unseen_people_are_recognised_and_other_motion_is_not() {
    let model = model();
    assert_eq!(model.labels, vec!["come", "handover_right", "stop"]);
    for sensor in [SensorConfig::depth_tracker(), SensorConfig::xsens()] {
        let test = gesture_stream(12, 9, &sensor, false).expect("test");
        let (reports, evals) = recognise(&model, &test).expect("recognise");
        let e = Evaluation::score(&model.labels, &test, &reports, 1.0, evals);
        println!("{:?} Hz\n{}", sensor.rate_hz, e.table());
        for l in &model.labels {
            assert!(e.recall(l) >= 0.95, "{l}: recall {}\n{}", e.recall(l), e.table());
        }
        assert_eq!(e.false_reports(), 0, "{}", e.table());
        let other = non_gesture_stream(12, 60.0, &sensor).expect("non-gesture");
        let (reports, evals) = recognise(&model, &other).expect("recognise");
        assert!(evals > 500, "{evals} windows");
        assert!(reports.is_empty(), "false gestures in walking / reaching: {reports:?}");
    }
}

#[test]
fn a_fourth_class_is_taught_from_labels() {
    let depth = SensorConfig::depth_tracker();
    let train = gesture_stream(21, 6, &depth, true).expect("train");
    let model = learn(&[&train], LearnConfig::default()).expect("learn");
    assert!(model.labels.iter().any(|l| l == "raise_hand"), "{:?}", model.labels);
    let test = gesture_stream(22, 6, &depth, true).expect("test");
    let (reports, evals) = recognise(&model, &test).expect("recognise");
    let e = Evaluation::score(&model.labels, &test, &reports, 1.0, evals);
    println!("{}", e.table());
    assert!(e.recall("raise_hand") >= 0.95, "{}", e.table());
}

#[test]
fn a_stop_gesture_stops_and_come_resumes_in_the_observer() {
    let model = model();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let robot = cowork_robot::RobotModel::from_urdf_file(root.join("config/robot/lwr4plus.urdf")).expect("robot");
    let mut o = Observer::new(robot, ObserverConfig::default(), Some(model)).expect("observer");
    let test = gesture_stream(12, 9, &SensorConfig::depth_tracker(), false).expect("test");
    let mut events = Vec::new();
    for m in &test.frames {
        let t = m.header.stamp.to_secs_f64();
        o.on_joint_state(t, &[], &[0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0]).expect("joints");
        let out = o.on_skeleton(m);
        if let Some(g) = out.gesture {
            events.push((g.detection.label.clone(), out.state.stopped, out.state.speed_scale));
        }
        assert!(out.state.mode == Mode::Far || out.state.mode == Mode::Interaction);
    }
    let mut saw_stop = false;
    for (label, stopped, speed) in &events {
        match label.as_str() {
            "stop" => {
                assert!(*stopped && *speed == 0.0);
                saw_stop = true;
            }
            "come" => assert!(!*stopped && *speed > 0.0),
            _ => {}
        }
    }
    assert!(saw_stop && events.iter().any(|e| e.0 == "come"), "{events:?}");
}
