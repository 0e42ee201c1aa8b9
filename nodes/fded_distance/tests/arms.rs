//! An arm of a two-arm scene (config/scenes/pizza.yaml, node handlers, no network): the
//! fded_distance of the left arm, started in namespace `/left`, finds the camera beside its base
//! under `world` on lwr_sim's `/tf_static`, takes the table as level in the world (the base's z
//! points out of the shoulder, not up), and sees the right arm as an obstacle. Before, the
//! table plane was z = 0 of the base frame: every point with world y below the shoulder was
//! "table", the right arm included, and the camera pose was only read from a direct edge.

use cowork_robot::LinkPoses;
use cowork_sim::{ArmHulls, Scene};
use fded_distance::{FdedNode, Params};
use nalgebra::Point3;

mod common;

use common::{model, rendered, root};

#[test]
fn the_left_arms_fded_sees_the_right_arm_and_not_the_table() {
    let model = model();
    let scene = Scene::from_file(&root().join("config/scenes/pizza.yaml")).expect("scene");
    let (mut lwr, image, info) = rendered(scene);

    // The left arm's node, with the bundled /left/fded_distance block.
    let text = std::fs::read_to_string(root().join("config/fded_distance.yaml")).expect("params");
    let mut params: Params = cowork_ros::params::from_str_in(&text, "fded_distance", Some("/left"), "fded_distance.yaml").expect("/left block");
    params.urdf = root().join("config/robot/lwr4plus.urdf").display().to_string();
    params.manipulated.scene = root().join("config/scenes/pizza.yaml").display().to_string();
    params.backend = "cpu".into();
    // A wrong fallback camera pose: the right one must come from /tf_static.
    params.camera_pose.position = [5.0, 5.0, 5.0];
    let mut node = FdedNode::new(model.clone(), params).expect("node");
    node.set_frame_prefix("left/");
    assert_eq!(node.base_frame(), "left/lwr_base_link");
    node.on_camera_info(&info).expect("camera info");
    node.on_joint_state(&lwr.joint_states(0)).expect("joint state");
    node.on_tf_static(&lwr.tf_static()).expect("tf_static");
    let msg = node.on_depth(&image).expect("frame").clone();
    assert_eq!(msg.header.frame_id, "left/lwr_base_link");

    let sim = lwr.simulator();
    let left_base = *sim.arm(0).base();
    let right = sim.arm(1);
    let hulls = ArmHulls::new(&model);
    let mut right_poses = LinkPoses::new();
    model.forward_kinematics(right.joint_positions(), &mut right_poses);
    let (mut on_right_arm, mut on_table) = (Vec::new(), Vec::new());
    for l in msg.links.iter().filter(|l| l.valid) {
        let o = &l.obstacle_point;
        let world = left_base * Point3::new(o.x, o.y, o.z);
        if hulls.distance_to_point(right.base(), &right_poses, &world) < 0.03 {
            on_right_arm.push((l.link_name.clone(), l.distance));
        }
        // Table points (z ≤ 0 of the world) are never obstacles; objects stand on it, so a
        // point may lie just above (margin 3 cm).
        if world.z < 0.0 {
            on_table.push((l.link_name.clone(), world));
        }
    }
    assert!(!on_right_arm.is_empty(), "no closest point of the left arm's links lies on the right arm: {:?}", msg.links);
    assert!(on_right_arm.iter().all(|(_, d)| *d > 0.1 && *d < 0.6), "{on_right_arm:?}");
    assert!(on_table.is_empty(), "table points taken as obstacles: {on_table:?}");
}
