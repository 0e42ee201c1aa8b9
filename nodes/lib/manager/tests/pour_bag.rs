//! The pour demonstration of `bags/kinesthetic-pour.mcap` replayed into the simulator (as
//! `lwr_sim` would move under its wrenches) and segmented by the manager: the nine actions of
//! Fig. 5.18 in order, each NOA reproduced by its DMPs within a few mm and degrees.

use cowork_manager::{Database, Input, Manager, ManagerConfig, ObjectReport, Output, Stamp, WorldReport, reproduction_error};
use cowork_sim::{GripperState, Simulator};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn report(sim: &Simulator) -> WorldReport {
    let tool = sim.tool_pose();
    let point = nalgebra::Point3::from(tool.translation.vector);
    WorldReport {
        t: sim.time_ns() as f64 * 1e-9,
        tool,
        gripper_closed: matches!(sim.gripper(), GripperState::Closed { .. }),
        held: sim.held_object().map(str::to_owned),
        objects: sim
            .objects()
            .iter()
            .map(|o| ObjectReport { name: o.name.clone(), pose: o.pose, distance: o.distance_to(&point), tilt: 0.0, visible: true })
            .collect(),
    }
}

#[test]
fn the_pour_bag_gives_the_nine_actions_of_fig_5_18() {
    let bag = root().join("bags/kinesthetic-pour.mcap");
    let mut sim = cowork_synth::load_simulator(&root().join("config"), "kitchen.yaml").expect("simulator");
    let mut speech = Vec::new();
    for m in cowork_bag::BagReader::open(&bag).expect("bag").messages() {
        let m = m.expect("message");
        if &*m.topic == "/speech_command" {
            let s: cowork_msgs::std_msgs::String = m.decode().expect("speech");
            speech.push((m.log_time_ns as i64, s.data));
        }
    }
    let mut manager = Manager::new(ManagerConfig::default(), Database::new("lwr"));
    let mut out: Vec<Output> = Vec::new();
    let stamp = |t: f64| Stamp { t, unix_s: 0 };
    manager.handle(&Input::World(report(&sim)), stamp(0.0), &mut out);
    let mut next = 0;
    cowork_synth::replay_teaching(&bag, &mut sim, 1.0, |s| {
        let t = s.time_ns() as f64 * 1e-9;
        while next < speech.len() && speech[next].0 < s.time_ns() {
            manager.handle(&Input::Speech(speech[next].1.clone()), stamp(t), &mut out);
            next += 1;
        }
        if s.time_ns() % 10_000_000 == 0 {
            manager.handle(&Input::World(report(s)), stamp(t), &mut out);
        }
    })
    .expect("replay");
    let labels: Vec<&str> = manager.learned().iter().map(|(s, _)| s.label.as_str()).collect();
    assert_eq!(
        labels,
        ["foa1(water)", "noa2(water)", "close3(water)", "foa4(cup)", "noa5(cup)", "foa6(world)", "open7(water)", "noa8(water)", "foa9(world)"]
    );
    let warnings: Vec<&Output> = out.iter().filter(|o| matches!(o, Output::Warn(_))).collect();
    assert!(warnings.is_empty(), "{warnings:#?}");
    for (seg, p) in manager.learned() {
        if let Some(e) = reproduction_error(p, seg, 0.001).expect("rollout") {
            assert!(e.position_max_m < 0.005 && e.orientation_max_rad < 5f64.to_radians(), "{}: {e:?}", seg.label);
        }
    }
    // The grasp NOA ends where the gripper closed: 2 cm above the bottle's top (0.13 m above its
    // centre) in the bottle's frame.
    let g = manager.database().get("noa2").expect("noa2").goal.position;
    assert!((g[2] - 0.13).abs() < 0.01 && g[0].hypot(g[1]) < 0.01, "{g:?}");
}
