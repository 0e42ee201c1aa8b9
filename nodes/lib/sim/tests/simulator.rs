//! Simulator behaviour: limits, determinism, gripper, admittance, bad input.

use cowork_robot::{DOF, RobotModel};
use cowork_sim::{CommandError, GripperState, Scene, SimParams, Simulator, Wrench};
use nalgebra::Vector3;
use proptest::prelude::*;

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn model() -> RobotModel {
    RobotModel::from_urdf_file(&root().join("config/robot/lwr4plus.urdf")).expect("URDF loads")
}

fn scene() -> Scene {
    Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene loads")
}

fn sim() -> Simulator {
    Simulator::new(model(), scene(), SimParams::default()).expect("simulator")
}

#[test]
fn velocity_command_integrates_at_1khz() {
    let mut s = sim();
    let q0 = *s.joint_positions();
    s.set_velocity_command(&[0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
    for _ in 0..50 {
        s.step();
    }
    assert_eq!(s.time_ns(), 50_000_000);
    let dq = s.joint_positions() - q0;
    assert!((dq[0] - 0.2 * 0.05).abs() < 1e-12, "{dq}");
    assert!(dq.rows(1, DOF - 1).norm() < 1e-15);
    assert!((s.joint_velocities()[0] - 0.2).abs() < 1e-9);
}

#[test]
fn stale_command_holds_the_robot() {
    let mut s = sim();
    s.set_velocity_command(&[0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
    for _ in 0..300 {
        s.step();
    }
    // Timeout 0.1 s: the joint moved for ~0.1 s only, and stands still now.
    let moved = s.joint_positions()[0] - sim().joint_positions()[0];
    assert!((moved - 0.2 * 0.101).abs() < 0.2 * 0.002, "moved {moved}");
    assert_eq!(s.joint_velocities()[0], 0.0);
}

#[test]
fn bad_commands_are_rejected_and_hold_the_robot() {
    let mut s = sim();
    s.set_velocity_command(&[0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
    s.step();
    assert_eq!(
        s.set_velocity_command(&[0.1; 6]),
        Err(CommandError::WrongLength { got: 6, expected: 7 })
    );
    s.step();
    assert_eq!(s.joint_velocities().norm(), 0.0);
    let err = s.set_velocity_command(&[0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap_err();
    assert!(matches!(err, CommandError::NotFinite { index: 1, .. }), "{err}");
    s.step();
    assert_eq!(s.joint_velocities().norm(), 0.0);
    assert!(s.joint_positions().iter().all(|v| v.is_finite()));
}

#[test]
fn speed_limits_scale_the_whole_command() {
    let mut s = sim();
    let limits: Vec<f64> = s.model().joint_limits().iter().map(|l| l.velocity).collect();
    // Joint 1 asked for twice its limit, joint 2 for half of its limit.
    s.set_velocity_command(&[2.0 * limits[0], 0.5 * limits[1], 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
    s.step();
    let qd = s.joint_velocities();
    assert!((qd[0] - limits[0]).abs() < 1e-9, "{qd}");
    assert!((qd[1] - 0.25 * limits[1]).abs() < 1e-9, "direction kept: {qd}");
}

#[test]
fn gripper_grasps_nearest_object_within_reach_and_carries_it() {
    let mut s = sim();
    // Nothing within 5 cm of the tool at the start pose.
    assert_eq!(s.command_gripper(true), None);
    assert_eq!(s.gripper(), GripperState::Closed { holding: None });
    s.command_gripper(false);
    // A scene with the cup's top 2 cm under the tool point.
    let tool = s.tool_pose().translation.vector;
    let mut sc = scene();
    let cup = sc.objects.iter_mut().find(|o| o.name == "cup").unwrap();
    cup.pose.position = [tool.x, tool.y, tool.z - 0.02 - 0.05];
    let mut s = Simulator::new(model(), sc, SimParams::default()).unwrap();
    let cup_pose = |s: &Simulator| s.objects().iter().find(|o| o.name == "cup").unwrap().pose;
    assert_eq!(s.command_gripper(true), Some("cup"));
    let grasp = s.tool_pose().inverse() * cup_pose(&s);
    let before = cup_pose(&s);
    s.set_velocity_command(&[0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]).unwrap();
    for _ in 0..100 {
        s.step();
    }
    let after = cup_pose(&s);
    assert!((after.translation.vector - before.translation.vector).norm() > 0.01);
    // Carried rigidly: same pose relative to the tool.
    let rel = s.tool_pose().inverse() * after;
    assert!((rel.translation.vector - grasp.translation.vector).norm() < 1e-9);
    assert!(rel.rotation.angle_to(&grasp.rotation) < 1e-9);
    assert_eq!(s.held_object(), Some("cup"));
    // Released above the table, it drops until its bottom touches the top (z = 0).
    s.command_gripper(false);
    assert_eq!(s.held_object(), None);
    let c = cup_pose(&s).translation.vector;
    assert!((c.z - 0.05).abs() < 1e-9, "cup centre at z = {}", c.z);
    assert!((c.x - after.translation.vector.x).abs() < 1e-12);
}

#[test]
fn released_block_lands_on_the_block_below_it() {
    let sc = Scene::from_file(&root().join("config/scenes/stacking.yaml")).expect("scene loads");
    let tool = Simulator::new(model(), sc.clone(), SimParams::default()).unwrap().tool_pose().translation.vector;
    assert!(tool.z > 0.15, "tool at z = {}", tool.z);
    let place = |sc: &mut Scene, name: &str, p: [f64; 3]| {
        sc.objects.iter_mut().find(|o| o.name == name).unwrap().pose.position = p;
    };
    let mut sc = sc;
    // box1 at the tool point; box3 on the table 2 cm to the side of the tool (footprints overlap).
    place(&mut sc, "box1", [tool.x, tool.y, tool.z]);
    place(&mut sc, "box3", [tool.x + 0.02, tool.y, 0.03]);
    let mut s = Simulator::new(model(), sc, SimParams::default()).unwrap();
    let z = |s: &Simulator, name: &str| s.objects().iter().find(|o| o.name == name).unwrap().pose.translation.vector.z;
    assert_eq!(s.command_gripper(true), Some("box1"));
    s.command_gripper(false);
    assert!((z(&s, "box1") - 0.09).abs() < 1e-9, "box1 centre at z = {} (on box3: 0.09)", z(&s, "box1"));
    assert!((z(&s, "box3") - 0.03).abs() < 1e-12);
    // Beside every other block it drops to the table.
    let mut sc = Scene::from_file(&root().join("config/scenes/stacking.yaml")).unwrap();
    place(&mut sc, "box1", [tool.x, tool.y, tool.z]);
    let mut s = Simulator::new(model(), sc, SimParams::default()).unwrap();
    assert_eq!(s.command_gripper(true), Some("box1"));
    s.command_gripper(false);
    assert!((z(&s, "box1") - 0.03).abs() < 1e-9, "box1 centre at z = {}", z(&s, "box1"));
}

#[test]
fn wrench_moves_the_tool_along_the_force() {
    let mut s = sim();
    let p0 = s.tool_pose().translation.vector;
    for _ in 0..200 {
        s.set_wrench(Wrench { force: Vector3::new(10.0, 0.0, 0.0), torque: Vector3::zeros() }, None)
            .unwrap();
        s.step();
    }
    let dp = s.tool_pose().translation.vector - p0;
    // eq. 4.6: c = 0.005 m/(N s) → 0.05 m/s for 10 N; 0.2 s → ~1 cm along x.
    assert!((dp.x - 0.01).abs() < 0.002, "{dp}");
    assert!(dp.y.abs() < 0.002 && dp.z.abs() < 0.002, "{dp}");
    // Once the person lets go (no wrench message for longer than the 0.1 s timeout) the arm
    // stays where it was left.
    for _ in 0..101 {
        s.step();
    }
    let q = *s.joint_positions();
    for _ in 0..200 {
        s.step();
    }
    assert!((s.joint_positions() - q).norm() < 1e-12);
}

#[test]
fn wrench_on_unknown_link_is_rejected() {
    let mut s = sim();
    let e = s
        .set_wrench(Wrench { force: Vector3::x(), torque: Vector3::zeros() }, Some("no_such_link"))
        .unwrap_err();
    assert_eq!(e, CommandError::UnknownLink { link: "no_such_link".into() });
}

#[test]
fn bad_scene_names_the_field() {
    let mut sc = scene();
    sc.objects[0].shape = cowork_sim::Shape::Sphere { radius: -1.0 };
    let e = sc.validate("kitchen.yaml").unwrap_err().to_string();
    assert!(e.contains("kitchen.yaml") && e.contains("radius"), "{e}");
    let mut sc = scene();
    sc.robot.as_mut().unwrap().initial_joints_deg[1] = 170.0;
    let e = Simulator::new(model(), sc, SimParams::default()).unwrap_err().to_string();
    assert!(e.contains("initial_joints_deg[1]") && e.contains("limits"), "{e}");
}

#[test]
fn scene_file_errors_name_the_file() {
    let dir = tempfile_dir();
    let p = dir.join("bad.yaml");
    std::fs::write(&p, "robot: {initial_joints_deg: [0,0,0,0,0,0,0]}\ntable: {size: [1,1,1], pose: {position: [0,0,0]}}\ncamera: {}\n").unwrap();
    let e = Scene::from_file(&p).unwrap_err().to_string();
    assert!(e.contains("bad.yaml") && e.contains("camera"), "{e}");
    let e = Scene::from_file(&dir.join("missing.yaml")).unwrap_err().to_string();
    assert!(e.contains("missing.yaml"), "{e}");
}

fn tempfile_dir() -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("cowork_sim_test_{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run_commands(commands: &[(u16, [f64; 7])]) -> Vec<[f64; 7]> {
    let mut s = sim();
    let mut out = Vec::new();
    for (steps, qd) in commands {
        // Rejected commands (NaN, huge) are part of the stream too.
        let _ = s.set_velocity_command(qd);
        for _ in 0..*steps {
            s.step();
        }
        let mut q = [0.0; 7];
        q.copy_from_slice(s.joint_positions().as_slice());
        out.push(q);
    }
    out
}

fn command() -> impl Strategy<Value = (u16, [f64; 7])> {
    let v = prop_oneof![
        8 => -10.0f64..10.0,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(1e300),
    ];
    (1u16..400, proptest::array::uniform7(v))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn joints_never_leave_their_limits(commands in proptest::collection::vec(command(), 1..12)) {
        let mut s = sim();
        let limits = *s.model().joint_limits();
        for (steps, qd) in &commands {
            let _ = s.set_velocity_command(qd);
            for _ in 0..*steps {
                s.step();
                for i in 0..DOF {
                    let q = s.joint_positions()[i];
                    let v = s.joint_velocities()[i];
                    prop_assert!(q >= limits[i].lower && q <= limits[i].upper, "joint {i} at {q}");
                    prop_assert!(v.abs() <= limits[i].velocity * (1.0 + 1e-9), "joint {i} speed {v}");
                }
            }
        }
    }

    #[test]
    fn simulation_is_bit_identical_across_runs(commands in proptest::collection::vec(command(), 1..8)) {
        let a = run_commands(&commands);
        let b = run_commands(&commands);
        for (x, y) in a.iter().zip(&b) {
            for i in 0..7 {
                prop_assert_eq!(x[i].to_bits(), y[i].to_bits());
            }
        }
    }
}

#[test]
fn a_person_places_objects_but_not_the_held_one() {
    use nalgebra::{Isometry3, Translation3, UnitQuaternion};
    let mut sc = scene();
    let tool = sim().tool_pose().translation.vector;
    let cup = sc.objects.iter_mut().find(|o| o.name == "cup").unwrap();
    cup.pose.position = [tool.x, tool.y, tool.z - 0.02 - 0.05];
    let mut s = Simulator::new(model(), sc, SimParams::default()).unwrap();
    let pose_of = |s: &Simulator, n: &str| s.objects().iter().find(|o| o.name == n).unwrap().pose;
    // The bottle lifted off the table, carried to the person's side and tilted: exactly there.
    let over = Isometry3::from_parts(Translation3::new(0.9, 0.4, 0.3), UnitQuaternion::from_euler_angles(0.0, 2.0, 0.0));
    s.place_object("bottle", over).expect("placed");
    s.step();
    assert_eq!(pose_of(&s, "bottle"), over);
    assert!(matches!(s.place_object("kettle", over), Err(CommandError::UnknownObject { .. })));
    let mut nan = over;
    nan.translation.vector.x = f64::NAN;
    assert!(matches!(s.place_object("bottle", nan), Err(CommandError::BadPose { .. })));
    assert_eq!(pose_of(&s, "bottle"), over, "a refused placement changes nothing");
    // The gripper's object is the robot's.
    assert_eq!(s.command_gripper(true), Some("cup"));
    let held = pose_of(&s, "cup");
    assert!(matches!(s.place_object("cup", over), Err(CommandError::HeldByGripper { .. })));
    assert_eq!(pose_of(&s, "cup"), held);
}
