//! Prints `cowork bag info`'s table (or JSON) for a bag; damaged bags are read as far as
//! possible and the damage is shown.
//!
//! `cargo run -p cowork_bag --example bag_info -- FILE [--json]`

use clap::Parser;

#[derive(Debug, Parser)]
struct Args {
    /// The MCAP file.
    file: std::path::PathBuf,
    /// Print JSON instead of a table.
    #[arg(long)]
    json: bool,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let reader = cowork_bag::BagReader::open_recoverable(&args.file)?;
    let info = reader.info();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        print!("{}", info.to_table());
    }
    Ok(())
}
