//! The one adapter between cowork and ROS 2.
//!
//! Only this crate and the node binaries depend on `ros2-client`. It gives:
//! - [`RosNode`]: a ROS 2 node on the DDS domain of `ROS_DOMAIN_ID`, with `use_sim_time`
//!   driven by `/clock` and its parameter services running in a background spinner;
//! - typed [`Publisher`] / [`Subscription`] for every [`cowork_msgs::RosMessage`], whose ROS type
//!   name comes from the message trait, so it can never drift from the struct;
//! - the QoS of every topic of the graph ([`qos`]);
//! - [`params::load`], the loader of ROS 2-shaped YAML parameter files;
//! - [`graph`]: the nodes of the domain and a topic's publishers / subscriptions with their QoS
//!   (`cowork node list`, `cowork topic info`);
//! - [`config`]: the bundled `config/` directory from any working directory;
//! - [`security`]: DDS Security (SROS2 keystores, `ROS_SECURITY_*`) for every node;
//! - [`shutdown`], Ctrl-C / SIGTERM handling for a clean stop;
//! - [`raw`]: untyped publishers / subscriptions of serialised CDR payloads named only by their
//!   type string (bag record and replay of types we do not know).
//!
//! ```no_run
//! use cowork_msgs::std_msgs::String as RosString;
//! use cowork_ros::{NodeConfig, RosNode, qos};
//! # fn main() -> anyhow::Result<()> {
//! let mut node = RosNode::new("talker", &NodeConfig::default())?;
//! let speech = node.publisher::<RosString>("/speech_command", &qos::reliable())?;
//! speech.publish(RosString { data: "teach".into() })?;
//! # Ok(()) }
//! ```

pub mod config;
pub mod graph;
pub mod input;
mod joints;
pub use joints::joint_positions;
mod node;
pub use node::{discovery_on_all_networks, domain_id_from_env};
pub mod params;
pub mod qos;
pub mod raw;
pub mod security;
pub mod shutdown;

pub use input::{DdsSource, Event, InputSource, RunOptions, StopCheck, WaitSet};
pub use node::{NodeConfig, Publisher, RosNode, Subscription, TopicInfo};

/// Default log filter: our own `info`; ros2-client only when something is really wrong;
/// RustDDS not at all: it reports normal events as errors (`leave_multicast_group: Cannot
/// assign requested address` on loopback-only hosts, "Cannot remove Writer GUID" on exit,
/// discovery races), which is noise in a user's terminal. Our own code reports every failure
/// that matters (publish, subscribe, join). `RUST_LOG` overrides it, e.g.
/// `RUST_LOG=info,rustdds=warn` brings RustDDS back.
pub const DEFAULT_LOG_FILTER: &str =
    "info,rustdds=off,ros2_client=error,ros2_client::node=off,ros2_client::distributions=off";

/// Sets up `tracing` logging to stderr, filtered by `RUST_LOG` (default [`DEFAULT_LOG_FILTER`]).
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(DEFAULT_LOG_FILTER));
    // A second call (tests) is harmless.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

/// The start-up every node binary shares once its own parameters are loaded: checks
/// `--duration` (s; positive and finite when given), installs the Ctrl-C / SIGTERM handler
/// ([`shutdown::install`]) and joins the graph as `name`.
pub fn start_node(name: &str, use_sim_time: bool, duration_s: Option<f64>) -> anyhow::Result<RosNode> {
    if let Some(d) = duration_s
        && !(d.is_finite() && d > 0.0)
    {
        anyhow::bail!("--duration {d}: must be a positive number of seconds");
    }
    shutdown::install();
    RosNode::new(name, &NodeConfig { use_sim_time, ..NodeConfig::default() })
}

/// The command-line options every node binary shares; flatten them into its clap `Args`
/// (`#[command(flatten)] node: cowork_ros::NodeArgs`).
#[derive(Debug, Clone, Default, clap::Args)]
pub struct NodeArgs {
    /// Take time from `/clock` (overrides `use_sim_time: false` in the parameter file).
    #[arg(long)]
    pub use_sim_time: bool,
    /// Stop after this many wall-clock seconds (runs until Ctrl-C otherwise).
    #[arg(long)]
    pub duration: Option<f64>,
}

impl NodeArgs {
    /// Loads the `node: ros__parameters:` block of `path` ([`params::load`]); returns it with
    /// the place to name in errors (the file's path).
    pub fn load<T: serde::de::DeserializeOwned>(&self, path: &std::path::Path, node: &str) -> anyhow::Result<(T, String)> {
        Ok((params::load(path, node)?, path.display().to_string()))
    }

    /// Joins the graph as `name` ([`start_node`]): sim time when the parameter file or
    /// `--use-sim-time` asks for it; returns the node and the [`RunOptions`] of `--duration`.
    pub fn start(&self, name: &str, use_sim_time: bool) -> anyhow::Result<(RosNode, RunOptions)> {
        let node = start_node(name, use_sim_time || self.use_sim_time, self.duration)?;
        Ok((node, RunOptions::for_duration(self.duration)))
    }
}

/// A node binary's `main`: logging to stderr, the command line parsed into `A` (clap's
/// usage errors and `--help` as usual), then `run`, ending as [`exit_code`] says (one line
/// `error: ...` on failure, a backtrace only with `RUST_BACKTRACE=1`).
pub fn node_main<A: clap::Parser>(run: impl FnOnce(A) -> anyhow::Result<()>) -> std::process::ExitCode {
    init_logging();
    exit_code(run(A::parse()))
}

/// `s` seconds as a [`std::time::Duration`] that never panics: NaN and negative values give
/// zero, values beyond 100 years (or infinite) give 100 years. `Duration::from_secs_f64`
/// panics on all of these, and a finite but extreme parameter (`1e20 s`, `--rate 1e-300`)
/// must not crash a node.
pub fn duration_s(s: f64) -> std::time::Duration {
    const CAP_S: f64 = 100.0 * 365.25 * 86_400.0;
    if s.is_nan() || s <= 0.0 {
        std::time::Duration::ZERO
    } else {
        std::time::Duration::from_secs_f64(s.min(CAP_S))
    }
}

#[cfg(test)]
mod duration_tests {
    use super::duration_s;
    use std::time::Duration;

    #[test]
    fn extreme_values_saturate_instead_of_panicking() {
        assert_eq!(duration_s(f64::NAN), Duration::ZERO);
        assert_eq!(duration_s(-1.0), Duration::ZERO);
        assert_eq!(duration_s(0.25), Duration::from_millis(250));
        assert_eq!(duration_s(1e20), duration_s(f64::INFINITY));
        assert!(duration_s(1.0 / 1e-300) > Duration::from_secs(3_000_000_000));
        let _ = std::time::Instant::now() + duration_s(1e300);
    }
}

/// At most `max_chars` characters of peer-supplied `text`, for logs and warnings: a longer
/// text is cut on a character boundary and marked with its full length in bytes, so a 1 MB
/// speech string is never copied into a warning.
pub fn text_prefix(text: &str, max_chars: usize) -> std::borrow::Cow<'_, str> {
    match text.char_indices().nth(max_chars) {
        None => std::borrow::Cow::Borrowed(text),
        Some((cut, _)) => std::borrow::Cow::Owned(format!("{}… ({} bytes)", &text[..cut], text.len())),
    }
}

#[cfg(test)]
mod text_prefix_tests {
    use super::text_prefix;

    #[test]
    fn long_texts_are_cut_on_a_character_boundary() {
        assert_eq!(text_prefix("teach", 8), "teach");
        let long = "é".repeat(1_000_000);
        let cut = text_prefix(&long, 10);
        assert!(cut.starts_with(&"é".repeat(10)) && cut.ends_with("(2000000 bytes)"), "{cut}");
        assert!(cut.len() < 64);
    }
}

/// A warning about an input or an output, produced by a node's pure handlers and logged by its
/// run loop through [`Warnings`]. `kind` is the rate-limit key (topic + what went wrong);
/// `message` names the topic and the field, and quotes peer text only through [`quote`].
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Warning {
    /// Rate-limit key, e.g. `/joint_states:length`.
    pub kind: String,
    /// The text logged.
    pub message: String,
}

impl Warning {
    /// A warning of `kind` saying `message`.
    pub fn new(kind: impl Into<String>, message: impl Into<String>) -> Self {
        Self { kind: kind.into(), message: message.into() }
    }
}

/// At most [`QUOTE_CHARS`] characters of peer-supplied `text`, for a warning ([`text_prefix`]).
pub fn quote(text: &str) -> std::borrow::Cow<'_, str> {
    text_prefix(text, QUOTE_CHARS)
}

/// Characters of peer text a warning quotes at most.
pub const QUOTE_CHARS: usize = 64;

/// Logs each kind of warning at most once per period, counting the ones held back; the one
/// limiter the nodes share. Time is the caller's `now_s` (s, any monotonic clock), so a test
/// drives it with a mock clock. At most [`Warnings::MAX_KINDS`] kinds are remembered (the
/// oldest is forgotten), so kinds built from peer data cannot grow it.
#[derive(Debug)]
pub struct Warnings {
    period_s: f64,
    last: std::collections::HashMap<String, (f64, u64)>,
    logged: u64,
}

impl Warnings {
    /// Kinds remembered at most.
    pub const MAX_KINDS: usize = 256;

    /// At most one warning of a kind per `period_s` seconds.
    pub fn new(period_s: f64) -> Self {
        Self { period_s: if period_s.is_finite() { period_s.max(0.0) } else { f64::MAX }, last: std::collections::HashMap::new(), logged: 0 }
    }

    /// Logs `w` at `now_s` unless a warning of its kind was logged within the period; returns
    /// whether it was logged.
    pub fn warn(&mut self, now_s: f64, w: &Warning) -> bool {
        self.warn_text(now_s, &w.kind, &w.message)
    }

    /// [`warn`](Self::warn) with the kind and message given apart.
    pub fn warn_text(&mut self, now_s: f64, kind: &str, message: &str) -> bool {
        if let Some((at, held)) = self.last.get_mut(kind) {
            if now_s - *at < self.period_s && now_s >= *at {
                *held += 1;
                return false;
            }
            tracing::warn!("{message} ({held} more like it since the last warning)");
            (*at, *held) = (now_s, 0);
            self.logged += 1;
            return true;
        }
        if self.last.len() >= Self::MAX_KINDS
            && let Some(oldest) = self.last.iter().min_by(|a, b| a.1.0.total_cmp(&b.1.0)).map(|(k, _)| k.clone())
        {
            self.last.remove(&oldest);
        }
        tracing::warn!("{message}");
        self.last.insert(kind.to_owned(), (now_s, 0));
        self.logged += 1;
        true
    }

    /// Warnings logged so far (not counting the ones held back).
    pub fn logged(&self) -> u64 {
        self.logged
    }
}

/// Monotonic seconds since the first call in this process: the `now_s` a run loop gives
/// [`Warnings`] when it has no better clock.
pub fn monotonic_s() -> f64 {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    START.get_or_init(std::time::Instant::now).elapsed().as_secs_f64()
}

#[cfg(test)]
mod warnings_tests {
    use super::{Warning, Warnings, quote};

    #[test]
    fn one_warning_per_kind_per_period_and_bounded_kinds() {
        let mut l = Warnings::new(10.0);
        assert!(l.warn(0.0, &Warning::new("a", "first")));
        assert!(!l.warn(5.0, &Warning::new("a", "again")));
        assert!(l.warn(5.0, &Warning::new("b", "other kind")));
        assert!(l.warn(10.5, &Warning::new("a", "after the period")));
        // A clock that jumps back (a new simulation) does not silence a kind for ever.
        assert!(l.warn(1.0, &Warning::new("a", "clock went back")));
        for i in 0..1000 {
            l.warn_text(20.0, &format!("k{i}"), "flood");
        }
        assert!(l.last.len() <= Warnings::MAX_KINDS);
        assert_eq!(quote(&"x".repeat(10_000)).len(), 64 + "… (10000 bytes)".len());
    }
}

/// Ends a binary's `main` the way a user expects of a command: `Ok` → success; an error → one
/// line `error: ...` on stderr with the whole context chain (`anyhow`'s `{:#}`: "reading
/// config/x.yaml: ...: missing field"), exit status 1, and no backtrace unless asked for with
/// `RUST_BACKTRACE=1` (then the multi-line report with its backtrace).
///
/// ```no_run
/// fn main() -> std::process::ExitCode {
///     cowork_ros::exit_code(run())
/// }
/// # fn run() -> anyhow::Result<()> { Ok(()) }
/// ```
pub fn exit_code(result: anyhow::Result<()>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            if backtrace_asked(std::env::var("RUST_BACKTRACE").ok().as_deref()) {
                eprintln!("error: {e:?}");
            } else {
                eprintln!("error: {}", one_line(&e));
            }
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, `outer: inner: ...`, leaving out a cause whose text
/// the line already holds (an error that prints its source, as `ParamsError::Io` does, would
/// otherwise say it twice).
fn one_line(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

/// Whether a `RUST_BACKTRACE` value asks for backtraces (as std reads it: anything but `0`).
fn backtrace_asked(value: Option<&str>) -> bool {
    value.is_some_and(|v| v != "0")
}

#[cfg(test)]
mod exit_code_tests {
    use super::{backtrace_asked, one_line};

    #[test]
    fn the_cause_chain_on_one_line_without_repeats() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file");
        let e = anyhow::Error::new(crate::params::ParamsError::Io { path: "config/x.yaml".into(), source: io })
            .context("starting lwr_sim");
        assert_eq!(one_line(&e), "starting lwr_sim: cannot read parameter file config/x.yaml: No such file");
    }

    #[test]
    fn backtraces_only_when_asked() {
        assert!(!backtrace_asked(None));
        assert!(!backtrace_asked(Some("0")));
        assert!(backtrace_asked(Some("1")));
        assert!(backtrace_asked(Some("full")));
    }
}
