//! Turning the cup's frame (`cowork_manager::turn`) on the coffee task learned in
//! `config/learned`: the jar carried over the cup and poured with the bottle put back beside
//! the cup where coffee-cooperative seed 3 left it.

mod common;

use common::{bundled_config, controller};
use cowork_manager::{
    ActionRequest, Database, Input, Manager, ManagerConfig, MotionOrder, MotionPlan, ObjectReport, Output, PreviewPath, Previewer, Stamp,
    WorldReport,
};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::Scene;
use nalgebra::{Isometry3, Vector3};



struct Kitchen {
    model: RobotModel,
    previewer: Previewer,
    db: Database,
    scene: Scene,
}

fn kitchen() -> Kitchen {
    let (model, scene, db) = common::kitchen_parts();
    let previewer = Previewer::new(model.clone(), controller(), scene.objects.iter().map(|o| (o.name.clone(), o.shape)), 0.005).expect("previewer");
    Kitchen { model, previewer, db, scene }
}

fn object(k: &Kitchen, name: &str) -> Isometry3<f64> {
    k.scene.objects.iter().find(|o| o.name == name).expect(name).pose.isometry()
}

fn world(k: &Kitchen, q: &JointVector, bottle: Isometry3<f64>) -> WorldReport {
    let tool = k.model.link_pose(q, k.model.tip_link());
    let objects = k
        .scene
        .objects
        .iter()
        .map(|o| {
            let pose = match o.name.as_str() {
                "bottle" => bottle,
                // Held: 10 cm under the tool.
                "coffee" => tool * Isometry3::translation(0.0, 0.0, 0.10),
                _ => o.pose.isometry(),
            };
            ObjectReport { name: o.name.clone(), pose, distance: 0.3, tilt: 0.0, visible: true }
        })
        .collect();
    WorldReport { t: 10.0, tool, gripper_closed: true, held: Some("coffee".into()), objects }
}

/// The arm after take(coffee) (`foa9`, `noa10` from the ready pose, previewed).
fn holding_the_jar(k: &Kitchen) -> JointVector {
    let deg = |d: [f64; 7]| JointVector::from_iterator(d.iter().map(|v| v.to_radians()));
    let mut q = deg([0.0, 30.0, 0.0, 90.0, 0.0, 60.0, 0.0]);
    let jar = object(k, "coffee");
    for id in ["foa9", "noa10"] {
        let p = k.db.get(id).expect(id);
        let tool = k.model.link_pose(&q, k.model.tip_link());
        let poses = p.rollout_poses(&jar, &tool, 0.01).expect("rollout");
        let path = match &poses {
            Some(poses) => PreviewPath::Stream { poses, period: 0.05, gain: 8.0, tracking: 0.03 },
            None => PreviewPath::Linear { goal: p.goal_at(&jar).expect("goal"), gain: p.linear_gain.expect("gain") },
        };
        let r = k.previewer.run(&q, &path, &[], 0.01);
        assert!(r.reached, "{id}: {r:?}");
        q = r.q_end;
    }
    q
}

/// Asks a manager with a previewer for `foa12(cup)` (carry the jar over the cup) with the bottle
/// at `bottle`; returns its outputs and the turn of the cup's frame it chose (deg), read from
/// the goal it sent against the taught one.
fn carry_over_the_cup(k: &Kitchen, bottle: Isometry3<f64>) -> (Vec<Output>, f64) {
    let mut m = Manager::new(ManagerConfig::default(), k.db.clone());
    m.set_previewer(Previewer::new(k.model.clone(), controller(), k.scene.objects.iter().map(|o| (o.name.clone(), o.shape)), 0.005).expect("previewer"));
    let q = holding_the_jar(k);
    let now = Stamp { t: 10.0, unix_s: 0 };
    let mut out = Vec::new();
    m.handle(&Input::Joints { t: 10.0, q }, now, &mut out);
    m.handle(&Input::World(world(k, &q, bottle)), now, &mut out);
    out.clear();
    m.handle(&Input::Action(ActionRequest { id: 1, label: "foa12(cup)".into(), stop: false }), now, &mut out);
    let goal = out
        .iter()
        .find_map(|o| match o {
            Output::Motion(MotionOrder { plan: Some(MotionPlan::Linear { goal, .. }), .. }) => Some(*goal),
            _ => None,
        })
        .expect("a linear motion to over the cup");
    let cup = object(k, "cup");
    let taught = k.db.get("foa12").expect("foa12").goal_at(&cup).expect("goal");
    let a = taught.translation.vector - cup.translation.vector;
    let b = goal.translation.vector - cup.translation.vector;
    (out, (a.x * b.y - a.y * b.x).atan2(a.x * b.x + a.y * b.y).to_degrees())
}

/// Coffee-cooperative seed 3's failure, without DDS: the bottle put back at (0.50, 0.28) beside
/// the cup. Previewed with the taught yaw, the carry and pour bring link 4 within millimetres of
/// it (in the graph the damper then held the pour 2 × 120 s); the manager turns the cup's frame
/// so the whole carry-and-pour keeps the clearance, and leaves it as taught when the bottle
/// stands where it was taught.
#[test]
fn the_cup_frame_turns_away_from_a_bottle_put_back_beside_the_cup() {
    let k = kitchen();
    let (out, turn) = carry_over_the_cup(&k, Isometry3::translation(0.50, 0.28, 0.11));
    let info: Vec<&String> = out.iter().filter_map(|o| if let Output::Info(t) = o { Some(t) } else { None }).collect();
    eprintln!("bottle beside the cup: turned {turn:+.1}°: {info:?}");
    let line = info.iter().find(|t| t.contains("turned")).expect("a turn is reported");
    assert!(line.contains("noa13(cup)") && line.contains("bottle"), "the taught pour comes close to the bottle: {line}");
    assert!(turn.abs() >= 14.0, "turned {turn}°");
    // The turned chain: clear of the damper's scene stop distance (3 cm) with a centimetre to
    // spare — no turn keeps the 6 cm asked for among the kitchen's objects here — and the
    // joints (the wrist) off their limits (the taught chain: 2°).
    let turned_part = line.rsplit("now: ").next().expect("turned part");
    let number = |key: &str| -> f64 {
        turned_part.split(key).nth(1).and_then(|t| t.split([' ', '°']).next()).and_then(|v| v.parse().ok()).expect(key)
    };
    assert!(number("clearance ") >= 0.04, "{line}");
    assert!(number("joint margin ") >= ManagerConfig::default().turn.joint_margin_deg, "{line}");

    let (out, turn) = carry_over_the_cup(&k, object(&k, "bottle"));
    assert!(turn.abs() < 0.5, "bottle where it was taught: turned {turn}°");
    assert!(!out.iter().any(|o| matches!(o, Output::Info(t) if t.contains("turned"))));

    // The same spot, tilted 100°: a person pouring from it over the cup — not at rest, not
    // avoided (it will be put back elsewhere).
    let pouring = Isometry3::new(Vector3::new(0.50, 0.28, 0.25), Vector3::x() * 100f64.to_radians());
    let (_, turn) = carry_over_the_cup(&k, pouring);
    assert!(turn.abs() < 0.5, "a bottle being poured is not avoided: turned {turn}°");
}



/// Coffee-cooperative seed 7's failure, without DDS: the jar's carry over the cup was previewed
/// while the person still had the bottle (not at rest: not avoided), the bottle was then put
/// down beside the cup, and the damper held the arm off it until the action timed out (120 s)
/// and the trial's time ran out. With the kitchen's `turn.stall_s` the carry, held 8 s with no
/// centimetre gained, gets the best other turn of the cup's frame, previewed from where the
/// arm is with the bottle now at rest, and is sent to its goal there; once.
#[test]
fn a_carry_over_the_cup_held_short_is_turned_another_way() {
    let k = kitchen();
    let cfg = bundled_config();
    assert!(cfg.turn.stall_s > 0.0 && cfg.turn.lift_m.is_empty(), "the kitchen turns a held carry, it does not lift it");
    let q = holding_the_jar(&k);
    let mut m = Manager::new(cfg, k.db.clone());
    m.set_previewer(Previewer::new(k.model.clone(), controller(), k.scene.objects.iter().map(|o| (o.name.clone(), o.shape)), 0.005).expect("previewer"));
    let at = |t: f64, bottle: Isometry3<f64>| WorldReport { t, ..world(&k, &q, bottle) };
    let pouring = Isometry3::new(Vector3::new(0.50, 0.28, 0.25), Vector3::x() * 100f64.to_radians());
    let beside = Isometry3::translation(0.50, 0.28, 0.11);
    let mut out = Vec::new();
    let now = |t: f64| Stamp { t, unix_s: 0 };
    m.handle(&Input::Joints { t: 10.0, q }, now(10.0), &mut out);
    m.handle(&Input::World(at(10.0, pouring)), now(10.0), &mut out);
    out.clear();
    m.handle(&Input::Action(ActionRequest { id: 1, label: "foa12(cup)".into(), stop: false }), now(10.0), &mut out);
    let goals = |out: &[Output]| -> Vec<Isometry3<f64>> {
        out.iter()
            .filter_map(|o| match o {
                Output::Motion(MotionOrder { plan: Some(MotionPlan::Linear { goal, .. }), .. }) => Some(*goal),
                _ => None,
            })
            .collect()
    };
    let first = goals(&out);
    assert_eq!(first.len(), 1, "{out:?}");
    // The bottle put down beside the cup; the arm held where it is.
    let mut out = Vec::new();
    let mut t = 10.0;
    let mut rescued_at = None;
    while t < 40.0 {
        t += 0.1;
        m.handle(&Input::Joints { t, q }, now(t), &mut out);
        m.handle(&Input::World(at(t, beside)), now(t), &mut out);
        if rescued_at.is_none() && !goals(&out).is_empty() {
            rescued_at = Some(t);
        }
    }
    let rescued_at = rescued_at.expect("the held carry is rescued");
    assert!(rescued_at >= 18.0, "not before stall_s: {rescued_at}");
    let line = out
        .iter()
        .find_map(|o| match o {
            Output::Info(t) if t.contains("held short") => Some(t.clone()),
            _ => None,
        })
        .expect("the rescue is reported");
    eprintln!("{line}");
    assert!(line.contains("cup turned") && !line.contains("turned +0°"), "{line}");
    let sent = goals(&out);
    assert_eq!(sent.len(), 1, "sent once, to the goal in the turned frame: {out:?}");
    let cup = object(&k, "cup");
    let (a, b) = (first[0].translation.vector - cup.translation.vector, sent[0].translation.vector - cup.translation.vector);
    assert!((a.z - b.z).abs() < 1e-9 && (a.xy().norm() - b.xy().norm()).abs() < 1e-9, "the same goal about the cup's axis, turned");
    assert!(first[0].rotation.angle_to(&sent[0].rotation) > 10f64.to_radians(), "turned: {line}");
}

/// "Upright" is the world's up in the arm's base frame (`Previewer::with_up`): for an arm on a
/// shoulder (the pizza's, base z horizontal) a standing bottle lies along the base's y, and
/// judged by the base's z no bottle ever rested, so no preview avoided one (`cowork experiment
/// pizza --arms uni` seed 2: "kept at +0° … clearance 1.000 m" while the pour held the forearm
/// 3 cm above the basil).
#[test]
fn objects_stand_upright_along_the_worlds_up() {
    let k = kitchen();
    let q = holding_the_jar(&k);
    // The bottle with its axis along the base's +y, beside the cup.
    let along_y = Isometry3::new(Vector3::new(0.50, 0.28, 0.11), Vector3::x() * (-90f64).to_radians());
    assert!(((along_y.rotation * Vector3::z()) - Vector3::y()).norm() < 1e-12);
    let kept_or_turned = |up: Vector3<f64>| -> String {
        let mut m = Manager::new(ManagerConfig::default(), k.db.clone());
        let previewer = Previewer::new(k.model.clone(), controller(), k.scene.objects.iter().map(|o| (o.name.clone(), o.shape)), 0.005).expect("previewer");
        m.set_previewer(previewer.with_up(up));
        let mut w = world(&k, &q, along_y);
        w.objects.retain(|o| ["cup", "coffee", "bottle"].contains(&o.name.as_str()));
        let now = Stamp { t: 10.0, unix_s: 0 };
        let mut out = Vec::new();
        m.handle(&Input::Joints { t: 10.0, q }, now, &mut out);
        m.handle(&Input::World(w), now, &mut out);
        out.clear();
        m.handle(&Input::Action(ActionRequest { id: 1, label: "foa12(cup)".into(), stop: false }), now, &mut out);
        out.iter()
            .find_map(|o| match o {
                Output::Info(t) | Output::Warn(t) if t.starts_with("foa12(cup): cup") => Some(t.clone()),
                _ => None,
            })
            .expect("the preview's verdict")
    };
    let base_z = kept_or_turned(Vector3::z());
    assert!(base_z.contains("kept at +0°") && base_z.contains("clearance 1.000 m"), "tilted 90° from the base's z: not at rest, not avoided: {base_z}");
    let world_up = kept_or_turned(Vector3::y());
    assert!(world_up.contains("bottle"), "upright along the world's up: at rest, previewed against: {world_up}");
}
