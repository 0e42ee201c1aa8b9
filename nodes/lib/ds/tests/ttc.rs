//! Task transition control (thesis Sec. 4.1.2) on the LWR model, closed loop (q integrated):
//! Table 4.1's three regimes, smooth transitions, Theorem 3's bound, no allocation.

mod common;

use cowork_ds::ik::Twist;
use cowork_ds::ttc::contact_point_at_link_end;
use cowork_ds::{Contact, Ttc, TtcConfig, TtcReport};
use cowork_robot::{JointVector, LinkPoses, RobotModel};
use nalgebra::Vector3;
use proptest::prelude::*;

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

const DT: f64 = 1e-3;

/// The elbow link (the contact link of Fig. 4.5): the link that joint 4 (index 3) moves.
fn elbow(model: &RobotModel) -> usize {
    model.joint_link(3)
}

struct Run {
    ee_error_max: f64,
    contact_error_end: f64,
    contact_speed_end: f64,
    ee_speed_end: f64,
    weights_end: [f64; 3],
    /// Largest weight of T³ = [T_ic, T_ee] over the run.
    w3_max: f64,
    /// When T³'s weight first passed ½ (s), if it did.
    takeover_s: Option<f64>,
    /// The end effector's position error accumulated over the run: ‖∫ (ẋ − ẋ_desired) dt‖ (m).
    ee_drift: f64,
    max_qdot_jump: f64,
    bound_violation: f64,
}

/// Runs `steps` control steps from `q_start` with the end effector asked to move at `ee_v`
/// (m/s, orientation held) and a force `force(k)` (N) at the end of `link`.
fn run(model: &RobotModel, link: Option<usize>, ee_v: Vector3<f64>, force: impl Fn(usize) -> Vector3<f64>, steps: usize) -> Run {
    run_with(TtcConfig::default(), model, link, ee_v, force, steps)
}

fn run_with(
    cfg: TtcConfig,
    model: &RobotModel,
    link: Option<usize>,
    ee_v: Vector3<f64>,
    force: impl Fn(usize) -> Vector3<f64>,
    steps: usize,
) -> Run {
    let mut ttc = Ttc::new(cfg).expect("config");
    let mut q = common::q_start();
    let mut poses = LinkPoses::new();
    let tip = model.tip_link();
    let mut twist = Twist::zeros();
    twist.fixed_rows_mut::<3>(0).copy_from(&ee_v);
    let mut report = TtcReport::default();
    let mut prev: Option<JointVector> = None;
    let mut r = Run {
        ee_error_max: 0.0,
        contact_error_end: 0.0,
        contact_speed_end: 0.0,
        ee_speed_end: 0.0,
        weights_end: [0.0; 3],
        w3_max: 0.0,
        takeover_s: None,
        ee_drift: 0.0,
        max_qdot_jump: 0.0,
        bound_violation: 0.0,
    };
    let mut drift = Vector3::zeros();
    for k in 0..steps {
        model.forward_kinematics(&q, &mut poses);
        let contact = link.map(|l| Contact { link: l, point: contact_point_at_link_end(model, &poses, l), force: force(k) });
        let qdot = ttc.step(model, &poses, tip, &twist, contact.as_ref(), DT, &mut report);
        let w = report.weights;
        assert!(w.iter().all(|v| *v >= 0.0) && (w.iter().sum::<f64>() - 1.0).abs() < 1e-9, "step {k}: {w:?}");
        let bound = report.stack_norms.iter().fold(0.0_f64, |m, v| m.max(*v));
        r.bound_violation = r.bound_violation.max(qdot.norm() - bound);
        if let Some(p) = prev {
            r.max_qdot_jump = r.max_qdot_jump.max((qdot - p).amax());
        }
        prev = Some(qdot);
        r.ee_error_max = r.ee_error_max.max((report.end_effector_twist.fixed_rows::<3>(0) - ee_v).norm());
        drift += (report.end_effector_twist.fixed_rows::<3>(0) - ee_v) * DT;
        r.ee_drift = drift.norm();
        r.w3_max = r.w3_max.max(w[2]);
        if w[2] > 0.5 && r.takeover_s.is_none() {
            r.takeover_s = Some(k as f64 * DT);
        }
        r.contact_error_end = (report.contact_velocity - report.contact_velocity_desired).norm();
        r.contact_speed_end = report.contact_velocity.norm();
        r.ee_speed_end = report.end_effector_twist.fixed_rows::<3>(0).norm();
        r.weights_end = w;
        q += qdot * DT;
    }
    r
}

#[test]
fn without_a_touch_the_primitive_runs_alone() {
    let model = common::lwr();
    let r = run(&model, None, Vector3::new(0.0, 0.1, 0.0), |_| Vector3::zeros(), 500);
    assert_eq!(r.weights_end, [1.0, 0.0, 0.0]);
    assert!(r.ee_error_max < 1e-3, "{}", r.ee_error_max);
}

#[test]
fn a_light_push_on_the_elbow_moves_it_in_the_null_space_and_leaves_the_primitive_exact() {
    let model = common::lwr();
    let l = elbow(&model);
    // 10 N (f_i ≤ f < f_s): T² = [T_ee, T_ic]; the tool keeps its 0.1 m/s along +y.
    let push = Vector3::new(0.0, 0.0, -10.0);
    let r = run(&model, Some(l), Vector3::new(0.0, 0.1, 0.0), |_| push, 1000);
    assert!(r.weights_end[1] > 0.999, "{:?}", r.weights_end);
    assert!(r.ee_error_max < 2e-3, "the end-effector task keeps priority: {} m/s off", r.ee_error_max);
    assert!(r.contact_speed_end > 0.005, "the elbow gives way in the null space: {} m/s", r.contact_speed_end);
}

#[test]
fn a_firm_push_at_the_tool_takes_over_the_end_effector() {
    let model = common::lwr();
    let tip = model.tip_link();
    // The primitive wants +y at 0.1 m/s; the person pushes the tool along −y.
    let ee_v = Vector3::new(0.0, 0.1, 0.0);
    // 10 N: the primitive wins (the guidance has no null space at the tool).
    let light = run(&model, Some(tip), ee_v, |_| Vector3::new(0.0, -10.0, 0.0), 1000);
    assert!(light.ee_error_max < 2e-3, "{}", light.ee_error_max);
    // 20 N (≥ f_s): T³; after the transition the tool moves at c f = 0.1 m/s along −y.
    let firm = run(&model, Some(tip), ee_v, |_| Vector3::new(0.0, -20.0, 0.0), 1000);
    assert!(firm.weights_end[2] > 0.999, "{:?}", firm.weights_end);
    assert!(firm.contact_error_end < 2e-3, "guidance followed: {} m/s off", firm.contact_error_end);
}

#[test]
fn crossing_the_thresholds_never_makes_the_joint_velocity_jump() {
    let model = common::lwr();
    let l = elbow(&model);
    // The force ramps 0 → 25 N and back over 2 s, crossing f_i and f_s both ways.
    let force = |k: usize| {
        let t = k as f64 * DT;
        let f = 25.0 * (std::f64::consts::PI * t / 2.0).sin().max(0.0);
        Vector3::new(0.0, f, 0.0)
    };
    let r = run(&model, Some(l), Vector3::new(0.05, 0.0, 0.0), force, 2000);
    assert!(r.bound_violation < 1e-9, "‖q̇‖ above max ‖q̇ⁱ‖ by {}", r.bound_violation);
    // The same run with the stacks switched at once (k₀ huge: no transition).
    let hard = TtcConfig { transition_gain: 1e12, ..TtcConfig::default() };
    let switched = run_with(hard, &model, Some(l), Vector3::new(0.05, 0.0, 0.0), force, 2000);
    eprintln!(
        "largest one-step joint-velocity change: TTC {:.4} rad/s, hard switch {:.4} rad/s",
        r.max_qdot_jump, switched.max_qdot_jump
    );
    assert!(
        r.max_qdot_jump * 10.0 < switched.max_qdot_jump,
        "TTC {} rad/s vs hard switch {} rad/s",
        r.max_qdot_jump,
        switched.max_qdot_jump
    );
    assert!(r.max_qdot_jump < 5e-3, "largest one-step change {} rad/s", r.max_qdot_jump);
}

/// Fig. 4.7's three settings of f_s (f_i = 5 N) in numbers: a push on the elbow ramped to 20 N
/// over 1 s and held, against a primitive moving the tool at 0.05 m/s. With f_s = 30 N the
/// guidance never takes priority (T_ic stays in T_ee's null space: the tool is not disturbed);
/// with 15 N it takes over once the push passes 15 N, with 5 N as soon as the push is felt;
/// once it has, the end effector's error accumulates where the two tasks conflict.
#[test]
fn the_switch_force_decides_when_the_guidance_takes_over_fig_4_7() {
    let model = common::lwr();
    let l = elbow(&model);
    let ee_v = Vector3::new(0.05, 0.0, 0.0);
    let force = |k: usize| Vector3::new(0.0, 20.0 * (k as f64 * DT).min(1.0), 0.0);
    let runs: Vec<(f64, Run)> = [5.0, 15.0, 30.0]
        .into_iter()
        .map(|fs| (fs, run_with(TtcConfig { switch_force: fs, ..TtcConfig::default() }, &model, Some(l), ee_v, force, 2000)))
        .collect();
    for (fs, r) in &runs {
        eprintln!(
            "f_s = {fs:>4} N: largest w(T³) {:.3}, T³ over ½ from {:?} s, weights at the end {:.3?}, \
             end-effector drift {:.1} mm, largest one-step joint-velocity change {:.4} rad/s",
            r.w3_max,
            r.takeover_s,
            r.weights_end,
            r.ee_drift * 1e3,
            r.max_qdot_jump
        );
        assert!(r.bound_violation < 1e-9, "f_s = {fs}: ‖q̇‖ above max ‖q̇ⁱ‖ by {}", r.bound_violation);
    }
    let (d5, d15, d30) = (&runs[0].1, &runs[1].1, &runs[2].1);
    assert_eq!(d30.w3_max, 0.0, "f_s = 30 N never hands T_ee over");
    assert!(d30.ee_drift < 1e-3, "f_s = 30 N: the tool keeps its path ({} m)", d30.ee_drift);
    assert!(d5.weights_end[2] > 0.999 && d15.weights_end[2] > 0.999, "{:?} {:?}", d5.weights_end, d15.weights_end);
    let (t5, t15) = (d5.takeover_s.expect("f_s = 5 N takes over"), d15.takeover_s.expect("f_s = 15 N takes over"));
    assert!(t5 + 0.3 < t15, "5 N takes over well before 15 N: {t5} s vs {t15} s");
    for d in [d5, d15] {
        assert!(d.ee_drift > 0.01 && d.ee_drift > 10.0 * d30.ee_drift, "drift {} m vs {} m with f_s = 30 N", d.ee_drift, d30.ee_drift);
    }
}

#[test]
fn a_step_allocates_nothing() {
    let model = common::lwr();
    let mut ttc = Ttc::new(TtcConfig::default()).expect("config");
    let q = common::q_start();
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let l = elbow(&model);
    let contact = Contact { link: l, point: contact_point_at_link_end(&model, &poses, l), force: Vector3::new(0.0, 20.0, 0.0) };
    let twist = Twist::zeros();
    let mut report = TtcReport::default();
    let before = cowork_testkit::allocations();
    for k in 0..2000 {
        let c = if k % 500 < 250 { Some(&contact) } else { None };
        std::hint::black_box(ttc.step(&model, &poses, model.tip_link(), &twist, c, DT, &mut report));
    }
    assert_eq!(cowork_testkit::allocations() - before, 0);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Any force sequence (also NaN), any contact link: w stays barycentric, ‖q̇‖ ≤ max ‖q̇ⁱ‖.
    #[test]
    fn weights_stay_barycentric_and_the_bound_holds(
        forces in proptest::collection::vec((-40.0f64..40.0, -40.0f64..40.0, -40.0f64..40.0, 0u8..20), 1..40),
        link_pick in 0usize..7,
    ) {
        let model = common::lwr();
        let link = model.joint_link(link_pick);
        let mut ttc = Ttc::new(TtcConfig::default()).expect("config");
        let mut q = common::q_start();
        let mut poses = LinkPoses::new();
        let mut report = TtcReport::default();
        let mut twist = Twist::zeros();
        twist[1] = 0.05;
        for (fx, fy, fz, hold) in forces {
            let f = if hold == 0 { Vector3::new(f64::NAN, 0.0, 0.0) } else { Vector3::new(fx, fy, fz) };
            for _ in 0..(hold as usize * 10 + 1) {
                model.forward_kinematics(&q, &mut poses);
                let c = Contact { link, point: contact_point_at_link_end(&model, &poses, link), force: f };
                let qdot = ttc.step(&model, &poses, model.tip_link(), &twist, Some(&c), DT, &mut report);
                let w = report.weights;
                prop_assert!(w.iter().all(|v| *v >= 0.0), "{:?}", w);
                prop_assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{:?}", w);
                let bound = report.stack_norms.iter().fold(0.0_f64, |m, v| m.max(*v));
                prop_assert!(qdot.norm() <= bound + 1e-9, "{} > {}", qdot.norm(), bound);
                prop_assert!(qdot.iter().all(|v| v.is_finite()));
                q += qdot * DT;
            }
        }
    }
}
