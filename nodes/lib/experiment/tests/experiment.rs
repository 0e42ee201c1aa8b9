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
        t += 1.0 / 60.0;
    }
    let first = judge.series.distance.first().unwrap().1;
    assert!(first > 1.0, "starts far: {first}");
    assert!(judge.min_distance().unwrap() <= 0.0, "walks into the arm");
    assert_eq!(judge.collisions, 1, "one clear -> touching transition");
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
        assert_eq!(&png[..4], b"\x89PNG", "{name}");
        assert!(
            png.len() > 5000,
            "{name}: {} bytes, a plot with text and lines",
            png.len()
        );
    }
}
