//! lwr_sim's depth camera over DDS: frames arrive on `/camera/depth/image_raw` with their
//! `/camera/depth/camera_info`, robot pixels sit at the depth forward kinematics puts them, and
//! the camera frame is on `/tf_static`.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use cowork_depth::{DepthImage, DepthRenderer, Intrinsics, Label, Layers};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use cowork_msgs::topics;
use cowork_ros::{NodeConfig, RosNode, Subscription};
use cowork_sim::{Scene, Simulator};
use lwr_sim::{LwrSim, LwrSimConfig, Pacing};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn private_domain() -> u16 {
    cowork_ros::domain::test_domain("lwr_sim depth test")
}

fn start_sim(domain: u16, config: LwrSimConfig, seconds: f64) -> std::thread::JoinHandle<anyhow::Result<()>> {
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).unwrap();
    let scene = Scene::from_file(&root().join("config/scenes/stacking.yaml")).unwrap();
    let sim = Simulator::new(model, scene, config.simulation.clone()).unwrap();
    let node = RosNode::new("lwr_sim", &NodeConfig { domain_id: Some(domain), ..Default::default() }).unwrap();
    std::thread::spawn(move || lwr_sim::run(node, LwrSim::new(sim, config), Pacing::Rate(1.0), Some(seconds)))
}

fn config(noise: bool, encoding: &str) -> LwrSimConfig {
    let mut c: LwrSimConfig = cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").unwrap();
    c.depth.enabled = true;
    c.depth.noise = noise;
    c.depth.encoding = encoding.into();
    c.validate("test").unwrap();
    c
}

fn wait<T: cowork_msgs::RosMessage>(sub: &Subscription<T>, timeout: Duration) -> Option<T> {
    let deadline = Instant::now() + timeout;
    while Instant::now() < deadline {
        if let Some(m) = sub.take_latest() {
            return Some(m);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    None
}

/// The noise-free frame of the stacking scene at its start joints, rendered here (with the
/// node's default floor).
fn local_render() -> (DepthRenderer, DepthImage, JointVector, Scene) {
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).unwrap();
    let scene = Scene::from_file(&root().join("config/scenes/stacking.yaml")).unwrap();
    let q = JointVector::from_iterator(scene.initial_joints_deg().iter().map(|d| d.to_radians()));
    let objects: Vec<_> = scene.objects.iter().map(|o| (o.shape, o.pose.isometry())).collect();
    let mut r = DepthRenderer::new(&model, &scene).unwrap();
    let depth = lwr_sim::depth::DepthConfig::default();
    r.set_floor(Some(cowork_depth::Floor::at(depth.floor_height_m))).unwrap();
    let mut out = DepthImage::default();
    r.render(&q, &objects, &[], &mut out).unwrap();
    (r, out, q, scene)
}

#[test]
fn depth_frames_show_the_robot_where_forward_kinematics_puts_it() {
    let domain = private_domain();
    let sim = start_sim(domain, config(false, "32FC1"), 6.0);
    let mut client = RosNode::new("depth_client", &NodeConfig { domain_id: Some(domain), ..Default::default() }).unwrap();
    let images = client.subscribe(&topics::DEPTH_IMAGE).unwrap();
    let infos = client.subscribe(&topics::DEPTH_CAMERA_INFO).unwrap();
    let tf_static = client.subscribe(&topics::TF_STATIC).unwrap();

    let image = wait(&images, Duration::from_secs(15)).expect("a depth frame arrives over DDS");
    let info = wait(&infos, Duration::from_secs(5)).expect("camera info arrives");
    let (local, expected, q, scene) = local_render();

    assert_eq!(image.encoding, "32FC1");
    assert_eq!(image.header.frame_id, scene.camera.frame_id);
    assert_eq!(info.header.frame_id, scene.camera.frame_id);
    let k = Intrinsics::from_camera_info(&info).unwrap();
    assert_eq!(k, *local.intrinsics());
    let statics = wait(&tf_static, Duration::from_secs(5)).expect("/tf_static arrives");
    let cam_tf = statics
        .transforms
        .iter()
        .find(|t| t.child_frame_id == scene.camera.frame_id)
        .expect("the camera's optical frame is on /tf_static");
    let p = scene.camera.pose.isometry().translation.vector;
    let t = &cam_tf.transform.translation;
    assert!((t.x - p.x).abs() + (t.y - p.y).abs() + (t.z - p.z).abs() < 1e-9);

    // The robot has not moved: the frame equals the local noise-free render exactly.
    let got = DepthImage::from_image_msg(&image).unwrap();
    assert_eq!(got.data.len(), expected.data.len());
    let differing = got.data.iter().zip(&expected.data).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "pixels differ from the local render");

    // Robot pixels against forward kinematics: the mesh vertex of each link nearest the
    // camera projects onto a pixel of that link whose depth is the vertex's depth.
    let model = local.model();
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let cam = local.camera_pose().inverse();
    let mut checked = 0;
    for link in 0..model.link_count() {
        let Some(mesh) = model.link_mesh(link) else { continue };
        let nearest = mesh
            .vertices
            .iter()
            .map(|v| cam * (poses.get(link) * v))
            .min_by(|a, b| a.z.total_cmp(&b.z))
            .unwrap();
        let Some((u, v, z)) = k.project(&nearest) else { continue };
        let (x, y) = k.pixel(u, v).unwrap();
        let i = (y * k.width + x) as usize;
        if local.labels()[i] != Label::Link(link as u16) {
            continue; // hidden by another link
        }
        let d = f64::from(got.data[i]);
        assert!((d - z).abs() < 0.01, "link {link}: depth {d} m at FK vertex depth {z} m");
        checked += 1;
    }
    assert!(checked >= 3, "only {checked} links checked (the others hide behind nearer links)");
    let robot = local.labels().iter().filter(|l| l.is_robot()).count();
    assert!(robot > 5000, "{robot} robot pixels");

    // A robot-only render (fDED's virtual depth) is a subset of the frame.
    let mut virt = DepthRenderer::new(model, &scene).unwrap();
    virt.set_layers(Layers::robot_only());
    let mut vd = DepthImage::default();
    virt.render(&q, &[] as &[(cowork_sim::Shape, nalgebra::Isometry3<f64>)], &[], &mut vd).unwrap();
    for (i, l) in local.labels().iter().enumerate() {
        if l.is_robot() {
            assert_eq!(vd.data[i], got.data[i]);
        }
    }
    sim.join().unwrap().unwrap();
}

#[test]
fn noisy_16uc1_frames_arrive_at_the_camera_rate() {
    let domain = private_domain();
    let sim = start_sim(domain, config(true, "16UC1"), 6.0);
    let mut client = RosNode::new("depth_client", &NodeConfig { domain_id: Some(domain), ..Default::default() }).unwrap();
    let images = client.subscribe(&topics::DEPTH_IMAGE).unwrap();
    let first = wait(&images, Duration::from_secs(15)).expect("a depth frame arrives over DDS");
    assert_eq!(first.encoding, "16UC1");
    // Frames over 2 s of (real-time paced) simulated time: each is stamped on the camera's
    // 30 Hz grid (frame k at the first 1 ms step at or after k/30 s). How many arrive depends
    // on how fast this build renders (frames are dropped, never queued), so only a floor.
    let t0 = Instant::now();
    let mut stamps = vec![first.header.stamp.to_nanos()];
    let mut last = first;
    while t0.elapsed() < Duration::from_secs(2) {
        while let Some(m) = images.take() {
            stamps.push(m.header.stamp.to_nanos());
            last = m;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    assert!(stamps.len() >= 5, "{} frames in 2 s", stamps.len());
    assert!(stamps.windows(2).all(|w| w[1] > w[0]), "stamps increase: {stamps:?}");
    let period = 1e9 / 30.0;
    for s in &stamps {
        // The newest frame time at or before the stamp is at most one 1 ms step earlier.
        let due = ((*s as f64 / period).floor() * period).round() as i64;
        assert!(s - due <= 1_000_000, "stamp {s} ns is not on the 30 Hz grid (frame due at {due} ns)");
    }

    let got = DepthImage::from_image_msg(&last).unwrap();
    let (_, clean, _, _) = local_render();
    let both: Vec<f32> = got
        .data
        .iter()
        .zip(&clean.data)
        .filter(|(a, b)| **a > 0.0 && **b > 0.0)
        .map(|(a, b)| (a - b).abs())
        .collect();
    assert!(both.len() > clean.valid_count() * 8 / 10, "most pixels have a return");
    let mut sorted = both.clone();
    sorted.sort_by(f32::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!(median > 0.0 && median < 0.01, "median |noisy − clean| = {median} m");
    sim.join().unwrap().unwrap();
}
