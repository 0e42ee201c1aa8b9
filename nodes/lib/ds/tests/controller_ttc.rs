//! Task transition control inside `DsController` (thesis Sec. 4.1.2): the controller's 1 kHz
//! step with a person's push, closed loop on the LWR model (q integrated). A light push leaves
//! the motion exactly as without one; a push between f_i and f_s moves the elbow in the null
//! space while the end effector keeps its path; a firm push on the tool takes the end effector
//! along; joint velocities never jump; bad pushes are ignored, naming why.

mod common;

use cowork_ds::ttc::contact_point_at_link_end;
use cowork_ds::{
    ControlOutput, ControllerConfig, DsController, ExternalWrench, TtcConfig, WrenchIgnored,
};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::Vector3;

const DT: f64 = 1e-3;

fn config(enabled: bool) -> ControllerConfig {
    ControllerConfig { ttc: TtcConfig { enabled, ..TtcConfig::default() }, ..ControllerConfig::default() }
}

struct Trace {
    /// End-effector positions, one per step.
    ee: Vec<Vector3<f64>>,
    /// End of the pushed link, one per step.
    contact: Vec<Vector3<f64>>,
    qdot: Vec<JointVector>,
    weights: Vec<[f64; 3]>,
    ignored: Vec<Option<WrenchIgnored>>,
}

/// 3 s of a constant-speed motion (0.1 m/s) towards a goal 25 cm away, a push `push(k)` on
/// `link` (None: no push) from 0.5 s to 2.0 s.
fn run(model: &RobotModel, cfg: ControllerConfig, link: usize, push: impl Fn(usize, f64) -> Option<ExternalWrench>) -> Trace {
    let mut ctl = DsController::new(model.clone(), cfg).expect("config");
    let mut q = common::q_start();
    let goal = common::tip_position(model, &q) + Vector3::new(0.0, 0.25, 0.0);
    let mut out = ControlOutput::default();
    let mut poses = LinkPoses::new();
    let mut tr = Trace { ee: vec![], contact: vec![], qdot: vec![], weights: vec![], ignored: vec![] };
    for k in 0..3000 {
        let t = k as f64 * DT;
        let input = common::input(q, common::command(common::constant_speed(0.1), goal), t);
        let w = if (500..2000).contains(&k) { push(k, t) } else { None };
        ctl.step_with_contact(&input, None, w.as_ref(), &mut out).expect("step");
        model.forward_kinematics(&q, &mut poses);
        tr.ee.push(poses.get(model.tip_link()).translation.vector);
        tr.contact.push(contact_point_at_link_end(model, &poses, link).coords);
        tr.qdot.push(out.qdot);
        tr.weights.push(out.diagnostics.contact.weights);
        tr.ignored.push(out.diagnostics.contact.ignored);
        q += out.qdot * DT;
    }
    tr
}

fn max_dev(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).norm()).fold(0.0, f64::max)
}

fn max_jump(q: &[JointVector]) -> f64 {
    let (k, j) = q.windows(2).map(|w| (w[1] - w[0]).amax()).enumerate().fold((0, 0.0), |m, (k, j)| if j > m.1 { (k, j) } else { m });
    eprintln!("largest jump {j:.4} rad/s at step {k}");
    j
}

fn wrench(link: usize, t: f64, f: Vector3<f64>) -> Option<ExternalWrench> {
    Some(ExternalWrench { stamp: t, link, force: f })
}

#[test]
fn a_light_push_leaves_the_motion_as_it_was() {
    let model = common::lwr();
    let elbow = model.joint_link(3);
    let free = run(&model, config(true), elbow, |_, _| None);
    let light = run(&model, config(true), elbow, |_, t| wrench(elbow, t, Vector3::new(0.0, 0.0, 4.0)));
    // Below f_i the stack is T_ee alone: the very same joint velocities.
    let dq = free.qdot.iter().zip(&light.qdot).map(|(a, b)| (a - b).amax()).fold(0.0, f64::max);
    assert!(dq < 1e-12, "light push changed q̇ by {dq}");
    assert!(light.weights.iter().all(|w| *w == [1.0, 0.0, 0.0]));
}

#[test]
fn a_medium_elbow_push_moves_the_elbow_in_the_null_space_only() {
    let model = common::lwr();
    let elbow = model.joint_link(3);
    let free = run(&model, config(true), elbow, |_, _| None);
    let f = Vector3::new(0.0, 0.0, 10.0);
    let pushed = run(&model, config(true), elbow, |_, t| wrench(elbow, t, f));
    let ee_dev = max_dev(&free.ee, &pushed.ee);
    let elbow_dev = max_dev(&free.contact, &pushed.contact);
    eprintln!("10 N on the elbow: end effector off its path by {:.2} mm, elbow moved {:.1} mm, weights at 2 s {:?}", ee_dev * 1e3, elbow_dev * 1e3, pushed.weights[1999]);
    assert!(pushed.weights[1999][1] > 0.99, "[T_ee, T_ic] at 2 s: {:?}", pushed.weights[1999]);
    assert!(ee_dev < 0.002, "end effector left its path by {ee_dev} m");
    assert!(elbow_dev > 0.02, "elbow moved {elbow_dev} m");
    // The push is upwards: the elbow rose.
    let rise = pushed.contact[1999].z - free.contact[1999].z;
    assert!(rise > 0.01, "elbow rise {rise}");
}

#[test]
fn a_firm_tool_push_takes_the_end_effector_along_without_a_jump() {
    let model = common::lwr();
    let tip = model.tip_link();
    let free = run(&model, config(true), tip, |_, _| None);
    // 20 N towards −x (across the motion's +y path): c f = 0.1 m/s, rising over 0.2 s and
    // falling over 0.2 s as a hand's force does (a force step is a step in ẋ_ic = c f itself,
    // which no blending smooths).
    let f = Vector3::new(-20.0, 0.0, 0.0);
    let ramp = |k: usize| (((k as f64 - 500.0) / 200.0).min((2000.0 - k as f64) / 200.0)).clamp(0.0, 1.0);
    let pushed = run(&model, config(true), tip, |k, t| wrench(tip, t, f * ramp(k)));
    let along = free.ee[1999].x - pushed.ee[1999].x;
    eprintln!("20 N on the tool for 1.5 s: end effector moved {:.1} mm along the push, weights at 1.75 s {:?}", along * 1e3, pushed.weights[1750]);
    assert!(pushed.weights[1750][2] > 0.99, "[T_ic, T_ee] at 1.75 s: {:?}", pushed.weights[1750]);
    // c f over the 1.3 s at full force after a 0.2 s ramp in, less the blend's ≈ 0.3 s.
    assert!(along > 0.08, "end effector moved {along} m along the push");
    // Never a jump: the largest one-step change with the push starting and ending is of the
    // order of the free motion's own, far below a hard switch.
    let jump = max_jump(&pushed.qdot);
    let free_jump = max_jump(&free.qdot);
    eprintln!("largest one-step joint-velocity change: {jump:.4} rad/s (free motion {free_jump:.4})");
    assert!(jump < 0.01, "q̇ jumped by {jump} rad/s");
    // The same push with the stacks switched at once (k₀ → ∞): the jump the blend avoids.
    let hard = ControllerConfig { ttc: TtcConfig { enabled: true, transition_gain: 1e12, ..TtcConfig::default() }, ..ControllerConfig::default() };
    let switched = run(&model, hard, tip, |k, t| wrench(tip, t, f * ramp(k)));
    let hard_jump = max_jump(&switched.qdot);
    eprintln!("with the stacks switched at once: {hard_jump:.4} rad/s");
    assert!(hard_jump > 5.0 * jump, "a hard switch jumps {hard_jump}, the blend {jump}");
    for w in &pushed.weights {
        assert!(w.iter().all(|v| *v >= 0.0) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{w:?}");
    }
}

#[test]
fn bad_pushes_are_ignored_with_the_reason_and_the_motion_runs_on() {
    let model = common::lwr();
    let elbow = model.joint_link(3);
    let free = run(&model, config(true), elbow, |_, _| None);
    let f = Vector3::new(0.0, 0.0, 20.0);
    type Case = (&'static str, fn(usize, f64, Vector3<f64>) -> Option<ExternalWrench>, fn(&WrenchIgnored) -> bool);
    let cases: [Case; 4] = [
        ("NaN", |l, t, _| wrench(l, t, Vector3::new(f64::NAN, 0.0, 1.0)), |w| matches!(w, WrenchIgnored::NonFinite)),
        ("huge", |l, t, _| wrench(l, t, Vector3::new(0.0, 0.0, 1e4)), |w| matches!(w, WrenchIgnored::TooLarge { .. })),
        ("unknown link", |_, t, f| wrench(99, t, f), |w| matches!(w, WrenchIgnored::UnknownLink { link: 99 })),
        ("stale", |l, t, f| wrench(l, t - 0.2, f), |w| matches!(w, WrenchIgnored::Stale { .. })),
    ];
    for (name, push, why) in cases {
        let bad = run(&model, config(true), elbow, |_, t| push(elbow, t, f));
        let dev = max_dev(&free.ee, &bad.ee);
        assert!(dev < 1e-12, "{name}: end effector moved by {dev}");
        assert!(bad.ignored[1000].as_ref().is_some_and(why), "{name}: {:?}", bad.ignored[1000]);
    }
    // TTC off: a good push is ignored as disabled.
    let off = run(&model, config(false), elbow, |_, t| wrench(elbow, t, f));
    assert!(max_dev(&free.ee, &off.ee) < 1e-12 && max_dev(&free.contact, &off.contact) < 1e-12);
    assert_eq!(off.ignored[1000], Some(WrenchIgnored::Disabled));
}

#[test]
fn ttc_parameters_are_validated_by_name() {
    let model = common::lwr();
    for (key, cfg) in [
        ("ttc.insert_force", TtcConfig { insert_force: f64::NAN, ..TtcConfig::default() }),
        ("ttc.switch_force", TtcConfig { switch_force: f64::INFINITY, ..TtcConfig::default() }),
        ("ttc.contact_gain", TtcConfig { contact_gain: -1.0, ..TtcConfig::default() }),
        ("ttc.max_wrench_age_s", TtcConfig { max_wrench_age_s: f64::NAN, ..TtcConfig::default() }),
        ("ttc.max_force", TtcConfig { max_force: 10.0, ..TtcConfig::default() }),
    ] {
        let c = ControllerConfig { ttc: cfg, ..ControllerConfig::default() };
        let e = DsController::new(model.clone(), c).expect_err(key).to_string();
        assert!(e.contains(key), "{key}: {e}");
    }
}
