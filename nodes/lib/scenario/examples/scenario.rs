//! Runs one scenario and prints its JSON summary (the library side of `cowork scenario`).
//!
//! `cargo run --release -p cowork_scenario --example scenario -- NAME [--key value ...] [--csv OUT]`
//!
//! `--sweep FROM:TO:STEP` (moving-sphere-* only) runs the scenario for each obstacle speed
//! along +y (m/s) with the other options, prints one JSON line per speed and then the first
//! failing speed (hand touched or goal not regained within 1 cm).

use std::path::PathBuf;

use cowork_robot::RobotModel;
use cowork_scenario::scenarios::sweep_moving_sphere_with;
use cowork_scenario::{Options, build, run};

fn speeds(spec: &str) -> Result<Vec<f64>, Box<dyn std::error::Error>> {
    let parts: Vec<f64> = spec.split(':').map(str::parse).collect::<Result<_, _>>()?;
    let [from, to, step] = parts[..] else {
        return Err(format!("--sweep {spec:?}: expected FROM:TO:STEP (m/s)").into());
    };
    if !(from > 0.0 && to >= from && step > 0.0) {
        return Err(format!("--sweep {spec:?}: need 0 < FROM <= TO and STEP > 0").into());
    }
    let n = ((to - from) / step + 1e-9).floor() as usize + 1;
    Ok((0..n).map(|i| ((from + step * i as f64) * 1000.0).round() / 1000.0).collect())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let name = args.next().ok_or("usage: scenario NAME [--key value ...] [--csv OUT] [--sweep FROM:TO:STEP]")?;
    let mut pairs = Vec::new();
    let mut csv = None;
    let mut sweep = None;
    while let Some(k) = args.next() {
        let key = k.strip_prefix("--").ok_or_else(|| format!("expected --key, got {k:?}"))?.to_owned();
        let value = args.next().ok_or_else(|| format!("--{key} needs a value"))?;
        match key.as_str() {
            "csv" => csv = Some(PathBuf::from(value)),
            "sweep" => sweep = Some(value),
            _ => pairs.push((key, value)),
        }
    }
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../config/robot/lwr4plus.urdf");
    let model = RobotModel::from_urdf_file(urdf)?;
    if let Some(spec) = sweep {
        let reach = match name.as_str() {
            "moving-sphere-hold" => false,
            "moving-sphere-reach" => true,
            other => return Err(format!("--sweep is for moving-sphere-hold / -reach, not {other}").into()),
        };
        let points = sweep_moving_sphere_with(&model, reach, &speeds(&spec)?, 0.01, &pairs)?;
        for p in &points {
            println!(
                "{}",
                serde_json::json!({ "speed_m_s": p.speed_m_s, "ok": p.ok, "summary": p.summary })
            );
        }
        match points.iter().find(|p| !p.ok) {
            Some(p) => println!("first failing speed: {} m/s", p.speed_m_s),
            None => println!("no failure up to {} m/s", points.last().map_or(0.0, |p| p.speed_m_s)),
        }
        return Ok(());
    }
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
