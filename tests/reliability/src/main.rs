//! `cowork-fuzz`: the reliability suite's fuzzing campaign on demand (CI runs a fixed budget as
//! the crate's test). Prints a table of inputs, errors and panics per parser family; writes the
//! inputs that panicked to `--crashes DIR` so they can be replayed.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Parser;

/// Mutation-fuzz every parser a peer, a file or a user can reach.
#[derive(Debug, Parser)]
#[command(name = "cowork-fuzz")]
struct Args {
    /// Mutated inputs per cheap target (costly targets get fewer, see `Target::cost`).
    #[arg(long, default_value_t = 20_000)]
    iterations: u64,
    /// Seed of the input stream (runs are repeatable).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Only targets whose name contains this text.
    #[arg(long)]
    only: Option<String>,
    /// Directory for inputs that panicked (one file per finding).
    #[arg(long)]
    crashes: Option<PathBuf>,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let mut targets = cowork_reliability::targets::all()?;
    if let Some(only) = &args.only {
        targets.retain(|t| t.name.contains(only.as_str()));
    }
    let mut reports = Vec::new();
    for t in &mut targets {
        eprintln!("fuzzing {} ...", t.name);
        reports.push(cowork_reliability::fuzz(t, args.iterations, args.seed));
    }
    print!("{}", cowork_reliability::table(&reports));
    if let Some(dir) = &args.crashes {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for r in &reports {
            for (i, f) in r.findings.iter().enumerate() {
                let name = format!("{}-{i}.bin", r.name.replace(['/', ' '], "_"));
                std::fs::write(dir.join(&name), &f.input).with_context(|| format!("cannot write {name}"))?;
            }
        }
    }
    let panics: u64 = reports.iter().map(|r| r.panics).sum();
    if panics > 0 {
        anyhow::bail!("{panics} inputs panicked");
    }
    Ok(())
}
