//! Reliability suite of the cowork graph (issue #19): mutation fuzzing of every parser that a
//! peer on DDS, a file or a user can reach, on the stable toolchain.
//!
//! Each [`Target`] is a seed corpus (real messages from the bundled bags, the bundled parameter
//! files, schemas and models, plus defaults) and a check that runs the product's own decode and
//! validate path on one input. [`fuzz`] feeds a target inputs from the [`mutate::Mutator`],
//! deterministic from a seed, and counts what happened: accepted, refused with an error, or a
//! **panic** (caught, with its message and the input kept so it can be replayed). A panic is
//! a bug: a node would die on that message or file.
//!
//! ```no_run
//! let mut targets = cowork_reliability::targets::all().unwrap();
//! let reports: Vec<_> = targets.iter_mut().map(|t| cowork_reliability::fuzz(t, 1000, 1)).collect();
//! print!("{}", cowork_reliability::table(&reports));
//! ```
//!
//! `cargo run --release -p cowork_reliability --bin cowork-fuzz -- --iterations 100000` runs a
//! long campaign; the crate's test runs a fixed budget in CI.

use std::cell::RefCell;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::Once;
use std::time::{Duration, Instant};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

pub mod mutate;
mod streams;
pub mod targets;

/// What the product did with one input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Decoded (and validated) without complaint.
    Accepted,
    /// Refused with an error.
    Refused,
}

/// One thing to fuzz.
pub struct Target {
    /// Row name, e.g. `cdr sensor_msgs/Image`.
    pub name: String,
    /// Family the table groups rows by, e.g. `cdr (every message type)`.
    pub family: &'static str,
    /// Seed inputs (at least one).
    pub seeds: Vec<Vec<u8>>,
    /// Tokens the mutator inserts (text formats).
    pub dictionary: &'static [&'static [u8]],
    /// Largest input, bytes.
    pub max_len: usize,
    /// Relative cost: a target gets `iterations / cost` inputs.
    pub cost: u32,
    /// Runs the product's decode/validate path on one input.
    pub check: Box<dyn FnMut(&[u8]) -> Verdict>,
}

impl std::fmt::Debug for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Target").field("name", &self.name).field("seeds", &self.seeds.len()).finish()
    }
}

/// A panic found by [`fuzz`].
#[derive(Debug, Clone)]
pub struct Finding {
    /// Panic message and location.
    pub message: String,
    /// The input that caused it.
    pub input: Vec<u8>,
}

/// What [`fuzz`] saw on one target.
#[derive(Debug, Clone)]
pub struct Report {
    /// [`Target::name`].
    pub name: String,
    /// [`Target::family`].
    pub family: &'static str,
    /// Inputs run.
    pub inputs: u64,
    /// Inputs accepted.
    pub accepted: u64,
    /// Inputs refused with an error.
    pub refused: u64,
    /// Inputs that panicked.
    pub panics: u64,
    /// The first few panics (at most [`MAX_FINDINGS`]).
    pub findings: Vec<Finding>,
    /// Slowest single input.
    pub slowest: Duration,
    /// Wall time of the whole run.
    pub elapsed: Duration,
}

/// Panics kept per target.
pub const MAX_FINDINGS: usize = 3;

thread_local! {
    static CAPTURING: RefCell<Option<String>> = const { RefCell::new(None) };
    static ACTIVE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Installs (once) a panic hook that, on a thread inside [`fuzz`], records the message quietly
/// instead of printing it; elsewhere it defers to the previous hook.
fn install_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if ACTIVE.with(|a| a.get()) {
                let payload = info
                    .payload()
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| info.payload().downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "(non-string panic payload)".to_owned());
                let place = info.location().map(|l| format!(" at {}:{}", l.file(), l.line())).unwrap_or_default();
                CAPTURING.with(|c| *c.borrow_mut() = Some(format!("{payload}{place}")));
            } else {
                previous(info);
            }
        }));
    });
}

/// Runs `target` on `iterations / target.cost` mutated inputs (at least 10) from `seed`, plus
/// every seed unchanged first.
pub fn fuzz(target: &mut Target, iterations: u64, seed: u64) -> Report {
    install_hook();
    let budget = (iterations / u64::from(target.cost.max(1))).max(10);
    let mut report = Report {
        name: target.name.clone(),
        family: target.family,
        inputs: 0,
        accepted: 0,
        refused: 0,
        panics: 0,
        findings: Vec::new(),
        slowest: Duration::ZERO,
        elapsed: Duration::ZERO,
    };
    let start = Instant::now();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let seeds = target.seeds.clone();
    let mutator = mutate::Mutator::new(&seeds, target.dictionary, target.max_len);
    let mut input = Vec::new();
    let check = &mut target.check;
    for i in 0..seeds.len() as u64 + budget {
        input.clear();
        match seeds.get(i as usize) {
            Some(s) => input.extend_from_slice(s),
            None => mutator.next(&mut rng, &mut input),
        }
        ACTIVE.with(|a| a.set(true));
        let t0 = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| check(&input)));
        report.slowest = report.slowest.max(t0.elapsed());
        ACTIVE.with(|a| a.set(false));
        report.inputs += 1;
        match outcome {
            Ok(Verdict::Accepted) => report.accepted += 1,
            Ok(Verdict::Refused) => report.refused += 1,
            Err(_) => {
                report.panics += 1;
                let message = CAPTURING.with(|c| c.borrow_mut().take()).unwrap_or_default();
                if report.findings.len() < MAX_FINDINGS {
                    report.findings.push(Finding { message, input: input.clone() });
                }
            }
        }
    }
    report.elapsed = start.elapsed();
    report
}

/// The reports as a Markdown table, one row per family (targets summed), then every panic.
pub fn table(reports: &[Report]) -> String {
    let mut families: Vec<&'static str> = Vec::new();
    for r in reports {
        if !families.contains(&r.family) {
            families.push(r.family);
        }
    }
    let mut out = String::from(
        "| target | parsers | inputs | accepted | refused | panics | slowest input ms | s |\n|---|---|---|---|---|---|---|---|\n",
    );
    let mut total = (0u64, 0u64);
    for f in families {
        let rows: Vec<&Report> = reports.iter().filter(|r| r.family == f).collect();
        let sum = |g: fn(&Report) -> u64| rows.iter().map(|r| g(r)).sum::<u64>();
        let slowest = rows.iter().map(|r| r.slowest).max().unwrap_or_default();
        let elapsed: Duration = rows.iter().map(|r| r.elapsed).sum();
        total.0 += sum(|r| r.inputs);
        total.1 += sum(|r| r.panics);
        out.push_str(&format!(
            "| {f} | {} | {} | {} | {} | {} | {:.1} | {:.1} |\n",
            rows.len(),
            sum(|r| r.inputs),
            sum(|r| r.accepted),
            sum(|r| r.refused),
            sum(|r| r.panics),
            slowest.as_secs_f64() * 1e3,
            elapsed.as_secs_f64(),
        ));
    }
    out.push_str(&format!("\n{} inputs, {} panics\n", total.0, total.1));
    for r in reports {
        for f in &r.findings {
            out.push_str(&format!(
                "PANIC in {}: {} (input {} bytes: {})\n",
                r.name,
                f.message,
                f.input.len(),
                preview(&f.input)
            ));
        }
    }
    out
}

/// A short printable view of an input.
pub fn preview(input: &[u8]) -> String {
    let head = &input[..input.len().min(48)];
    if let Ok(text) = std::str::from_utf8(head) {
        format!("{text:?}")
    } else {
        head.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join("")
    }
}
