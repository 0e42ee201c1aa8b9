//! The 1 kHz simulator step allocates nothing: integration, limits, FK, admittance, held object.

use cowork_robot::RobotModel;
use cowork_sim::{Scene, SimParams, Simulator, Wrench};
use nalgebra::Vector3;

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

#[test]
fn ten_thousand_steps_allocate_nothing() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..");
    let model = RobotModel::from_urdf_file(root.join("config/robot/lwr4plus.urdf")).unwrap();
    let mut scene = Scene::from_file(&root.join("config/scenes/kitchen.yaml")).unwrap();
    let mut sim = Simulator::new(model.clone(), scene.clone(), SimParams::default()).unwrap();
    // Put the cup in the gripper so the held-object path runs too.
    let tool = sim.tool_pose().translation.vector;
    scene.objects.iter_mut().find(|o| o.name == "cup").unwrap().pose.position = [tool.x, tool.y, tool.z - 0.07];
    let mut sim_holding = Simulator::new(model, scene, SimParams::default()).unwrap();
    assert_eq!(sim_holding.command_gripper(true), Some("cup"));

    // The counter sees allocations at all.
    let before = cowork_testkit::allocations();
    drop(std::hint::black_box(vec![1u8; 16]));
    assert!(cowork_testkit::allocations() > before);

    let before = cowork_testkit::allocations();
    for i in 0..10_000 {
        let s = (i as f64 * 1e-3).sin();
        sim.set_velocity_command(&[0.3 * s, -0.2, 0.1, 0.2 * s, 0.0, -0.1, 0.4]).unwrap();
        sim.step();
        sim_holding
            .set_wrench(Wrench { force: Vector3::new(5.0 * s, 2.0, -1.0), torque: Vector3::zeros() }, None)
            .unwrap();
        sim_holding.step();
    }
    let count = cowork_testkit::allocations() - before;
    assert_eq!(count, 0, "{count} allocations in 20 000 steps");
}
