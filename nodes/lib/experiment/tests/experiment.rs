//! The ROS-free half of the runner: descriptions, bad scenes, sequencing, judging, report.

use std::path::{Path, PathBuf};

use cowork_experiment::plan::{Options, Step};
use cowork_experiment::{DistanceMethod, Error, Judge, Output, Progress, Sequencer, build};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{MotionStatus, WorldObject, WorldState};
use cowork_msgs::sensor_msgs::JointState;
use cowork_people::{Action, BodySize, MessageMeta, Performer, Stance, Timeline};
use cowork_robot::RobotModel;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn options(seed: u64) -> Options {
    Options {
        seed,
        scene: None,
        distance: DistanceMethod::Fded,
        time_limit_s: None,
    }
}

#[test]
fn unknown_experiment_names_the_known_ones() {
    let e = build("stacking", &root(), &options(1)).unwrap_err();
    assert!(matches!(e, Error::UnknownExperiment { .. }), "{e}");
    assert!(e.to_string().contains("stacking-hri"), "{e}");
}

#[test]
fn stacking_hri_script_and_seeded_variants() {
    let a = build("stacking-hri", &root(), &options(3)).unwrap();
    // Two blocks, eight steps each: above, down, grasp, lift, above, down, release, up.
    assert_eq!(a.steps.len(), 16);
    assert!(matches!(&a.steps[2], Step::Grip { close: true, object } if object == "block1"));
    assert!(matches!(&a.steps[14], Step::Grip { close: false, object } if object == "block2"));
    // block2 is released 5 mm above block1's top at g3 (0.55, -0.30): g4.
    let Step::Move { goal, .. } = &a.steps[13] else {
        panic!()
    };
    assert!(
        (goal[0] - 0.55).abs() < 1e-9
            && (goal[1] + 0.30).abs() < 1e-9
            && (goal[2] - 0.0425).abs() < 1e-9,
        "{goal:?}"
    );
    assert_eq!(a.placements.len(), 2);
    assert_eq!(
        a.variant,
        build("stacking-hri", &root(), &options(3)).unwrap().variant,
        "deterministic per seed"
    );
    let variants: Vec<_> = (1..8)
        .map(|s| build("stacking-hri", &root(), &options(s)).unwrap().variant)
        .collect();
    assert!(
        variants.iter().any(|v| v.side == "+y") && variants.iter().any(|v| v.side == "-y"),
        "both sides"
    );
    assert!(
        variants.iter().any(|v| v.reach_speeds_m_s.len() > 1),
        "several reaches in some runs"
    );
    for v in &variants {
        assert!((1.55..=1.90).contains(&v.body_height_m));
        assert!(v.reach_speeds_m_s.iter().all(|s| (0.5..=1.5).contains(s)));
    }
    assert!(a.people.duration() > 8.0);
}

#[test]
fn scene_with_an_object_off_the_table_is_refused() {
    let text = std::fs::read_to_string(root().join("config/scenes/stacking-hri.yaml")).unwrap();
    let bad = text.replace(
        "position: [0.45, 0.35, 0.0125]",
        "position: [0.45, 1.35, 0.0125]",
    );
    assert_ne!(bad, text);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("off.yaml");
    std::fs::write(&path, bad).unwrap();
    let o = Options {
        scene: Some(path),
        ..options(1)
    };
    let e = build("stacking-hri", &root(), &o).unwrap_err();
    assert!(
        e.to_string().contains("block2") && e.to_string().contains("off the table"),
        "{e}"
    );
}

fn status(id: u32, state: u8) -> MotionStatus {
    MotionStatus {
        command_id: id,
        state,
        ..MotionStatus::default()
    }
}

fn world(held: &str, closed: bool) -> WorldState {
    WorldState {
        gripper_state: if closed {
            WorldState::GRIPPER_CLOSED
        } else {
            WorldState::GRIPPER_OPEN
        },
        held_object: held.into(),
        ..WorldState::default()
    }
}

#[test]
fn sequencer_waits_for_convergence_and_the_world() {
    let steps = vec![
        Step::Move {
            label: "a".into(),
            goal: [0.5, 0.0, 0.3],
            speed: 0.3,
        },
        Step::Grip {
            close: true,
            object: "box1".into(),
        },
        Step::Move {
            label: "b".into(),
            goal: [0.5, 0.1, 0.3],
            speed: 0.3,
        },
    ];
    let mut s = Sequencer::new(steps);
    let mut out = Vec::new();
    assert_eq!(s.update(0.0, None, None, &mut out), Progress::Running);
    let Output::Motion(m) = &out[0] else {
        panic!("{out:?}")
    };
    assert_eq!((m.id, m.nominal_speed, m.hold_orientation), (1, 0.3, true));
    out.clear();
    // Converged for another id is not this step; no status for 1 s sends it again.
    assert_eq!(
        s.update(
            0.5,
            Some(&status(7, MotionStatus::STATE_CONVERGED)),
            None,
            &mut out
        ),
        Progress::Running
    );
    assert!(out.is_empty());
    s.update(1.1, None, None, &mut out);
    assert!(
        matches!(&out[..], [Output::Motion(m)] if m.id == 1),
        "{out:?}"
    );
    out.clear();
    s.update(
        1.2,
        Some(&status(1, MotionStatus::STATE_CONVERGED)),
        None,
        &mut out,
    );
    assert_eq!(out, vec![Output::Gripper("close")]);
    out.clear();
    // Closed on nothing: fails after 1 s naming the step and what is held.
    let p = s
        .clone()
        .update(2.3, None, Some(&world("", true)), &mut out);
    let Progress::Failed(reason) = p else {
        panic!("{p:?}")
    };
    assert!(
        reason.contains("grasp box1") && reason.contains("holding \"\""),
        "{reason}"
    );
    out.clear();
    s.update(1.5, None, Some(&world("box1", true)), &mut out);
    assert!(
        matches!(&out[..], [Output::Motion(m)] if m.id == 2),
        "{out:?}"
    );
    out.clear();
    let p = s.clone().update(
        1.6,
        Some(&status(2, MotionStatus::STATE_ABORTED)),
        None,
        &mut out,
    );
    assert!(
        matches!(p, Progress::Failed(ref r) if r.contains("aborted")),
        "{p:?}"
    );
    assert_eq!(
        s.update(
            3.0,
            Some(&status(2, MotionStatus::STATE_CONVERGED)),
            None,
            &mut out
        ),
        Progress::Done
    );
    assert_eq!(s.finished().len(), 3);
}

fn model() -> RobotModel {
    RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).unwrap()
}

fn joints(t: f64, model: &RobotModel) -> JointState {
    let q = [
        0.0,
        30f64.to_radians(),
        0.0,
        90f64.to_radians(),
        0.0,
        60f64.to_radians(),
        0.0,
    ];
    JointState {
        header: cowork_msgs::std_msgs::Header {
            stamp: Time::from_secs_f64(t),
            frame_id: String::new(),
        },
        name: model.joint_names().to_vec(),
        position: q.to_vec(),
        velocity: vec![0.0; 7],
        effort: Vec::new(),
    }
}

/// The people of `tl` at `t` (s) into `judge`, as the runner sends them.
fn skeletons_at(judge: &mut Judge, tl: &Timeline, t: f64) {
    for (id, pose) in tl.poses_at(t) {
        let meta = MessageMeta {
            stamp: Time::from_secs_f64(t),
            frame_id: cowork_people::BASE_FRAME,
            source: "xsens",
            person_id: id,
            with_velocities: true,
        };
        judge.on_skeleton(&pose.to_message(&meta));
    }
}

#[test]
fn judge_measures_the_true_distance_and_counts_a_contact_once() {
    let model = model();
    let mut judge = Judge::new(model.clone(), cowork_people::DEFAULT_FLOOR_Z).unwrap();
    judge.on_joint_state(&joints(0.0, &model));
    // A person walking from 2 m away straight through the robot.
    let p = Performer::new(
        1,
        BodySize::MEDIUM,
        Stance::new(2.0, 0.0, std::f64::consts::PI),
        1,
    )
    .unwrap()
    .then(Action::Walk {
        to: nalgebra::Point2::new(0.3, 0.0),
        speed: 1.0,
        face_yaw: None,
    })
    .unwrap();
    let mut tl = Timeline::new();
    tl.add(0.0, p).unwrap();
    let mut t = 0.0;
    while t <= tl.duration() {
        skeletons_at(&mut judge, &tl, t);
        t += 1.0 / 60.0;
    }
    let first = judge.series.distance.first().unwrap().1;
    assert!(first > 1.0, "starts far: {first}");
    assert!(judge.min_distance().unwrap() <= 0.0, "walks into the arm");
    assert_eq!(judge.collisions, 1, "one clear -> touching transition");
    // The arm stood still: the person walked into it.
    let c = &judge.contacts[0];
    assert!(c.robot_closing_m_s.abs() < 1e-9, "{c:?}");
    assert!(c.person_closing_m_s > 0.3, "{c:?}");
}

#[test]
fn a_contact_says_the_robot_moved_into_a_person_standing_still() {
    let model = model();
    let mut judge = Judge::new(model.clone(), cowork_people::DEFAULT_FLOOR_Z).unwrap();
    // Someone standing beside the arm, to its left (+y), facing it.
    let p = Performer::new(1, BodySize::MEDIUM, Stance::new(0.35, 0.55, -std::f64::consts::FRAC_PI_2), 1)
        .unwrap()
        .then(Action::Stand { duration: 4.0 })
        .unwrap();
    let mut tl = Timeline::new();
    tl.add(0.0, p).unwrap();
    // Joint 1 turns the arm towards them at 1 rad/s.
    let mut t = 0.0;
    while t <= tl.duration() {
        let mut js = joints(t, &model);
        js.position[0] = t;
        js.velocity[0] = 1.0;
        judge.on_joint_state(&js);
        skeletons_at(&mut judge, &tl, t);
        t += 1.0 / 120.0;
    }
    assert!(judge.collisions >= 1, "the arm swept into them: closest {:?}", judge.closest);
    let c = &judge.contacts[0];
    assert!(c.robot_closing_m_s > 0.1, "{c:?}");
    assert!(c.person_closing_m_s.abs() < 0.5 * c.robot_closing_m_s, "{c:?}");
}

#[test]
fn placements_are_judged_from_the_world() {
    let model = model();
    let mut judge = Judge::new(model, cowork_people::DEFAULT_FLOOR_Z).unwrap();
    let obj = |name: &str, x: f64, y: f64, z: f64| WorldObject {
        name: name.into(),
        pose: Pose {
            position: Point { x, y, z },
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            },
        },
        ..WorldObject::default()
    };
    let mut w = world("", false);
    w.objects = vec![
        obj("block1", 0.55, 0.35, 0.0125),
        obj("block2", 0.45, 0.35, 0.0125),
    ];
    judge.on_world(&w);
    w.objects = vec![
        obj("block1", 0.555, -0.30, 0.0125),
        obj("block2", 0.55, -0.30, 0.0375),
    ];
    judge.on_world(&w);
    let e = build("stacking-hri", &root(), &options(1)).unwrap();
    let r = judge.placements(&e.placements);
    assert!(
        r[0].success && (r[0].error_m.unwrap() - 0.005).abs() < 1e-9,
        "{r:?}"
    );
    assert!(
        r[1].success && (r[1].error_m.unwrap() - 0.005).abs() < 1e-9,
        "on block1 (measured against its final centre): {r:?}"
    );
    // block2 beside the stack, on the table: failed.
    w.objects[1] = obj("block2", 0.55, -0.27, 0.0125);
    judge.on_world(&w);
    let r = judge.placements(&e.placements);
    assert!(r[0].success && !r[1].success, "{r:?}");
    // block2 missing from the world: failed, no error value.
    w.objects.pop();
    judge.on_world(&w);
    let r = judge.placements(&e.placements);
    assert!(!r[1].success && r[1].error_m.is_none());
}

#[test]
fn report_writes_pngs_and_an_index() {
    let mut s = cowork_experiment::Series::default();
    for i in 0..200 {
        let t = i as f64 * 0.05;
        s.distance.push((t, 0.5 - 0.04 * t));
        s.measured_distance.push((t, 0.5 - 0.04 * t + 0.01));
        s.tool_speed.push((t, 0.3));
        s.alpha.push((t, if t < 5.0 { 0.3 } else { 0.1 }));
        s.processing_ms.push((t, 1.9));
        // Every plot has data (a plot without any is not drawn, issue #51).
        let mode = if t < 5.0 { 0 } else { 1 };
        s.human_state.push((t, cowork_experiment::judge::ObservedState { mode, present: true, stopped: false }));
        s.executed_qdot.push((t, 0.2));
    }
    s.backend = "cpu".into();
    let dir = tempfile::tempdir().unwrap();
    let trial = cowork_experiment::report::ReportTrial {
        title: "t <1>".into(),
        row: vec![("min distance (m)".into(), "0.100".into())],
        series: s,
    };
    cowork_experiment::report::write_report(dir.path(), "test", &[trial]).unwrap();
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(
        html.contains("t &lt;1&gt;") && html.contains("trial0-distance.png"),
        "{html}"
    );
    for name in ["distance", "speed", "mode", "processing", "qdot"] {
        let png = std::fs::read(dir.path().join(format!("trial0-{name}.png"))).unwrap();
        assert!(dir.path().join(format!("trial0-{name}.csv")).is_file(), "{name}: the data beside the plot");
        assert_eq!(&png[..4], b"\x89PNG", "{name}");
        assert!(
            png.len() > 5000,
            "{name}: {} bytes, a plot with text and lines",
            png.len()
        );
    }
}

#[test]
fn gestures_hri_script_waits_for_come_and_hands_block1_over() {
    let a = build("gestures-hri", &root(), &options(2)).unwrap();
    assert!(
        matches!(&a.steps[0], Step::AwaitGesture { label } if label == "come"),
        "{:?}",
        a.steps[0]
    );
    // above, down, grasp, lift block1; hand it over; release; block2's eight steps onto g3.
    assert!(matches!(&a.steps[3], Step::Grip { close: true, object } if object == "block1"));
    assert!(
        matches!(&a.steps[5], Step::Handover { object, offset, .. } if object == "block1" && (offset[2] - 0.05).abs() < 1e-12)
    );
    assert!(matches!(&a.steps[6], Step::Grip { close: false, object } if object == "block1"));
    assert_eq!(a.steps.len(), 7 + 8);
    assert_eq!(a.placements.len(), 1);
    assert_eq!(a.placements[0].object, "block2");
    // The person performs come, stop, come, handover right, in that order.
    let performed: Vec<String> = cowork_experiment::cooperation::performed(&a.people)
        .into_iter()
        .map(|p| p.label)
        .collect();
    assert_eq!(performed, ["come", "stop", "come", "handover_right"]);
    let e = build(
        "gestures-hri",
        &root(),
        &Options {
            distance: DistanceMethod::Flacco,
            ..options(1)
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("stacking-hri only"), "{e}");
}

fn hand_world(held: &str) -> WorldState {
    WorldState {
        gripper_state: WorldState::GRIPPER_CLOSED,
        held_object: held.into(),
        ..WorldState::default()
    }
}

#[test]
fn sequencer_waits_for_gestures_and_follows_the_hand_with_end_effector_avoidance_off() {
    let steps = vec![
        Step::AwaitGesture {
            label: "come".into(),
        },
        Step::Handover {
            object: "block1".into(),
            offset: [0.0, 0.0, 0.05],
            speed: 0.3,
            reach_centre: [0.0, 0.0, 0.31],
            reach_radius: 0.9,
        },
        Step::Move {
            label: "next".into(),
            goal: [0.5, 0.0, 0.3],
            speed: 0.3,
        },
    ];
    let mut s = Sequencer::new(steps);
    let mut out = Vec::new();
    let w = hand_world("block1");
    // Nothing before `come` (a `stop` is not a `come`).
    s.on_gesture(0.5, "stop");
    assert_eq!(s.update(1.0, None, Some(&w), &mut out), Progress::Running);
    assert!(out.is_empty(), "{out:?}");
    s.on_gesture(1.5, "come");
    // come → the handover step, which waits for its gesture and a fresh hand.
    const STILL: [f64; 3] = [0.0; 3];
    s.on_hand(1.9, [0.3, -0.6, 0.2], STILL);
    assert_eq!(s.update(2.0, None, Some(&w), &mut out), Progress::Running);
    assert!(out.is_empty(), "{out:?}");
    s.on_gesture(2.5, "handover_right");
    // A hand 0.5 s old is not aimed at.
    s.update(2.6, None, Some(&w), &mut out);
    assert!(out.is_empty(), "stale hand: {out:?}");
    // A hand on its way (0.5 m/s) or out of reach (1.2 m away) is not aimed at either.
    s.on_hand(2.62, [0.3, -0.6, 0.2], [0.5, 0.0, 0.0]);
    s.update(2.63, None, Some(&w), &mut out);
    s.on_hand(2.64, [0.3, -1.2, 0.2], STILL);
    s.update(2.65, None, Some(&w), &mut out);
    assert!(out.is_empty(), "moving / unreachable hand: {out:?}");
    s.on_hand(2.65, [0.3, -0.6, 0.2], STILL);
    s.update(2.7, None, Some(&w), &mut out);
    let Some(Output::Motion(m)) = out.pop() else {
        panic!("handover not commanded")
    };
    assert!(m.end_effector_avoidance_off);
    assert!((m.goal.position.z - 0.25).abs() < 1e-12 && (m.goal.position.y + 0.6).abs() < 1e-12);
    let first = m.id;
    // The hand moves 1 cm: same goal; 5 cm: a new goal (new id), still avoidance off.
    s.on_hand(2.8, [0.31, -0.6, 0.2], STILL);
    s.update(2.8, Some(&status(first, MotionStatus::STATE_RUNNING)), Some(&w), &mut out);
    assert!(out.is_empty(), "{out:?}");
    s.on_hand(2.9, [0.35, -0.6, 0.2], STILL);
    s.update(2.9, Some(&status(first, MotionStatus::STATE_RUNNING)), Some(&w), &mut out);
    let Some(Output::Motion(m2)) = out.pop() else {
        panic!("no re-target")
    };
    assert!(m2.id > first && m2.end_effector_avoidance_off);
    assert!((m2.goal.position.x - 0.35).abs() < 1e-12);
    // Converged on the old id is not done; on the new one it is, and the next move has
    // end-effector avoidance back on.
    s.update(3.0, Some(&status(first, MotionStatus::STATE_CONVERGED)), Some(&w), &mut out);
    assert!(out.is_empty());
    // Converged, but the newest hand is stale (it went out of view): no release yet.
    s.update(3.4, Some(&status(m2.id, MotionStatus::STATE_CONVERGED)), Some(&w), &mut out);
    assert!(out.is_empty(), "{out:?}");
    s.on_hand(3.45, [0.35, -0.6, 0.2], STILL);
    s.update(3.5, Some(&status(m2.id, MotionStatus::STATE_CONVERGED)), Some(&w), &mut out);
    let Some(Output::Motion(m3)) = out.pop() else {
        panic!("next step not sent")
    };
    assert!(!m3.end_effector_avoidance_off && m3.label == "next");
    let h = &s.handovers()[0];
    assert_eq!((h.gesture_t, h.commanded_t, h.goals.len()), (2.5, 2.7, 2));
    // A handover of something not held fails, naming it.
    let mut t = Sequencer::new(vec![Step::Handover {
        object: "block1".into(),
        offset: [0.0; 3],
        speed: 0.3,
        reach_centre: [0.0; 3],
        reach_radius: 1.0,
    }]);
    let p = t.update(0.0, None, Some(&hand_world("block2")), &mut out);
    assert!(
        matches!(&p, Progress::Failed(r) if r.contains("block1 is not held")),
        "{p:?}"
    );
}

#[test]
fn gesture_reactions_are_judged_from_the_tool_speed_and_the_release() {
    use cowork_experiment::cooperation::{Performed, Release, failures, reactions};
    use cowork_experiment::sequencer::HandoverLog;
    let mut series = cowork_experiment::Series::default();
    // Tool: moving 0.1 m/s, stop recognised at 10 s: at rest from 10.3 s; come at 14 s:
    // moving again from 14.4 s.
    for k in 0..400 {
        let t = 5.0 + 0.05 * f64::from(k);
        let v = if (10.3..14.4).contains(&t) { 0.001 } else { 0.1 };
        series.tool_speed.push((t, v));
    }
    series.gestures = vec![
        (10.0, "stop".into()),
        (14.0, "come".into()),
        (18.0, "handover_right".into()),
    ];
    let performed = [
        Performed { label: "stop".into(), start_s: 7.0, end_s: 9.6 },
        Performed { label: "come".into(), start_s: 11.0, end_s: 13.7 },
        Performed { label: "handover_right".into(), start_s: 15.0, end_s: 17.8 },
        Performed { label: "come".into(), start_s: 1.0, end_s: 3.0 },
    ];
    let handovers = [HandoverLog {
        object: "block1".into(),
        gesture_t: 18.0,
        commanded_t: 18.2,
        goals: vec![],
    }];
    let release = |d: f64| Release {
        object: "block1".into(),
        t: 24.0,
        distance_to_hand_m: d,
        hand: [0.0; 3],
        object_centre: [0.0; 3],
    };
    let r = reactions(&series, 0.0, 25.0, &performed, &handovers, &[release(0.03)]);
    assert_eq!(r.len(), 4, "{r:?}");
    assert!(r[0].acted && (r[0].reaction_s.unwrap() - 0.3).abs() < 0.06, "{:?}", r[0]);
    assert!(r[1].acted && (r[1].reaction_s.unwrap() - 0.4).abs() < 0.06, "{:?}", r[1]);
    assert!(r[2].acted && (r[2].reaction_s.unwrap() - 0.2).abs() < 1e-9 && r[2].release_distance_m == Some(0.03));
    // The first come was performed but never recognised: a failure.
    assert!(!r[3].acted && r[3].recognised_s.is_none());
    let f = failures(&r);
    assert_eq!(f.len(), 1, "{f:?}");
    // Released 8 cm from the hand: not acted on. A robot that kept moving after the stop: not.
    let r = reactions(&series, 0.0, 25.0, &performed[..3], &handovers, &[release(0.08)]);
    assert!(!r[2].acted && r[2].note.contains("0.080"), "{:?}", r[2]);
    for p in series.tool_speed.iter_mut().filter(|p| (12.0..13.0).contains(&p.0)) {
        p.1 = 0.05;
    }
    let r = reactions(&series, 0.0, 25.0, &performed[..3], &handovers, &[release(0.03)]);
    assert!(!r[0].acted && r[0].note.contains("moved"), "{:?}", r[0]);
}

/// The tool's speed is judged against the α_h of the newest `/human/state` at that time: 0.2
/// m/s under 0.3 is within, 0.15 m/s once α_h fell to 0.1 is the peak (+0.05 m/s); with
/// nobody close, only the 0.3 m/s samples count.
#[test]
fn the_fastest_tool_speed_is_judged_against_the_alpha_of_its_time() {
    use cowork_msgs::msg::HumanState;
    let model = model();
    let mut judge = Judge::new(model, cowork_people::DEFAULT_FLOOR_Z).unwrap();
    assert!(judge.fastest_over_allowed(false).is_none(), "no /human/state yet");
    let state = |t: f64, alpha: f64| HumanState {
        header: cowork_msgs::std_msgs::Header { stamp: Time::from_secs_f64(t), ..Default::default() },
        present: true,
        speed_scale: alpha,
        ..HumanState::default()
    };
    judge.on_human_state(&state(0.0, 0.3));
    judge.on_human_state(&state(2.0, 0.1));
    let mut y = 0.0;
    // 1/16 s steps: exact in binary, so every step is one sample (≥ 50 ms).
    for k in 0..=64 {
        let t = 0.0625 * f64::from(k);
        let mut w = WorldState::default();
        w.header.stamp = Time::from_secs_f64(t);
        w.tool_pose.position = Point { x: 0.5, y, z: 0.3 };
        judge.on_world(&w);
        y += if t < 2.0 { 0.2 * 0.0625 } else { 0.15 * 0.0625 };
    }
    let peak = judge.fastest_over_allowed(false).unwrap();
    assert!((peak.speed_m_s - 0.15).abs() < 1e-6 && peak.allowed_m_s == 0.1, "{peak:?}");
    assert!(peak.t_s > 2.0, "{peak:?}");
    // Nobody close (α_h at its largest, 0.3 m/s): 0.2 m/s, 0.1 m/s under the allowed speed.
    let own = judge.fastest_over_allowed(true).unwrap();
    assert!((own.speed_m_s - 0.2).abs() < 1e-6 && own.allowed_m_s == 0.3 && own.t_s < 2.0, "{own:?}");
}
