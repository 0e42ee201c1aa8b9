//! Scenario names, options and the entry point [`synthesize`].

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use cowork_robot::RobotModel;
use cowork_sim::{Scene, SimParams, Simulator};

use crate::depth::DepthRig;
use crate::runner::Runner;
use crate::{Result, SynthError, gestures, kitchen, pizza, pour, stacking, static_scene};

/// The scenario bags the synthesiser writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[non_exhaustive]
pub enum Scenario {
    /// Kinesthetic demonstration of the pouring task: wrench + speech (Sec. 5.2.3, A.2.3).
    KinestheticPour,
    /// Robot held in a few configurations and boxes only, for the fDED tables (Sec. 5.1.2).
    StaticScene,
    /// Robot moving boxes while a person walks in, reaches, sweeps a hand, leaves (Sec. 5.1.3).
    StackingHuman,
    /// Labelled gestures come / stop / handover right by varied people (Sec. 5.1.3).
    Gestures,
    /// Kinesthetic demonstration of add(coffee): the jar poured into the cup ([`kitchen`]).
    KinestheticCoffee,
    /// Kinesthetic demonstration of use(spoon): stirring in the cup ([`kitchen`]).
    KinestheticSpoon,
    /// Kinesthetic demonstration of add(tea): the tea box emptied into the cup ([`kitchen`]).
    KinestheticTea,
    /// Imitation teaching of the whole pizza task by a person's left arm ([`pizza`]).
    PizzaDemoLeft,
    /// Imitation teaching of the whole pizza task by a person's right arm ([`pizza`]).
    PizzaDemoRight,
}

impl Scenario {
    /// Every scenario, in the order the CLI lists them.
    pub const ALL: &'static [Scenario] = &[
        Scenario::KinestheticPour,
        Scenario::StaticScene,
        Scenario::StackingHuman,
        Scenario::Gestures,
        Scenario::KinestheticCoffee,
        Scenario::KinestheticSpoon,
        Scenario::KinestheticTea,
        Scenario::PizzaDemoLeft,
        Scenario::PizzaDemoRight,
    ];

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            Scenario::KinestheticPour => "kinesthetic-pour",
            Scenario::StaticScene => "static-scene",
            Scenario::StackingHuman => "stacking-human",
            Scenario::Gestures => "gestures",
            Scenario::KinestheticCoffee => "kinesthetic-coffee",
            Scenario::KinestheticSpoon => "kinesthetic-spoon",
            Scenario::KinestheticTea => "kinesthetic-tea",
            Scenario::PizzaDemoLeft => "pizza-demo-left",
            Scenario::PizzaDemoRight => "pizza-demo-right",
        }
    }

    /// Scene file under `config/scenes/`.
    pub fn scene_file(self) -> &'static str {
        match self {
            Scenario::KinestheticPour
            | Scenario::KinestheticCoffee
            | Scenario::KinestheticSpoon
            | Scenario::KinestheticTea => "kitchen.yaml",
            Scenario::StaticScene | Scenario::StackingHuman | Scenario::Gestures => "stacking.yaml",
            Scenario::PizzaDemoLeft => pizza::DemoArm::Left.scene_file(),
            Scenario::PizzaDemoRight => pizza::DemoArm::Right.scene_file(),
        }
    }

    /// The demonstrating arm of an imitation-teaching scenario; `None` for the others.
    pub fn pizza_arm(self) -> Option<pizza::DemoArm> {
        match self {
            Scenario::PizzaDemoLeft => Some(pizza::DemoArm::Left),
            Scenario::PizzaDemoRight => Some(pizza::DemoArm::Right),
            _ => None,
        }
    }

    /// Length of the bag when no `--duration` is given, s (for the people scenarios it depends
    /// on the people drawn from `seed`; for the pizza demonstrations it is the length of the
    /// plan in the scene of `config/` under the working directory — [`synthesize`] plans in
    /// its `config_dir`).
    pub fn default_duration_s(self, seed: u64) -> Result<f64> {
        Ok(match self {
            Scenario::KinestheticPour => pour::NATURAL_DURATION_S,
            Scenario::StaticScene => static_scene::SEGMENT_S * static_scene::CONFIGURATIONS_DEG.len() as f64,
            Scenario::StackingHuman => stacking::default_duration_s(seed)?,
            Scenario::Gestures => gestures::default_duration_s(seed)?,
            Scenario::KinestheticCoffee => kitchen::COFFEE_DURATION_S,
            Scenario::KinestheticSpoon => kitchen::SPOON_DURATION_S,
            Scenario::KinestheticTea => kitchen::TEA_DURATION_S,
            Scenario::PizzaDemoLeft | Scenario::PizzaDemoRight => {
                let options = SynthOptions { seed, ..SynthOptions::default() };
                pizza_plan(self, &options)?.1.duration_s
            }
        })
    }
}

impl std::fmt::Display for Scenario {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Scenario {
    type Err = SynthError;

    fn from_str(s: &str) -> Result<Self> {
        Self::ALL.iter().copied().find(|sc| sc.name() == s).ok_or_else(|| SynthError::UnknownScenario {
            name: s.to_owned(),
            known: Self::ALL.iter().map(|s| s.name()).collect::<Vec<_>>().join(", "),
        })
    }
}

/// Options of one synthesis run.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthOptions {
    /// Seed of every random choice (noise, people, gestures): same seed, same bytes.
    pub seed: u64,
    /// Bag length, s; `None` for the scenario's default.
    pub duration_s: Option<f64>,
    /// Sensor noise (depth noise, skeleton jitter, force-sensor noise).
    pub noise: bool,
    /// Depth frames + camera info at 30 Hz (off: much smaller bags).
    pub depth: bool,
    /// The `config/` folder (robot URDF, scenes, `lwr_sim.yaml`).
    pub config_dir: PathBuf,
    /// Kinesthetic scenarios: a teacher drawn from the seed ([`pour::TeacherStyle::from_seed`]:
    /// pace, path, grasp) instead of the bundled one.
    pub vary_teacher: bool,
    /// Kinesthetic scenarios: demonstrations made before this one in the same session (each
    /// with this seed, noise and teacher, at its natural length): the bag starts where they
    /// left the arm and the objects, so the bags replay one after the other into one simulator
    /// (`cowork teach --bag A --bag B`).
    pub after: Vec<Scenario>,
    /// Kinesthetic scenarios: the scene file the demonstration starts from instead of the
    /// scenario's own (`config_dir/scenes/...`): the arm's `initial_joints_deg` and the objects
    /// where a running graph has them (the teacher shows an open subtask mid-task, Fig. 5.23).
    pub start_scene: Option<PathBuf>,
}

impl Default for SynthOptions {
    fn default() -> Self {
        Self {
            seed: 0,
            duration_s: None,
            noise: true,
            depth: true,
            config_dir: PathBuf::from("config"),
            vary_teacher: false,
            after: Vec::new(),
            start_scene: None,
        }
    }
}

impl Scenario {
    /// The demonstration of a kinesthetic scenario and its natural length (s); `None` for the
    /// others.
    pub fn demonstration(self) -> Option<(&'static pour::Demonstration, f64)> {
        match self {
            Scenario::KinestheticPour => Some((&pour::POUR, pour::NATURAL_DURATION_S)),
            Scenario::KinestheticCoffee => Some((&kitchen::COFFEE, kitchen::COFFEE_DURATION_S)),
            Scenario::KinestheticSpoon => Some((&kitchen::SPOON, kitchen::SPOON_DURATION_S)),
            Scenario::KinestheticTea => Some((&kitchen::TEA, kitchen::TEA_DURATION_S)),
            _ => None,
        }
    }

    /// The teacher of a kinesthetic scenario under `options`.
    pub fn teacher(self, options: &SynthOptions) -> pour::TeacherStyle {
        match self.demonstration() {
            Some((demo, _)) if options.vary_teacher => pour::TeacherStyle::from_seed(options.seed, demo),
            _ => pour::TeacherStyle::default(),
        }
    }
}

/// Plays the demonstrations of `options.after` in `sim` (into a scratch bag beside `path`,
/// removed) and returns a fresh simulator whose scene is their end state: the arm's joints and
/// every object where they left them (the gripper is open after each demonstration).
fn after_demonstrations(mut sim: Simulator, options: &SynthOptions, path: &Path) -> Result<Simulator> {
    let scratch = path.with_extension("before.tmp.mcap");
    for prev in &options.after {
        let Some((demo, natural)) = prev.demonstration() else {
            return Err(SynthError::BadOption {
                option: "after",
                value: prev.to_string(),
                reason: "only kinesthetic demonstrations can come before a kinesthetic one".into(),
            });
        };
        let style = prev.teacher(options);
        let plan = pour::plan_demonstration_by(&sim, demo, 1.0, &style)?;
        let mut quiet = |_: f64| {};
        let mut run = Runner::new(sim, &scratch, natural * style.pace, &mut quiet)?;
        pour::run_pour(&mut run, &plan, options.seed, options.noise, |_| Ok(()))?;
        run.streams.finish()?;
        let _ = std::fs::remove_file(&scratch);
        if let Some(held) = run.sim.held_object() {
            return Err(SynthError::Plan {
                scenario: demo.scenario,
                reason: format!("`{held}` is still held at the end of the demonstration; the next one cannot start"),
            });
        }
        // Each demonstration's bag starts at t = 0 from where the previous one left the arm
        // (as its own synthesis did); continuing the clock instead ran the path of the second
        // one from its end, so a third demonstration started from the first one's end pose.
        sim = continue_from(&run.sim)?;
    }
    Ok(sim)
}

/// A fresh simulator (t = 0) whose scene is `sim`'s current state: the arm's joints as the
/// initial joints and every object where it is now. The gripper starts open: call it between
/// demonstrations, when nothing is held.
pub fn continue_from(sim: &Simulator) -> Result<Simulator> {
    let mut scene = sim.scene().clone();
    scene.set_initial_joints_deg(sim.joint_positions().iter().map(|q| q.to_degrees()).collect());
    for o in &mut scene.objects {
        if let Some(now) = sim.objects().iter().find(|s| s.name == o.name) {
            let p = now.pose.translation.vector;
            let q = now.pose.rotation.coords;
            o.pose = cowork_sim::Pose { position: [p.x, p.y, p.z], rpy: None, quaternion_xyzw: Some([q.x, q.y, q.z, q.w]), look_at: None };
        }
    }
    Ok(Simulator::new(sim.model().clone(), scene, sim.params().clone())?)
}

/// What [`synthesize`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct SynthSummary {
    /// The scenario.
    pub scenario: Scenario,
    /// The bag.
    pub path: PathBuf,
    /// Simulated length, s.
    pub duration_s: f64,
    /// Messages per topic.
    pub counts: BTreeMap<String, u64>,
    /// File size, bytes.
    pub bytes: u64,
}

/// Loads the robot, the scenario's scene and the simulator parameters of `lwr_sim` (the
/// `simulation` block of `config/lwr_sim.yaml` when present, else the defaults).
pub fn load_simulator(config_dir: &Path, scene_file: &str) -> Result<Simulator> {
    simulator_in(config_dir, &config_dir.join("scenes").join(scene_file))
}

/// A simulator of the scene file `scene` with the robot and parameters of `config_dir`.
fn simulator_in(config_dir: &Path, scene: &Path) -> Result<Simulator> {
    let model = RobotModel::from_urdf_file(config_dir.join("robot/lwr4plus.urdf"))?;
    let scene = Scene::from_file(scene)?;
    let params = lwr_sim_params(&config_dir.join("lwr_sim.yaml"))?;
    Ok(Simulator::new(model, scene, params)?)
}

fn lwr_sim_params(path: &Path) -> Result<SimParams> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Ok(SimParams::default());
    };
    let bad = |message: String| SynthError::Sim {
        source: cowork_sim::SimError::Parse { path: path.to_owned(), message },
    };
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let block = doc
        .get("lwr_sim")
        .and_then(|n| n.get("ros__parameters"))
        .and_then(|p| p.get("simulation"));
    let params = match block {
        Some(b) => serde_yaml_ng::from_value::<SimParams>(b.clone())
            .map_err(|e| bad(format!("lwr_sim.ros__parameters.simulation: {e}")))?,
        None => SimParams::default(),
    };
    params.validate(&path.display().to_string())?;
    Ok(params)
}

fn check_duration(d: f64) -> Result<f64> {
    if d.is_finite() && d > 0.0 && d <= 3600.0 {
        Ok(d)
    } else {
        Err(SynthError::BadOption {
            option: "--duration",
            value: d.to_string(),
            reason: "must be a number of seconds in (0, 3600]".into(),
        })
    }
}

/// The simulator of a pizza demonstration's scene and its plan under `options`.
fn pizza_plan(scenario: Scenario, options: &SynthOptions) -> Result<(Simulator, pizza::PizzaPlan)> {
    let Some(arm) = scenario.pizza_arm() else {
        return Err(SynthError::Plan { scenario: "synth", reason: format!("{scenario} is not an imitation-teaching demonstration") });
    };
    let sim = load_simulator(&options.config_dir, scenario.scene_file())?;
    let plan = pizza::plan_demo(&sim, arm, &pizza::PizzaStyle::from_seed(options.seed))?;
    Ok((sim, plan))
}

/// `pizza-demo-*`: skeletons + speech + `/clock` (no depth frames: the sensor is the Xsens
/// suit; no joint states: the graph's `lwr_sim` moves the arm from the retargeted skeletons).
fn synthesize_pizza(scenario: Scenario, options: &SynthOptions, path: &Path, progress: &mut dyn FnMut(f64)) -> Result<SynthSummary> {
    if let Some(scene) = &options.start_scene {
        return Err(SynthError::BadOption {
            option: "start_scene",
            value: scene.display().to_string(),
            reason: format!("{scenario} is not a kinesthetic demonstration"),
        });
    }
    if !options.after.is_empty() {
        return Err(SynthError::BadOption {
            option: "after",
            value: options.after.iter().map(|s| s.name()).collect::<Vec<_>>().join(","),
            reason: format!("{scenario} is not a kinesthetic demonstration"),
        });
    }
    let (sim, plan) = pizza_plan(scenario, options)?;
    let duration = match options.duration_s {
        Some(d) => {
            let d = check_duration(d)?;
            if d < plan.duration_s {
                return Err(SynthError::BadOption {
                    option: "--duration",
                    value: d.to_string(),
                    reason: format!(
                        "{scenario} with seed {} lasts {:.3} s; a longer bag keeps the person still after `done`",
                        options.seed, plan.duration_s
                    ),
                });
            }
            d
        }
        None => plan.duration_s,
    };
    let counts = pizza::write_demo(&sim, &plan, path, duration, progress)?;
    progress(1.0);
    let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    Ok(SynthSummary { scenario, path: path.to_owned(), duration_s: duration, counts, bytes })
}

/// Writes the bag of `scenario` at `path`. `progress` is called with the fraction done (0..1).
pub fn synthesize(
    scenario: Scenario,
    options: &SynthOptions,
    path: &Path,
    progress: &mut dyn FnMut(f64),
) -> Result<SynthSummary> {
    if scenario.pizza_arm().is_some() {
        return synthesize_pizza(scenario, options, path, progress);
    }
    let duration = match options.duration_s {
        Some(d) => check_duration(d)?,
        None => scenario.default_duration_s(options.seed)?,
    };
    let mut sim = match &options.start_scene {
        Some(scene) if scenario.demonstration().is_some() => simulator_in(&options.config_dir, scene)?,
        Some(scene) => {
            return Err(SynthError::BadOption {
                option: "start_scene",
                value: scene.display().to_string(),
                reason: format!("{scenario} is not a kinesthetic demonstration"),
            });
        }
        None => load_simulator(&options.config_dir, scenario.scene_file())?,
    };
    if !options.after.is_empty() {
        if scenario.demonstration().is_none() {
            return Err(SynthError::BadOption {
                option: "after",
                value: options.after.iter().map(|s| s.name()).collect::<Vec<_>>().join(","),
                reason: format!("{scenario} is not a kinesthetic demonstration"),
            });
        }
        sim = after_demonstrations(sim, options, path)?;
    }
    // Depth noise gets its own stream so that adding depth does not change the other streams.
    let depth_seed = options.seed ^ 0x6465_7074_685f_6e6f;
    let mut depth = if options.depth { Some(DepthRig::new(&sim, depth_seed, options.noise)?) } else { None };
    let mut written_s = duration;
    let counts = match scenario {
        Scenario::KinestheticPour
        | Scenario::KinestheticCoffee
        | Scenario::KinestheticSpoon
        | Scenario::KinestheticTea => {
            let Some((demo, natural)) = scenario.demonstration() else {
                return Err(SynthError::Plan { scenario: "synth", reason: format!("{scenario} has no demonstration") });
            };
            let scale = duration / natural;
            if !(0.6..=5.0).contains(&scale) {
                return Err(SynthError::BadOption {
                    option: "--duration",
                    value: duration.to_string(),
                    reason: format!(
                        "{scenario} stretches its {natural} s demonstration by 0.6..5 (a faster one would exceed the joint speed limits)"
                    ),
                });
            }
            let style = scenario.teacher(options);
            let plan = pour::plan_demonstration_by(&sim, demo, scale, &style)?;
            written_s = duration * style.pace;
            let mut run = Runner::new(sim, path, written_s, progress)?;
            pour::run_pour(&mut run, &plan, options.seed, options.noise, |run| {
                if let Some(rig) = depth.as_mut() {
                    while let Some(t) = rig.due(run.now()) {
                        rig.write_frame(&mut run.streams, t, &run.sim, &[])?;
                    }
                }
                Ok(())
            })?;
            run.streams.finish()?
        }
        Scenario::StaticScene => {
            let mut run = Runner::new(sim, path, duration, progress)?;
            static_scene::run_static(&mut run, &mut depth)?;
            run.streams.finish()?
        }
        Scenario::StackingHuman => {
            let mut run = Runner::new(sim, path, duration, progress)?;
            stacking::run_stacking(&mut run, &mut depth, options.seed, options.noise)?;
            run.streams.finish()?
        }
        Scenario::PizzaDemoLeft | Scenario::PizzaDemoRight => {
            return Err(SynthError::Plan { scenario: "synth", reason: format!("{scenario} is written by synthesize_pizza") });
        }
        Scenario::Gestures => {
            let set = gestures::gesture_set(options.seed, options.duration_s)?;
            let mut run = Runner::new(sim, path, duration, progress)?;
            gestures::run_gestures(&mut run, &mut depth, &set, options.seed, options.noise)?;
            run.streams.finish()?
        }
    };
    progress(1.0);
    let bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    Ok(SynthSummary { scenario, path: path.to_owned(), duration_s: written_s, counts, bytes })
}
