//! Per-link trace of a recorded trial as CSV: true link–person distance beside the distance
//! node's report for that link, its age, and what the controller did.
//!
//!     cargo run --release -p cowork_experiment --example link_trace -- out/bags/stacking-hri-fded-1.mcap [BELOW_M] > trace.csv

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let bag = PathBuf::from(args.next().ok_or("usage: link_trace BAG.mcap [BELOW_M]")?);
    let below: f64 = match args.next() {
        Some(s) => s.parse().map_err(|e| format!("BELOW_M {s:?}: {e}"))?,
        None => 0.3,
    };
    let model = cowork_robot::RobotModel::from_urdf_file("config/robot/lwr4plus.urdf")?;
    let trace = cowork_experiment::trace::link_trace(&bag, &model, cowork_people::DEFAULT_FLOOR_Z, below)?;
    println!("{}", cowork_experiment::trace::LinkSample::CSV_HEADER);
    for s in &trace {
        println!("{}", s.csv_row());
    }
    Ok(())
}
