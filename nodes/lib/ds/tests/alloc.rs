//! `DsController::step` never touches the heap: 10 000 steps with obstacles at the end effector
//! and a link, moving obstacles, the escape path, stale data (braking), bad input and hold
//! commands allocate nothing.

mod common;

use cowork_ds::{ControlOutput, ControllerConfig, DsController, LinkDistance, Primitive};
use cowork_robot::LinkPoses;
use nalgebra::{Point3, Vector3};
use std::hint::black_box;

#[global_allocator]
static GLOBAL: cowork_testkit::CountingAllocator = cowork_testkit::CountingAllocator;

use cowork_testkit::allocations;

#[test]
fn ten_thousand_steps_allocate_nothing() {
    let model = common::lwr();
    let mut q = common::q_start();
    let goal = common::tip_position(&model, &q) + Vector3::new(0.05, 0.35, -0.05);
    let mut ctl = DsController::new(model.clone(), ControllerConfig::default()).expect("config");
    let points = common::link_points(&model, 4);
    let mut poses = LinkPoses::new();
    // Inputs prepared beforehand (the test's own Vec allocations stay outside the count).
    let mut inputs = Vec::with_capacity(10_000);
    for k in 0..10_000 {
        let t = k as f64 * 1e-3;
        let mut input = common::input(q, common::command(common::constant_speed(0.3), goal), t);
        model.forward_kinematics(&q, &mut poses);
        let centre = Point3::from(goal + Vector3::new(0.0, -0.15 + 0.1 * (t * 2.0).sin(), 0.0));
        input.distances = common::sphere_distances(
            &poses,
            &points,
            &centre,
            0.05,
            &Vector3::new(0.0, 0.2, 0.0),
            t,
        );
        match k % 1000 {
            // Stale distances: braking path.
            100..=250 => input.distances.stamp = t - 0.5,
            // Head-on contact at the end effector: escape path.
            300..=320 => {
                let tip = model.tip_link();
                let x = common::tip_position(&model, &q);
                let f = (goal - x).normalize();
                input.distances.links[tip] = LinkDistance {
                    valid: true,
                    distance: 0.0,
                    robot_point: Point3::from(x),
                    obstacle_point: Point3::from(x),
                    normal: -f,
                    obstacle_velocity: Vector3::zeros(),
                };
            }
            400 => input.distances.links[3].normal = Vector3::zeros(),
            500..=520 => input.command.primitive = Primitive::Hold,
            600 => input.command.id = 2,
            700..=710 => input.command.goal = Vector3::new(9.0, 0.0, 0.0),
            // An obstacle inside the stop distance of the elbow: link-distance damper.
            800..=850 => {
                let elbow = model.joint_link(3);
                let p = Point3::from(poses.get(elbow).translation.vector);
                let n = Vector3::new(0.0, -1.0, 0.0);
                input.distances.links[elbow] = LinkDistance {
                    valid: true,
                    distance: 0.05,
                    robot_point: p,
                    obstacle_point: p - n * 0.05,
                    normal: n,
                    obstacle_velocity: n * 0.5,
                };
            }
            // Aging distances inside the watchdog's slow zone.
            900..=950 => input.distances.stamp = t - 0.2,
            _ => {}
        }
        q += JointVectorStep::small(k);
        inputs.push(input);
    }
    let mut out = ControlOutput::default();
    let mut faults = 0usize;
    let mut escapes = 0usize;
    let mut damped = 0usize;
    let mut slowed = 0usize;

    // The counter itself must see allocations, or the test could never fail.
    let before = allocations();
    black_box(vec![1u8; 16]);
    assert_eq!(allocations(), before + 1);

    let before = allocations();
    for input in &inputs {
        if ctl.step(input, &mut out).is_err() {
            faults += 1;
        }
        escapes += usize::from(out.diagnostics.escaping);
        damped += usize::from(out.diagnostics.safety.active);
        slowed += usize::from(out.diagnostics.age_scale < 1.0);
        black_box(&out);
    }
    let after = allocations();
    assert_eq!(after - before, 0, "allocations in 10 000 control steps");
    assert!(faults > 1000, "fault paths exercised: {faults}");
    assert!(escapes > 0, "escape path exercised");
    assert!(damped > 100, "link-distance damper exercised: {damped}");
    assert!(slowed > 100, "watchdog slow zone exercised: {slowed}");
}

/// A small deterministic joint drift so the configurations vary along the run.
struct JointVectorStep;

impl JointVectorStep {
    fn small(k: usize) -> cowork_robot::JointVector {
        let s = (k as f64 * 0.003).sin() * 1e-4;
        cowork_robot::JointVector::from_element(s)
    }
}

/// The step with task transition control active allocates nothing either: 6000 steps of a
/// closed loop with pushes below f_i, between f_i and f_s, above f_s, released, stale, NaN,
/// huge and on an unknown link.
#[test]
fn steps_with_task_transition_control_allocate_nothing() {
    use cowork_ds::{ExternalWrench, TtcConfig};
    let model = common::lwr();
    let mut q = common::q_start();
    let goal = common::tip_position(&model, &q) + Vector3::new(0.05, 0.25, -0.05);
    let cfg = ControllerConfig { ttc: TtcConfig { enabled: true, ..TtcConfig::default() }, ..ControllerConfig::default() };
    let mut ctl = DsController::new(model.clone(), cfg).expect("config");
    let elbow = model.joint_link(3);
    let tip = model.tip_link();
    let mut out = ControlOutput::default();
    let mut blended = 0usize;
    let mut ignored = 0usize;
    let before = allocations();
    for k in 0..6000 {
        let t = k as f64 * 1e-3;
        let input = common::input(q, common::command(common::constant_speed(0.2), goal), t);
        let (link, f, stamp) = match k / 500 {
            0 => (elbow, 3.0, t),
            1 => (elbow, 10.0, t),
            2 => (tip, 20.0, t),
            3 => (tip, 0.0, t),
            4 => (elbow, 10.0, t - 1.0),
            5 => (elbow, f64::NAN, t),
            6 => (elbow, 1e6, t),
            7 => (99, 10.0, t),
            8 => (tip, 30.0, t),
            _ => (elbow, 8.0, t),
        };
        let w = ExternalWrench { stamp, link, force: Vector3::new(0.0, f, 0.0) };
        let _ = ctl.step_with_contact(&input, None, Some(&w), &mut out);
        blended += usize::from(out.diagnostics.contact.weights[0] < 1.0);
        ignored += usize::from(out.diagnostics.contact.ignored.is_some());
        q += out.qdot * 1e-3;
        black_box(&out);
    }
    let after = allocations();
    assert_eq!(after - before, 0, "allocations in 6000 steps with TTC");
    assert!(blended > 1500, "TTC blend exercised: {blended}");
    assert!(ignored >= 2000, "ignored wrenches exercised: {ignored}");
}
