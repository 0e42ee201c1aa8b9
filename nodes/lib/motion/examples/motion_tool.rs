//! Driver of the cross-checks in `tests/crosscheck/check_motion.sh` (not a user tool: users
//! have `cowork learn` and `cowork bench lasa`).
//!
//! ```text
//! motion_tool gmr GMM.json N_IN POINTS.csv          -> one line per point: conditional mean
//! motion_tool dtw PAIRS.csv                          -> one distance per line (1-D pairs a;b)
//! motion_tool dmp DEMO.csv N_BASIS REPEATS OUT.csv   -> reproduction to OUT.csv, timing line
//! motion_tool lasa-k DIR MOTIONS KMAX SUBSAMPLE      -> "name,K" per motion (BIC)
//! motion_tool lasa-time DIR MOTIONS REPEATS          -> EM+BIC time per motion (min of REPEATS)
//! motion_tool lasa DIR MOTIONS [EXT_DIR]             -> the LASA table
//! ```

use std::path::Path;
use std::time::Instant;

use cowork_motion::cgmr::{Components, fit_gmr_ds};
use cowork_motion::csv_io::{read_demonstration, read_points, write_trajectory};
use cowork_motion::dmp::{Dmp, DmpConfig};
use cowork_motion::lasa::{
    LasaOptions, evaluate_external, evaluate_motion, format_table, list_motions, load_motion,
};
use cowork_motion::{Gmm, Gmr, Result};

fn arg(args: &[String], i: usize) -> Result<&str> {
    args.get(i)
        .map(String::as_str)
        .ok_or_else(|| cowork_motion::MotionError::InvalidParameter {
            name: format!("argument {i}"),
            reason: "missing".into(),
        })
}

fn num<T: std::str::FromStr>(s: &str) -> Result<T> {
    s.parse()
        .map_err(|_| cowork_motion::MotionError::InvalidParameter {
            name: s.into(),
            reason: "not a number".into(),
        })
}

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().collect();
    match run(&args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("motion_tool: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run(args: &[String]) -> Result<()> {
    match arg(args, 1)? {
        "gmr" => {
            let text = std::fs::read_to_string(arg(args, 2)?).map_err(|source| {
                cowork_motion::MotionError::Io {
                    file: arg(args, 2).unwrap_or("").into(),
                    source,
                }
            })?;
            let gmm: Gmm = serde_json::from_str(&text).map_err(|e| {
                cowork_motion::MotionError::InvalidParameter {
                    name: "gmm json".into(),
                    reason: e.to_string(),
                }
            })?;
            let n_in: usize = num(arg(args, 3)?)?;
            let gmr = Gmr::new(gmm, n_in)?;
            let (n, pts) = read_points(Path::new(arg(args, 4)?))?;
            let mut out = vec![0.0; gmr.n_out()];
            for x in pts.chunks(n) {
                gmr.predict(x, &mut out)?;
                println!(
                    "{}",
                    out.iter()
                        .map(|v| format!("{v:.17e}"))
                        .collect::<Vec<_>>()
                        .join(",")
                );
            }
        }
        "dtw" => {
            let text = std::fs::read_to_string(arg(args, 2)?).map_err(|source| {
                cowork_motion::MotionError::Io {
                    file: arg(args, 2).unwrap_or("").into(),
                    source,
                }
            })?;
            for line in text.lines().filter(|l| !l.trim().is_empty()) {
                let (a, b) = line.split_once(';').ok_or_else(|| {
                    cowork_motion::MotionError::InvalidParameter {
                        name: "pair".into(),
                        reason: "expected a;b".into(),
                    }
                })?;
                let p = |s: &str| s.split(',').map(num::<f64>).collect::<Result<Vec<f64>>>();
                println!(
                    "{:.17e}",
                    cowork_motion::dtw::dtw_distance(&p(a)?, &p(b)?, 1, None)?
                );
            }
        }
        "dmp" => {
            let demo = read_demonstration(Path::new(arg(args, 2)?))?;
            let cfg = DmpConfig {
                n_basis: num(arg(args, 3)?)?,
                ..DmpConfig::default()
            };
            let repeats: usize = num(arg(args, 4)?)?;
            let dt = demo.duration() / (demo.len() - 1) as f64;
            let mut times = Vec::new();
            let mut tr = None;
            for _ in 0..repeats.max(1) {
                let t0 = Instant::now();
                let dmp = Dmp::fit(&demo, &cfg)?;
                let r = dmp.rollout(None, None, 1.0, dt, demo.len() - 1, 0.0)?;
                times.push(t0.elapsed().as_secs_f64());
                tr = Some(r);
            }
            times.sort_by(f64::total_cmp);
            if let Some(tr) = tr {
                write_trajectory(Path::new(arg(args, 5)?), &tr)?;
            }
            println!("median_fit_rollout_s={:.6e}", times[times.len() / 2]);
        }
        "lasa-k" => {
            let root = Path::new(arg(args, 2)?);
            let motions: usize = num(arg(args, 3)?)?;
            let kmax: usize = num(arg(args, 4)?)?;
            let sub: usize = num(arg(args, 5)?)?;
            for (name, dir) in list_motions(root)?.into_iter().take(motions) {
                let demos = load_motion(&dir)?;
                let (ds, _) = fit_gmr_ds(
                    &demos,
                    Components::Bic(kmax),
                    &LasaOptions::default().em,
                    sub,
                )?;
                println!("{name},{}", ds.gmr.n_components());
            }
        }
        "lasa-time" => {
            // Training only (EM + BIC over K = 1..10 at the benchmark's settings), the fastest of
            // REPEATS runs per motion: robust against other load on the machine.
            let root = Path::new(arg(args, 2)?);
            let motions: usize = num(arg(args, 3)?)?;
            let repeats: usize = num(arg(args, 4)?)?;
            let opts = LasaOptions::default();
            let mut times = Vec::new();
            for (name, dir) in list_motions(root)?.into_iter().take(motions) {
                let demos = load_motion(&dir)?;
                let mut best = f64::INFINITY;
                let mut k = 0;
                for _ in 0..repeats.max(1) {
                    let t0 = Instant::now();
                    let (ds, _) = fit_gmr_ds(
                        &demos,
                        Components::Bic(opts.k_max),
                        &opts.em,
                        opts.subsample,
                    )?;
                    best = best.min(t0.elapsed().as_secs_f64() * 1e3);
                    k = ds.gmr.n_components();
                }
                println!("{name},{k},{best:.3}");
                times.push(best);
            }
            times.sort_by(f64::total_cmp);
            println!("median_ms,{:.3}", times[times.len() / 2]);
        }
        "lasa" => {
            let root = Path::new(arg(args, 2)?);
            let motions: usize = num(arg(args, 3)?)?;
            let ext = args.get(4).map(Path::new);
            let opts = LasaOptions::default();
            let mut rows = Vec::new();
            let mut externals = Vec::new();
            for (name, dir) in list_motions(root)?.into_iter().take(motions) {
                let demos = load_motion(&dir)?;
                let row = evaluate_motion(&name, &demos, &opts)?;
                eprintln!(
                    "{name}: K={} gmr area {:.1} cgmr area {:.1} rand {:.2}/{:.2}",
                    row.k,
                    row.gmr.area,
                    row.cgmr.area,
                    row.gmr.random_reached,
                    row.cgmr.random_reached
                );
                rows.push(row);
                if let Some(e) = ext {
                    externals.push(evaluate_external(&demos, &e.join(&name))?);
                }
            }
            print!("{}", format_table(&rows, ext.map(|_| externals.as_slice())));
        }
        other => {
            return Err(cowork_motion::MotionError::InvalidParameter {
                name: "subcommand".into(),
                reason: format!("unknown `{other}`"),
            });
        }
    }
    Ok(())
}
