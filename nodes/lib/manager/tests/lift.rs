//! Lifting a carry over a standing bottle (`TurnConfig::lift_m`, `cowork_manager::turn`) on the
//! pizza task learned in `config/learned-pizza`: `cowork experiment pizza --arms uni` seed 9,
//! where the right arm's carry of the tomato to over the pizza, one straight line from the
//! grasp at bottle height, ran through the oil standing between them; no turn of the pizza's
//! frame cleared it and the damper held the arm until the action timed out twice.

use cowork_ds::ControllerConfig;
use cowork_manager::{
    ActionKind, ActionRequest, Database, Input, Manager, ManagerConfig, MotionOrder, MotionPlan, MotionReport, MotionState, ObjectReport,
    Output, PreviewPath, Previewer, Stamp, WorldReport,
};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::Scene;
use nalgebra::{Isometry3, Vector3};

fn root() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

fn block(file: &str, node: &str, key: &str) -> serde_yaml_ng::Value {
    let text = std::fs::read_to_string(root().join("config").join(file)).expect(file);
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(&text).expect("yaml");
    doc[node]["ros__parameters"][key].clone()
}

/// The right arm of config/scenes/pizza.yaml with seed 9's ingredients (world frame).
struct Pizza {
    model: RobotModel,
    scene: Scene,
    base: Isometry3<f64>,
    db: Database,
}

fn pizza() -> Pizza {
    let model = RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).expect("urdf");
    let mut scene = Scene::from_file(&root().join("config/scenes/pizza.yaml")).expect("scene");
    for o in &mut scene.objects {
        let xy = match o.name.as_str() {
            "tomato" => [0.511, -0.530],
            "oil" => [0.540, -0.394],
            "cheese" => [0.359, -0.455],
            "basil" => [0.260, -0.546],
            _ => continue,
        };
        o.pose.position[0] = xy[0];
        o.pose.position[1] = xy[1];
    }
    let base = scene.arm_base_for_prefix("right/").expect("right arm");
    let db = Database::load(&root().join("config/learned-pizza/primitives/lwr_right.primitives.json")).expect("learned database");
    Pizza { model, scene, base, db }
}

impl Pizza {
    fn previewer(&self) -> Previewer {
        let controller: ControllerConfig = serde_yaml_ng::from_value(block("ds_controller.yaml", "ds_controller", "controller")).expect("controller");
        Previewer::new(self.model.clone(), controller, self.scene.objects.iter().map(|o| (o.name.clone(), o.shape)), 0.005)
            .expect("previewer")
            .with_up(self.base.inverse().rotation * Vector3::z())
    }

    /// Scene object `name`, the arm's base frame.
    fn object(&self, name: &str) -> Isometry3<f64> {
        self.base.inverse() * self.scene.objects.iter().find(|o| o.name == name).expect(name).pose.isometry()
    }

    fn config(&self, lift: bool) -> ManagerConfig {
        let mut cfg: ManagerConfig = serde_yaml_ng::from_value(block("robot_manager.yaml", "robot_manager", "manager")).expect("manager block");
        cfg.robot = "lwr_right".into();
        cfg.label_prefix = "r".into();
        cfg.objects = ["pizza", "tomato", "oil", "cheese", "basil"].iter().map(|o| (o.to_string(), o.to_string())).collect();
        // The right arm's block over the defaults, as the node merges them.
        let right = block("robot_manager.yaml", "/right/robot_manager", "manager");
        cfg.workspace = serde_yaml_ng::from_value(right["workspace"].clone()).expect("workspace");
        cfg.turn = serde_yaml_ng::from_value(right["turn"].clone()).expect("turn");
        assert!(!cfg.turn.lift_m.is_empty(), "the pizza arms lift");
        if !lift {
            cfg.turn.lift_m.clear();
        }
        assert!(cfg.turn.problem().is_none());
        cfg
    }

    /// The arm after take(tomato) (`rfoa1`, `rnoa2` from the scene's initial joints, previewed).
    fn holding_the_tomato(&self) -> JointVector {
        let arm = self.scene.arms.iter().find(|a| a.name == "right").expect("right arm");
        let mut q = JointVector::from_iterator(arm.initial_joints_deg.iter().map(|v| v.to_radians()));
        let tomato = self.object("tomato");
        let previewer = self.previewer();
        for id in ["rfoa1", "rnoa2"] {
            let p = self.db.get(id).expect(id);
            let tool = self.model.link_pose(&q, self.model.tip_link());
            let poses = p.rollout_poses(&tomato, &tool, 0.01).expect("rollout");
            let path = match &poses {
                Some(poses) => PreviewPath::Stream { poses, period: 0.05, gain: 8.0, tracking: 0.03 },
                None => PreviewPath::Linear { goal: p.goal_at(&tomato).expect("goal"), gain: p.linear_gain.expect("gain") },
            };
            let r = previewer.run(&q, &path, &[], 0.01);
            assert!(r.reached, "{id}: {r:?}");
            q = r.q_end;
        }
        q
    }

    fn world(&self, t: f64, tool: Isometry3<f64>) -> WorldReport {
        let objects = self
            .scene
            .objects
            .iter()
            .map(|o| {
                // Held: 5 cm under the tool.
                let pose = if o.name == "tomato" { tool * Isometry3::translation(0.0, 0.0, 0.05) } else { self.object(&o.name) };
                ObjectReport { name: o.name.clone(), pose, distance: 0.3, tilt: 0.0, visible: true }
            })
            .collect();
        WorldReport { t, tool, gripper_closed: true, held: Some("tomato".into()), objects }
    }
}

fn linear_goals(out: &[Output]) -> Vec<(u32, Isometry3<f64>)> {
    out.iter()
        .filter_map(|o| match o {
            Output::Motion(MotionOrder { id, plan: Some(MotionPlan::Linear { goal, .. }), .. }) => Some((*id, *goal)),
            _ => None,
        })
        .collect()
}

fn verdict(out: &[Output]) -> String {
    out.iter()
        .find_map(|o| match o {
            Output::Info(t) | Output::Warn(t) if t.starts_with("rfoa4(pizza): ") => Some(t.clone()),
            _ => None,
        })
        .expect("the preview's verdict")
}

/// The manager's report of a held action it rescued.
fn held_short(out: &[Output]) -> Option<String> {
    out.iter().find_map(|o| match o {
        Output::Info(t) if t.contains("held short") => Some(t.clone()),
        _ => None,
    })
}

/// The clearance after `key` in a verdict's part, m.
fn clearance(part: &str) -> f64 {
    part.split("clearance ").nth(1).and_then(|t| t.split(' ').next()).and_then(|v| v.parse().ok()).expect("clearance")
}

#[test]
fn a_carry_held_short_by_a_standing_bottle_is_lifted_over_it() {
    let k = pizza();
    let q = k.holding_the_tomato();
    let tool = k.model.link_pose(&q, k.model.tip_link());
    let start = |lift: bool| -> (Manager, Vec<Output>) {
        let mut m = Manager::new(k.config(lift), k.db.clone());
        m.set_previewer(k.previewer());
        let now = Stamp { t: 10.0, unix_s: 0 };
        let mut out = Vec::new();
        m.handle(&Input::Joints { t: 10.0, q }, now, &mut out);
        m.handle(&Input::World(k.world(10.0, tool)), now, &mut out);
        out.clear();
        m.handle(&Input::Action(ActionRequest { id: 4, label: "rfoa4(pizza)".into(), stop: false }), now, &mut out);
        (m, out)
    };
    // The tool stays where it is (the damper holds the arm off the oil) from 10 s to `until`.
    let hold = |m: &mut Manager, until: f64| -> Vec<Output> {
        let mut out = Vec::new();
        let mut t = 10.0;
        while t < until {
            t += 0.1;
            let now = Stamp { t, unix_s: 0 };
            m.handle(&Input::Joints { t, q }, now, &mut out);
            m.handle(&Input::World(k.world(t, tool)), now, &mut out);
        }
        out
    };

    // The straight carry runs first: one motion to the goal, whatever its preview says.
    let (mut m, out) = start(true);
    let straight = verdict(&out);
    eprintln!("straight: {straight}");
    assert!(straight.contains("at oil") && clearance(straight.rsplit("now: ").next().expect("verdict")) < 0.05, "the carry passes the oil: {straight}");
    let goals = linear_goals(&out);
    assert_eq!(goals.len(), 1, "one straight motion");
    let (id0, goal) = goals[0];
    // Held 7.9 s: still straight on.
    assert!(linear_goals(&hold(&mut m, 17.9)).is_empty(), "not stalled yet");

    // Held 8 s: lifted from here, up, across above the goal, down onto it.
    let (mut m, _) = start(true);
    let out = hold(&mut m, 18.05);
    let lifted = held_short(&out).expect("the stall is reported");
    eprintln!("stalled: {lifted}");
    assert!(clearance(lifted.rsplit("lifted: ").next().expect("lifted part")) > clearance(&lifted), "the lift gains clearance: {lifted}");
    let h: f64 = lifted.split("lifted ").nth(1).and_then(|t| t.split(' ').next()).and_then(|v| v.parse().ok()).expect("height");
    assert!(k.config(true).turn.lift_m.contains(&h));
    let up = k.base.inverse().rotation * Vector3::z();
    let goals = linear_goals(&out);
    assert_eq!(goals.len(), 1, "the first leg only: {out:?}");
    let (id1, via1) = goals[0];
    assert!(id1 > id0);
    assert!((via1.translation.vector - (tool.translation.vector + up * h)).norm() < 1e-9, "straight up from where the tool is held");
    // Lifted once: held again, nothing more.
    assert!(linear_goals(&hold(&mut m, 30.0)).is_empty(), "a stalled action is lifted once");

    // The tool passes the first via point: the second leg; that one: the carry's own goal.
    let mut out = Vec::new();
    let near = |p: &Isometry3<f64>| Isometry3::from_parts((p.translation.vector + Vector3::new(0.01, 0.0, 0.0)).into(), p.rotation);
    m.handle(&Input::World(k.world(31.0, near(&via1))), Stamp { t: 31.0, unix_s: 0 }, &mut out);
    let goals = linear_goals(&out);
    assert_eq!(goals.len(), 1, "{out:?}");
    let (id2, via2) = goals[0];
    assert!(id2 > id1);
    assert!((via2.translation.vector - (goal.translation.vector + up * h)).norm() < 1e-9, "h above the goal");
    out.clear();
    // Converging on a via point starts the next leg too.
    m.handle(&Input::Motion(MotionReport { command_id: id2, state: MotionState::Converged, reason: String::new() }), Stamp { t: 33.0, unix_s: 0 }, &mut out);
    let goals = linear_goals(&out);
    assert_eq!(goals.len(), 1, "{out:?}");
    let (id3, last) = goals[0];
    assert!((last.translation.vector - goal.translation.vector).norm() < 1e-9, "down onto the goal");
    assert!(!out.iter().any(|o| matches!(o, Output::Action(a) if a.done)), "not done at a via point");
    out.clear();
    m.handle(&Input::Motion(MotionReport { command_id: id3, state: MotionState::Converged, reason: String::new() }), Stamp { t: 35.0, unix_s: 0 }, &mut out);
    assert!(
        out.iter().any(|o| matches!(o, Output::Action(a) if a.done && a.kind == ActionKind::Foa && a.label == "rfoa4(pizza)")),
        "done at the goal: {out:?}"
    );

    // Without lift heights (the kitchen's way): never lifted; the pizza's frame is turnable,
    // so the held carry gets another turn instead, once.
    let (mut m, _) = start(false);
    let out = hold(&mut m, 30.0);
    let turned = held_short(&out).expect("the stall is reported");
    assert!(turned.contains("pizza turned") && !turned.contains("lifted"), "lift_m empty: turned, not lifted: {turned}");
    assert!(linear_goals(&out).len() <= 1, "rescued once: {out:?}");
}

/// A pour held short (the forearm held over a bottle, `uni` seed 2 of the first lifted table):
/// its reference time stops; after `stall_s` the pizza's frame is turned another way from
/// where the arm is and the rollout restarts there.
#[test]
fn a_pour_held_short_is_turned_another_way() {
    let k = pizza();
    let q0 = k.holding_the_tomato();
    // Carried over the pizza as taught (previewed).
    let pizza_pose = k.object("pizza");
    let carry = k.db.get("rfoa4").expect("rfoa4");
    let path = PreviewPath::Linear { goal: carry.goal_at(&pizza_pose).expect("goal"), gain: carry.linear_gain.expect("gain") };
    let q = k.previewer().run(&q0, &path, &[], 0.01).q_end;
    let tool = k.model.link_pose(&q, k.model.tip_link());
    let mut m = Manager::new(k.config(true), k.db.clone());
    m.set_previewer(k.previewer());
    let mut out = Vec::new();
    let now = Stamp { t: 10.0, unix_s: 0 };
    m.handle(&Input::Joints { t: 10.0, q }, now, &mut out);
    m.handle(&Input::World(k.world(10.0, tool)), now, &mut out);
    m.handle(&Input::Action(ActionRequest { id: 5, label: "rnoa5(pizza)".into(), stop: false }), now, &mut out);
    let first = linear_goals(&out);
    assert_eq!(first.len(), 1, "the stream's first goal: {out:?}");
    // The tool stays where it is: the reference advances while it is within tracking reach of
    // the tool, then stops.
    let mut out = Vec::new();
    let mut t = 10.0;
    let mut turned_at = None;
    while t < 60.0 && turned_at.is_none() {
        t += 0.1;
        m.handle(&Input::Joints { t, q }, Stamp { t, unix_s: 0 }, &mut out);
        m.handle(&Input::World(k.world(t, tool)), Stamp { t, unix_s: 0 }, &mut out);
        if held_short(&out).is_some() {
            turned_at = Some(t);
        }
    }
    let turned_at = turned_at.expect("the stalled pour is turned");
    assert!(turned_at >= 18.0, "not before stall_s: {turned_at}");
    let turned = held_short(&out).expect("the stalled pour is turned");
    eprintln!("{turned}");
    assert!(turned.contains("pizza turned") && !turned.contains("turned +0°"), "{turned}");
    let restarted = linear_goals(&out);
    assert!(!restarted.is_empty() && restarted[0].0 > first[0].0, "the rollout restarts: {out:?}");
}
