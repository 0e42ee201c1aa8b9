//! The sample bags in `bags/` are exactly what `cowork bag synth` writes with the options listed
//! in `bags/bags.txt` (regenerate them with `bags/regenerate.sh` after changing the synthesiser,
//! the renderer or the people models).

use std::path::PathBuf;

use cowork_bag::BagReader;
use cowork_synth::{Scenario, SynthOptions, synthesize};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

struct Entry {
    file: String,
    scenario: Scenario,
    options: SynthOptions,
}

fn manifest() -> Vec<Entry> {
    let text = std::fs::read_to_string(repo().join("bags/bags.txt")).expect("bags/bags.txt");
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|line| {
            let words: Vec<&str> = line.split_whitespace().collect();
            assert!(words.len() >= 4, "bags/bags.txt: `{line}`: file scenario seed duration [flags]");
            let mut options = SynthOptions {
                seed: words[2].parse().expect("seed"),
                duration_s: Some(words[3].parse().expect("duration")),
                config_dir: repo().join("config"),
                ..SynthOptions::default()
            };
            for flag in &words[4..] {
                match *flag {
                    "--no-noise" => options.noise = false,
                    "--no-depth" => options.depth = false,
                    other => panic!("bags/bags.txt: unknown flag {other}"),
                }
            }
            Entry { file: words[0].to_owned(), scenario: words[1].parse().expect("scenario"), options }
        })
        .collect()
}

#[test]
fn sample_bags_are_what_the_command_writes() {
    let entries = manifest();
    assert_eq!(entries.len(), Scenario::ALL.len(), "one sample bag per scenario");
    let dir = tempfile::tempdir().unwrap();
    let mut total = 0;
    for e in &entries {
        let committed = repo().join("bags").join(&e.file);
        let reader = BagReader::open(&committed).unwrap_or_else(|err| panic!("{}: {err}", committed.display()));
        assert!(reader.info().message_count > 0);
        let fresh = dir.path().join(&e.file);
        synthesize(e.scenario, &e.options, &fresh, &mut |_| {}).unwrap();
        let (a, b) = (std::fs::read(&committed).unwrap(), std::fs::read(&fresh).unwrap());
        total += a.len();
        assert!(
            a == b,
            "bags/{} ({} bytes) differs from what `cowork bag synth {}` writes now ({} bytes): \
             run bags/regenerate.sh",
            e.file,
            a.len(),
            e.scenario,
            b.len()
        );
    }
    assert!(total < 20_000_000, "bags/ holds {total} bytes of sample bags (keep it under 20 MB)");
}
