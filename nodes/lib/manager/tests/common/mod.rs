//! A scripted demonstration on a mock clock: the tool moves along straight pieces, objects
//! stand still unless held, the gripper grasps the object within reach — enough to drive the
//! manager without a simulator.
#![allow(dead_code)]

use cowork_manager::{Input, Manager, ObjectReport, Output, Stamp, WorldReport};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

pub fn down() -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
}

pub fn at(x: f64, y: f64, z: f64) -> Isometry3<f64> {
    Isometry3::from_parts(Translation3::new(x, y, z), down())
}

/// A ball-object world: distance = |tool − centre| − radius (the bottle a 0.11 m ball).
#[derive(Debug, Clone)]
pub struct ToyWorld {
    pub t: f64,
    pub tool: Isometry3<f64>,
    pub objects: Vec<(String, Isometry3<f64>, f64, bool)>,
    pub closed: bool,
    pub held: Option<usize>,
    pub grasp: Isometry3<f64>,
}

impl ToyWorld {
    pub fn kitchen() -> Self {
        Self {
            t: 0.0,
            tool: at(0.3, 0.0, 0.5),
            objects: vec![
                ("bottle".into(), Isometry3::translation(0.45, 0.35, 0.11), 0.11, true),
                ("cup".into(), Isometry3::translation(0.60, 0.00, 0.05), 0.05, true),
            ],
            closed: false,
            held: None,
            grasp: Isometry3::identity(),
        }
    }

    pub fn report(&self) -> WorldReport {
        let p = self.tool.translation.vector;
        WorldReport {
            t: self.t,
            tool: self.tool,
            gripper_closed: self.closed,
            held: self.held.map(|i| self.objects[i].0.clone()),
            objects: self
                .objects
                .iter()
                .map(|(n, pose, r, vis)| ObjectReport {
                    name: n.clone(),
                    pose: *pose,
                    distance: ((p - pose.translation.vector).norm() - r).max(0.0),
                    tilt: 0.0,
                    visible: *vis,
                })
                .collect(),
        }
    }

    pub fn gripper(&mut self, close: bool) {
        if !close {
            self.closed = false;
            self.held = None;
            return;
        }
        self.closed = true;
        let p = self.tool.translation.vector;
        self.held = self
            .objects
            .iter()
            .position(|(_, pose, r, _)| (p - pose.translation.vector).norm() - r <= 0.05);
        if let Some(i) = self.held {
            self.grasp = self.tool.inverse() * self.objects[i].1;
        }
    }

    pub fn step(&mut self, dt: f64) {
        self.t = ((self.t + dt) * 1e6).round() * 1e-6;
        if let Some(i) = self.held {
            self.objects[i].1 = self.tool * self.grasp;
        }
    }
}

/// Drives a manager with a toy world at 100 Hz.
pub struct Driver {
    pub world: ToyWorld,
    pub manager: Manager,
    pub out: Vec<Output>,
}

impl Driver {
    pub fn new(manager: Manager) -> Self {
        let mut d = Self { world: ToyWorld::kitchen(), manager, out: Vec::new() };
        d.feed_world();
        d
    }

    pub fn stamp(&self) -> Stamp {
        Stamp { t: self.world.t, unix_s: 1_700_000_000 }
    }

    pub fn input(&mut self, i: Input) {
        let s = self.stamp();
        self.manager.handle(&i, s, &mut self.out);
    }

    pub fn feed_world(&mut self) {
        let r = self.world.report();
        self.input(Input::World(r));
    }

    /// Moves the tool to `goal` in `duration` s (minimum jerk), reporting at 100 Hz.
    pub fn move_to(&mut self, goal: Isometry3<f64>, duration: f64) {
        let start = self.world.tool;
        let n = (duration * 100.0).round() as usize;
        for i in 1..=n {
            let s = i as f64 / n as f64;
            let mj = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
            let p = start.translation.vector.lerp(&goal.translation.vector, mj);
            let q = start.rotation.slerp(&goal.rotation, mj);
            self.world.tool = Isometry3::from_parts(Translation3::from(p), q);
            self.world.step(0.01);
            self.feed_world();
            self.input(Input::Tick);
        }
    }

    pub fn wait(&mut self, duration: f64) {
        let goal = self.world.tool;
        self.move_to(goal, duration);
    }

    pub fn say(&mut self, words: &str) {
        self.input(Input::Speech(words.into()));
        for o in self.out.clone() {
            if let Output::Gripper(c) = o {
                self.world.gripper(c == cowork_manager::GripperCommand::Close);
            }
        }
    }

    /// Output log since the last call.
    pub fn take(&mut self) -> Vec<Output> {
        std::mem::take(&mut self.out)
    }
}

pub fn segments(out: &[Output]) -> Vec<String> {
    out.iter()
        .filter_map(|o| match o {
            Output::Segment(s) => Some(s.label.clone()),
            _ => None,
        })
        .collect()
}

pub fn warnings(out: &[Output]) -> Vec<String> {
    out.iter()
        .filter_map(|o| match o {
            Output::Warn(w) => Some(w.clone()),
            _ => None,
        })
        .collect()
}

/// A pour-like demonstration: approach the bottle, grasp, carry over the cup, tilt, place, release.
pub fn teach_pour(d: &mut Driver) {
    d.say("teach");
    d.wait(0.5);
    let b = d.world.objects[0].1.translation.vector;
    d.move_to(at(b.x, b.y, 0.40), 2.0);
    d.move_to(at(b.x, b.y, 0.24), 1.5);
    d.say("gripper close");
    d.wait(0.3);
    d.move_to(at(b.x, b.y, 0.42), 1.5);
    let c = d.world.objects[1].1.translation.vector;
    d.move_to(at(c.x, c.y - 0.05, 0.40), 2.0);
    let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -1.5) * down();
    d.move_to(Isometry3::from_parts(Translation3::new(c.x, c.y - 0.05, 0.18), tilt), 2.0);
    d.wait(0.5);
    d.move_to(at(c.x, c.y - 0.05, 0.40), 1.5);
    d.move_to(at(0.42, 0.20, 0.30), 2.0);
    d.move_to(at(0.42, 0.20, 0.24), 1.0);
    d.say("gripper open");
    d.wait(0.3);
    d.move_to(at(0.42, 0.20, 0.40), 1.0);
    d.say("done");
}

/// The simulator's state as `lwr_sim` reports it on `/lwr/world`.
pub fn sim_report(sim: &cowork_sim::Simulator) -> WorldReport {
    let tool = sim.tool_pose();
    let point = nalgebra::Point3::from(tool.translation.vector);
    WorldReport {
        t: sim.time_ns() as f64 * 1e-9,
        tool,
        gripper_closed: matches!(sim.gripper(), cowork_sim::GripperState::Closed { .. }),
        held: sim.held_object().map(str::to_owned),
        objects: sim
            .objects()
            .iter()
            .map(|o| ObjectReport { name: o.name.clone(), pose: o.pose, distance: o.distance_to(&point), tilt: 0.0, visible: true })
            .collect(),
    }
}

/// A kinesthetic-teaching bag replayed into the kitchen simulator (as `lwr_sim` would move
/// under its wrenches), its speech and a 100 Hz world report fed to a fresh manager with the
/// default configuration: the manager (with what it learned) and every output.
pub fn learn_from_bag(bag: &std::path::Path, config_dir: &std::path::Path) -> (Manager, Vec<Output>) {
    use cowork_manager::{Database, ManagerConfig};
    let mut sim = cowork_synth::load_simulator(config_dir, "kitchen.yaml").expect("simulator");
    let mut speech = Vec::new();
    for m in cowork_bag::BagReader::open(bag).expect("bag").messages() {
        let m = m.expect("message");
        if &*m.topic == "/speech_command" {
            let s: cowork_msgs::std_msgs::String = m.decode().expect("speech");
            speech.push((m.log_time_ns as i64, s.data));
        }
    }
    let mut manager = Manager::new(ManagerConfig::default(), Database::new("lwr"));
    let mut out: Vec<Output> = Vec::new();
    let stamp = |t: f64| Stamp { t, unix_s: 0 };
    manager.handle(&Input::World(sim_report(&sim)), stamp(0.0), &mut out);
    let mut next = 0;
    cowork_synth::replay_teaching(bag, &mut sim, 1.0, |s| {
        let t = s.time_ns() as f64 * 1e-9;
        while next < speech.len() && speech[next].0 < s.time_ns() {
            manager.handle(&Input::Speech(speech[next].1.clone()), stamp(t), &mut out);
            next += 1;
        }
        if s.time_ns() % 10_000_000 == 0 {
            manager.handle(&Input::World(sim_report(s)), stamp(t), &mut out);
        }
    })
    .expect("replay");
    (manager, out)
}

/// The motion orders in `out`, in order.
pub fn orders(out: &[Output]) -> Vec<cowork_manager::MotionOrder> {
    out.iter()
        .filter_map(|o| match o {
            Output::Motion(m) => Some(m.clone()),
            _ => None,
        })
        .collect()
}

/// The repository root.
pub fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

/// The `controller:` block of config/ds_controller.yaml: what the node previews with.
pub fn controller() -> cowork_ds::ControllerConfig {
    let text = std::fs::read_to_string(root().join("config/ds_controller.yaml")).expect("ds_controller.yaml");
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(&text).expect("yaml");
    serde_yaml_ng::from_value(doc["ds_controller"]["ros__parameters"]["controller"].clone()).expect("controller block")
}

/// The manager block of config/robot_manager.yaml (the kitchen arm), as the node reads it.
pub fn bundled_config() -> cowork_manager::ManagerConfig {
    let text = std::fs::read_to_string(root().join("config/robot_manager.yaml")).expect("robot_manager.yaml");
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(&text).expect("yaml");
    let cfg: cowork_manager::ManagerConfig =
        serde_yaml_ng::from_value(doc["robot_manager"]["ros__parameters"]["manager"].clone()).expect("manager block");
    assert!(cfg.turn.problem().is_none());
    cfg
}

/// The kitchen arm and what it works with: the LWR model, config/scenes/kitchen.yaml and the
/// coffee task's learned primitives (config/learned).
pub fn kitchen_parts() -> (cowork_robot::RobotModel, cowork_sim::Scene, cowork_manager::Database) {
    let model = cowork_robot::RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("urdf");
    let scene = cowork_sim::Scene::from_file(&root().join("config/scenes/kitchen.yaml")).expect("scene");
    let db = cowork_manager::Database::load(&root().join("config/learned/primitives/lwr.primitives.json")).expect("learned database");
    (model, scene, db)
}
