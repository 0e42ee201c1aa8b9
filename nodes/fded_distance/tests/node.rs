//! The node message by message (no network), then over DDS on a private domain beside an
//! in-process `lwr_sim` (its `/joint_states` and `/tf_static`), with depth frames rendered by
//! the test at the simulator's joint state and published at 30 Hz, bad frames among them.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_depth::{DepthImage, Encoding, Intrinsics};
use cowork_fded::{Fded, FdedParams, Frame};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Quaternion, Transform, TransformStamped, Vector3};
use cowork_msgs::msg::LinkDistances;
use cowork_msgs::sensor_msgs::{CameraInfo, Image, JointState};
use cowork_msgs::std_msgs::Header;
use cowork_msgs::tf2_msgs::TFMessage;
use cowork_msgs::visualization_msgs::{Marker, MarkerArray};
use cowork_robot::RobotModel;
use cowork_ros::{NodeConfig, RosNode, qos};
use fded_distance::{FdedNode, Params, RunOptions};
use nalgebra::{Isometry3, Point3};

const FRAME: &str = "camera_depth_optical_frame";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn model() -> RobotModel {
    RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("bundled URDF")
}

fn params() -> Params {
    let mut p: Params =
        cowork_ros::params::load(&root().join("config/fded_distance.yaml"), "fded_distance").expect("bundled parameters");
    p.urdf = root().join("config/robot/lwr4plus.urdf").display().to_string();
    p.manipulated.scene = root().join("config/scenes/kitchen.yaml").display().to_string();
    // The test frames show the robot and one sphere in front of nothing (no table, no walls):
    // a few per cent of the pixels, which the bundled blind-camera bound would refuse.
    p.min_valid_fraction = 0.005;
    p
}

fn kitchen_camera() -> (Isometry3<f64>, Intrinsics) {
    let scene = cowork_sim::Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("kitchen scene");
    let c = &scene.camera;
    (c.pose.isometry(), Intrinsics { width: c.width, height: c.height, fx: c.fx, fy: c.fy, cx: c.cx, cy: c.cy })
}

/// The robot as a sensor sees it at `q`, plus a sphere of radius `r` at `centre` (base frame).
fn render(model: &RobotModel, k: &Intrinsics, cam: &Isometry3<f64>, q: &[f64], centre: Point3<f64>, r: f64) -> DepthImage {
    let mut f = Fded::new(model, k, FdedParams::default()).expect("fded");
    let empty = DepthImage::new(k.width, k.height);
    f.prepare(&Frame { stamp: 0.0, depth: &empty, camera_pose: cam, joints: Some(q) }).expect("prepare");
    let mut img = DepthImage { data: f.buffers().virtual_depth.clone(), ..empty };
    let c = (cam.inverse() * centre).coords;
    for v in 0..k.height {
        for u in 0..k.width {
            let d = nalgebra::Vector3::new((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy, 1.0);
            let (a, b, cc) = (d.norm_squared(), -2.0 * d.dot(&c), c.norm_squared() - r * r);
            let disc = b * b - 4.0 * a * cc;
            if disc >= 0.0 {
                let t = ((-b - disc.sqrt()) / (2.0 * a)) as f32;
                let px = &mut img.data[(v * k.width + u) as usize];
                if t > 0.0 && (*px <= 0.0 || t < *px) {
                    *px = t;
                }
            }
        }
    }
    img
}

/// Independent reference for a frame: the CPU pipeline on the same image.
fn reference(model: &RobotModel, k: &Intrinsics, cam: &Isometry3<f64>, q: &[f64], img: &DepthImage) -> f64 {
    let mut f = Fded::new(model, k, FdedParams::default()).expect("fded");
    let mut out = f.new_output();
    f.process(&Frame { stamp: 0.0, depth: img, camera_pose: cam, joints: Some(q) }, &mut out).expect("cpu frame");
    out.minimum().expect("the sphere is seen").distance
}

fn joint_state(model: &RobotModel, q: &[f64], stamp: Time) -> JointState {
    JointState {
        header: Header { stamp, frame_id: String::new() },
        name: model.joint_names().to_vec(),
        position: q.to_vec(),
        ..Default::default()
    }
}

fn tf_static(base: &str, cam: &Isometry3<f64>) -> TFMessage {
    let t = cam.translation.vector;
    let r = cam.rotation.quaternion();
    TFMessage {
        transforms: vec![TransformStamped {
            header: Header { stamp: Time::default(), frame_id: base.to_owned() },
            child_frame_id: FRAME.to_owned(),
            transform: Transform {
                translation: Vector3 { x: t.x, y: t.y, z: t.z },
                rotation: Quaternion { x: r.i, y: r.j, z: r.k, w: r.w },
            },
        }],
    }
}

const Q: [f64; 7] = [0.0, 0.5, 0.0, -1.2, 0.0, 0.6, 0.0];

#[test]
fn bad_input_is_skipped_and_good_frames_match_the_library() {
    let model = model();
    let (cam, k) = kitchen_camera();
    let mut node = FdedNode::new(model.clone(), params()).expect("node");
    let img = render(&model, &k, &cam, &Q, Point3::new(0.75, 0.0, 0.75), 0.08);
    let msg32 = img.to_image_msg(Time::from_secs_f64(1.0), FRAME, Encoding::F32Metres);

    let s = node.on_depth(&msg32).expect_err("no camera info yet");
    assert_eq!(s.kind, "no_camera_info");
    let mut bad_info = k.to_camera_info(Time::default(), FRAME);
    bad_info.k[0] = f64::NAN;
    assert_eq!(node.on_camera_info(&bad_info).expect_err("NaN fx").kind, "camera_info");
    node.on_camera_info(&k.to_camera_info(Time::default(), FRAME)).expect("camera info");
    let s = node.on_depth(&msg32).expect_err("no joint state yet");
    assert_eq!(s.kind, "no_joint_state");
    let mut js = joint_state(&model, &Q, Time::from_secs_f64(1.0));
    js.position[3] = f64::NAN;
    assert_eq!(node.on_joint_state(&js).expect_err("NaN joint").kind, "joint_state");
    js.position.pop();
    assert_eq!(node.on_joint_state(&js).expect_err("short joint state").kind, "joint_state");
    node.on_joint_state(&joint_state(&model, &Q, Time::from_secs_f64(1.0))).expect("joint state");
    let mut bad_tf = tf_static(&model.link_names()[0], &cam);
    bad_tf.transforms[0].transform.rotation.w = f64::NAN;
    assert_eq!(node.on_tf_static(&bad_tf).expect_err("NaN rotation").kind, "tf_static");
    node.on_tf_static(&tf_static(&model.link_names()[0], &cam)).expect("tf_static");

    let want = reference(&model, &k, &cam, &Q, &img);
    let got = node.on_depth(&msg32).expect("32FC1 frame").clone();
    let backend = node.backend().expect("engine built");
    assert_eq!(got.backend, backend);
    assert!(got.min_index >= 0);
    let m = &got.links[got.min_index as usize];
    assert!(m.valid);
    assert!((m.distance - want).abs() <= 1e-3, "32FC1 over {backend}: {} vs library {want}", m.distance);
    assert!(got.processing_time > 0.0);
    assert_eq!(got.header.frame_id, model.link_names()[0]);
    assert_eq!(got.links.len(), model.link_count());
    // Markers: four per link, the closest link's segment joining its two points.
    let markers = node.markers().clone();
    assert_eq!(markers.markers.len(), 4 * model.link_count());
    let seg = markers
        .markers
        .iter()
        .find(|mk| mk.ns == fded_distance::markers::NS_SEGMENT && mk.id == got.min_index)
        .expect("segment of the closest link");
    assert_eq!(seg.action, Marker::ADD);
    assert_eq!(seg.header, got.header);
    assert_eq!(seg.points, vec![m.robot_point, m.obstacle_point]);
    for (i, l) in got.links.iter().enumerate() {
        let actions: Vec<i32> = markers.markers[4 * i..4 * i + 4].iter().map(|mk| mk.action).collect();
        let want = if l.valid { Marker::ADD } else { Marker::DELETE };
        assert!(actions.iter().all(|&a| a == want), "link {} valid {} markers {actions:?}", l.link_name, l.valid);
    }

    // 16UC1: the same scene quantised to mm still gives the distance within a few mm.
    let msg16 = img.to_image_msg(Time::from_secs_f64(1.1), FRAME, Encoding::U16Millimetres);
    let got16 = node.on_depth(&msg16).expect("16UC1 frame").clone();
    let d16 = got16.links[got16.min_index as usize].distance;
    assert!((d16 - want).abs() <= 5e-3, "16UC1: {d16} vs {want}");

    // Unknown encoding, wrong size, truncated data, step x height != size: skipped with the
    // topic and the reason, and the node goes on.
    let mut rgb = msg32.clone();
    rgb.encoding = "rgb8".into();
    let s = node.on_depth(&rgb).expect_err("rgb8");
    assert_eq!(s.kind, "image");
    assert!(s.message.contains("/camera/depth/image_raw") && s.message.contains("rgb8"), "{}", s.message);
    let small = DepthImage::new(320, 240).to_image_msg(Time::default(), FRAME, Encoding::F32Metres);
    let s = node.on_depth(&small).expect_err("size");
    assert_eq!(s.kind, "size");
    assert!(s.message.contains("320x240"), "{}", s.message);
    let mut short = msg32.clone();
    short.data.truncate(1000);
    assert_eq!(node.on_depth(&short).expect_err("short data").kind, "image");
    let mut long = msg32.clone();
    long.data.extend_from_slice(&[0; 4]);
    assert_eq!(node.on_depth(&long).expect_err("data longer than step x height").kind, "image");
    let mut bad_step = msg32.clone();
    bad_step.step = 4 * k.width - 4;
    assert_eq!(node.on_depth(&bad_step).expect_err("step below width").kind, "image");
    // All-NaN and all-zero frames are a blind (covered) camera, not free space: no distances
    // are published for them (the controller's watchdog then holds the robot).
    let nan = Image { data: f32::NAN.to_le_bytes().repeat((k.width * k.height) as usize), ..msg32.clone() };
    let s = node.on_depth(&nan).expect_err("NaN frame");
    assert_eq!(s.kind, "blind");
    assert!(s.message.contains("blind camera") && s.message.contains("0 of 307200"), "{}", s.message);
    let zero = Image { data: vec![0; msg16.data.len()], ..msg16.clone() };
    assert_eq!(node.on_depth(&zero).expect_err("all-zero 16UC1 frame").kind, "blind");
    // A frame with returns but no obstacle: every link invalid, markers deleted.
    let far = Image { data: 9.5f32.to_le_bytes().repeat((k.width * k.height) as usize), ..msg32.clone() };
    let none = node.on_depth(&far).expect("a far wall").clone();
    assert_eq!(none.min_index, -1);
    assert!(none.links.iter().all(|l| !l.valid));
    assert!(node.markers().markers.iter().all(|mk| mk.action == Marker::DELETE), "nothing seen: markers deleted");
    let again = node.on_depth(&msg32).expect("good frame after bad ones").clone();
    assert!((again.links[again.min_index as usize].distance - want).abs() <= 1e-3);
}

#[test]
fn joint_state_closest_to_the_frame_stamp_is_used() {
    let model = model();
    let (cam, k) = kitchen_camera();
    let mut node = FdedNode::new(model.clone(), params()).expect("node");
    node.on_camera_info(&k.to_camera_info(Time::default(), FRAME)).expect("camera info");
    node.on_tf_static(&tf_static(&model.link_names()[0], &cam)).expect("tf_static");
    let img = render(&model, &k, &cam, &Q, Point3::new(0.75, 0.0, 0.75), 0.08);
    let want = reference(&model, &k, &cam, &Q, &img);
    // The robot at Q at t = 2.0 s; elsewhere before and after. The frame at 2.0 s must be
    // computed at Q, whatever arrived later.
    let elsewhere = [1.0, -0.5, 0.3, -0.4, 0.2, 0.1, 0.0];
    for (t, q) in [(1.9, &elsewhere), (2.0, &Q), (2.1, &elsewhere), (2.2, &elsewhere)] {
        node.on_joint_state(&joint_state(&model, q, Time::from_secs_f64(t))).expect("joint state");
    }
    let got = node.on_depth(&img.to_image_msg(Time::from_secs_f64(2.0), FRAME, Encoding::F32Metres)).expect("frame").clone();
    assert!(node.take_notice().is_none());
    assert!((got.links[got.min_index as usize].distance - want).abs() <= 1e-3, "{} vs {want}", got.links[got.min_index as usize].distance);
    // A frame far from every joint state: the newest is used, with a notice naming the topic.
    node.on_depth(&img.to_image_msg(Time::from_secs_f64(9.0), FRAME, Encoding::F32Metres)).expect("frame");
    let notice = node.take_notice().expect("old joint state noticed");
    assert!(notice.message.contains("/joint_states"), "{}", notice.message);
    // Time going back (a looped bag) restarts the history: the new state alone is used.
    node.on_joint_state(&joint_state(&model, &Q, Time::from_secs_f64(0.5))).expect("joint state");
    let got = node.on_depth(&img.to_image_msg(Time::from_secs_f64(0.5), FRAME, Encoding::F32Metres)).expect("frame").clone();
    assert!(node.take_notice().is_none());
    assert!((got.links[got.min_index as usize].distance - want).abs() <= 1e-3);
}

#[test]
fn bundled_parameters_are_valid_and_typos_fail() {
    params().validate("config/fded_distance.yaml").expect("valid");
    let bad = "fded_distance:\n  ros__parameters:\n    backend: cuda\n";
    let p: Params = cowork_ros::params::from_str(bad, "fded_distance", "t.yaml").expect("parses");
    assert!(p.validate("t.yaml").is_err());
    let typo = "fded_distance:\n  ros__parameters:\n    fded: { tile: 8 }\n";
    assert!(cowork_ros::params::from_str::<Params>(typo, "fded_distance", "t.yaml").is_err());
}

fn private_domain() -> u16 {
    cowork_ros::domain::test_domain("fded_distance node test")
}

#[test]
fn over_dds_beside_lwr_sim() {
    let domain = private_domain();
    let model = model();

    // lwr_sim: clock, joint states, the camera's /tf_static and its rendered depth camera
    // (/camera/depth/image_raw + camera_info, 30 Hz, Kinect-like noise), real time.
    let sim_model = model.clone();
    std::thread::spawn(move || {
        let config: lwr_sim::LwrSimConfig =
            cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("lwr_sim params");
        let scene = cowork_sim::Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
        let sim = cowork_sim::Simulator::new(sim_model, scene, config.simulation.clone()).expect("sim");
        let node = RosNode::new("lwr_sim", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("node");
        let _ = lwr_sim::run(node, lwr_sim::LwrSim::new(sim, config), lwr_sim::Pacing::Rate(1.0), Some(60.0));
    });

    let stop = Arc::new(AtomicBool::new(false));
    let fded_node = RosNode::new("fded_distance", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("node");
    let fded = FdedNode::new(model.clone(), params()).expect("fded node");
    let options = RunOptions { duration_s: Some(90.0), stop: Some(Arc::clone(&stop)) };
    let handle = std::thread::spawn(move || fded_distance::run(fded_node, fded, &options));

    let mut client = RosNode::new("test_observer", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("client");
    let bad_images = client.publisher::<Image>("/camera/depth/image_raw", &qos::sensor_data()).expect("pub");
    let images = client.subscription::<Image>("/camera/depth/image_raw", &qos::sensor_data()).expect("sub");
    let infos = client.subscription::<CameraInfo>("/camera/depth/camera_info", &qos::sensor_data()).expect("sub");
    let joints = client.subscription::<JointState>("/joint_states", &qos::reliable()).expect("sub");
    let tf = client.subscription::<TFMessage>("/tf_static", &qos::latched()).expect("sub");
    let distances = client.subscription::<LinkDistances>("/fded/distances", &qos::reliable()).expect("sub");
    let markers = client.subscription::<MarkerArray>("/fded/markers", &qos::reliable()).expect("sub");
    let mut marker_arrays = 0;
    let mut marker_checked = 0;

    let mut cam = None;
    let mut q: Option<Vec<f64>> = None;
    let mut k = None;
    let mut seen: std::collections::HashMap<(i32, u32), Image> = std::collections::HashMap::new();
    let mut received: Vec<LinkDistances> = Vec::new();
    let mut bad_sent_at = None;
    let mut after_bad = 0;
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(60) && !(received.len() >= 15 && after_bad >= 5) {
        if let Some(m) = tf.take() {
            cam = cam.or_else(|| m.transforms.iter().find(|t| t.child_frame_id == FRAME).and_then(fded_distance::isometry));
        }
        if let Some(js) = joints.take_latest() {
            q = Some(js.position.clone());
        }
        if let Some(info) = infos.take_latest() {
            k = Intrinsics::from_camera_info(&info).ok();
        }
        while let Some(img) = images.take() {
            if img.encoding == "32FC1" && seen.len() < 2000 {
                seen.insert((img.header.stamp.sec, img.header.stamp.nanosec), img);
            }
        }
        while let Some(m) = distances.take() {
            if bad_sent_at.is_some() {
                after_bad += 1;
            }
            received.push(m);
        }
        while let Some(ma) = markers.take() {
            marker_arrays += 1;
            // Match with its result by stamp: the closest link's segment joins its points.
            let stamp = ma.markers.first().map(|mk| mk.header.stamp);
            if let Some(r) = received.iter().rev().find(|r| Some(r.header.stamp) == stamp)
                && r.min_index >= 0
            {
                let l = &r.links[r.min_index as usize];
                let seg = ma
                    .markers
                    .iter()
                    .find(|mk| mk.ns == fded_distance::markers::NS_SEGMENT && mk.id == r.min_index)
                    .expect("segment marker of the closest link");
                assert_eq!(seg.points, vec![l.robot_point, l.obstacle_point]);
                marker_checked += 1;
            }
        }
        // Once results flow, bad frames: an unknown encoding, a wrong size, truncated data.
        if received.len() >= 5 && bad_sent_at.is_none() {
            let good = seen.values().next().cloned().expect("an image was seen");
            let mut rgb = good.clone();
            rgb.encoding = "bgr8".into();
            let small = DepthImage::new(32, 24).to_image_msg(good.header.stamp, FRAME, Encoding::F32Metres);
            let mut short = good.clone();
            short.data.truncate(100);
            for bad in [rgb, small, short] {
                bad_images.publish(bad).expect("publish");
            }
            bad_sent_at = Some(Instant::now());
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    stop.store(true, Ordering::SeqCst);
    let summary = handle.join().expect("node thread").expect("node ran cleanly");
    assert!(summary.frames >= received.len() as u64, "{summary:?} but {} results received", received.len());

    let (cam, q, k) = (cam.expect("lwr_sim's /tf_static camera"), q.expect("joint states"), k.expect("camera info"));
    assert!(received.len() >= 15, "only {} results in 60 s", received.len());
    assert!(after_bad >= 5, "only {after_bad} results after the bad frames: the node must go on");
    let backend = received[0].backend.clone();
    assert!(backend == "wgpu" || backend == "cpu", "backend {backend:?}");
    // Each result against the library on the very frame it came from (the robot stands still).
    let mut checked = 0;
    let mut reference_fded = Fded::new(&model, &k, FdedParams::default()).expect("fded");
    let mut out = reference_fded.new_output();
    let mut depth = DepthImage::default();
    for m in &received {
        assert_eq!(m.backend, backend);
        assert!(m.processing_time > 0.0);
        let Some(img) = seen.get(&(m.header.stamp.sec, m.header.stamp.nanosec)) else { continue };
        depth.read_image_msg(img).expect("lwr_sim image decodes");
        let frame = Frame { stamp: m.header.stamp.to_secs_f64(), depth: &depth, camera_pose: &cam, joints: Some(q.as_slice()) };
        reference_fded.process(&frame, &mut out).expect("reference frame");
        assert_eq!(m.min_index, out.closest.map_or(-1, |i| i as i32), "global minimum link");
        for (got, want) in m.links.iter().zip(&out.links) {
            assert_eq!(got.valid, want.valid, "link {} validity", got.link_name);
            if want.valid {
                assert!((got.distance - want.distance).abs() <= 1e-3, "link {}: {} vs {}", got.link_name, got.distance, want.distance);
            }
        }
        checked += 1;
    }
    assert!(checked >= 5, "only {checked} results could be matched to their frames");
    assert!(marker_arrays >= 10, "only {marker_arrays} marker arrays on /fded/markers");
    assert!(marker_checked >= 1, "no marker array matched a result with an obstacle in view");
    let mut times: Vec<f64> = received.iter().map(|m| m.processing_time).collect();
    times.sort_by(f64::total_cmp);
    let min = &received[received.len() - 1];
    eprintln!(
        "over DDS beside lwr_sim: {summary:?}; {} results ({after_bad} after 3 bad frames), {checked} checked against the library, backend {backend}, processing median {:.2} ms, max {:.2} ms; last global minimum {}",
        received.len(),
        times[times.len() / 2] * 1e3,
        times[times.len() - 1] * 1e3,
        if min.min_index >= 0 { format!("{:.4} m ({})", min.links[min.min_index as usize].distance, min.links[min.min_index as usize].link_name) } else { "none".into() },
    );
}

/// A flood of `/tf_static` child frames stops at the bound with a warning; known frames keep
/// updating and the real camera keeps working.
#[test]
fn camera_frames_from_tf_static_are_bounded() {
    let model = model();
    let (cam, _) = kitchen_camera();
    let mut node = FdedNode::new(model.clone(), params()).expect("node");
    let base = model.link_names()[0].clone();
    node.on_tf_static(&tf_static(&base, &cam)).expect("the camera");
    let mut refused = 0;
    for i in 0..1000 {
        let mut m = tf_static(&base, &cam);
        m.transforms[0].child_frame_id = format!("stranger_{i}");
        if let Err(s) = node.on_tf_static(&m) {
            assert!(s.message.contains("already 64 frames known"), "{}", s.message);
            refused += 1;
        }
    }
    assert_eq!(refused, 1000 - (fded_distance::MAX_CAMERA_FRAMES - 1));
    node.on_tf_static(&tf_static(&base, &cam)).expect("a known frame still updates");
}

#[test]
fn method_flacco_gives_sphere_distances_with_points_and_normals() {
    let model = model();
    let (cam, k) = kitchen_camera();
    let mut p = params();
    p.method = "flacco".into();
    let mut node = FdedNode::new(model.clone(), p).expect("node");
    node.on_camera_info(&k.to_camera_info(Time::default(), FRAME)).expect("camera info");
    node.on_joint_state(&joint_state(&model, &Q, Time::from_secs_f64(1.0))).expect("joint state");
    node.on_tf_static(&tf_static(&model.link_names()[0], &cam)).expect("tf_static");
    // Flacco et al. skip depths outside 1.8–3.5 m: a sphere beside the robot, ~1.9 m away.
    let centre = Point3::new(0.05, 0.3, 0.5);
    let img = render(&model, &k, &cam, &Q, centre, 0.08);
    let got = node.on_depth(&img.to_image_msg(Time::from_secs_f64(1.0), FRAME, Encoding::F32Metres)).expect("frame").clone();
    assert_eq!(got.backend, "spheres");
    assert_eq!(got.links.len(), model.link_count(), "one entry per link");
    assert!(got.min_index >= 0);
    let m = &got.links[got.min_index as usize];
    assert!(m.valid && m.distance.is_finite());
    // The spheres (r = 0.12 m) are fatter than the links: never further than fDED's distance.
    let want = reference(&model, &k, &cam, &Q, &img);
    assert!(m.distance <= want + 1e-3, "Flacco {} vs fDED {want}", m.distance);
    // The obstacle point lies on the sphere obstacle (r = 0.08).
    let o = Point3::new(m.obstacle_point.x, m.obstacle_point.y, m.obstacle_point.z);
    assert!(((o - centre).norm() - 0.08).abs() < 0.01, "obstacle point {o}");
    let n = nalgebra::Vector3::new(m.normal.x, m.normal.y, m.normal.z);
    assert!((n.norm() - 1.0).abs() < 1e-9);
    let r = Point3::new(m.robot_point.x, m.robot_point.y, m.robot_point.z);
    assert!(((r - o).norm() - m.distance).abs() < 1e-6 || m.distance == 0.0, "robot point {r} at the distance");
    // Nothing in range: every link invalid (no obstacle), not the 0.5 m default.
    let far = img.to_image_msg(Time::from_secs_f64(1.1), FRAME, Encoding::F32Metres);
    let far = Image { data: 9.5f32.to_le_bytes().repeat((k.width * k.height) as usize), ..far };
    let none = node.on_depth(&far).expect("far wall").clone();
    assert!(none.links.iter().all(|l| !l.valid) && none.min_index == -1);
    let mut bad = params();
    bad.method = "spheres".into();
    assert!(bad.validate("x").unwrap_err().to_string().contains("fded or flacco"));
}

/// Golden file: a scripted stream through the node's inbox and handlers
/// ([`fded_distance::run_scripted`]): a frame before any camera info, bad intrinsics, a
/// NaN joint state, a bad transform, then good frames with a sphere approaching the arm, an
/// unknown encoding and a blind frame; every output summarised one JSON per line and compared
/// with `tests/golden/fded.jsonl` (`UPDATE_GOLDEN=1` rewrites it).
#[test]
fn scripted_stream_gives_the_golden_outputs() {
    use cowork_testkit::{ScriptedSource, assert_golden};
    use fded_distance::{Input, Output};
    use serde_json::json;

    let model = model();
    let (cam, k) = kitchen_camera();
    let mut p = params();
    p.publish_markers = true;
    // The CPU path: the golden distances must not depend on which adapter a machine has.
    p.backend = "cpu".into();
    let mut node = FdedNode::new(model.clone(), p).expect("node");
    let frame = |t: f64, x: f64| render(&model, &k, &cam, &Q, Point3::new(x, 0.0, 0.75), 0.08).to_image_msg(Time::from_secs_f64(t), FRAME, Encoding::F32Metres);
    let mut bad_info = k.to_camera_info(Time::default(), FRAME);
    bad_info.k[0] = f64::NAN;
    let mut nan_joints = joint_state(&model, &Q, Time::from_secs_f64(0.2));
    nan_joints.position[3] = f64::NAN;
    let mut bad_tf = tf_static(&model.link_names()[0], &cam);
    bad_tf.transforms[0].transform.rotation.w = f64::NAN;
    let mut script = vec![
        (0.10, Input::Depth(frame(0.1, 0.9))),
        (0.15, Input::CameraInfo(bad_info)),
        (0.20, Input::JointState(nan_joints)),
        (0.25, Input::TfStatic(bad_tf)),
        (0.30, Input::CameraInfo(k.to_camera_info(Time::default(), FRAME))),
        (0.31, Input::TfStatic(tf_static(&model.link_names()[0], &cam))),
    ];
    for (i, x) in [0.95, 0.9, 0.85, 0.8].into_iter().enumerate() {
        let t = 0.4 + 0.1 * i as f64;
        script.push((t - 0.01, Input::JointState(joint_state(&model, &Q, Time::from_secs_f64(t)))));
        script.push((t, Input::Depth(frame(t, x))));
    }
    let mut rgb = frame(0.9, 0.8);
    rgb.encoding = "rgb8".into();
    script.push((0.9, Input::Depth(rgb)));
    let blind = Image { data: f32::NAN.to_le_bytes().repeat((k.width * k.height) as usize), ..frame(1.0, 0.8) };
    script.push((1.0, Input::Depth(blind)));
    let mut source = ScriptedSource::new(script, 1.1);

    let mut lines = Vec::new();
    let summary = fded_distance::run_scripted(&mut source, &mut node, &mut |out| {
        lines.push(
            match out {
                Output::Distances(d) => {
                    let m = &d.links[d.min_index.max(0) as usize];
                    json!({ "distances": d.header.stamp.to_secs_f64(), "min_link": m.link_name, "min_mm": (m.distance * 1e3).round(), "valid": d.links.iter().filter(|l| l.valid).count() })
                }
                Output::Markers(m) => json!({ "markers": m.markers.len() }),
                Output::Warning(w) => json!({ "warning": w.kind, "message": w.message }),
            }
            .to_string(),
        );
    });
    assert_eq!(summary.frames, 4, "the four good frames");
    let text = lines.join("\n");
    for kind in ["no_camera_info", "camera_info", "joint_state", "tf_static", "image", "blind"] {
        assert!(text.contains(&format!("\"warning\":\"{kind}\"")), "{kind} missing:\n{text}");
    }
    assert_golden(&PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden/fded.jsonl"), &lines);
}
