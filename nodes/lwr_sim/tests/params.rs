//! Every numeric parameter set to NaN, +inf, -inf and an out-of-range value in turn is refused
//! by `LwrSimConfig::validate`, with an error naming the key.

use lwr_sim::LwrSimConfig;
use lwr_sim::depth::{MAX_FLOOR_DISTANCE_M, MAX_PERSON_TIMEOUT_S};

type Set = fn(&mut LwrSimConfig, f64);

/// (key, setter, out-of-range values).
fn float_fields() -> Vec<(&'static str, Set, Vec<f64>)> {
    vec![
        ("simulation.step_s", |c, v| c.simulation.step_s = v, vec![0.0, -0.001, 0.2]),
        ("simulation.command_timeout_s", |c, v| c.simulation.command_timeout_s = v, vec![0.0, -1.0]),
        ("simulation.admittance_gain", |c, v| c.simulation.admittance_gain = v, vec![-0.005]),
        ("simulation.admittance_rotational_gain", |c, v| c.simulation.admittance_rotational_gain = v, vec![-0.05]),
        ("simulation.admittance_damping", |c, v| c.simulation.admittance_damping = v, vec![-0.05]),
        ("simulation.wrench_timeout_s", |c, v| c.simulation.wrench_timeout_s = v, vec![0.0, -0.1]),
        ("simulation.grasp_reach_m", |c, v| c.simulation.grasp_reach_m = v, vec![-0.05]),
        ("publish.clock_rate_hz", |c, v| c.publish.clock_rate_hz = v, vec![0.0, -1.0, 2000.0]),
        ("publish.joint_state_rate_hz", |c, v| c.publish.joint_state_rate_hz = v, vec![0.0, 2000.0]),
        ("publish.tf_rate_hz", |c, v| c.publish.tf_rate_hz = v, vec![0.0, 2000.0]),
        ("publish.world_rate_hz", |c, v| c.publish.world_rate_hz = v, vec![0.0, 2000.0]),
        ("external_wrench.report_rate_hz", |c, v| c.external_wrench.report_rate_hz = v, vec![0.0, 2000.0]),
        ("depth.floor_height_m", |c, v| c.depth.floor_height_m = v, vec![MAX_FLOOR_DISTANCE_M + 1.0, -MAX_FLOOR_DISTANCE_M - 1.0]),
        ("depth.person_timeout_s", |c, v| c.depth.person_timeout_s = v, vec![0.0, -0.5, MAX_PERSON_TIMEOUT_S * 2.0]),
    ]
}

#[test]
fn every_numeric_parameter_refuses_non_finite_and_out_of_range_values() {
    LwrSimConfig::default().validate("cfg.yaml").expect("the defaults are valid");
    for (key, set, out_of_range) in float_fields() {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY].into_iter().chain(out_of_range) {
            let mut c = LwrSimConfig::default();
            set(&mut c, v);
            match c.validate("cfg.yaml") {
                Ok(()) => panic!("`{key}` = {v} was accepted"),
                Err(e) => {
                    let e = format!("{e:#}");
                    assert!(e.starts_with("cfg.yaml:"), "{e}");
                    assert!(e.contains(&format!("`{key}`")), "`{key}` = {v}: the error does not name the key: {e}");
                }
            }
        }
    }
}

#[test]
fn the_bundled_file_holds_the_defaults_and_edge_values_pass() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let file: LwrSimConfig = cowork_ros::params::load(&root.join("config/lwr_sim.yaml"), "lwr_sim").expect("bundled parameters");
    assert_eq!(file, LwrSimConfig::default());
    let mut c = LwrSimConfig::default();
    c.publish.clock_rate_hz = 1000.0;
    c.simulation.admittance_gain = 0.0;
    c.depth.floor_height_m = -MAX_FLOOR_DISTANCE_M;
    c.depth.person_timeout_s = MAX_PERSON_TIMEOUT_S;
    c.validate("cfg.yaml").expect("edge values are valid");
}
