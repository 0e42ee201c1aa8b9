//! `cowork bag synth SCENARIO -o FILE`: deterministic scenario bags (see `cowork_synth`).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;
use cowork_synth::{Scenario, SynthOptions, synthesize};
use indicatif::{ProgressBar, ProgressStyle};

/// Arguments of `cowork bag synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// Scenario: kinesthetic-pour, kinesthetic-coffee, kinesthetic-spoon, kinesthetic-tea,
    /// static-scene, stacking-human, gestures, pizza-demo-left or pizza-demo-right.
    pub scenario: String,
    /// The MCAP file to write (overwritten).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Seed of every random choice: the same seed writes the same bytes.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Length of the bag, s (default: the scenario's own length).
    #[arg(long)]
    pub duration: Option<f64>,
    /// No sensor noise (depth noise, skeleton jitter, force-sensor noise).
    #[arg(long)]
    pub no_noise: bool,
    /// No depth frames and camera info (much smaller bags).
    #[arg(long)]
    pub no_depth: bool,
    /// The config folder (robot URDF, scenes, lwr_sim.yaml).
    #[arg(long, default_value = "config", value_parser = cowork_ros::config::path_arg)]
    pub config_dir: PathBuf,
    /// Kinesthetic scenarios: a teacher drawn from the seed (pace, path, grasp) instead of the
    /// bundled one.
    #[arg(long)]
    pub vary_teacher: bool,
    /// Kinesthetic scenarios: a demonstration made before this one in the same session (with
    /// the same seed, noise and teacher); repeat in order. The bag starts where they left the
    /// arm and the objects, so `cowork teach --bag A --bag B` replays them one after the other.
    #[arg(long = "after")]
    pub after: Vec<String>,
    /// Kinesthetic scenarios: start from this scene file (the arm's `initial_joints_deg`, the
    /// objects' poses) instead of the scenario's own, e.g. where a running task left them.
    #[arg(long)]
    pub start_scene: Option<PathBuf>,
}

/// Writes the bag and prints what it holds.
pub fn run(args: SynthArgs) -> Result<()> {
    let scenario: Scenario = args.scenario.parse()?;
    let options = SynthOptions {
        seed: args.seed,
        duration_s: args.duration,
        noise: !args.no_noise,
        depth: !args.no_depth,
        config_dir: args.config_dir,
        vary_teacher: args.vary_teacher,
        after: args.after.iter().map(|a| a.parse()).collect::<Result<_, _>>()?,
        start_scene: args.start_scene,
    };
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {percent:>3}% {elapsed_precise} (eta {eta})")
            .context("progress bar template")?
            .progress_chars("=> "),
    );
    bar.set_message(format!("synth {scenario}"));
    let start = Instant::now();
    let summary = synthesize(scenario, &options, &args.output, &mut |f| bar.set_position((f * 1000.0) as u64))
        .with_context(|| format!("synthesising {scenario} into {}", args.output.display()))?;
    bar.finish_and_clear();
    println!(
        "{}: {scenario}, seed {}, {:.1} s, {:.2} MB, written in {:.1} s",
        summary.path.display(),
        options.seed,
        summary.duration_s,
        summary.bytes as f64 / 1e6,
        start.elapsed().as_secs_f64()
    );
    for (topic, count) in &summary.counts {
        println!("  {topic:<32} {count:>7}");
    }
    Ok(())
}
