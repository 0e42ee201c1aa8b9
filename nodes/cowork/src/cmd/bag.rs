//! `cowork bag ...`: MCAP bags with the ROS 2 profile (see the `cowork_bag` library).
//!
//! `info` reads a bag; `record` subscribes to the live graph over DDS and writes a bag; `play`
//! republishes a bag over DDS with its original timing (scheduling in `cowork_bag::Player`);
//! `bench` measures replay timing and throughput. Another command is one more variant of
//! [`BagCommand`] with its `Args` struct and one `match` arm in [`run`].

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use cowork_bag::{BagReader, check_bag};

mod bench;
mod play;
mod record;

/// Bag commands.
#[derive(Debug, Subcommand)]
pub enum BagCommand {
    /// Topics, types, message counts and duration of a bag, as a table (or JSON), and a check of
    /// every message (graph topic types, schemas, payloads, image sizes and encodings).
    ///
    /// A damaged bag is read as far as possible: the figures cover the readable part, the
    /// damage (file and byte offset) is printed and the command exits with an error.
    Info {
        /// The MCAP file.
        file: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Skip the per-message checks (only the summary figures).
        #[arg(long)]
        no_check: bool,
    },
    /// Record topics of the live graph (DDS domain of ROS_DOMAIN_ID) into an MCAP bag.
    Record(record::RecordArgs),
    /// Republish a bag over DDS with its original timing, driving /clock.
    Play(play::PlayArgs),
    /// Measure replay: timing error at --rate 1 and --max throughput on a 640x480 depth bag.
    Bench(bench::BenchArgs),
    /// Write a deterministic scenario bag (kinesthetic-pour, static-scene, stacking-human,
    /// gestures) from a seed.
    Synth(super::bag_synth::SynthArgs),
}

/// Runs a `cowork bag` command.
pub fn run(cmd: BagCommand) -> Result<()> {
    match cmd {
        BagCommand::Info { file, json, no_check } => info(&file, json, !no_check),
        BagCommand::Record(args) => record::run(&args),
        BagCommand::Play(args) => play::run(&args).map(|_| ()),
        BagCommand::Bench(args) => bench::run(&args),
        BagCommand::Synth(args) => super::bag_synth::run(args),
    }
}

fn info(file: &std::path::Path, json: bool, check: bool) -> Result<()> {
    let reader = BagReader::open_recoverable(file)
        .with_context(|| format!("reading bag {}", file.display()))?;
    let info = reader.info();
    let checks = if check { check_bag(&reader) } else { Vec::new() };
    let bad: u64 = checks.iter().map(|c| c.bad).sum();
    if json {
        let mut value = serde_json::to_value(&info)?;
        if let Some(obj) = value.as_object_mut()
            && check
        {
            obj.insert("checks".into(), serde_json::to_value(&checks)?);
        }
        println!("{}", serde_json::to_string_pretty(&value)?);
    } else {
        print!("{}", info.to_table());
        if check {
            let flagged: Vec<_> = checks.iter().filter(|c| c.bad > 0).collect();
            if flagged.is_empty() {
                println!("checks: every message of a known type decodes and passes its checks");
            }
            for c in flagged {
                println!(
                    "check failed: {} ({}): {} of {} messages bad; first: {}",
                    c.topic,
                    c.type_name,
                    c.bad,
                    c.messages,
                    c.first_error.as_deref().unwrap_or("")
                );
            }
        }
    }
    if let Some(damage) = reader.damage() {
        bail!("bag {} is damaged: {damage}", file.display());
    }
    if bad > 0 {
        bail!("bag {}: {bad} messages fail their checks (see above)", file.display());
    }
    Ok(())
}
