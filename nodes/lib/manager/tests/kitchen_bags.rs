//! The other kitchen subtasks' demonstrations (`cowork bag synth kinesthetic-coffee |
//! kinesthetic-spoon | kinesthetic-tea`, written here into a temporary directory: they are not
//! bundled in `bags/`), replayed into the simulator and segmented by the manager: each gives
//! the FOA / NOA / gripper sequence of its subtask, the gripper closes on the right object,
//! the NOAs are reproduced by their DMPs within a few mm and degrees.

mod common;

use cowork_manager::{Output, reproduction_error};
use cowork_synth::{Scenario, SynthOptions, synthesize};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

/// `max_error_m`: the largest NOA reproduction error allowed (open loop, object frame).
fn check(scenario: Scenario, object: &str, max_error_m: f64) {
    let dir = tempfile::tempdir().expect("tempdir");
    let bag = dir.path().join(format!("{scenario}.mcap"));
    let options = SynthOptions { seed: 1, depth: false, config_dir: root().join("config"), ..SynthOptions::default() };
    let summary = synthesize(scenario, &options, &bag, &mut |_| {}).expect("synthesis");
    assert_eq!(summary.counts["/speech_command"], 4, "teach, gripper close, gripper open, done");
    let (manager, out) = common::learn_from_bag(&bag, &root().join("config"));
    let labels: Vec<&str> = manager.learned().iter().map(|(s, _)| s.label.as_str()).collect();
    let o = object;
    let want = [
        format!("foa1({o})"),
        format!("noa2({o})"),
        format!("close3({o})"),
        "foa4(cup)".into(),
        "noa5(cup)".into(),
        "foa6(world)".into(),
        format!("open7({o})"),
        format!("noa8({o})"),
        "foa9(world)".into(),
    ];
    let warnings: Vec<&Output> = out.iter().filter(|o| matches!(o, Output::Warn(_))).collect();
    assert_eq!(labels, want, "{scenario}: {warnings:#?}");
    assert!(warnings.is_empty(), "{scenario}: {warnings:#?}");
    for (seg, p) in manager.learned() {
        if let Some(e) = reproduction_error(p, seg, 0.001).expect("rollout") {
            assert!(e.position_max_m < max_error_m && e.position_rms_m < 0.002 && e.orientation_max_rad < 5f64.to_radians(), "{scenario} {}: {e:?}", seg.label);
        }
    }
    // The grasp NOA ends 2 cm above the object's top, in the object's frame.
    let g = manager.database().get("noa2").expect("noa2").goal.position;
    assert!(g[0].hypot(g[1]) < 0.01, "{scenario}: {g:?}");
    println!("{scenario}: {}", manager.learned().iter().map(|(s, _)| format!("{} {:.2}-{:.2}", s.label, s.t_start, s.t_end)).collect::<Vec<_>>().join(", "));
}

#[test]
fn add_coffee_is_segmented_into_its_nine_actions() {
    check(Scenario::KinestheticCoffee, "coffee", 0.005);
}

#[test]
fn use_spoon_is_segmented_into_its_nine_actions() {
    // Stirring: 16 changes of direction in 8 s against the DMP's 30 basis functions leave
    // up to 6 mm at the corners (1.5 mm RMS).
    check(Scenario::KinestheticSpoon, "spoon", 0.008);
}

#[test]
fn add_tea_is_segmented_into_its_nine_actions() {
    check(Scenario::KinestheticTea, "tea", 0.005);
}
