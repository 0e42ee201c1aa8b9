//! Closed loop for the imitation-teaching pizza demonstrations: each bag's skeletons, streamed
//! through the arm retargeting of eq. 4.7 (`cowork_observer::Retargeter`), drive the arm of a
//! 1 kHz simulator of the teaching scene (`set_arm_joint_target`), and its speech drives the
//! gripper. Every ingredient is taken, held tilted over the pizza, put back upright where it
//! was; the planned joints are reproduced; the robot manager's proximity-sphere segmentation
//! gives 3 NOA + 3 FOA + 2 gripper commands per ingredient (+ one closing FOA).

use std::path::PathBuf;

use cowork_bag::BagReader;
use cowork_msgs::msg::Skeleton;
use cowork_msgs::std_msgs::String as RosString;
use cowork_observer::{RetargetConfig, Retargeter};
use cowork_synth::pizza::{self, DemoArm, INGREDIENTS, PIZZA, PizzaStyle, plan_demo};
use cowork_synth::{Scenario, SynthOptions, load_simulator, synthesize};
use nalgebra::{Point3, Vector3};

fn config_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config")
}

fn scenario(arm: DemoArm) -> Scenario {
    match arm {
        DemoArm::Left => Scenario::PizzaDemoLeft,
        DemoArm::Right => Scenario::PizzaDemoRight,
    }
}

/// What one replay measured.
#[derive(Debug)]
struct Replay {
    duration_s: f64,
    max_joint_error_rad: f64,
    speed_limited: usize,
    segments: Vec<String>,
}

fn lowest(o: &cowork_sim::ObjectState) -> f64 {
    let (h, r) = match o.shape {
        cowork_sim::Shape::Cylinder { radius, height } => (height, radius),
        _ => panic!("cylinders only"),
    };
    let a = o.pose.rotation * Vector3::z();
    o.pose.translation.vector.z - 0.5 * h * a.z.abs() - r * (1.0 - a.z * a.z).max(0.0).sqrt()
}

fn replay(arm: DemoArm, seed: u64) -> Replay {
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("pizza.mcap");
    let options = SynthOptions {
        seed,
        depth: false,
        config_dir: config_dir(),
        ..SynthOptions::default()
    };
    let summary = synthesize(scenario(arm), &options, &bag, &mut |_| {}).unwrap();
    assert_eq!(
        summary.counts["/speech_command"], 10,
        "{:?}",
        summary.counts
    );
    assert!(summary.duration_s < 240.0, "{} s", summary.duration_s);
    let expected_frames = (summary.duration_s * 120.0).floor() as u64 + 1;
    assert_eq!(summary.counts["/human/skeleton"], expected_frames);

    let mut sim = load_simulator(&config_dir(), arm.scene_file()).unwrap();
    let plan = plan_demo(&sim, arm, &PizzaStyle::from_seed(seed)).unwrap();
    let me = sim.arm_index(arm.name()).unwrap();
    let other = 1 - me;
    let other_q = *sim.arm(other).joint_positions();
    let q0 = *sim.arm(me).joint_positions();
    let config = RetargetConfig {
        side: arm.side(),
        mount_rpy: pizza::mount_rpy(sim.arm(me).base()),
        ..RetargetConfig::default()
    };
    let mut retarget = Retargeter::new(sim.model().clone(), config, q0).unwrap();
    let start: Vec<_> = sim.objects().iter().map(|o| o.pose).collect();
    let pizza_i = sim.objects().iter().position(|o| o.name == PIZZA).unwrap();
    let pizza_c = start[pizza_i].translation.vector;
    let pizza_top = pizza_c.z + 0.01;
    let limits = *sim.model().joint_limits();
    let samples: Vec<Vec<Point3<f64>>> = (0..sim.model().link_count())
        .map(|l| {
            sim.model().link_mesh(l).map_or_else(Vec::new, |m| {
                m.vertices.iter().step_by(3).copied().collect()
            })
        })
        .collect();

    let reader = BagReader::open(&bag).unwrap();
    let mut msgs: Vec<_> = reader
        .messages()
        .map(|m| m.unwrap())
        .filter(|m| &*m.topic != "/clock")
        .collect();
    msgs.sort_by_key(|m| m.log_time_ns);
    let mut msgs = msgs.into_iter().peekable();
    let end_ns = (summary.duration_s * 1e9).round() as i64;
    let mut r = Replay {
        duration_s: summary.duration_s,
        max_joint_error_rad: 0.0,
        speed_limited: 0,
        segments: Vec::new(),
    };
    let mut grasped = Vec::new();
    let mut over_since: Option<f64> = None;
    let mut over_best = vec![0.0_f64; INGREDIENTS.len()];
    // The robot manager's segmentation (nodes/lib/manager/src/segment.rs), at 100 Hz.
    let mut inside: Option<usize> = None;
    let mut pending = false;
    let mut teaching = false;
    while sim.time_ns() <= end_ns {
        let now = sim.time_ns();
        while let Some(m) = msgs.next_if(|m| m.log_time_ns as i64 <= now) {
            match &*m.topic {
                "/human/skeleton" => {
                    let s: Skeleton = m.decode().unwrap();
                    assert_eq!(
                        (
                            s.source.as_str(),
                            s.person_id,
                            s.header.frame_id.as_str(),
                            s.poses.len()
                        ),
                        (Skeleton::SOURCE_XSENS, 1, "world", 11)
                    );
                    let out = retarget.retarget_message(&s, "world").unwrap();
                    let want = plan.joints_at(s.header.stamp.to_secs_f64());
                    r.max_joint_error_rad = r.max_joint_error_rad.max((out.joints - want).amax());
                    r.speed_limited += usize::from(out.speed_limited);
                    sim.set_arm_joint_target(me, out.joints.as_slice()).unwrap();
                }
                "/speech_command" => {
                    let words: RosString = m.decode().unwrap();
                    let (who, what) = words.data.split_once(": ").unwrap();
                    assert_eq!(who, arm.name());
                    let t = m.log_time_ns as f64 * 1e-9;
                    match what {
                        "teach" => teaching = true,
                        "done" => {
                            r.segments
                                .push(if inside.is_some() { "noa" } else { "foa" }.into());
                            teaching = false;
                        }
                        "gripper close" | "gripper open" => {
                            let close = what == "gripper close";
                            r.segments
                                .push(if inside.is_some() { "noa" } else { "foa" }.into());
                            let got = sim.command_arm_gripper(me, close).map(str::to_owned);
                            if close {
                                grasped.push(got.clone().unwrap_or_else(|| {
                                    panic!("seed {seed}: nothing grasped at {t:.2} s")
                                }));
                            }
                            r.segments.push(format!(
                                "{}({})",
                                if close { "close" } else { "open" },
                                got.unwrap_or_default()
                            ));
                            pending = true;
                        }
                        other => panic!("unknown words {other}"),
                    }
                }
                other => panic!("unexpected topic {other}"),
            }
        }
        sim.step();
        // Links of both arms above the table; joints off their limits; the other arm still.
        for a in 0..2 {
            let arm_state = sim.arm(a);
            for (l, vs) in samples.iter().enumerate() {
                let pose = arm_state.base() * arm_state.link_poses().get(l);
                for v in vs {
                    assert!(
                        (pose * v).z >= 0.0,
                        "seed {seed}: link {l} of arm {a} under the table top at {:.3} s",
                        now as f64 * 1e-9
                    );
                }
            }
        }
        let q = sim.arm(me).joint_positions();
        for i in 0..7 {
            assert!(
                q[i] > limits[i].lower + 0.15 && q[i] < limits[i].upper - 0.15,
                "seed {seed}: joint {i} at {:.1} deg",
                q[i].to_degrees()
            );
        }
        assert_eq!(*sim.arm(other).joint_positions(), other_q);
        let t = sim.time_ns() as f64 * 1e-9;
        // Held over the pizza: lowest point 5-20 cm over it, centre within 8 cm in x-y.
        let held = sim.arm_held_object(me).map(str::to_owned);
        if let Some(name) = &held {
            let o = sim.objects().iter().find(|o| &o.name == name).unwrap();
            let low = lowest(o) - pizza_top;
            let off = (o.pose.translation.vector.xy() - pizza_c.xy()).norm();
            if (0.05..=0.20).contains(&low) && off <= 0.08 {
                let since = *over_since.get_or_insert(t);
                let k = INGREDIENTS.iter().position(|n| n == name).unwrap();
                over_best[k] = over_best[k].max(t - since);
            } else {
                over_since = None;
            }
        } else {
            over_since = None;
        }
        if teaching && sim.time_ns() % 10_000_000 == 0 {
            let tool = Point3::from(sim.world_tool_pose(me).translation.vector);
            let held_i = sim
                .objects()
                .iter()
                .position(|o| Some(&o.name) == held.as_ref());
            let mut within: Vec<(f64, usize)> = sim
                .objects()
                .iter()
                .enumerate()
                .filter(|(i, _)| Some(*i) != held_i)
                .map(|(i, o)| (o.distance_to(&tool), i))
                .filter(|(d, _)| *d <= 0.12)
                .collect();
            within.sort_by(|a, b| a.0.total_cmp(&b.0));
            assert!(
                within.len() <= 1,
                "seed {seed}: the tool is in {} spheres at {t:.2} s",
                within.len()
            );
            let now_in = within.first().map(|w| w.1);
            if pending || inside.is_some_and(|i| Some(i) == held_i) {
                pending = false;
                inside = now_in;
            } else if now_in != inside {
                match inside {
                    Some(i) => r.segments.push(format!("noa({})", sim.objects()[i].name)),
                    None => r
                        .segments
                        .push(format!("foa({})", sim.objects()[now_in.unwrap()].name)),
                }
                inside = now_in;
            }
        }
    }
    assert_eq!(grasped, INGREDIENTS, "seed {seed}");
    for (k, best) in over_best.iter().enumerate() {
        assert!(
            *best >= 1.5,
            "seed {seed}: {} held over the pizza for {best:.2} s",
            INGREDIENTS[k]
        );
    }
    for (i, o) in sim.objects().iter().enumerate() {
        let moved = (o.pose.translation.vector - start[i].translation.vector).norm();
        let tilt = (o.pose.rotation * Vector3::z()).angle(&Vector3::z());
        let limit = if INGREDIENTS.contains(&o.name.as_str()) {
            0.02
        } else {
            1e-12
        };
        assert!(
            moved <= limit && tilt < 5f64.to_radians(),
            "seed {seed}: {} ends {moved:.4} m from where it was, tilted {:.1} deg",
            o.name,
            tilt.to_degrees()
        );
    }
    r
}

fn check_segments(r: &Replay) {
    // FOA into the bottle's sphere, NOA down, close, FOA into the pizza's sphere, NOA out,
    // FOA back (closed by open), NOA out of the bottle's sphere; a last FOA closed by `done`.
    let mut want = Vec::new();
    for (k, name) in INGREDIENTS.iter().enumerate() {
        if k == 0 {
            want.push(format!("foa({name})"));
        }
        want.extend([
            format!("noa"),
            format!("close({name})"),
            format!("foa({PIZZA})"),
            format!("noa({PIZZA})"),
            "foa".into(),
            format!("open()"),
            format!("noa({name})"),
        ]);
        want.push(match INGREDIENTS.get(k + 1) {
            Some(next) => format!("foa({next})"),
            None => "foa".into(),
        });
    }
    assert_eq!(r.segments, want);
}

#[test]
fn left_demonstration_replays_through_the_retargeting_and_segments_per_ingredient() {
    let r = replay(DemoArm::Left, 0);
    println!("left seed 0: {r:?}");
    assert!(r.max_joint_error_rad < 0.01, "{r:?}");
    assert_eq!(r.speed_limited, 0);
    check_segments(&r);
}

#[test]
fn right_demonstration_replays_through_the_retargeting_and_segments_per_ingredient() {
    let r = replay(DemoArm::Right, 0);
    println!("right seed 0: {r:?}");
    assert!(r.max_joint_error_rad < 0.01, "{r:?}");
    assert_eq!(r.speed_limited, 0);
    check_segments(&r);
}

#[test]
fn seeds_give_different_valid_demonstrations() {
    let mut lengths = Vec::new();
    for seed in 1..5 {
        let r = replay(
            if seed % 2 == 0 {
                DemoArm::Left
            } else {
                DemoArm::Right
            },
            seed,
        );
        println!(
            "seed {seed}: {:.1} s, joint error {:.2e} rad",
            r.duration_s, r.max_joint_error_rad
        );
        assert!(
            r.max_joint_error_rad < 0.01 && r.speed_limited == 0,
            "{r:?}"
        );
        check_segments(&r);
        lengths.push(r.duration_s);
    }
    lengths.dedup();
    assert!(lengths.len() > 1, "{lengths:?}");
}

#[test]
fn same_seed_same_bytes_and_bad_scenes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let options = SynthOptions {
        seed: 3,
        depth: false,
        config_dir: config_dir(),
        ..SynthOptions::default()
    };
    let (a, b) = (dir.path().join("a.mcap"), dir.path().join("b.mcap"));
    synthesize(Scenario::PizzaDemoLeft, &options, &a, &mut |_| {}).unwrap();
    synthesize(Scenario::PizzaDemoLeft, &options, &b, &mut |_| {}).unwrap();
    assert!(std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap());
    assert_eq!(
        "pizza-demo-right".parse::<Scenario>().unwrap(),
        Scenario::PizzaDemoRight
    );
    // A single-arm scene has no named arms.
    let kitchen = load_simulator(&config_dir(), "kitchen.yaml").unwrap();
    let e = plan_demo(&kitchen, DemoArm::Left, &PizzaStyle::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no named arms"), "{e}");
    // A scene whose arms are not called left / right.
    let text = std::fs::read_to_string(config_dir().join("scenes/pizza-teach-left.yaml"))
        .unwrap()
        .replace("name: left", "name: port");
    let scene_file = dir.path().join("scene.yaml");
    std::fs::write(&scene_file, text).unwrap();
    let scene = cowork_sim::Scene::from_file(&scene_file).unwrap();
    let model = kitchen.model().clone();
    let sim =
        cowork_sim::Simulator::new(model.clone(), scene.clone(), kitchen.params().clone()).unwrap();
    let e = plan_demo(&sim, DemoArm::Left, &PizzaStyle::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no arm `left`") && e.contains("port"), "{e}");
    // An ingredient out of reach, one missing.
    let mut far =
        cowork_sim::Scene::from_file(&config_dir().join("scenes/pizza-teach-left.yaml")).unwrap();
    far.objects
        .iter_mut()
        .find(|o| o.name == "oil")
        .unwrap()
        .pose
        .position = [0.85, 0.6, 0.08];
    let sim =
        cowork_sim::Simulator::new(model.clone(), far.clone(), kitchen.params().clone()).unwrap();
    let e = plan_demo(&sim, DemoArm::Left, &PizzaStyle::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("`oil`") && e.contains("cannot be grasped"),
        "{e}"
    );
    let mut missing =
        cowork_sim::Scene::from_file(&config_dir().join("scenes/pizza-teach-left.yaml")).unwrap();
    missing.objects.retain(|o| o.name != "basil");
    let sim = cowork_sim::Simulator::new(model, missing, kitchen.params().clone()).unwrap();
    let e = plan_demo(&sim, DemoArm::Left, &PizzaStyle::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no object `basil`"), "{e}");
    // A bag shorter than the demonstration.
    let short = SynthOptions {
        duration_s: Some(10.0),
        ..options
    };
    let e = synthesize(Scenario::PizzaDemoLeft, &short, &a, &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("--duration"), "{e}");
}
