//! Every numeric parameter set to NaN, +inf, -inf and an out-of-range value in turn is refused
//! by `Params::validate`, with an error naming the key.

use attentional_supervisor::{MAX_TASK_DEPTH, Params};

type Set = fn(&mut Params, f64);

/// (key, setter, out-of-range values).
fn float_fields() -> Vec<(&'static str, Set, Vec<f64>)> {
    vec![
        ("tick_rate_hz", |p, v| p.tick_rate_hz = v, vec![0.0, -1.0, 20_000.0]),
        ("snapshot_rate_hz", |p, v| p.snapshot_rate_hz = v, vec![-1.0, 200.0]),
        ("attention.lambda_min_s", |p, v| p.attention.lambda_min_s = v, vec![0.0, -0.1]),
        ("attention.lambda_max_s", |p, v| p.attention.lambda_max_s = v, vec![0.05]),
        ("attention.r_min_m", |p, v| p.attention.r_min_m = v, vec![-0.1]),
        ("attention.r_max_m", |p, v| p.attention.r_max_m = v, vec![0.0, -1.0]),
        ("attention.k", |p, v| p.attention.k = v, vec![-1.0]),
        ("attention.hysteresis", |p, v| p.attention.hysteresis = v, vec![-0.1]),
    ]
}

fn refused(p: &Params, key: &str, what: &str) {
    match p.validate("cfg.yaml") {
        Ok(()) => panic!("`{key}` = {what} was accepted"),
        Err(e) => {
            let e = format!("{e:#}");
            assert!(e.starts_with("cfg.yaml:"), "{e}");
            assert!(e.contains(&format!("`{key}`")), "`{key}` = {what}: the error does not name the key: {e}");
        }
    }
}

#[test]
fn every_numeric_parameter_refuses_non_finite_and_out_of_range_values() {
    Params::default().validate("cfg.yaml").expect("the defaults are valid");
    for (key, set, out_of_range) in float_fields() {
        for v in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY].into_iter().chain(out_of_range) {
            let mut p = Params::default();
            set(&mut p, v);
            refused(&p, key, &v.to_string());
        }
    }
    for d in [0, MAX_TASK_DEPTH + 1] {
        let mut p = Params::default();
        p.attention.max_depth = d;
        refused(&p, "attention.max_depth", &d.to_string());
    }
}

#[test]
fn edge_values_inside_the_ranges_are_accepted() {
    for p in [
        Params { snapshot_rate_hz: 0.0, ..Params::default() },
        Params { tick_rate_hz: 10_000.0, snapshot_rate_hz: 10_000.0, ..Params::default() },
        Params { attention: cowork_supervisor::SupervisorConfig { k: 0.0, hysteresis: 0.0, max_depth: MAX_TASK_DEPTH, ..Default::default() }, ..Params::default() },
    ] {
        p.validate("cfg.yaml").unwrap_or_else(|e| panic!("{p:?}: {e:#}"));
    }
}
