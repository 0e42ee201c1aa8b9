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
//! - [`domain`]: DDS domains leased per machine, so two graphs never share one;
//! - [`config`]: the bundled `config/` directory from any working directory;
//! - [`security`]: DDS Security (SROS2 keystores, `ROS_SECURITY_*`) for every node;
//! - [`shutdown`], Ctrl-C / SIGTERM handling for a clean stop;
//! - [`raw`]: untyped publishers / subscriptions of serialised CDR payloads named only by their
//!   type string (bag record and replay of types we do not know);
//! - [`node_main`] / [`NodeArgs`]: a node binary's start-up, which understands ROS 2's
//!   `--ros-args -r __ns:=/left -r __node:=NAME` ([`split_ros_args`]), so one binary runs per arm
//!   in the arm's namespace (see [`cowork_msgs::topics`] for which topics are per arm).
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
pub mod dds_threads;
pub mod domain;
pub mod graph;
pub mod input;
mod joints;
pub mod log;
pub use joints::joint_positions;
mod node;
pub use node::{discovery_on_all_networks, domain_id_from_env, is_name_token};
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

/// Sets up `tracing` logging to stderr, filtered by `RUST_LOG` (default [`DEFAULT_LOG_FILTER`]):
/// colour only on a terminal, wall clock and simulated time on every line, repeated lines folded
/// ([`log`]).
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(DEFAULT_LOG_FILTER));
    // A second call (tests) is harmless.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_timer(log::WallAndSimTime)
        .with_ansi(log::colour())
        .with_writer(log::FoldingStderr::default())
        .try_init();
}

/// The start-up every node binary shares once its own parameters are loaded: checks
/// `--duration` (s; positive and finite when given), installs the Ctrl-C / SIGTERM handler
/// ([`shutdown::install`]) and joins the graph as `name` in the root namespace, or as the
/// command line's `--ros-args` ([`ros_args`]) say: `-r __node:=NAME` renames the node,
/// `-r __ns:=/left` puts it (and its per-arm topics) in `/left`.
pub fn start_node(name: &str, use_sim_time: bool, duration_s: Option<f64>) -> anyhow::Result<RosNode> {
    if let Some(d) = duration_s
        && !(d.is_finite() && d > 0.0)
    {
        anyhow::bail!("--duration {d}: must be a positive number of seconds");
    }
    shutdown::install();
    let ros = ros_args();
    let name = ros.node_name.as_deref().unwrap_or(name);
    let namespace = ros.namespace.clone().unwrap_or_else(|| "/".to_owned());
    let node = RosNode::new(name, &NodeConfig { namespace, use_sim_time, ..NodeConfig::default() })?;
    if ros.namespace.is_some() {
        tracing::info!("joined the graph as {}", node.fully_qualified_name());
    }
    Ok(node)
}

/// What a node's `--ros-args` section set ([`split_ros_args`]); `None`: not given.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RosArgs {
    /// `-r __ns:=NS`: the node's namespace, `/` or absolute (`/left`).
    pub namespace: Option<String>,
    /// `-r __node:=NAME` (or rcl's older `__name`): the node's name instead of the binary's.
    pub node_name: Option<String>,
}

/// The `--ros-args` of this process, set once by [`node_main`].
static ROS_ARGS: std::sync::OnceLock<RosArgs> = std::sync::OnceLock::new();

/// The `--ros-args` [`node_main`] found on this process's command line; none (the root
/// namespace, the binary's own node name) in a process that did not start through it.
pub fn ros_args() -> &'static RosArgs {
    static NONE: RosArgs = RosArgs { namespace: None, node_name: None };
    ROS_ARGS.get().unwrap_or(&NONE)
}

/// What [`split_ros_args`] understands, for its errors.
const SUPPORTED_ROS_ARGS: &str = "cowork nodes understand only `-r __ns:=/NS` and `-r __node:=NAME` (also as `--remap`)";

/// Takes the ROS 2 arguments out of a command line (`args[0]` is the program): every
/// `--ros-args` section, up to a lone `--` (which ends it and is dropped) or the end, as rcl
/// reads them. The rest comes back in order, for clap. Understood: `-r`/`--remap` `__ns:=NS`
/// (an absolute namespace, `/left`) and `__node:=NAME` (`__name:=NAME`); a later one wins.
/// Anything else in a section (`-p`, `--params-file`, a topic remapping, a node-targeted
/// `NODE:__ns:=...`) is an error naming it: a node must not run with an argument it ignored.
pub fn split_ros_args(args: Vec<std::ffi::OsString>) -> anyhow::Result<(Vec<std::ffi::OsString>, RosArgs)> {
    let mut rest = Vec::with_capacity(args.len());
    let mut ros = RosArgs::default();
    let mut args = args.into_iter();
    rest.extend(args.next());
    let mut in_section = false;
    while let Some(arg) = args.next() {
        if !in_section {
            if arg == "--ros-args" {
                in_section = true;
            } else {
                rest.push(arg);
            }
            continue;
        }
        let Some(text) = arg.to_str() else {
            anyhow::bail!("--ros-args: argument {arg:?} is not UTF-8; {SUPPORTED_ROS_ARGS}");
        };
        match text {
            "--" => in_section = false,
            "--ros-args" => {}
            "-r" | "--remap" => {
                let rule = args.next().ok_or_else(|| anyhow::anyhow!("--ros-args: {text} needs a rule, e.g. `{text} __ns:=/left`"))?;
                let Some(rule) = rule.to_str() else {
                    anyhow::bail!("--ros-args: remapping rule {rule:?} is not UTF-8");
                };
                remap(&mut ros, rule)?;
            }
            other => anyhow::bail!("--ros-args: unsupported ROS argument `{other}`; {SUPPORTED_ROS_ARGS}"),
        }
    }
    Ok((rest, ros))
}

/// Applies one `-r FROM:=TO` rule of a `--ros-args` section to `ros`.
fn remap(ros: &mut RosArgs, rule: &str) -> anyhow::Result<()> {
    match rule.split_once(":=") {
        Some(("__ns", namespace)) => {
            node::validate_namespace(namespace).map_err(|e| anyhow::anyhow!("--ros-args -r {rule}: {e}"))?;
            ros.namespace = Some(namespace.to_owned());
        }
        Some(("__node" | "__name", name)) => {
            if !node::is_name_token(name) {
                anyhow::bail!("--ros-args -r {rule}: invalid node name {name:?} (ASCII letters, digits and _, not starting with a digit)");
            }
            ros.node_name = Some(name.to_owned());
        }
        _ => anyhow::bail!("--ros-args: unsupported remapping rule `{rule}`; {SUPPORTED_ROS_ARGS}"),
    }
    Ok(())
}

#[cfg(test)]
mod ros_args_tests {
    use super::{RosArgs, split_ros_args};
    use std::ffi::OsString;

    fn split(args: &[&str]) -> anyhow::Result<(Vec<String>, RosArgs)> {
        let (rest, ros) = split_ros_args(args.iter().map(OsString::from).collect())?;
        Ok((rest.into_iter().map(|a| a.into_string().expect("UTF-8")).collect(), ros))
    }

    fn ros(namespace: Option<&str>, node_name: Option<&str>) -> RosArgs {
        RosArgs { namespace: namespace.map(str::to_owned), node_name: node_name.map(str::to_owned) }
    }

    #[test]
    fn without_ros_args_everything_goes_to_clap() {
        let args = ["ds_controller", "--params", "x.yaml", "--", "--ros-args-like"];
        assert_eq!(split(&args).unwrap(), (args.map(str::to_owned).to_vec(), RosArgs::default()));
        assert_eq!(split(&[]).unwrap(), (vec![], RosArgs::default()));
    }

    #[test]
    fn namespace_and_node_name_are_taken_out() {
        let (rest, ros_args) =
            split(&["ds_controller", "--use-sim-time", "--ros-args", "-r", "__ns:=/left", "--remap", "__node:=left_ds"]).unwrap();
        assert_eq!(rest, ["ds_controller", "--use-sim-time"]);
        assert_eq!(ros_args, ros(Some("/left"), Some("left_ds")));
        // rcl's older spelling of __node, the root namespace, and a later rule winning.
        let (_, ros_args) = split(&["n", "--ros-args", "-r", "__ns:=/a", "-r", "__name:=b", "-r", "__ns:=/"]).unwrap();
        assert_eq!(ros_args, ros(Some("/"), Some("b")));
    }

    #[test]
    fn a_lone_double_dash_ends_the_section() {
        let (rest, ros_args) =
            split(&["fded_distance", "--ros-args", "-r", "__ns:=/right", "--", "--params", "p.yaml", "--ros-args", "-r", "__node:=f", "--"]).unwrap();
        assert_eq!(rest, ["fded_distance", "--params", "p.yaml"]);
        assert_eq!(ros_args, ros(Some("/right"), Some("f")));
    }

    #[test]
    fn other_ros_arguments_are_refused_by_name() {
        for (args, named) in [
            (&["n", "--ros-args", "--params-file", "p.yaml"][..], "`--params-file`"),
            (&["n", "--ros-args", "-p", "use_sim_time:=true"][..], "`-p`"),
            (&["n", "--ros-args", "-r", "joint_states:=/js"][..], "`joint_states:=/js`"),
            (&["n", "--ros-args", "-r", "ds:__ns:=/left"][..], "`ds:__ns:=/left`"),
            (&["n", "--ros-args", "-r"][..], "-r needs a rule"),
        ] {
            let e = split(args).expect_err(named).to_string();
            assert!(e.contains(named), "{e}");
            assert!(!e.contains('\n'), "one line: {e}");
            if !named.contains("needs") {
                assert!(e.contains("__ns:=/NS") && e.contains("__node:=NAME"), "says what is supported: {e}");
            }
        }
    }

    #[test]
    fn bad_namespaces_and_node_names_are_refused() {
        for bad in ["left", "/left/", "/9left", "/le-ft", ""] {
            let e = split(&["n", "--ros-args", "-r", &format!("__ns:={bad}")]).expect_err(bad).to_string();
            assert!(e.contains(&format!("invalid ROS namespace {bad:?}")), "{e}");
        }
        let e = split(&["n", "--ros-args", "-r", "__node:=ds-left"]).expect_err("bad name").to_string();
        assert!(e.contains("invalid node name \"ds-left\""), "{e}");
    }
}

/// The command-line options every node binary shares; flatten them into its clap `Args`
/// (`#[command(flatten)] node: cowork_ros::NodeArgs`). ROS 2's `--ros-args` section is not
/// clap's: [`node_main`] takes it out first ([`split_ros_args`]) and [`NodeArgs::start`] uses it.
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

    /// Joins the graph as `name` ([`start_node`]; renamed and namespaced by `--ros-args`): sim
    /// time when the parameter file or `--use-sim-time` asks for it; returns the node and the
    /// [`RunOptions`] of `--duration`.
    pub fn start(&self, name: &str, use_sim_time: bool) -> anyhow::Result<(RosNode, RunOptions)> {
        let node = start_node(name, use_sim_time || self.use_sim_time, self.duration)?;
        Ok((node, RunOptions::for_duration(self.duration)))
    }
}

/// A node binary's `main`: logging to stderr, the ROS 2 arguments taken out of the command
/// line ([`split_ros_args`]: `--ros-args -r __ns:=/left -r __node:=NAME`, kept for
/// [`start_node`] in [`ros_args`]), the rest parsed into `A` (clap's usage errors and `--help`
/// as usual), then `run`, ending as [`exit_code`] says (one line `error: ...` on failure, a
/// backtrace only with `RUST_BACKTRACE=1`).
///
/// While `run` runs, a watchdog checks every [`DDS_WATCH_PERIOD`] that the process's DDS
/// threads still run ([`dds_threads`]); when they ended (the process was stopped and continued)
/// it stops `run` as Ctrl-C would and runs it again on fresh arguments, as a launcher's
/// respawn would: what the node held in memory starts over.
pub fn node_main<A: clap::Parser>(run: impl Fn(A) -> anyhow::Result<()>) -> std::process::ExitCode {
    init_logging();
    let (args, ros) = match split_ros_args(config::resolve_args(std::env::args_os())) {
        Ok(split) => split,
        Err(e) => return exit_code(Err(e)),
    };
    if ROS_ARGS.set(ros).is_err() {
        return exit_code(Err(anyhow::anyhow!("node_main was called twice in one process")));
    }
    if let Err(e) = std::thread::Builder::new().name("dds-watchdog".into()).spawn(watch_dds_threads) {
        tracing::warn!("cannot start the DDS watchdog ({e}); a node stopped and continued may stay silent");
    }
    loop {
        let result = run(A::parse_from(args.clone()));
        if shutdown::take_restart() && !shutdown::signalled() {
            let ended = match &result {
                Ok(()) => "its run ended".to_owned(),
                Err(e) => one_line(e),
            };
            tracing::warn!("restarting the node in this process ({ended})");
            continue;
        }
        return exit_code(result);
    }
}

/// How often [`node_main`]'s watchdog looks at the DDS threads.
pub const DDS_WATCH_PERIOD: std::time::Duration = std::time::Duration::from_millis(250);

fn watch_dds_threads() {
    loop {
        std::thread::sleep(DDS_WATCH_PERIOD);
        if shutdown::requested() {
            continue;
        }
        if let Some(missing) = dds_threads::lost() {
            tracing::error!(
                "the DDS threads of this process ended ({missing}; RustDDS leaves them on EINTR, which a stopped and continued process gets): restarting the node"
            );
            shutdown::request_restart();
        }
    }
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
