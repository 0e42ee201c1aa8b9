//! Teaching an open subtask in the running graph (thesis Fig. 5.23, `tea-reuse`): the robot
//! executes what it has learned; when the supervisor reaches a subtask nobody taught it waits
//! for a demonstration, and the scripted teacher of the seed shows it from where the arm and
//! the objects are now — `teach`, the guiding wrenches, `gripper close|open`, `done` — into the
//! same lwr_sim (`--follow-wrench-stamps`), robot manager and supervisor. The demonstration is
//! synthesised at that moment (`cowork_synth` with [`SynthOptions::start_scene`]), so it starts
//! from the executed state, not from the scene file's. The teacher says `teach` first and takes
//! the arm once the manager has let it go and it is still: before that the controller may still
//! be moving it (the link damper backing away from a person at the table: tea-reuse seed 2 moved
//! 14 cm between the state the demonstration was made from and its first wrench, and the
//! open-loop replay closed the hand 6 cm beside the tea box).

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use cowork_graph::TeachingFeed;
use cowork_msgs::msg::WorldState;
use cowork_msgs::sensor_msgs::JointState;
use cowork_ros::RosNode;
use cowork_sim::Scene;
use cowork_synth::{Scenario, SynthOptions};
use serde::Serialize;

/// What teaching the open subtask took.
#[derive(Debug, Clone, Default, Serialize)]
pub struct OpenTeaching {
    /// The demonstration shown.
    pub scenario: String,
    /// Simulated time the runner saw the supervisor wait for it, s after the robot started.
    pub asked_at_s: Option<f64>,
    /// Teaching time: the demonstration's length, s.
    pub teaching_s: Option<f64>,
    /// Wall time of the replay, s.
    pub wall_s: f64,
}

/// The scene as the graph has it now: `base` with the arm at `joints` (rad, the model's order)
/// and every object at its `/lwr/world` pose.
pub fn scene_now(base: &Scene, world: &WorldState, joints: &JointState) -> Result<Scene> {
    let mut scene = base.clone();
    if joints.position.len() != scene.initial_joints_deg().len() {
        bail!(
            "/joint_states has {} positions, the scene's arm {}",
            joints.position.len(),
            scene.initial_joints_deg().len()
        );
    }
    scene.set_initial_joints_deg(joints.position.iter().map(|q| q.to_degrees()).collect());
    for o in &mut scene.objects {
        let Some(w) = world.objects.iter().find(|w| w.name == o.name) else { continue };
        if w.held {
            bail!("{} is still held: a demonstration starts with the gripper open", o.name);
        }
        let (p, q) = (&w.pose.position, &w.pose.orientation);
        o.pose.position = [p.x, p.y, p.z];
        o.pose.rpy = None;
        o.pose.quaternion_xyzw = Some([q.x, q.y, q.z, q.w]);
    }
    Ok(scene)
}

/// Fastest joint allowed while the arm counts as let go and still, rad/s.
pub const STILL_JOINT_SPEED: f64 = 0.005;

/// Whether `joints` (stamped at least `after_s`, simulated s) shows the arm still.
pub fn still_after(joints: &JointState, after_s: f64) -> bool {
    joints.header.stamp.to_secs_f64() >= after_s && !joints.velocity.is_empty() && joints.velocity.iter().all(|v| v.abs() < STILL_JOINT_SPEED)
}

/// Synthesises the seed's teacher showing `scenario` from `scene` (written beside the bag in
/// `dir`) and returns the bag.
pub fn synthesise_from(scenario: Scenario, seed: u64, scene: &Scene, dir: &Path) -> Result<PathBuf> {
    let scene_path = dir.join(format!("{scenario}.start.yaml"));
    std::fs::write(&scene_path, serde_yaml_ng::to_string(scene)?).with_context(|| format!("writing {}", scene_path.display()))?;
    let bag = dir.join(format!("{scenario}.from-executed.mcap"));
    let options = SynthOptions { seed, depth: false, vary_teacher: true, start_scene: Some(scene_path), ..SynthOptions::default() };
    cowork_synth::synthesize(scenario, &options, &bag, &mut |_| {})
        .with_context(|| format!("synthesising the {scenario} demonstration of seed {seed} from the executed state"))?;
    Ok(bag)
}

/// Plays `bag` into the running graph: waits until lwr_sim hears `/external_wrench` and the
/// manager and the supervisor `/speech_command`, then replays it half a second later on the
/// simulated clock, in lockstep with the manager (`poll` drains the runner's readers and
/// returns the newest `/robot_stream` stamp). Returns the demonstration's length, s.
pub fn play(node: &mut RosNode, bag: &Path, rate: f64, poll: &mut dyn FnMut() -> Result<Option<f64>, String>) -> Result<f64> {
    // `teach` was said before the demonstration was made (the runner waits for the let-go arm).
    let feed = TeachingFeed::new(node, bag).with_context(|| format!("reading {}", bag.display()))?.without_word("teach");
    let until = Instant::now() + Duration::from_secs(20);
    while !feed.matched(node, 1, 2) {
        poll().map_err(anyhow::Error::msg)?;
        if Instant::now() > until {
            bail!("lwr_sim, the robot manager and the supervisor did not match the teacher's publishers within 20 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let length = feed.duration_s();
    let t0 = node.now().to_secs_f64() + 0.5;
    let limit = Duration::from_secs_f64(120.0 + 6.0 * length / rate.min(1.0));
    // As `cowork teach`: wrenches 0.2 s ahead of the clock and at most 0.3 s ahead of the
    // manager; the clock runs 3 s past the last word (`done`) for the supervisor to finish.
    let fed = feed.play_paced(node, t0, 0.2, 3.0, limit, 0.3, poll)?;
    if fed.dropped > 0 {
        bail!("{} of the teacher's messages were dropped by a full DDS queue", fed.dropped);
    }
    Ok(length)
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_msgs::msg::WorldObject;

    fn kitchen() -> Scene {
        Scene::from_file(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/scenes/kitchen.yaml"))).expect("kitchen scene")
    }

    fn world(tea_held: bool) -> WorldState {
        let mut w = WorldState::default();
        let mut tea = WorldObject { name: "tea".into(), held: tea_held, ..Default::default() };
        (tea.pose.position.x, tea.pose.position.y, tea.pose.position.z) = (0.35, 0.40, 0.04);
        (tea.pose.orientation.z, tea.pose.orientation.w) = (0.6, 0.8);
        w.objects.push(tea);
        w
    }

    fn joints(n: usize) -> JointState {
        JointState { position: (0..n).map(|i| 0.1 * i as f64).collect(), ..Default::default() }
    }

    #[test]
    fn the_start_scene_has_the_executed_arm_and_objects_and_keeps_the_rest() {
        let base = kitchen();
        let scene = scene_now(&base, &world(false), &joints(7)).expect("scene");
        assert!((scene.initial_joints_deg()[3] - 0.3f64.to_degrees()).abs() < 1e-9);
        let tea = scene.objects.iter().find(|o| o.name == "tea").expect("tea");
        assert_eq!(tea.pose.position, [0.35, 0.40, 0.04]);
        assert_eq!(tea.pose.quaternion_xyzw, Some([0.0, 0.0, 0.6, 0.8]));
        assert_eq!(tea.pose.rpy, None);
        // Objects the world did not report stay where the scene has them.
        let cup = |s: &Scene| s.objects.iter().find(|o| o.name == "cup").map(|o| o.pose.clone());
        assert_eq!(cup(&scene), cup(&base));
        // It loads as a scene again (what the synthesiser reads).
        let text = serde_yaml_ng::to_string(&scene).expect("yaml");
        let path = std::env::temp_dir().join(format!("open-subtask-{}.yaml", std::process::id()));
        std::fs::write(&path, text).expect("write");
        Scene::from_file(&path).expect("valid scene");
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_held_object_or_a_short_joint_state_is_refused_by_name() {
        let e = scene_now(&kitchen(), &world(true), &joints(7)).expect_err("held");
        assert!(e.to_string().contains("tea is still held"), "{e}");
        let e = scene_now(&kitchen(), &world(false), &joints(6)).expect_err("6 joints");
        assert!(e.to_string().contains("6 positions"), "{e}");
    }
}
