//! The pour demonstration of `bags/kinesthetic-pour.mcap` replayed into the simulator (as
//! `lwr_sim` would move under its wrenches) and segmented by the manager: the nine actions of
//! Fig. 5.18 in order, each NOA reproduced by its DMPs within a few mm and degrees.

mod common;

use cowork_manager::{Output, reproduction_error};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

#[test]
fn the_pour_bag_gives_the_nine_actions_of_fig_5_18() {
    let (manager, out) = common::learn_from_bag(&root().join("bags/kinesthetic-pour.mcap"), &root().join("config"));
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
