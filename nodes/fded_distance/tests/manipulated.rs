//! The manipulated object is not an obstacle (node handlers, no network): a kitchen frame
//! rendered by lwr_sim's camera with the bottle 3 cm under the tool and the cup beside it.
//! Without a `/manipulated_objects` list the bottle is the closest obstacle; a fresh list
//! naming it removes exactly its pixels, so the cup becomes the closest; a stale list, a name
//! with no shape, a bad list or a list in another frame remove nothing (fail closed).

use cowork_msgs::msg::{LinkDistances, ObjectState, ObjectStream, WorldState};
use cowork_msgs::sensor_msgs::{CameraInfo, Image};
use cowork_robot::RobotModel;
use cowork_sim::{Scene, Simulator};
use fded_distance::{FdedNode, Params};
use lwr_sim::LwrSim;
use nalgebra::{Point3, Vector3};

mod common;

use common::{model, rendered, root};

fn params() -> Params {
    let mut p: Params =
        cowork_ros::params::load(&root().join("config/fded_distance.yaml"), "fded_distance").expect("bundled parameters");
    p.urdf = root().join("config/robot/lwr4plus.urdf").display().to_string();
    p.manipulated.scene = root().join("config/scenes/kitchen.yaml").display().to_string();
    p.backend = "cpu".into();
    p
}

struct Setup {
    lwr: LwrSim,
    image: Image,
    info: CameraInfo,
    bottle: Point3<f64>,
    cup: Point3<f64>,
}

/// The kitchen with the bottle (r 0.035, h 0.22) 3 cm under the tool point and the cup
/// (r 0.04, h 0.10) 0.2 m beside it; one noise-free frame at 0.05 s.
fn setup() -> Setup {
    let mut scene = Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
    let tool = Simulator::new(model(), scene.clone(), cowork_sim::SimParams::default()).expect("sim").tool_pose().translation.vector;
    let bottle = Point3::new(tool.x, tool.y, tool.z - 0.03 - 0.11);
    let cup = Point3::new(tool.x, tool.y + 0.2, tool.z - 0.05);
    for o in &mut scene.objects {
        match o.name.as_str() {
            "bottle" => o.pose.position = bottle.coords.into(),
            "cup" => o.pose.position = cup.coords.into(),
            _ => {}
        }
    }
    let (lwr, image, info) = rendered(scene);
    Setup { lwr, image, info, bottle, cup }
}

fn node(s: &mut Setup) -> FdedNode {
    let mut node = FdedNode::new(model(), params()).expect("node");
    node.on_camera_info(&s.info).expect("camera info");
    node.on_joint_state(&s.lwr.joint_states(0)).expect("joint state");
    node.on_tf_static(&s.lwr.tf_static()).expect("tf_static");
    node
}

/// The list robot_manager would send with these objects of `world`.
fn list(world: &WorldState, names: &[&str]) -> ObjectStream {
    ObjectStream {
        header: world.header.clone(),
        objects: names
            .iter()
            .map(|n| {
                let pose = world.objects.iter().find(|o| o.name == *n).map_or_else(|| world.tool_pose, |o| o.pose);
                ObjectState { name: (*n).to_owned(), pose, robot_distance: 0.0, visible: true }
            })
            .collect(),
    }
}

/// Distance of `p` from a vertical cylinder's surface region (axis distance − r, height).
fn near_cylinder(p: &Point3<f64>, centre: &Point3<f64>, r: f64, h: f64, tol: f64) -> bool {
    let d = p - centre;
    Vector3::new(d.x, d.y, 0.0).norm() <= r + tol && d.z.abs() <= h / 2.0 + tol
}

/// The closest obstacle of the hand (the last two links): what the end-effector modulation
/// reacts to. (The base links see the occluded space behind the bottle, eq. 5.17.)
fn closest(msg: &LinkDistances) -> (f64, Point3<f64>) {
    let l = msg
        .links
        .iter()
        .filter(|l| l.valid && matches!(l.link_name.as_str(), "lwr_link_6" | "lwr_link_7" | "lwr_ee_link"))
        .min_by(|a, b| a.distance.total_cmp(&b.distance))
        .expect("the hand sees an obstacle");
    (l.distance, Point3::new(l.obstacle_point.x, l.obstacle_point.y, l.obstacle_point.z))
}

#[test]
fn the_manipulated_object_is_removed_and_everything_else_stays() {
    let mut s = setup();
    let mut node = node(&mut s);
    let world = s.lwr.world(0);
    let t = world.header.stamp.to_secs_f64();
    assert!((s.image.header.stamp.to_secs_f64() - t).abs() < 1e-9, "frame and world at the same time");

    // No list: the bottle under the tool is the closest obstacle.
    let (d0, p0) = closest(&node.on_depth(&s.image).expect("frame").clone());
    assert!(d0 < 0.08, "the bottle 3 cm under the tool: {d0}");
    assert!(near_cylinder(&p0, &s.bottle, 0.035, 0.22, 0.02), "closest point {p0} on the bottle");
    assert!(node.removed().objects.is_empty() && node.removed().pixels == 0);
    assert!(node.take_notice().is_none());

    // A list 0.5 s older than the frame: stale, nothing removed, said so.
    let mut old = list(&world, &["bottle"]);
    old.header.stamp = cowork_msgs::builtin_interfaces::Time::from_secs_f64(t - 0.5);
    node.on_manipulated(&old).expect("a good list");
    let (d, _) = closest(&node.on_depth(&s.image).expect("frame").clone());
    assert_eq!(d, d0);
    assert_eq!(node.removed().pixels, 0);
    let n = node.take_notice().expect("stale notice");
    assert_eq!(n.kind, "manipulated_stale", "{n:?}");

    // A fresh list naming an object with no shape: it stays an obstacle, said so.
    node.on_manipulated(&list(&world, &["teapot"])).expect("a good list");
    let (d, _) = closest(&node.on_depth(&s.image).expect("frame").clone());
    assert_eq!(d, d0);
    let n = node.take_notice().expect("unknown-object notice");
    assert!(n.kind == "manipulated_object" && n.message.contains("teapot") && n.message.contains("bottle"), "{n:?}");

    // A list with a NaN pose is refused and clears what was known; one in another frame too.
    let mut bad = list(&world, &["bottle"]);
    bad.objects[0].pose.position.x = f64::NAN;
    assert_eq!(node.on_manipulated(&bad).expect_err("NaN pose").kind, "manipulated");
    let (d, _) = closest(&node.on_depth(&s.image).expect("frame").clone());
    assert_eq!(d, d0, "the teapot list was cleared, nothing removed, no notice");
    let mut other = list(&world, &["bottle"]);
    other.header.frame_id = "camera_depth_optical_frame".into();
    let e = node.on_manipulated(&other).expect_err("wrong frame");
    assert!(e.message.contains("camera_depth_optical_frame"), "{e:?}");
    let (d, _) = closest(&node.on_depth(&s.image).expect("frame").clone());
    assert_eq!(d, d0);
    let too_many = list(&world, &["bottle"; 9]);
    assert!(node.on_manipulated(&too_many).is_err());

    // A fresh list naming the bottle: its pixels go, the cup is now the closest obstacle.
    node.on_manipulated(&list(&world, &["bottle"])).expect("a good list");
    let msg = node.on_depth(&s.image).expect("frame").clone();
    assert_eq!(node.removed().objects, vec!["bottle".to_owned()]);
    assert!(node.removed().pixels > 200, "{} bottle pixels removed", node.removed().pixels);
    let (d1, p1) = closest(&msg);
    assert!(d1 > d0 + 0.05, "without the bottle the closest obstacle is further: {d0} -> {d1}");
    // On the cup or in the space it hides from the camera (x towards the robot, same y).
    assert!((p1.y - s.cup.y).abs() < 0.06 && p1.z > s.cup.z - 0.08, "closest point {p1} by the cup {} (d {d1})", s.cup);
    for l in msg.links.iter().filter(|l| l.valid && !matches!(l.link_name.as_str(), "lwr_base_link" | "lwr_link_1")) {
        let p = Point3::new(l.obstacle_point.x, l.obstacle_point.y, l.obstacle_point.z);
        assert!(!near_cylinder(&p, &s.bottle, 0.035, 0.22, 0.02), "{}: obstacle point {p} on the bottle", l.link_name);
    }

    // Both the bottle and the cup manipulated (held bottle, pour over the cup): neither is
    // the closest obstacle any more.
    node.on_manipulated(&list(&world, &["bottle", "cup"])).expect("a good list");
    let msg = node.on_depth(&s.image).expect("frame").clone();
    assert_eq!(node.removed().objects.len(), 2);
    let (d2, p2) = closest(&msg);
    assert!(d2 > d1, "{d1} -> {d2}");
    assert!((p2.y - s.cup.y).abs() > 0.06, "{p2}");
}

#[test]
fn disabled_or_without_shapes_nothing_is_removed() {
    let mut s = setup();
    let world = s.lwr.world(0);
    for p in [
        Params { manipulated: fded_distance::ManipulatedParams { enabled: false, ..params().manipulated }, ..params() },
        Params { manipulated: fded_distance::ManipulatedParams { scene: String::new(), ..params().manipulated }, ..params() },
    ] {
        let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF");
        let mut node = FdedNode::new(model, p).expect("node");
        node.on_camera_info(&s.info).expect("camera info");
        node.on_joint_state(&s.lwr.joint_states(0)).expect("joint state");
        node.on_tf_static(&s.lwr.tf_static()).expect("tf_static");
        node.on_manipulated(&list(&world, &["bottle"])).expect("accepted");
        let (d, p) = closest(&node.on_depth(&s.image).expect("frame").clone());
        assert!(d < 0.08 && near_cylinder(&p, &s.bottle, 0.035, 0.22, 0.02), "{d} {p}");
        assert_eq!(node.removed().pixels, 0);
    }
    // A scene file that does not load is a start-up error naming the parameter.
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("URDF");
    let p = Params { manipulated: fded_distance::ManipulatedParams { scene: "/nonexistent.yaml".into(), ..params().manipulated }, ..params() };
    let e = FdedNode::new(model, p).expect_err("missing scene");
    assert!(format!("{e:#}").contains("manipulated.scene"), "{e:#}");
    let _ = &mut s;
}
