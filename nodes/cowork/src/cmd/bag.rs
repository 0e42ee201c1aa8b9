//! `cowork bag ...`: MCAP bags with the ROS 2 profile (see the `cowork_bag` library).
//!
//! `info` is implemented here; `record` and `play` need the ROS adapter side and come later.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Subcommand;
use cowork_bag::BagReader;

/// Bag commands.
#[derive(Debug, Subcommand)]
pub enum BagCommand {
    /// Topics, types, message counts and duration of a bag, as a table (or JSON).
    ///
    /// A damaged bag is read as far as possible: the figures cover the readable part, the
    /// damage (file and byte offset) is printed and the command exits with an error.
    Info {
        /// The MCAP file.
        file: PathBuf,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Write a deterministic scenario bag (kinesthetic-pour, static-scene, stacking-human,
    /// gestures) from a seed.
    Synth(super::bag_synth::SynthArgs),
}

/// Runs a `cowork bag` command.
pub fn run(cmd: BagCommand) -> Result<()> {
    match cmd {
        BagCommand::Info { file, json } => info(&file, json),
        BagCommand::Synth(args) => super::bag_synth::run(args),
    }
}

fn info(file: &std::path::Path, json: bool) -> Result<()> {
    let reader = BagReader::open_recoverable(file)
        .with_context(|| format!("reading bag {}", file.display()))?;
    let info = reader.info();
    if json {
        println!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        print!("{}", info.to_table());
    }
    if let Some(damage) = reader.damage() {
        bail!("bag {} is damaged: {damage}", file.display());
    }
    Ok(())
}
