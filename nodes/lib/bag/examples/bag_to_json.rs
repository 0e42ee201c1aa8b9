//! Prints every message of a bag as a JSON line {topic, type, log_time_ns, publish_time_ns,
//! msg} (known types decoded with cowork_msgs; for others, or on error, `error` instead of
//! `msg`). Damaged bags are read as far as possible, the damage reported on stderr.
//!
//! `cargo run -p cowork_bag --example bag_to_json -- FILE`

use std::io::Write;

use clap::Parser;
use cowork_bag::BagReader;

#[derive(Debug, Parser)]
struct Args {
    /// The MCAP file.
    file: std::path::PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let reader = BagReader::open_recoverable(&args.file)?;
    if let Some(d) = reader.damage() {
        eprintln!("warning: {d}");
    }
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    for m in reader.messages() {
        let m = match m {
            Ok(m) => m,
            Err(e) => {
                eprintln!("warning: {e}");
                continue;
            }
        };
        let mut line = serde_json::json!({
            "topic": &*m.topic,
            "type": &*m.type_name,
            "log_time_ns": m.log_time_ns,
            "publish_time_ns": m.publish_time_ns,
        });
        match m.decode_json() {
            Ok(msg) => line["msg"] = msg,
            Err(e) => line["error"] = e.to_string().into(),
        }
        writeln!(out, "{line}")?;
    }
    out.flush()?;
    Ok(())
}
