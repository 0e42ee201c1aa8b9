//! Every numeric parameter of ds_controller, set to NaN, +∞, −∞ and an out-of-range value in
//! turn, is refused by `Params::validate` with an error naming its key (issue #20 item 4; a
//! NaN `modulation.full_distance` or `influence_distance` used to turn avoidance off silently).
//! The table must list every floating-point key of `Params` (checked against its serialised
//! form), so a new parameter without a row fails here.

use std::collections::BTreeSet;

use ds_controller::Params;

type Setter = fn(&mut Params) -> &mut f64;

/// (key as the YAML file spells it, the field, a finite value out of its range for the
/// defaults). The out-of-range values of keys bounded by another key (`slow_distance` >
/// `stop_distance` …) break that relation.
fn float_keys() -> Vec<(&'static str, Setter, f64)> {
    vec![
        ("status_rate_hz", |p| &mut p.status_rate_hz, 0.0),
        ("default_linear_gain", |p| &mut p.default_linear_gain, -1.0),
        ("warning_period_s", |p| &mut p.warning_period_s, 0.0),
        ("controller.period_s", |p| &mut p.controller.period_s, 0.5),
        ("controller.slow_after_s", |p| &mut p.controller.slow_after_s, 0.5),
        ("controller.stale_after_s", |p| &mut p.controller.stale_after_s, 0.0),
        ("controller.future_tolerance_s", |p| &mut p.controller.future_tolerance_s, -0.01),
        ("controller.brake_deceleration", |p| &mut p.controller.brake_deceleration, 0.0),
        ("controller.resume_time_s", |p| &mut p.controller.resume_time_s, -0.1),
        ("controller.goal_tolerance_m", |p| &mut p.controller.goal_tolerance_m, 0.0),
        ("controller.orientation_tolerance_rad", |p| &mut p.controller.orientation_tolerance_rad, 0.0),
        ("controller.scaling.far_speed", |p| &mut p.controller.scaling.far_speed, 0.0),
        ("controller.scaling.interaction_speed", |p| &mut p.controller.scaling.interaction_speed, 1.0),
        ("controller.modulation.epsilon", |p| &mut p.controller.modulation.epsilon, 1.0),
        ("controller.modulation.full_distance", |p| &mut p.controller.modulation.full_distance, -0.1),
        ("controller.modulation.influence_distance", |p| &mut p.controller.modulation.influence_distance, 0.4),
        ("controller.escape.speed_threshold", |p| &mut p.controller.escape.speed_threshold, 0.0),
        ("controller.escape.contact_distance", |p| &mut p.controller.escape.contact_distance, -0.01),
        ("controller.escape.perturbation_speed", |p| &mut p.controller.escape.perturbation_speed, 0.0),
        ("controller.ik.damping", |p| &mut p.controller.ik.damping, -0.01),
        ("controller.ik.link_damping", |p| &mut p.controller.ik.link_damping, -0.01),
        ("controller.ik.orientation_gain", |p| &mut p.controller.ik.orientation_gain, -1.0),
        ("controller.ik.max_angular_speed", |p| &mut p.controller.ik.max_angular_speed, 0.0),
        ("controller.ik.velocity_limit_fraction", |p| &mut p.controller.ik.velocity_limit_fraction, 1.5),
        ("controller.ik.position_margin", |p| &mut p.controller.ik.position_margin, -0.01),
        ("controller.ik.posture_gain", |p| &mut p.controller.ik.posture_gain, -1.0),
        ("controller.ik.posture_max_speed", |p| &mut p.controller.ik.posture_max_speed, 0.0),
        ("controller.ik.limit_zone", |p| &mut p.controller.ik.limit_zone, 1.5),
        ("controller.ik.limit_gain", |p| &mut p.controller.ik.limit_gain, -1.0),
        ("controller.safety.stop_distance", |p| &mut p.controller.safety.stop_distance, 0.0),
        ("controller.safety.slow_distance", |p| &mut p.controller.safety.slow_distance, 0.05),
        ("controller.safety.approach_speed", |p| &mut p.controller.safety.approach_speed, 0.0),
        ("controller.safety.retreat_gain", |p| &mut p.controller.safety.retreat_gain, -1.0),
        ("controller.safety.scene_stop_distance", |p| &mut p.controller.safety.scene_stop_distance, 0.2),
        ("controller.safety.scene_slow_distance", |p| &mut p.controller.safety.scene_slow_distance, 0.02),
        ("controller.safety.max_obstacle_speed", |p| &mut p.controller.safety.max_obstacle_speed, -1.0),
        ("controller.safety.hand_radius", |p| &mut p.controller.safety.hand_radius, -0.01),
        ("controller.safety.damping", |p| &mut p.controller.safety.damping, -0.01),
        ("controller.safety.null_space_max_speed", |p| &mut p.controller.safety.null_space_max_speed, 0.0),
        ("controller.ttc.max_wrench_age_s", |p| &mut p.controller.ttc.max_wrench_age_s, 0.0),
        ("controller.ttc.max_force", |p| &mut p.controller.ttc.max_force, 10.0),
        ("controller.ttc.contact_gain", |p| &mut p.controller.ttc.contact_gain, 0.0),
        ("controller.ttc.insert_force", |p| &mut p.controller.ttc.insert_force, 0.0),
        ("controller.ttc.switch_force", |p| &mut p.controller.ttc.switch_force, 1.0),
        ("controller.ttc.transition_gain", |p| &mut p.controller.ttc.transition_gain, 0.0),
        ("controller.ttc.damping", |p| &mut p.controller.ttc.damping, -0.01),
        ("controller.ttc.contact_damping", |p| &mut p.controller.ttc.contact_damping, -0.01),
        ("scene_objects.margin_m", |p| &mut p.scene_objects.margin_m, 0.5),
        ("scene_objects.max_age_s", |p| &mut p.scene_objects.max_age_s, 0.0),
    ]
}

/// The name the error must contain: the key without `controller.` (the controller's own
/// validation names `modulation.full_distance`, the message says `controller: …` before it).
fn named(key: &str) -> &str {
    key.strip_prefix("controller.").unwrap_or(key)
}

/// Dotted paths of every floating-point value in `v`.
fn float_paths(v: &serde_json::Value, prefix: &str, out: &mut BTreeSet<String>) {
    match v {
        serde_json::Value::Number(n) if n.is_f64() => {
            out.insert(prefix.to_owned());
        }
        serde_json::Value::Object(m) => {
            for (k, child) in m {
                let path = if prefix.is_empty() { k.clone() } else { format!("{prefix}.{k}") };
                float_paths(child, &path, out);
            }
        }
        _ => {}
    }
}

#[test]
fn the_table_lists_every_float_parameter() {
    let mut paths = BTreeSet::new();
    float_paths(&serde_json::to_value(Params::default()).expect("serialisable"), "", &mut paths);
    let listed: BTreeSet<String> = float_keys().iter().map(|(k, _, _)| (*k).to_owned()).collect();
    assert_eq!(paths, listed, "float keys of Params (left) vs the table (right)");
}

#[test]
fn defaults_are_valid_and_each_bad_value_is_refused_naming_its_key() {
    Params::default().validate("defaults").expect("the defaults are valid");
    let mut failures = Vec::new();
    let mut tried = 0;
    for (key, field, out_of_range) in float_keys() {
        let mut p = Params::default();
        let good = *field(&mut p);
        // The out-of-range value must really differ from the default (and not be NaN).
        assert!(out_of_range.is_finite() && out_of_range != good, "{key}");
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, out_of_range] {
            // Documented: `.inf` keeps eq. 5.6 at every distance (no fading).
            if key == "controller.modulation.influence_distance" && bad == f64::INFINITY {
                let mut p = Params::default();
                *field(&mut p) = bad;
                assert!(p.validate("test").is_ok(), "influence_distance = inf must stay allowed");
                continue;
            }
            let mut p = Params::default();
            *field(&mut p) = bad;
            tried += 1;
            match p.validate("test.yaml") {
                Ok(()) => failures.push(format!("{key} = {bad} accepted")),
                Err(e) => {
                    let msg = format!("{e:#}");
                    if !msg.contains(named(key)) || !msg.contains("test.yaml") {
                        failures.push(format!("{key} = {bad} refused without naming the key and the file: {msg}"));
                    }
                }
            }
        }
    }
    assert_eq!(tried, 4 * float_keys().len() - 1);
    assert!(failures.is_empty(), "{} of {tried}:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn integer_parameters_out_of_range_are_refused_naming_their_key() {
    for (key, set) in [
        ("max_model_file_bytes", (|p: &mut Params| p.max_model_file_bytes = 0) as fn(&mut Params)),
        ("max_model_file_bytes", |p| p.max_model_file_bytes = 1 << 40),
        ("safety.iterations", |p| p.controller.safety.iterations = 0),
        ("safety.iterations", |p| p.controller.safety.iterations = 21),
    ] {
        let mut p = Params::default();
        set(&mut p);
        let e = p.validate("test.yaml").expect_err(key);
        assert!(format!("{e:#}").contains(key), "{key}: {e:#}");
    }
}

#[test]
fn a_nan_modulation_distance_in_the_parameter_file_is_refused_at_load() {
    // The path a node takes at start: YAML text → Params → validate.
    for (key, yaml_key) in [("modulation.full_distance", "full_distance"), ("modulation.influence_distance", "influence_distance")] {
        let text = format!("ds_controller:\n  ros__parameters:\n    controller:\n      modulation:\n        {yaml_key}: .nan\n");
        let p: Params = cowork_ros::params::from_str(&text, "ds_controller", "test.yaml").expect("parses");
        let e = p.validate("test.yaml").expect_err(key);
        assert!(format!("{e:#}").contains(key), "{e:#}");
    }
}

#[test]
fn a_bad_posture_reference_is_refused_naming_its_joint() {
    for (bad, joint) in [(f64::NAN, 0), (f64::INFINITY, 3), (7.0, 6)] {
        let mut p = Params::default();
        let mut r = [Some(0.0); 7];
        r[joint] = Some(bad);
        p.controller.ik.posture_reference = Some(r);
        let msg = format!("{:#}", p.validate("test.yaml").expect_err("refused"));
        assert!(msg.contains(&format!("ik.posture_reference[{joint}]")) && msg.contains("test.yaml"), "{msg}");
    }
    let mut p = Params::default();
    p.controller.ik.posture_reference = Some([Some(0.0), None, Some(0.0), None, Some(0.0), None, Some(0.0)]);
    p.validate("test.yaml").expect("a reference for joints 1, 3, 5, 7 is valid");
}
