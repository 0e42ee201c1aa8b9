//! The way round (`cowork_manager::turn`, `turn.way_round`), on the coffee task learned in
//! `config/learned`: an approach whose preview from the arm's joints stops short goes back to
//! the ready pose in joint space first.

mod common;

use common::{bundled_config, controller};
use cowork_manager::{
    ActionRequest, Database, Input, Manager, ManagerConfig, MotionOrder, MotionPlan, MotionReport, MotionState, ObjectReport, Output,
    Previewer, Stamp, WorldReport,
};
use cowork_robot::{JointVector, RobotModel};
use cowork_sim::Scene;
use nalgebra::{Isometry3, Translation3, UnitQuaternion};


fn deg(d: &[f64]) -> JointVector {
    JointVector::from_iterator(d.iter().map(|v| v.to_radians()))
}



struct Kitchen {
    model: RobotModel,
    scene: Scene,
    db: Database,
    ready: JointVector,
}

fn kitchen() -> Kitchen {
    let (model, scene, db) = common::kitchen_parts();
    let ready = deg(scene.initial_joints_deg());
    Kitchen { model, scene, db, ready }
}

fn manager(k: &Kitchen, cfg: ManagerConfig, ready: bool) -> Manager {
    let mut m = Manager::new(cfg, k.db.clone());
    let p = Previewer::new(k.model.clone(), controller(), k.scene.objects.iter().map(|o| (o.name.clone(), o.shape)), 0.005).expect("previewer");
    m.set_previewer(if ready { p.with_ready(k.ready) } else { p });
    m
}

/// The world of coffee-closed-bottle seed 2 when the jar's retreat `noa16(coffee)` was done: the
/// hand free above the jar put back at (0.42, -0.21), the bottle at (0.49, 0.37).
fn world(k: &Kitchen, q: &JointVector, t: f64) -> WorldReport {
    let tool = k.model.link_pose(q, k.model.tip_link());
    let objects = k
        .scene
        .objects
        .iter()
        .map(|o| {
            let pose = match o.name.as_str() {
                "bottle" => Isometry3::from_parts(Translation3::new(0.4908, 0.3742, 0.11), UnitQuaternion::identity()),
                "coffee" => Isometry3::from_parts(Translation3::new(0.4156, -0.2054, 0.06), UnitQuaternion::identity()),
                _ => o.pose.isometry(),
            };
            ObjectReport { name: o.name.clone(), pose, distance: 0.3, tilt: 0.0, visible: true }
        })
        .collect();
    WorldReport { t, tool, gripper_closed: false, held: None, objects }
}

/// Seed 2's arm then (recorded): the pour turned +150° left joint 6 on its −120° limit and
/// joint 3 at −118°, the tool pointing down as in the ready pose.
fn wound_up() -> JointVector {
    deg(&[18.92, 102.95, -118.03, 106.33, -84.26, -120.0, 97.4])
}

fn motions(out: &[Output]) -> Vec<MotionOrder> {
    out.iter()
        .filter_map(|o| match o {
            Output::Motion(m) => Some(m.clone()),
            _ => None,
        })
        .collect()
}

/// Starts `foa1(water)` (the approach to the bottle) from joints `q`; returns the outputs of
/// the start and of the next world report.
fn approach(m: &mut Manager, k: &Kitchen, q: JointVector) -> (Vec<Output>, Vec<Output>) {
    let now = |t: f64| Stamp { t, unix_s: 0 };
    let mut out = Vec::new();
    m.handle(&Input::Joints { t: 10.0, q }, now(10.0), &mut out);
    m.handle(&Input::World(world(k, &q, 10.0)), now(10.0), &mut out);
    out.clear();
    m.handle(&Input::Action(ActionRequest { id: 1, label: "foa1(water)".into(), stop: false }), now(10.0), &mut out);
    let mut next = Vec::new();
    m.handle(&Input::Joints { t: 10.01, q }, now(10.01), &mut next);
    m.handle(&Input::World(world(k, &q, 10.01)), now(10.01), &mut next);
    (out, next)
}

/// Coffee-closed-bottle seed 2's failure, without DDS: from the wound-up arm the approach to the
/// water bottle drove joint 7 onto its +170° limit and stood 5 cm short for 120 s. The approach
/// is sent at once; previewed on the next world report it stops short, so the manager sends a
/// joint move back to the ready pose and, once the controller reports it converged, the same
/// approach. From the ready pose, nothing of this happens. It fails on the code before the way
/// round: the approach was sent and left as it was.
#[test]
fn an_approach_from_a_wound_up_arm_goes_back_to_the_ready_pose_first() {
    let k = kitchen();
    let cfg = bundled_config();
    assert!(cfg.turn.way_round, "on in the bundled configuration");
    let mut m = manager(&k, cfg.clone(), true);
    let (start, next) = approach(&mut m, &k, wound_up());
    let first = motions(&start);
    let Some(MotionPlan::Linear { goal, .. }) = first.first().and_then(|o| o.plan.clone()) else {
        panic!("the approach goes out at once, unpreviewed: {start:?}")
    };
    let line = next
        .iter()
        .find_map(|o| match o {
            Output::Info(t) if t.contains("ready pose") => Some(t.clone()),
            _ => None,
        })
        .unwrap_or_else(|| panic!("the way round is reported: {next:?}"));
    eprintln!("{line}");
    assert!(line.starts_with("foa1(water): straight on it stops") && line.contains("(reaches"), "{line}");
    let unwind = motions(&next);
    assert_eq!(unwind.len(), 1, "{next:?}");
    let Some(MotionPlan::Joints { joints, tool, .. }) = unwind[0].plan.clone() else { panic!("a joint move: {unwind:?}") };
    assert_eq!(joints, k.ready);
    assert!((tool.translation.vector - k.model.link_pose(&k.ready, k.model.tip_link()).translation.vector).norm() < 1e-9);
    // Converged: the approach again, to the same goal.
    let mut out = Vec::new();
    let report = MotionReport { command_id: unwind[0].id, state: MotionState::Converged, reason: String::new() };
    m.handle(&Input::Motion(report), Stamp { t: 17.0, unix_s: 0 }, &mut out);
    let again = motions(&out);
    assert!(
        matches!(again.as_slice(), [MotionOrder { plan: Some(MotionPlan::Linear { goal: g, .. }), .. }] if *g == goal),
        "{out:?}"
    );
    assert!(!out.iter().any(|o| matches!(o, Output::Action(a) if a.done)), "not done before the approach converges: {out:?}");

    // From the ready pose the approach reaches: no joint move.
    let mut m = manager(&k, cfg.clone(), true);
    let (_, next) = approach(&mut m, &k, k.ready);
    assert!(motions(&next).is_empty() && !next.iter().any(|o| matches!(o, Output::Info(t) | Output::Warn(t) if t.contains("short"))), "{next:?}");

    // Off, or with no ready pose known: the approach runs on as it was.
    let mut m = manager(&k, ManagerConfig { turn: cowork_manager::TurnConfig { way_round: false, ..cfg.turn.clone() }, ..cfg.clone() }, true);
    assert!(motions(&approach(&mut m, &k, wound_up()).1).is_empty());
    let mut m = manager(&k, cfg, false);
    assert!(motions(&approach(&mut m, &k, wound_up()).1).is_empty());
}

/// Coffee-cooperative seed 9's failure, without DDS: `foa17(spoon)` (the approach to the spoon)
/// previewed from the start reaches, and in the graph it stood 1.5 cm short with joint 7 on
/// its limit until the action timed out. Held short for `turn.stall_s` (8 s) with no
/// centimetre gained, the empty hand is unwound from where it stands: the joint move back to
/// the ready pose, then the approach again. Not before 8 s, once, and never with an object in
/// the hand.
#[test]
fn an_approach_held_short_with_an_empty_hand_is_unwound_from_where_it_stands() {
    let k = kitchen();
    let cfg = bundled_config();
    let stall_s = cfg.turn.stall_s;
    assert!(stall_s > 0.0);
    // Joint 7 turned 100° from the ready pose: the preview from the start reaches.
    let mut q = k.ready;
    q[6] = 100f64.to_radians();
    let run = |held: Option<&str>| -> (Vec<(f64, Output)>, Vec<Output>) {
        let mut m = manager(&k, cfg.clone(), true);
        let now = |t: f64| Stamp { t, unix_s: 0 };
        let at = |t: f64| WorldReport { held: held.map(str::to_owned), gripper_closed: held.is_some(), ..world(&k, &q, t) };
        let mut out = Vec::new();
        m.handle(&Input::Joints { t: 10.0, q }, now(10.0), &mut out);
        m.handle(&Input::World(at(10.0)), now(10.0), &mut out);
        out.clear();
        m.handle(&Input::Action(ActionRequest { id: 1, label: "foa17(spoon)".into(), stop: false }), now(10.0), &mut out);
        let start = std::mem::take(&mut out);
        let mut timed = Vec::new();
        let mut t = 10.0;
        while t < 30.0 {
            t += 0.1;
            m.handle(&Input::Joints { t, q }, now(t), &mut out);
            m.handle(&Input::World(at(t)), now(t), &mut out);
            timed.extend(out.drain(..).map(|o| (t, o)));
        }
        (timed, start)
    };
    let (timed, start) = run(None);
    assert_eq!(motions(&start).len(), 1, "the approach: {start:?}");
    let moves: Vec<(f64, &MotionOrder)> = timed
        .iter()
        .filter_map(|(t, o)| match o {
            Output::Motion(m) => Some((*t, m)),
            _ => None,
        })
        .collect();
    assert_eq!(moves.len(), 1, "one rescue: {timed:?}");
    let (t, order) = moves[0];
    assert!(t >= 10.0 + stall_s, "not before stall_s: at {t}");
    assert!(matches!(&order.plan, Some(MotionPlan::Joints { joints, .. }) if *joints == k.ready), "{order:?}");
    let line = timed
        .iter()
        .find_map(|(_, o)| match o {
            Output::Info(t) if t.contains("held short") => Some(t.clone()),
            _ => None,
        })
        .expect("reported");
    eprintln!("{line}");
    assert!(line.starts_with("foa17(spoon): held short of its goal") && line.contains("ready pose"), "{line}");

    // Holding the spoon already (a put-back held short): not unwound.
    let (timed, _) = run(Some("spoon"));
    assert!(!timed.iter().any(|(_, o)| matches!(o, Output::Motion(_))), "{timed:?}");
}

/// Seed 9 at `68416f6`: `foa17(spoon)` stood 1.5 cm short of its goal for 120 s, inside the 3 cm
/// where a lifted or turned motion counts as converging, so it was never taken for held.
/// Near its goal an approach must still gain 2 mm per `stall_s`.
#[test]
fn an_approach_standing_a_centimetre_and_a_half_short_is_held_short() {
    let k = kitchen();
    let cfg = bundled_config();
    let mut q = k.ready;
    q[6] = 100f64.to_radians();
    let mut m = manager(&k, cfg.clone(), true);
    let now = |t: f64| Stamp { t, unix_s: 0 };
    let mut out = Vec::new();
    m.handle(&Input::Joints { t: 10.0, q }, now(10.0), &mut out);
    m.handle(&Input::World(world(&k, &q, 10.0)), now(10.0), &mut out);
    out.clear();
    m.handle(&Input::Action(ActionRequest { id: 1, label: "foa17(spoon)".into(), stop: false }), now(10.0), &mut out);
    let Some(MotionPlan::Linear { goal, .. }) = motions(&out).first().and_then(|o| o.plan.clone()) else { panic!("{out:?}") };
    // The tool 1.5 cm short of the goal, standing.
    let short = Isometry3::from_parts(Translation3::from(goal.translation.vector + nalgebra::Vector3::new(0.0, 0.0, 0.015)), goal.rotation);
    let mut t = 10.0;
    let mut unwound_at = None;
    while t < 30.0 && unwound_at.is_none() {
        t += 0.1;
        out.clear();
        m.handle(&Input::Joints { t, q }, now(t), &mut out);
        m.handle(&Input::World(WorldReport { tool: short, ..world(&k, &q, t) }), now(t), &mut out);
        if motions(&out).iter().any(|o| matches!(o.plan, Some(MotionPlan::Joints { .. }))) {
            unwound_at = Some(t);
        }
    }
    let at = unwound_at.expect("unwound");
    assert!(at >= 10.0 + cfg.turn.stall_s, "not before stall_s: {at}");
}
