//! Contents of the static-scene, stacking-human and gestures bags.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use cowork_bag::BagReader;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::sensor_msgs::{Image, JointState};
use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_synth::{Scenario, SynthOptions, synthesize};
use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion, Quaternion};

fn config_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config")
}

fn synth(dir: &Path, scenario: Scenario, duration: Option<f64>, depth: bool) -> PathBuf {
    let path = dir.join(format!("{scenario}.mcap"));
    let options = SynthOptions {
        seed: 4,
        duration_s: duration,
        noise: false,
        depth,
        config_dir: config_dir(),
        ..SynthOptions::default()
    };
    synthesize(scenario, &options, &path, &mut |_| {}).unwrap();
    path
}

fn messages(path: &Path) -> Vec<cowork_bag::RawMessage> {
    BagReader::open(path).unwrap().messages().map(|m| m.unwrap()).collect()
}

fn counts(msgs: &[cowork_bag::RawMessage]) -> BTreeMap<String, usize> {
    let mut c = BTreeMap::new();
    for m in msgs {
        *c.entry(m.topic.to_string()).or_default() += 1;
    }
    c
}

#[test]
fn static_scene_holds_each_configuration_still_and_renders_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = synth(dir.path(), Scenario::StaticScene, Some(7.5), true);
    let msgs = messages(&path);
    let c = counts(&msgs);
    assert_eq!(c["/camera/depth/image_raw"], 226, "{c:?}");
    assert_eq!(c["/camera/depth/camera_info"], 226);
    assert_eq!(c["/joint_states"], 751);
    assert_eq!(c["/tf_static"], 1);
    assert!(!c.contains_key("/human/skeleton"));
    // 5 segments of 1.5 s: still from 1.0 s into each; frames in a still part are identical
    // (noise off), frames of different segments differ.
    let mut still: BTreeMap<i64, Vec<Vec<u8>>> = BTreeMap::new();
    for m in msgs.iter().filter(|m| &*m.topic == "/camera/depth/image_raw") {
        let t = m.log_time_ns as f64 * 1e-9;
        let seg = (t / 1.5).floor();
        if t - seg * 1.5 > 1.05 && t - seg * 1.5 < 1.45 {
            let img: Image = m.decode().unwrap();
            assert_eq!((img.width, img.height, img.encoding.as_str()), (640, 480, "16UC1"));
            still.entry(seg as i64).or_default().push(img.data);
        }
    }
    assert_eq!(still.len(), 5);
    for frames in still.values() {
        assert!(frames.len() >= 10);
        assert!(frames.iter().all(|f| f == &frames[0]), "a still segment's frames differ");
    }
    let firsts: Vec<&Vec<u8>> = still.values().map(|f| &f[0]).collect();
    for w in firsts.windows(2) {
        assert!(w[0] != w[1], "two configurations render the same image");
    }
    for m in msgs.iter().filter(|m| &*m.topic == "/joint_states") {
        let t = m.log_time_ns as f64 * 1e-9;
        let into = t - (t / 1.5).floor() * 1.5;
        if into > 1.01 && into < 1.49 {
            let js: JointState = m.decode().unwrap();
            assert!(js.velocity.iter().all(|v| *v == 0.0), "moving at {t} s: {:?}", js.velocity);
        }
    }
}

/// `child`'s pose in the base frame: `/tf` is a tree (each link in its parent's frame), so the
/// transforms are composed up to `lwr_base_link`.
fn tf_pose(tf: &TFMessage, child: &str) -> Option<Isometry3<f64>> {
    let edge = |c: &str| tf.transforms.iter().find(|t| t.child_frame_id == c);
    let iso = |t: &cowork_msgs::geometry_msgs::TransformStamped| {
        let (p, q) = (&t.transform.translation, &t.transform.rotation);
        Isometry3::from_parts(
            Translation3::new(p.x, p.y, p.z),
            UnitQuaternion::from_quaternion(Quaternion::new(q.w, q.x, q.y, q.z)),
        )
    };
    let first = edge(child)?;
    let (mut pose, mut frame) = (iso(first), first.header.frame_id.clone());
    for _ in 0..tf.transforms.len() {
        if frame == "lwr_base_link" {
            return Some(pose);
        }
        let up = edge(&frame)?;
        pose = iso(up) * pose;
        frame = up.header.frame_id.clone();
    }
    None
}

#[test]
fn stacking_human_moves_boxes_slows_near_the_person_and_draws_the_person() {
    let dir = tempfile::tempdir().unwrap();
    let path = synth(dir.path(), Scenario::StackingHuman, None, true);
    let msgs = messages(&path);
    let c = counts(&msgs);
    let skeletons: Vec<(u64, Skeleton)> = msgs
        .iter()
        .filter(|m| &*m.topic == "/human/skeleton")
        .map(|m| (m.log_time_ns, m.decode().unwrap()))
        .collect();
    // Xsens at 120 Hz from the person's entry (1 s) to the end of the visit.
    assert!(skeletons.len() > 120 * 12, "{c:?}");
    assert!(skeletons.iter().all(|(_, s)| s.source == "xsens" && s.segment_names.len() == 11));
    let first = skeletons[0].0 as f64 * 1e-9;
    assert!((first - 1.0).abs() < 0.01, "first skeleton at {first} s");
    let gaps = skeletons.windows(2).map(|w| w[1].0 - w[0].0).max().unwrap();
    assert!(gaps <= 8_333_334, "gap {gaps} ns between skeletons");

    // Both boxes end at their targets; the tool moves at most 0.3 m/s, and at most ~0.1 m/s
    // while the person's hand is within 0.6 m of it.
    let tfs: Vec<(f64, TFMessage)> = msgs
        .iter()
        .filter(|m| &*m.topic == "/tf")
        .map(|m| (m.log_time_ns as f64 * 1e-9, m.decode().unwrap()))
        .collect();
    for (name, xy) in cowork_synth::stacking::MOVES {
        let placed = tfs.iter().any(|(_, tf)| {
            let p = tf_pose(tf, name).unwrap().translation.vector;
            ((p.x - xy[0]).powi(2) + (p.y - xy[1]).powi(2)).sqrt() < 0.01 && (p.z - 0.03).abs() < 1e-3
        });
        assert!(placed, "{name} never placed on the table at {xy:?}");
    }
    // ... and every box is on the table (not in it, not above it) at the end.
    let last = &tfs.last().unwrap().1;
    for name in ["box1", "box2", "box3", "box4"] {
        let z = tf_pose(last, name).unwrap().translation.vector.z;
        assert!((0.0299..0.0301).contains(&z) || z > 0.05, "{name} at z = {z} at the end");
    }
    let hand_at = |t: f64| {
        let ns = (t * 1e9) as u64;
        skeletons
            .iter()
            .min_by_key(|(s, _)| s.abs_diff(ns))
            .filter(|(s, _)| s.abs_diff(ns) < 10_000_000)
            .and_then(|(_, sk)| sk.segment("right_hand").map(|p| Point3::new(p.position.x, p.position.y, p.position.z)))
    };
    let (mut fast, mut slow_near) = (0.0_f64, 0.0_f64);
    let mut near_samples = 0;
    for w in tfs.windows(2) {
        let (a, b) = (tf_pose(&w[0].1, "lwr_ee_link").unwrap(), tf_pose(&w[1].1, "lwr_ee_link").unwrap());
        let v = (b.translation.vector - a.translation.vector).norm() / (w[1].0 - w[0].0);
        fast = fast.max(v);
        if let Some(h) = hand_at(w[1].0)
            && (h - Point3::from(b.translation.vector)).norm() < 0.45
        {
            near_samples += 1;
            slow_near = slow_near.max(v);
        }
    }
    assert!(fast < 0.31 && fast > 0.25, "top tool speed {fast} m/s");
    assert!(near_samples > 10, "the hand never came near the tool");
    assert!(slow_near < 0.105, "tool speed {slow_near} m/s with the hand near");

    // The person is in the depth frames: at the pelvis pixel, the depth is the pelvis' depth.
    let tf_static: TFMessage = msgs.iter().find(|m| &*m.topic == "/tf_static").unwrap().decode().unwrap();
    let camera = tf_pose(&tf_static, "camera_depth_optical_frame").unwrap();
    let (t_mid, sk) = &skeletons[skeletons.len() / 2];
    let frame: Image = msgs
        .iter()
        .filter(|m| &*m.topic == "/camera/depth/image_raw")
        .min_by_key(|m| m.log_time_ns.abs_diff(*t_mid))
        .unwrap()
        .decode()
        .unwrap();
    let sternum = sk.segment("sternum").unwrap().position;
    let p = camera.inverse() * Point3::new(sternum.x, sternum.y, sternum.z);
    let (u, v) = ((525.0 * p.x / p.z + 319.5).round() as usize, (525.0 * p.y / p.z + 239.5).round() as usize);
    assert!(u < 640 && v < 480, "sternum outside the image ({u}, {v})");
    let i = 2 * (v * 640 + u);
    let mm = u16::from_le_bytes([frame.data[i], frame.data[i + 1]]) as f64;
    assert!((mm * 1e-3 - p.z).abs() < 0.2, "depth at the sternum {mm} mm, sternum at {:.3} m", p.z);
}

#[test]
fn gestures_are_labelled_with_their_performances() {
    let dir = tempfile::tempdir().unwrap();
    let path = synth(dir.path(), Scenario::Gestures, None, false);
    let msgs = messages(&path);
    let c = counts(&msgs);
    assert!(!c.contains_key("/camera/depth/image_raw"));
    let labels: Vec<serde_json::Value> = msgs
        .iter()
        .filter(|m| &*m.topic == "/human/gesture_label")
        .map(|m| {
            let s: RosString = m.decode().unwrap();
            let v: serde_json::Value = serde_json::from_str(&s.data).unwrap();
            assert!((v["end"].as_f64().unwrap() - m.log_time_ns as f64 * 1e-9).abs() < 1e-6);
            v
        })
        .collect();
    assert_eq!(labels.len(), cowork_synth::gestures::DEFAULT_COUNT);
    for kind in ["come", "stop", "handover_right"] {
        assert_eq!(labels.iter().filter(|l| l["label"] == kind).count(), 3, "{kind}");
    }
    let skeletons: Vec<(f64, Skeleton)> = msgs
        .iter()
        .filter(|m| &*m.topic == "/human/skeleton")
        .map(|m| (m.log_time_ns as f64 * 1e-9, m.decode().unwrap()))
        .collect();
    assert!(skeletons.iter().all(|(_, s)| s.source == "depth_tracker"));
    let heights: std::collections::BTreeSet<i64> =
        labels.iter().map(|l| (l["height_m"].as_f64().unwrap() * 100.0) as i64).collect();
    assert!(heights.len() >= 5, "body sizes {heights:?}");
    for l in &labels {
        let (start, end) = (l["start"].as_f64().unwrap(), l["end"].as_f64().unwrap());
        let id = l["person_id"].as_u64().unwrap() as u32;
        let during = skeletons.iter().filter(|(t, s)| *t >= start && *t <= end && s.person_id == id).count();
        // The depth tracker at 30 Hz (a few frames dropped).
        assert!(during as f64 >= 0.8 * 30.0 * (end - start), "{during} frames in {l}");
        assert!(skeletons.iter().filter(|(t, _)| *t >= start && *t <= end).all(|(_, s)| s.person_id == id));
    }
}
