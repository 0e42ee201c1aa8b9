//! Goal refinement study of thesis Sec. 4.1.3 (Fig. 4.3–4.4) through the controller's own 1 kHz
//! step with task transition control (`DsController::step_with_contact`: IK, link damper,
//! saturation and the TTC blend), kinematic closed loop on the LWR (q integrated; no DDS).
//!
//! A pick-and-place learned from five demonstrations (HMM, left-to-right, 7 states, 1
//! Gaussian, η = 0.7) runs as a learned primitive (its generated path tracked with position
//! feedback). A scripted teacher presses the tool (≥ 16 N, above f_s) towards a goal g′ 12 cm
//! off the learned one from t_c = 3 s on; each executed trajectory refines the HMM after the
//! first contact (`HmmPrimitive::refine_after`, App. A.3.3); the robot then runs alone.
//!
//!     cargo run --release -p cowork_ds --example refine_goal
//!
//! Prints: executions until the autonomous end point is within the HMM's own reproduction
//! error of g′ (or within 1 cm), the end-effector error at g′ after each, and the largest
//! change of the motion before the first contact.

use std::path::PathBuf;

use cowork_ds::tracker::{DEFAULT_GAIN, PathTracker};
use cowork_ds::{
    ControlInput, ControlOutput, ControllerConfig, Distances, DsController, ExternalWrench, HumanInput,
    HumanState, MotionCommand, Primitive, TtcConfig,
};
use cowork_motion::Demonstration;
use cowork_motion::hmm::{HmmConfig, HmmPrimitive};
use cowork_people::guide::Guide;
use cowork_robot::{JointVector, RobotModel};
use nalgebra::Vector3;

/// Controller period (s).
const DT: f64 = 1e-3;
/// Sampling of the generated path and of the executed demonstration (s).
const SAMPLE: f64 = 0.01;
const T_CONTACT: f64 = 3.0;

fn demonstration(a: Vector3<f64>, b: Vector3<f64>, duration: f64, bow: f64) -> Demonstration {
    Demonstration::minimum_jerk(a.as_slice(), b.as_slice(), &[0.0, 0.0, bow], duration, 0.5, SAMPLE).expect("demonstration")
}

struct Execution {
    /// Tool positions every SAMPLE while the reference ran, then 1 s more.
    path: Vec<Vector3<f64>>,
    reference_len: usize,
    first_contact: Option<f64>,
    max_priority_weight: f64,
}

fn execute(model: &RobotModel, q_start: &JointVector, goal: Vector3<f64>, hmm: &HmmPrimitive, g_new: Option<Vector3<f64>>) -> Execution {
    let x0 = model.link_pose(q_start, model.tip_link()).translation.vector;
    let tr = hmm.generate(Some(x0.as_slice()), SAMPLE).expect("generate");
    let mut field = PathTracker::from_flat(&tr.pos, &tr.vel, SAMPLE, DEFAULT_GAIN).expect("path");
    let reference = field.positions().to_vec();
    let teacher = g_new.and_then(|g| Guide::new(reference.clone(), SAMPLE, T_CONTACT, g));
    let cfg = ControllerConfig { ttc: TtcConfig { enabled: true, ..TtcConfig::default() }, ..ControllerConfig::default() };
    let f_i = cfg.ttc.insert_force;
    let mut ctl = DsController::new(model.clone(), cfg).expect("config");
    let tip = model.tip_link();
    let mut q = *q_start;
    let mut out = ControlOutput::default();
    let mut ex = Execution { path: Vec::new(), reference_len: reference.len(), first_contact: None, max_priority_weight: 0.0 };
    let end = (reference.len() - 1) as f64 * SAMPLE;
    let steps = ((end + 1.0) / DT).round() as usize;
    let every = (SAMPLE / DT).round() as usize;
    for k in 0..steps {
        let t = k as f64 * DT;
        let x = model.link_pose(&q, tip).translation.vector;
        if k % every == 0 {
            ex.path.push(x);
        }
        let input = ControlInput {
            time: t,
            q,
            command: MotionCommand { id: 1, primitive: Primitive::Learned, goal, orientation: None, end_effector_avoidance: true },
            distances: Distances::clear(t),
            human: HumanInput { stamp: t, state: HumanState::default() },
        };
        // The teacher: the primitive's own path until t_c, then bent smoothly to end at g′
        // 0.5 s before the reference ends; pressing ≥ 16 N towards where the tool should be.
        let wrench =
            teacher.as_ref().and_then(|g| g.push(t, &x)).map(|force| ExternalWrench { stamp: t, link: tip, force });
        if wrench.is_some_and(|w| w.force.norm() >= f_i) && ex.first_contact.is_none() {
            ex.first_contact = Some(t);
        }
        ctl.step_with_contact(&input, Some(&mut field), wrench.as_ref(), &mut out).expect("step");
        ex.max_priority_weight = ex.max_priority_weight.max(out.diagnostics.contact.weights[2]);
        q += out.qdot * DT;
    }
    ex
}

fn main() {
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf).expect("LWR URDF loads");
    let q_start = JointVector::from_row_slice(&[0.0, 0.6, 0.0, -1.3, 0.0, 0.7, 0.0]);
    let x0 = model.link_pose(&q_start, model.tip_link()).translation.vector;
    let goal = x0 + Vector3::new(0.0, 0.30, -0.10);
    let g_new = goal + Vector3::new(0.12, 0.0, 0.0);
    let demos: Vec<Demonstration> =
        [0.0, 0.01, -0.01, 0.02, -0.02].iter().map(|&bow| demonstration(x0, goal, 4.0, bow)).collect();
    let mut hmm = HmmPrimitive::fit(&demos, &HmmConfig { states: 7, forgetting: 0.7, ..HmmConfig::default() }).expect("fit");
    let last = |e: &Execution| *e.path.last().expect("path");
    let before = execute(&model, &q_start, goal, &hmm, None);
    let fit_error = (last(&before) - goal).norm();
    println!("learned primitive alone: end {:.1} mm from g (its reproduction error), {:.1} mm from g′", fit_error * 1e3, (last(&before) - g_new).norm() * 1e3);
    let criterion = fit_error.max(0.01);
    let mut reached_after = None;
    for iteration in 1..=5 {
        let taught = execute(&model, &q_start, goal, &hmm, Some(g_new));
        let Some(contact) = taught.first_contact else {
            println!("execution {iteration}: the teacher never pushed");
            break;
        };
        let taught_err = (last(&taught) - g_new).norm();
        let demo_len = taught.reference_len.min(taught.path.len());
        let t: Vec<f64> = (0..demo_len).map(|k| k as f64 * SAMPLE).collect();
        let p: Vec<f64> = taught.path[..demo_len].iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        let kept = hmm.refine_after(&Demonstration::new(3, t, p, None).expect("demo"), contact).expect("refine");
        let alone = execute(&model, &q_start, goal, &hmm, None);
        let err = (last(&alone) - g_new).norm();
        let n = (contact / SAMPLE) as usize;
        let unchanged = before.path.iter().zip(&alone.path).take(n).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
        println!(
            "execution {iteration} with the teacher: first contact {contact:.2} s, w3 max {:.2}, tool {:.1} mm from g′; \
             refined ({kept} of 7 states kept); alone: EE error at g′ {:.1} mm, motion before t_c moved ≤ {:.1} mm, duration {:.2} s",
            taught.max_priority_weight,
            taught_err * 1e3,
            err * 1e3,
            unchanged * 1e3,
            alone.reference_len as f64 * SAMPLE
        );
        if err <= criterion && reached_after.is_none() {
            reached_after = Some(iteration);
        }
    }
    match reached_after {
        Some(n) => println!("reaches g′ on its own (within {:.1} mm) after {n} refined execution(s) (thesis: 3)", criterion * 1e3),
        None => println!("does not reach g′ on its own within {:.1} mm after 5 refined executions", criterion * 1e3),
    }
}
