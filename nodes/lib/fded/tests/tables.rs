//! Prints the benchmark tables (quick set) when run explicitly:
//! `cargo test -p cowork_fded --test tables -- --ignored --nocapture`. Timing belongs to the
//! benchmark, not the test suite, hence ignored by default.

mod common;

use cowork_fded::bench::{TablesOptions, print_tables, static_scene};

#[test]
#[ignore = "benchmark; run with --ignored --nocapture"]
fn print_quick_tables() {
    let model = common::model();
    let frames = std::env::var("FDED_FRAMES").ok().and_then(|v| v.parse().ok()).unwrap_or(10);
    let quick = std::env::var("FDED_FULL").is_err();
    let scene = static_scene(&model, frames, 1).unwrap();
    let opts = TablesOptions { reps: 5, threads: 2, budget: std::time::Duration::from_secs(2), quick };
    print_tables(&model, &scene, &opts, &mut std::io::stdout().lock()).unwrap();
}
