//! `cowork scenario NAME [--key value ...]`: the DS controller's simulated experiments (thesis
//! Fig. 5.3–5.7, Sec. 5.1.3) on the simulated clock, printed as a JSON summary.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use cowork_robot::RobotModel;
use cowork_scenario::{NAMES, Options, build, run as run_scenario, scenarios::sweep_moving_sphere_with};

/// Arguments of `cowork scenario`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Scenarios: three-obstacles, box-in-out, moving-sphere-hold, moving-sphere-reach, \
hand-hit, stacking-human.\n\
Options (per scenario; unknown ones are an error): --duration S, --distance-rate HZ, --gain K; \
moving-sphere-*: --obstacle-velocity vx,vy,vz  --obstacle-start x,y,z  --radius R  --lead S; \
three-obstacles: --gap M; hand-hit: --sweep-time S; stacking-human: --interaction-distance M  \
--enter-at S  --stand-x M  --reach-range M  --reach-time S  --hold S  --reach-to x,y,z (fixed reach)  \
--far-speed V  --interaction-speed V.\n\
Also: --csv OUT (trajectory), --csv-every N (rows every N steps, default 10), \
--sweep FROM:TO:STEP (moving-sphere-*: obstacle speeds along +y, with the other options; prints the first failing speed).")]
pub struct ScenarioArgs {
    /// Robot description.
    #[arg(long, default_value = "config/robot/lwr4plus.urdf", value_parser = cowork_ros::config::path_arg)]
    pub urdf: PathBuf,
    /// Scenario name.
    pub name: String,
    /// `--key value` pairs.
    #[arg(trailing_var_arg = true, allow_hyphen_values = true, value_name = "--KEY VALUE")]
    pub options: Vec<String>,
}

/// Runs the scenario and prints its summary.
pub fn run(args: ScenarioArgs) -> Result<()> {
    if !NAMES.contains(&args.name.as_str()) {
        bail!("unknown scenario {:?} (known: {})", args.name, NAMES.join(", "));
    }
    let mut pairs = Vec::new();
    let mut it = args.options.iter();
    while let Some(k) = it.next() {
        let Some(key) = k.strip_prefix("--") else {
            bail!("expected --key value, found {k:?}");
        };
        let Some(v) = it.next() else { bail!("option --{key} has no value") };
        pairs.push((key.to_owned(), v.clone()));
    }
    let take = |pairs: &mut Vec<(String, String)>, key: &str| {
        pairs.iter().position(|(k, _)| k == key).map(|i| pairs.remove(i).1)
    };
    let csv = take(&mut pairs, "csv").map(PathBuf::from);
    let csv_every: usize = match take(&mut pairs, "csv-every") {
        Some(v) => v.parse().ok().filter(|n| *n > 0).with_context(|| format!("--csv-every {v:?}: expected a positive integer"))?,
        None => 10,
    };
    let sweep = take(&mut pairs, "sweep");
    let model = RobotModel::from_urdf_file(cowork_ros::config::resolve(&args.urdf))
        .with_context(|| format!("cannot load robot description {}", args.urdf.display()))?;

    if let Some(spec) = sweep {
        let reach = match args.name.as_str() {
            "moving-sphere-hold" => false,
            "moving-sphere-reach" => true,
            other => bail!("--sweep is for moving-sphere-hold / moving-sphere-reach, not {other}"),
        };
        let parts: Vec<f64> = spec.split(':').map(str::parse).collect::<Result<_, _>>()
            .with_context(|| format!("--sweep {spec:?}: expected FROM:TO:STEP (m/s)"))?;
        let [from, to, step] = parts[..] else { bail!("--sweep {spec:?}: expected FROM:TO:STEP (m/s)") };
        if !(from > 0.0 && to >= from && step > 0.0) {
            bail!("--sweep {spec:?}: need 0 < FROM <= TO and STEP > 0");
        }
        let n = ((to - from) / step + 1e-9).floor() as usize + 1;
        let speeds: Vec<f64> = (0..n).map(|i| ((from + step * i as f64) * 1000.0).round() / 1000.0).collect();
        let points = sweep_moving_sphere_with(&model, reach, &speeds, 0.01, &pairs)?;
        println!("{:>9}  {:>4}  {:>13}  {:>15}  {:>18}  {:>10}  {:>9}", "speed_m_s", "ok", "hand_min_m", "arm_min_m", "final_goal_error_m", "collisions", "max_qd/lim");
        for p in &points {
            let s = &p.summary;
            println!(
                "{:9.2}  {:>4}  {:13.4}  {:15.4}  {:18.4}  {:10}  {:9.3}",
                p.speed_m_s, if p.ok { "yes" } else { "NO" }, s.min_hand_distance_m, s.min_distance_m,
                s.final_goal_error_m, s.collisions, s.max_joint_velocity_ratio
            );
        }
        match points.iter().find(|p| !p.ok) {
            Some(p) => println!("first failing speed: {:.2} m/s", p.speed_m_s),
            None => println!("no failure up to {:.2} m/s", speeds.last().copied().unwrap_or(0.0)),
        }
        return Ok(());
    }

    let setup = build(&model, &args.name, &Options::new(&args.name, pairs))?;
    let summary = match &csv {
        Some(path) => {
            let mut w = super::output::Output::create(path)?;
            let s = run_scenario(&model, setup, Some((&mut w, csv_every)))?;
            w.commit()?;
            s
        }
        None => run_scenario(&model, setup, None)?,
    };
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}
