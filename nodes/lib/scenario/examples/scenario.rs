//! Runs one scenario and prints its JSON summary (the library side of `cowork scenario`).
//!
//! `cargo run --release -p cowork_scenario --example scenario -- NAME [--key value ...] [--csv OUT]`

use std::path::PathBuf;

use cowork_robot::RobotModel;
use cowork_scenario::{Options, build, run};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().ok_or("usage: scenario NAME [--key value ...] [--csv OUT]")?;
    let mut pairs = Vec::new();
    let mut csv = None;
    while let Some(k) = args.next() {
        let key = k.strip_prefix("--").ok_or_else(|| format!("expected --key, got {k:?}"))?.to_owned();
        let value = args.next().ok_or_else(|| format!("--{key} needs a value"))?;
        if key == "csv" {
            csv = Some(PathBuf::from(value));
        } else {
            pairs.push((key, value));
        }
    }
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf)?;
    let setup = build(&model, &name, &Options::new(&name, pairs))?;
    let summary = match csv {
        Some(path) => {
            let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
            run(&model, setup, Some((&mut w, 10)))?
        }
        None => run(&model, setup, None)?,
    };
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}
