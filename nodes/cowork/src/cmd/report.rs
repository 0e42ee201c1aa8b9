//! `cowork report RUN.mcap... -o DIR`: the experiment report of recorded runs, judged from the
//! bags exactly as `cowork experiment` judges live. A plot whose topics the bag lacks is not
//! drawn; the page names the missing topics.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use cowork_experiment::report::{Metadata, ReportHead, ReportTrial, near_person_columns, write_report};
use cowork_experiment::{Judge, Stats};
use cowork_robot::RobotModel;

/// Arguments of `cowork report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Recorded runs (`cowork experiment --record`, `cowork bag record`).
    #[arg(required = true)]
    pub bags: Vec<PathBuf>,
    /// Output directory (index.html + PNGs).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Robot description.
    #[arg(long, default_value = "config/robot/lwr4plus.urdf", value_parser = cowork_ros::config::path_arg)]
    pub urdf: PathBuf,
}

/// Judges every bag and writes the report.
pub fn run(args: ReportArgs) -> Result<()> {
    let model = RobotModel::from_urdf_file(cowork_ros::config::resolve(&args.urdf))
        .with_context(|| format!("cannot load robot description {}", args.urdf.display()))?;
    let mut trials = Vec::new();
    for bag in &args.bags {
        let mut judge = Judge::new(model.clone(), cowork_people::DEFAULT_FLOOR_Z)?;
        let feed = cowork_experiment::bag::feed_bag(bag, &mut judge)
            .with_context(|| format!("reading {}", bag.display()))?;
        if feed.used == 0 {
            bail!(
                "{}: no message on the judged topics (/joint_states, /human/skeleton, /fded/distances, /human/state, /lwr/world, ...)",
                bag.display()
            );
        }
        if feed.damaged {
            tracing::warn!(
                "{}: damaged bag; the readable part is reported",
                bag.display()
            );
        }
        if let Some(p) = &feed.first_problem {
            tracing::warn!(
                "{}: {} message(s) did not decode, e.g. {p}",
                bag.display(),
                feed.undecodable
            );
        }
        let s = &judge.series;
        let processing = Stats::of(s.processing_ms.iter().map(|p| p.1));
        let span = s
            .executed_qdot
            .first()
            .zip(s.executed_qdot.last())
            .map_or(0.0, |(a, b)| b.0 - a.0);
        let m = |v: Option<f64>| v.map_or("-".into(), |d| format!("{d:.3}"));
        let row = vec![
            ("min distance (m)".into(), m(judge.min_distance())),
            ("collisions".into(), judge.collisions.to_string()),
            ("duration (s)".into(), format!("{span:.1}")),
            ("backend".into(), s.backend.clone()),
            (
                "processing median / p99 (ms)".into(),
                processing.map_or("-".into(), |p| format!("{:.2} / {:.2}", p.median, p.p99)),
            ),
            (
                "speed far / interaction (m/s)".into(),
                format!("{} / {}", m(judge.speed_at(0.3)), m(judge.speed_at(0.1))),
            ),
            ("speed switches".into(), judge.speed_switches().to_string()),
            (
                "gestures".into(),
                s.gestures
                    .iter()
                    .map(|g| g.1.as_str())
                    .collect::<Vec<_>>()
                    .join(" "),
            ),
        ];
        let mut row = row;
        row.extend(near_person_columns(s));
        trials.push(ReportTrial {
            title: bag.display().to_string(),
            row,
            series: judge.series,
        });
    }
    let bags: Vec<String> = args.bags.iter().map(|b| b.display().to_string()).collect();
    let head = ReportHead {
        title: "cowork report".into(),
        meta: Metadata::of_this_run()
            .with("bags", bags.join(", "))
            .with("rate, seed, person", "not recorded in a bag: see the run's JSON or its command line"),
        tables: Vec::new(),
    };
    write_report(&args.output, head, &trials)?;
    println!("report: {}", args.output.join("index.html").display());
    Ok(())
}
