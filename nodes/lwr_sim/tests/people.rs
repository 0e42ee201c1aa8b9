//! People in the simulated depth camera: a `/human/skeleton` message puts a capsule body on the
//! floor of the rendered image; it disappears after the timeout; bad skeletons change nothing.

use cowork_depth::Label;
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::sensor_msgs::{CameraInfo, Image};
use cowork_people::{Action, BodySize, MessageMeta, Performer, Stance};
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use lwr_sim::depth::{DepthCamera, DepthSnapshot};
use lwr_sim::{LwrSim, LwrSimConfig};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn node() -> (LwrSim, LwrSimConfig) {
    let mut config: LwrSimConfig =
        cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").expect("bundled parameters load");
    config.depth.noise = false;
    config.validate("lwr_sim.yaml").unwrap();
    let model = RobotModel::from_urdf_file(&root().join("config/robot/lwr4plus.urdf")).unwrap();
    let scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).unwrap();
    (LwrSim::new(Simulator::new(model, scene, config.simulation.clone()).unwrap(), config.clone()), config)
}

/// A tall person standing behind the robot, facing the camera.
fn skeleton(t: f64) -> Skeleton {
    let p = Performer::new(7, BodySize::TALL, Stance::new(-0.6, -0.4, 0.0), 3)
        .unwrap()
        .then(Action::Stand { duration: 5.0 })
        .unwrap();
    p.pose(t).to_message(&MessageMeta {
        stamp: Time::from_nanos((t * 1e9) as i64),
        frame_id: "lwr_base_link",
        source: Skeleton::SOURCE_XSENS,
        person_id: 7,
        with_velocities: true,
    })
}

/// Pixels per label kind of one noise-free frame of the node's current state.
fn render(lwr: &LwrSim, config: &LwrSimConfig) -> (usize, usize) {
    let mut camera = DepthCamera::new(lwr.simulator(), &config.depth).unwrap();
    let mut snap = DepthSnapshot::default();
    snap.capture(lwr.simulator(), lwr.people());
    camera.render(&snap, &mut Image::default(), &mut CameraInfo::default()).unwrap();
    let labels = camera.renderer().labels();
    let person = labels.iter().filter(|l| matches!(l, Label::Person(_))).count();
    let floor = labels.iter().filter(|l| **l == Label::Floor).count();
    (person, floor)
}

#[test]
fn a_skeleton_puts_a_person_in_the_depth_image_until_it_times_out() {
    let (mut lwr, config) = node();
    let (person, floor) = render(&lwr, &config);
    assert_eq!(person, 0);
    assert!(floor > 10_000, "the floor is seen around the table: {floor} px");

    assert_eq!(lwr.on_skeleton(&skeleton(1.0)), None);
    assert_eq!(lwr.people().ids().collect::<Vec<_>>(), [7]);
    let (person, floor_with) = render(&lwr, &config);
    assert!(person > 3_000, "person pixels: {person}");
    assert!(floor_with < floor, "the person hides some floor");

    // A malformed skeleton (no head) is refused; the person stays as last seen.
    let mut bad = skeleton(1.1);
    let head = bad.segment_names.iter().position(|n| n == "head").unwrap();
    bad.segment_names.remove(head);
    bad.poses.remove(head);
    bad.velocities.remove(head);
    let refused = lwr.on_skeleton(&bad).expect("a malformed skeleton is refused with a warning");
    assert_eq!(refused.kind, "/human/skeleton:frame");
    assert!(refused.message.contains("person 7"), "{}", refused.message);
    assert_eq!(lwr.people().rejected(), 1);
    assert_eq!(render(&lwr, &config).0, person);

    // No message for longer than the timeout: gone.
    let steps = (config.depth.person_timeout_s / config.simulation.step_s) as usize + 2;
    for _ in 0..steps {
        lwr.step();
    }
    assert_eq!(lwr.people().ids().count(), 0);
    assert_eq!(render(&lwr, &config).0, 0);
}

#[test]
fn depth_parameters_are_checked() {
    let (_, mut config) = node();
    config.depth.floor_height_m = f64::NAN;
    let e = config.validate("lwr_sim.yaml").unwrap_err().to_string();
    assert!(e.contains("depth.floor_height_m"), "{e}");
    config.depth.floor_height_m = -0.75;
    config.depth.person_timeout_s = 0.0;
    let e = config.validate("lwr_sim.yaml").unwrap_err().to_string();
    assert!(e.contains("depth.person_timeout_s"), "{e}");
}
