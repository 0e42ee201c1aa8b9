//! Teachers drawn per seed (`vary_teacher`) and demonstrations made one after the other
//! (`after`): each bag, replayed into the simulator its predecessors left, still grasps its
//! object, uses it at the cup and puts it back; different seeds give different demonstrations.
//! The three demonstrations of prepareCoffee in a row: the spoon's bag (after two others) used
//! to start from where the *first* one left the arm (the second ran on a clock that had not
//! been reset) and missed the spoon by 15 cm when replayed after the coffee's.

use std::path::{Path, PathBuf};

use cowork_sim::Simulator;
use cowork_synth::{Applied, Scenario, SynthOptions, continue_from, load_simulator, replay_teaching, synthesize};

fn config_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config")
}

fn options(seed: u64, after: &[Scenario]) -> SynthOptions {
    SynthOptions { seed, depth: false, config_dir: config_dir(), vary_teacher: true, after: after.to_vec(), ..SynthOptions::default() }
}

/// Replays `bag` into `sim`; returns the objects grasped and the largest tilt of `object`
/// while held (rad).
fn replay(bag: &Path, sim: &mut Simulator, object: &str) -> (Vec<String>, f64) {
    let mut tilt = 0.0f64;
    let r = replay_teaching(bag, sim, 0.5, |s| {
        if s.held_object() == Some(object)
            && let Some(o) = s.objects().iter().find(|o| o.name == object)
        {
            let up = o.pose.rotation * nalgebra::Vector3::z();
            tilt = tilt.max(up.z.clamp(-1.0, 1.0).acos());
        }
    })
    .unwrap();
    let grasped = r
        .gripper_events
        .iter()
        .filter_map(|(_, a)| match a {
            Applied::GripperClosed(Some(o)) => Some(o.clone()),
            _ => None,
        })
        .collect();
    (grasped, tilt)
}

#[test]
fn teachers_differ_by_seed_and_each_demonstration_replays_after_the_previous_ones() {
    let dir = tempfile::tempdir().unwrap();
    let steps = [
        (Scenario::KinestheticPour, "bottle", 1.5),
        (Scenario::KinestheticCoffee, "coffee", 1.5),
        // The spoon's bowl turned down into the cup: its z axis horizontal.
        (Scenario::KinestheticSpoon, "spoon", 1.2),
    ];
    let mut lengths = Vec::new();
    for seed in [3u64, 8] {
        let mut sim = load_simulator(&config_dir(), "kitchen.yaml").unwrap();
        let mut before = Vec::new();
        for (k, (scenario, object, min_tilt)) in steps.iter().enumerate() {
            let bag = dir.path().join(format!("{scenario}-{seed}.mcap"));
            let summary = synthesize(*scenario, &options(seed, &before), &bag, &mut |_| {}).unwrap();
            if k == 0 {
                lengths.push(summary.duration_s);
            }
            let (grasped, tilt) = replay(&bag, &mut sim, object);
            assert_eq!(grasped, [object.to_string()], "seed {seed}: {scenario} after {before:?}");
            assert!(tilt > *min_tilt, "seed {seed}: {object} used at the cup (tilt {tilt:.2} rad)");
            assert!(sim.held_object().is_none(), "seed {seed}: {object} put back");
            let o = sim.objects().iter().find(|o| o.name == *object).unwrap();
            assert!(o.pose.translation.z < 0.2, "seed {seed}: {object} back on the table: {:?}", o.pose.translation);
            sim = continue_from(&sim).unwrap();
            before.push(*scenario);
        }
    }
    assert!((lengths[0] - lengths[1]).abs() > 0.1, "the teachers' paces differ: {lengths:?}");
    assert_ne!(
        std::fs::read(dir.path().join("kinesthetic-pour-3.mcap")).unwrap(),
        std::fs::read(dir.path().join("kinesthetic-pour-8.mcap")).unwrap()
    );
}

#[test]
fn a_demonstration_cannot_follow_a_scenario_that_is_not_one() {
    let dir = tempfile::tempdir().unwrap();
    let e = synthesize(Scenario::KinestheticCoffee, &options(1, &[Scenario::Gestures]), &dir.path().join("x.mcap"), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("gestures"), "{e}");
    let e = synthesize(Scenario::Gestures, &options(1, &[Scenario::KinestheticPour]), &dir.path().join("y.mcap"), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a kinesthetic demonstration"), "{e}");
}
