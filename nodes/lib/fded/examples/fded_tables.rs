//! Prints thesis Tables 5.1 and 5.2 and the Flacco comparison on the synthetic static scene
//! (the same as `cowork bench fded`, without the CLI's other dependencies).
//!
//!     cargo run --release -p cowork_fded --example fded_tables -- [FRAMES] [REPS] [--quick]

use cowork_fded::bench::{TablesOptions, print_tables, static_scene};
use cowork_robot::RobotModel;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let quick = args.iter().any(|a| a == "--quick");
    let nums: Vec<usize> = args.iter().filter_map(|a| a.parse().ok()).collect();
    let frames = nums.first().copied().unwrap_or(20);
    let reps = nums.get(1).copied().unwrap_or(5);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(path)?;
    let scene = static_scene(&model, frames, 1)?;
    let opts = TablesOptions { reps, threads: 2, budget: std::time::Duration::from_secs(3), quick };
    print_tables(&model, &scene, &opts, &mut std::io::stdout().lock())?;
    Ok(())
}
