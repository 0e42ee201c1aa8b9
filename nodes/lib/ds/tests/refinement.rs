//! Incremental kinesthetic refinement of an end-effector HMM primitive through the task
//! transition controller (thesis Sec. 4.1.3, Fig. 4.3–4.4), kinematic closed loop on the LWR:
//! a pick-and-place motion learned from five demonstrations (left-to-right HMM, 7 states,
//! 1 Gaussian), executed with TTC while a scripted teacher presses the tool towards a new goal
//! g′ after t_c = 3 s; each executed trajectory refines the HMM after the contact
//! (`refine_after`, App. A.3.3), the states before it kept. As in the thesis, the robot then
//! reaches g′ on its own — here to within the HMM's own reproduction error — and the motion
//! before t_c stays (figures printed with --nocapture).
//!
//! What is judged is where the simulated tool went (q integrated), not what was commanded.

mod common;

use cowork_ds::ik::{Twist, orientation_error};
use cowork_ds::{Contact, Ttc, TtcConfig, TtcReport};
use cowork_motion::Demonstration;
use cowork_motion::hmm::{HmmConfig, HmmPrimitive};
use cowork_robot::{LinkPoses, RobotModel};
use nalgebra::{UnitQuaternion, Vector3};

const DT: f64 = 0.01;
/// The teacher starts correcting this long after the start (s), as in Fig. 4.4.
const T_CONTACT: f64 = 3.0;
/// Position feedback of the primitive's tracking (1/s).
const KP: f64 = 5.0;

/// Minimum-jerk point-to-point path from `a` to `b` over `duration` s, then 0.5 s at rest at
/// `b` (a person holds the object there before letting go), sampled at DT, with a vertical bow
/// `bow` (m) at mid-way (demonstrations differ a little).
fn demonstration(a: Vector3<f64>, b: Vector3<f64>, duration: f64, bow: f64) -> Demonstration {
    let n = (duration / DT).round() as usize + 1;
    let rest = (0.5 / DT) as usize;
    let mut t = Vec::with_capacity(n + rest);
    let mut pos = Vec::with_capacity(3 * (n + rest));
    for k in 0..n + rest {
        let s = (k as f64 / (n - 1) as f64).min(1.0);
        let m = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
        let p = a + (b - a) * m + Vector3::new(0.0, 0.0, bow * (std::f64::consts::PI * s).sin());
        t.push(k as f64 * DT);
        pos.extend_from_slice(p.as_slice());
    }
    Demonstration::new(3, t, pos, None).expect("demonstration")
}

/// The path the teacher wants: the primitive's own path until T_CONTACT, then bent smoothly so
/// that it ends at the new goal `g_new`.
fn teacher_target(reference: &[Vector3<f64>], k: usize, g_new: Vector3<f64>) -> Vector3<f64> {
    let t = k as f64 * DT;
    let end = (reference.len() - 1) as f64 * DT;
    // The teacher has brought the tool to g′ 0.5 s before the reference ends (its rest).
    let s = ((t - T_CONTACT) / (end - 0.5 - T_CONTACT)).clamp(0.0, 1.0);
    let m = s * s * (3.0 - 2.0 * s);
    let last = reference[reference.len() - 1];
    reference[k.min(reference.len() - 1)] + (g_new - last) * m
}

struct Execution {
    /// Tool positions (m, base frame), one per DT.
    path: Vec<Vector3<f64>>,
    /// Samples of `path` while the reference ran (the rest is the settling second).
    reference_len: usize,
    /// Time the teacher's force first reached f_i (s).
    first_contact: Option<f64>,
    /// Largest TTC weight of T³ seen.
    max_priority_weight: f64,
}

/// Executes `hmm` from the robot's start with TTC; with `g_new`, the teacher presses the tool
/// towards the path bent to it (firmly: at least 16 N, above f_s, as a person who wants the robot
/// to give way and holds it there).
fn execute(model: &RobotModel, hmm: &HmmPrimitive, g_new: Option<Vector3<f64>>) -> Execution {
    let mut q = common::q_start();
    let mut poses = LinkPoses::new();
    model.forward_kinematics(&q, &mut poses);
    let tip = model.tip_link();
    let x0 = poses.get(tip).translation.vector;
    let r0: UnitQuaternion<f64> = poses.get(tip).rotation;
    let tr = hmm.generate(Some(x0.as_slice()), DT).expect("generate");
    let reference: Vec<Vector3<f64>> = tr.pos.chunks(3).map(Vector3::from_column_slice).collect();
    let velocity: Vec<Vector3<f64>> = tr.vel.chunks(3).map(Vector3::from_column_slice).collect();
    let mut ttc = Ttc::new(TtcConfig::default()).expect("config");
    let mut report = TtcReport::default();
    let mut out = Execution { path: Vec::new(), reference_len: reference.len(), first_contact: None, max_priority_weight: 0.0 };
    // The reference, then 1 s holding its end.
    let steps = reference.len() + (1.0 / DT) as usize;
    for k in 0..steps {
        model.forward_kinematics(&q, &mut poses);
        let x = poses.get(tip).translation.vector;
        out.path.push(x);
        let i = k.min(reference.len() - 1);
        let v_ref = if k < reference.len() { velocity[i] } else { Vector3::zeros() };
        let mut twist = Twist::zeros();
        twist.fixed_rows_mut::<3>(0).copy_from(&(v_ref + KP * (reference[i] - x)));
        twist.fixed_rows_mut::<3>(3).copy_from(&(5.0 * orientation_error(&poses.get(tip).rotation, &r0)));
        let contact = g_new.and_then(|g_new| {
            let e = teacher_target(&reference, k, g_new) - x;
            let t = k as f64 * DT;
            if t < T_CONTACT || e.norm() < 1e-4 {
                return None;
            }
            let force = e.normalize() * (3000.0 * e.norm()).clamp(16.0, 40.0);
            Some(Contact { link: tip, point: x.into(), force })
        });
        if let Some(c) = &contact
            && out.first_contact.is_none()
            && c.force.norm() >= TtcConfig::default().insert_force
        {
            out.first_contact = Some(k as f64 * DT);
        }
        let qdot = ttc.step(model, &poses, tip, &twist, contact.as_ref(), DT, &mut report);
        out.max_priority_weight = out.max_priority_weight.max(report.weights[2]);
        q += qdot * DT;
    }
    out
}

fn as_demonstration(path: &[Vector3<f64>]) -> Demonstration {
    let t = (0..path.len()).map(|k| k as f64 * DT).collect();
    let pos = path.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    Demonstration::new(3, t, pos, None).expect("executed trajectory")
}

#[test]
fn corrections_through_ttc_move_the_goal_of_the_hmm_primitive() {
    let model = common::lwr();
    let x0 = common::tip_position(&model, &common::q_start());
    // Pick-and-place: 30 cm sideways and 10 cm down in 4 s; the new goal g′ 12 cm further in x.
    let goal = x0 + Vector3::new(0.0, 0.30, -0.10);
    let shift = Vector3::new(0.12, 0.0, 0.0);
    let demos: Vec<Demonstration> =
        [0.0, 0.01, -0.01, 0.02, -0.02].iter().map(|&bow| demonstration(x0, goal, 4.0, bow)).collect();
    let cfg = HmmConfig { states: 7, forgetting: 0.6, ..HmmConfig::default() };
    let mut hmm = HmmPrimitive::fit(&demos, &cfg).expect("fit");

    let g_new = goal + shift;
    let before = execute(&model, &hmm, None);
    let end = |e: &Execution| *e.path.last().expect("path");
    let mut distances = vec![(end(&before) - g_new).norm()];
    assert!((end(&before) - goal).norm() < 0.03, "the learned primitive reaches g: {:?} vs {goal:?}", end(&before));
    for iteration in 1..=3 {
        let taught = execute(&model, &hmm, Some(g_new));
        let contact = taught.first_contact.expect("the teacher pushed");
        assert!(contact >= T_CONTACT - 1e-9, "{contact}");
        assert!(taught.max_priority_weight > 0.9, "the guidance took priority (w₃ = {})", taught.max_priority_weight);
        let off = (end(&taught) - g_new).norm();
        assert!(off < 0.02, "iteration {iteration}: the teacher brought the tool to g′ ({off} m off: {:?} vs {g_new:?}; w3 max {})", end(&taught), taught.max_priority_weight);
        // The executed motion (while the primitive ran) is the new demonstration.
        let kept = hmm.refine_after(&as_demonstration(&taught.path[..taught.reference_len]), contact).expect("refine");
        eprintln!("iteration {iteration}: contact at {contact:.2} s, {kept} states kept");
        let alone = execute(&model, &hmm, None);
        distances.push((end(&alone) - g_new).norm());
    }
    let after = execute(&model, &hmm, None);
    // Before the first contact the motion is the old one (first 2.5 s, same times).
    let unchanged = before.path.iter().zip(&after.path).take((2.5 / DT) as usize).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    // The primitive's own reproduction error: its end against the demonstrations' goal.
    let fit_error = (end(&before) - goal).norm();
    eprintln!(
        "distance of the autonomous end point to g′ after 0..3 corrections: {:?} m (the fit's own end error {:.3} m); \
         motion before t_c changed by at most {:.4} m; generated motion {:.2} s -> {:.2} s",
        distances.iter().map(|d| (d * 1e3).round() / 1e3).collect::<Vec<_>>(),
        fit_error,
        unchanged,
        before.reference_len as f64 * DT,
        after.reference_len as f64 * DT,
    );
    assert!(distances[0] > 0.10, "{distances:?}");
    // Each correction takes the end at least η − 0.1 of the remaining way to g′ (η = 0.6) ...
    for w in distances.windows(2) {
        assert!(w[1] < (1.1 - cfg.forgetting) * w[0], "each correction brings the end closer: {distances:?}");
    }
    // ... and after three it is within the HMM's own reproduction error of g′ (plus 1 cm).
    assert!(distances[3] < 2.0 * fit_error + 0.01, "{distances:?} vs fit error {fit_error}");
    assert!(unchanged < 0.025, "the part before the first contact is kept: {unchanged} m");
    assert!(after.reference_len as f64 <= 1.2 * before.reference_len as f64, "the motion keeps its duration");
}
