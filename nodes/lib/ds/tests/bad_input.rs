//! Bad input is rejected with a reason and the robot is held (braked), never moved blind; bad
//! configuration fails at construction naming the field.

mod common;

use cowork_ds::{
    ControlInput, ControlOutput, ControllerConfig, DsController, Error, Fault, HoldReason,
    LinkDistance, Status,
};
use nalgebra::{Point3, Vector3};

fn moving_controller() -> (DsController, ControlInput, ControlOutput) {
    let model = common::lwr();
    let q = common::q_start();
    let goal = common::tip_position(&model, &q) + Vector3::new(0.0, 0.3, 0.0);
    let mut ctl = DsController::new(model, ControllerConfig::default()).expect("config");
    let mut out = ControlOutput::default();
    let input = common::input(q, common::command(common::constant_speed(0.3), goal), 0.0);
    for k in 0..300 {
        let mut i = input;
        i.time = k as f64 * 1e-3;
        i.distances.stamp = i.time;
        i.human.stamp = i.time;
        ctl.step(&i, &mut out).expect("valid");
    }
    assert!(out.qdot.norm() > 0.01);
    (ctl, input, out)
}

fn obstacle(distance: f64, normal: Vector3<f64>) -> LinkDistance {
    LinkDistance {
        valid: true,
        distance,
        robot_point: Point3::new(0.3, 0.0, 0.5),
        obstacle_point: Point3::new(0.4, 0.0, 0.5),
        normal,
        obstacle_velocity: Vector3::zeros(),
    }
}

fn rejected(modify: impl Fn(&mut ControlInput)) -> Fault {
    let (mut ctl, mut input, mut out) = moving_controller();
    let before = out.qdot;
    input.time = 0.3;
    input.distances.stamp = 0.3;
    input.human.stamp = 0.3;
    modify(&mut input);
    let fault = ctl.step(&input, &mut out).expect_err("bad input rejected");
    assert!(matches!(out.status, Status::Held(HoldReason::Fault(f)) if f == fault));
    // Braking: every joint slower than before, none reversed.
    for i in 0..7 {
        assert!(out.qdot[i].abs() <= before[i].abs());
        assert!(out.qdot[i] * before[i] >= 0.0);
    }
    assert!(out.qdot.norm() < before.norm());
    fault
}

#[test]
fn nan_and_infinite_distances_are_rejected() {
    let f = rejected(|i| {
        i.distances.count = 9;
        i.distances.links[8] = obstacle(f64::NAN, Vector3::x());
    });
    assert_eq!(
        f,
        Fault::NonFinite {
            what: "distance",
            link: 8
        }
    );
    assert!(f.to_string().contains("distance"), "{f}");
    let f = rejected(|i| {
        i.distances.count = 9;
        i.distances.links[3] = obstacle(f64::INFINITY, Vector3::x());
    });
    assert_eq!(
        f,
        Fault::NonFinite {
            what: "distance",
            link: 3
        }
    );
}

#[test]
fn bad_normals_are_rejected() {
    let f = rejected(|i| {
        i.distances.count = 9;
        i.distances.links[5] = obstacle(0.1, Vector3::new(f64::NAN, 0.0, 1.0));
    });
    assert_eq!(
        f,
        Fault::NonFinite {
            what: "normal",
            link: 5
        }
    );
    let f = rejected(|i| {
        i.distances.count = 9;
        i.distances.links[5] = obstacle(0.1, Vector3::zeros());
    });
    assert_eq!(f, Fault::ZeroNormal { link: 5 });
    assert_eq!(f.to_string(), "zero obstacle normal for link 5");
}

#[test]
fn invalid_entries_are_ignored() {
    let (mut ctl, mut input, mut out) = moving_controller();
    input.time = 0.3;
    input.distances.stamp = 0.3;
    input.human.stamp = 0.3;
    input.distances.count = 9;
    input.distances.links[5] = LinkDistance {
        valid: false,
        ..obstacle(f64::NAN, Vector3::zeros())
    };
    ctl.step(&input, &mut out)
        .expect("invalid entries carry no data");
}

#[test]
fn goal_out_of_reach_and_bad_primitive_are_rejected() {
    let f = rejected(|i| i.command.goal = Vector3::new(3.0, 0.0, 0.5));
    assert!(matches!(f, Fault::GoalOutOfReach { .. }), "{f}");
    let f = rejected(|i| i.command.primitive = common::linear(-1.0));
    assert_eq!(
        f,
        Fault::BadPrimitive {
            what: "gain",
            value: -1.0
        }
    );
    let f = rejected(|i| i.q[2] = f64::NAN);
    assert_eq!(
        f,
        Fault::NonFinite {
            what: "q",
            link: usize::MAX
        }
    );
    let f = rejected(|i| {
        i.distances.count = 40;
    });
    assert!(matches!(f, Fault::TooManyLinks { given: 40, .. }));
}

#[test]
fn hold_command_brakes_without_fault() {
    let (mut ctl, mut input, mut out) = moving_controller();
    input.command.primitive = cowork_ds::Primitive::Hold;
    let mut t = 0.3;
    for _ in 0..2000 {
        input.time = t;
        input.distances.stamp = t;
        input.human.stamp = t;
        ctl.step(&input, &mut out).expect("hold is no fault");
        assert_eq!(out.status, Status::Held(HoldReason::Command));
        t += 1e-3;
    }
    assert_eq!(out.qdot.norm(), 0.0);
}

#[test]
fn stop_from_the_person_holds() {
    let (mut ctl, mut input, mut out) = moving_controller();
    input.human.state.stopped = true;
    input.time = 0.3;
    input.distances.stamp = 0.3;
    input.human.stamp = 0.3;
    ctl.step(&input, &mut out).expect("valid");
    assert_eq!(out.status, Status::Held(HoldReason::SpeedZero));
    assert_eq!(out.diagnostics.alpha, 0.0);
    // Only the orientation-hold feedback remains (tiny).
    assert!(out.diagnostics.ee_velocity.norm() == 0.0);
}

#[test]
fn bad_config_is_named() {
    let model = common::lwr();
    let mut cfg = ControllerConfig::default();
    cfg.modulation.epsilon = f64::NAN;
    let err = DsController::new(model.clone(), cfg).expect_err("NaN epsilon");
    assert!(
        matches!(
            err,
            Error::Config {
                field: "modulation.epsilon",
                ..
            }
        ),
        "{err}"
    );
    let mut cfg = ControllerConfig::default();
    cfg.scaling.interaction_speed = 0.5;
    let err = DsController::new(model.clone(), cfg).expect_err("interaction faster than far");
    assert!(
        err.to_string().contains("scaling.interaction_speed"),
        "{err}"
    );
    let cfg = ControllerConfig {
        stale_after_s: -1.0,
        ..ControllerConfig::default()
    };
    assert!(DsController::new(model, cfg).is_err());
}

#[test]
fn config_yaml_round_trip_and_unknown_fields() {
    let cfg = ControllerConfig::default();
    let text = serde_yaml_ng::to_string(&cfg).expect("serialise");
    let back: ControllerConfig = serde_yaml_ng::from_str(&text).expect("parse");
    assert_eq!(back, cfg);
    let partial: ControllerConfig =
        serde_yaml_ng::from_str("stale_after_s: 0.05\nscaling:\n  far_speed: 0.25\n")
            .expect("partial");
    assert_eq!(partial.stale_after_s, 0.05);
    assert_eq!(partial.scaling.far_speed, 0.25);
    assert_eq!(partial.scaling.interaction_speed, 0.1);
    let err = serde_yaml_ng::from_str::<ControllerConfig>("stale_after: 0.05\n").expect_err("typo");
    assert!(err.to_string().contains("stale_after"), "{err}");
}

/// A NaN (or inverted) modulation distance used to pass validation and switch avoidance off
/// without a word; every such configuration is refused, naming the field.
#[test]
fn nan_or_inverted_modulation_distances_are_refused() {
    for (field, set) in [
        ("modulation.full_distance", (|c: &mut ControllerConfig| c.modulation.full_distance = f64::NAN) as fn(&mut ControllerConfig)),
        ("modulation.full_distance", |c| c.modulation.full_distance = -0.1),
        ("modulation.influence_distance", |c| c.modulation.influence_distance = f64::NAN),
        ("modulation.influence_distance", |c| c.modulation.influence_distance = 0.2),
        ("future_tolerance_s", |c| c.future_tolerance_s = f64::NAN),
        ("future_tolerance_s", |c| c.future_tolerance_s = 1.0),
    ] {
        let mut cfg = ControllerConfig::default();
        set(&mut cfg);
        let e = cfg.validate().expect_err(field);
        assert!(e.to_string().contains(field), "{field}: {e}");
    }
    let unbounded = ControllerConfig {
        modulation: cowork_ds::ModulationConfig { influence_distance: f64::INFINITY, ..Default::default() },
        ..ControllerConfig::default()
    };
    unbounded.validate().expect("an infinite influence distance (the thesis's eq. 5.6 everywhere) is valid");
}
