//! Node processes of the cowork graph and the kinesthetic teaching feed — the one place that
//! starts, watches and stops them, shared by `cowork experiment`, `cowork teach` and the graph
//! tests.
//!
//! A [`Graph`] runs node binaries on one private `ROS_DOMAIN_ID` it holds a
//! [`DomainLease`] on (two graphs on one machine never share a domain), and refuses to go on
//! when a [`Stranger`] (a participant it did not start) writes on its topics. Each node with its stdout and
//! stderr in `<logs>/<name>.log`; it names the first process that died (exit status, end of its
//! log) and stops them all as `ros2 launch` does: SIGINT (the nodes save what they learned and
//! stop cleanly), SIGTERM after 2 s to any still running (a process started with SIGINT ignored,
//! as `nohup … &` from a script leaves its children), SIGKILL after 5 s — also when dropped, so
//! a failing caller leaves nothing running.
//! [`TeachingFeed`] plays kinesthetic demonstrations (the `/external_wrench` and
//! `/speech_command` of one or more bags) into such a graph on the simulated clock.
//!
//! ```no_run
//! use cowork_graph::Graph;
//! # fn main() -> Result<(), cowork_graph::Error> {
//! // A DDS domain no other graph on this machine has (see `cowork_ros::domain`).
//! let mut graph = Graph::leased("my experiment", "out/logs".as_ref())?;
//! graph.spawn("lwr_sim", "target/release/lwr_sim".as_ref(), &["--rate", "2"])?;
//! graph.check_alive()?;
//! graph.stop();
//! # Ok(()) }
//! ```

mod feed;

use std::ffi::OsStr;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

pub use cowork_ros::domain::{DomainError, DomainLease};
pub use cowork_ros::graph::Stranger;
pub use feed::{FeedSummary, TeachingFeed};
/// The signals [`Graph::signal`] sends.
pub use nix::sys::signal::Signal;

/// What can go wrong with the graph's processes or the teaching feed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A log file or directory could not be created.
    #[error("{path}: {source}")]
    Log {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A node binary could not be started.
    #[error("cannot start {name} ({}): {source}", program.display())]
    Spawn {
        /// Node name.
        name: String,
        /// The binary.
        program: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A node process exited while it should be running.
    #[error("{name} exited ({status}); its log {} ends:\n{tail}", log.display())]
    Exited {
        /// Node name.
        name: String,
        /// Its exit status, in words.
        status: String,
        /// Its log file.
        log: PathBuf,
        /// The last lines of its log.
        tail: String,
    },
    /// A teaching bag could not be read or holds a message that does not decode.
    #[error("teaching bag {}: {message}", path.display())]
    Bag {
        /// The bag.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A DDS publisher could not be created or written.
    #[error("{topic}: {message}")]
    Dds {
        /// The topic.
        topic: &'static str,
        /// What the DDS layer said.
        message: String,
    },
    /// The teaching feed did not finish in time.
    #[error("the teaching feed did not finish in {limit_s:.0} s of wall time (simulated time {sim_s:.2} s, {left} messages left)")]
    FeedTimeout {
        /// The wall-time limit, s.
        limit_s: f64,
        /// Simulated time when it gave up, s.
        sim_s: f64,
        /// Messages not yet published.
        left: usize,
    },
    /// No DDS domain could be leased.
    #[error(transparent)]
    Domain(#[from] DomainError),
    /// Participants the graph did not start write on its topics: its nodes would read their
    /// messages as the graph's.
    #[error("DDS domain {domain}: {} — the graph refuses to go on reading a stranger's messages (set COWORK_ALLOW_STRANGERS=1 to only warn)", strangers.iter().map(ToString::to_string).collect::<Vec<_>>().join("; "))]
    Strangers {
        /// The graph's domain.
        domain: u16,
        /// Who.
        strangers: Vec<Stranger>,
    },
    /// The graph's stranger watch could not join the domain.
    #[error("DDS domain {domain}: cannot watch for strangers: {message}")]
    Watch {
        /// The graph's domain.
        domain: u16,
        /// Why.
        message: String,
    },
    /// The caller's liveness check failed while the feed played (e.g. a node died).
    #[error("{0}")]
    Aborted(String),
}

/// `Result` of this crate.
pub type Result<T> = std::result::Result<T, Error>;

/// One node process.
#[derive(Debug)]
struct Proc {
    name: String,
    child: Child,
    log: PathBuf,
    /// The binary and its arguments, to start it again ([`Graph::kill`], [`Graph::restart`]).
    program: PathBuf,
    args: Vec<std::ffi::OsString>,
}

/// A node killed by [`Graph::kill`], to be started again by [`Graph::restart`].
#[derive(Debug)]
pub struct Killed {
    name: String,
    program: PathBuf,
    args: Vec<std::ffi::OsString>,
}

impl Killed {
    /// The node's name.
    pub fn name(&self) -> &str {
        &self.name
    }
}

/// The node processes of one graph on one leased DDS domain. Dropping it stops them all (and
/// then gives the domain back).
#[derive(Debug)]
pub struct Graph {
    domain: u16,
    /// This graph's id: its nodes get `COWORK_GRAPH_ID`, which marks their participants.
    id: String,
    logs: PathBuf,
    cwd: Option<PathBuf>,
    procs: Vec<Proc>,
    /// Follows the domain's participants, from the first [`check_alive`](Self::check_alive).
    watch: Option<(cowork_ros::RosNode, cowork_ros::graph::StrangerWatch)>,
    /// When the domain was last checked for strangers.
    watched_at: Option<Instant>,
    /// Strangers already warned about (`COWORK_ALLOW_STRANGERS`).
    tolerated: Vec<String>,
    // Last: the domain is given back only after the processes have stopped.
    lease: DomainLease,
}

/// Wall seconds between two looks for strangers.
const STRANGER_CHECK_PERIOD_S: f64 = 0.5;

/// A fresh graph id: 12 hex digits from the process's random hasher keys, the pid and the time.
fn new_graph_id() -> String {
    use std::hash::{BuildHasher as _, Hasher as _};
    let mut h = std::hash::RandomState::new().build_hasher();
    h.write_u32(std::process::id());
    h.write_u128(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos()));
    format!("{:012x}", h.finish() & 0xffff_ffff_ffff)
}

/// Seconds a node gets to stop after SIGINT before it is killed.
pub const STOP_GRACE_S: f64 = 5.0;
/// Seconds after SIGINT when a node still running gets SIGTERM.
pub const SIGTERM_AFTER_S: f64 = 2.0;

impl Graph {
    /// No process yet, on the domain of `lease` (held until the graph is dropped); `logs` is
    /// created.
    pub fn new(lease: DomainLease, logs: &Path) -> Result<Self> {
        std::fs::create_dir_all(logs).map_err(|source| Error::Log { path: logs.to_owned(), source })?;
        Ok(Self {
            domain: lease.id(),
            id: new_graph_id(),
            logs: logs.to_owned(),
            cwd: None,
            procs: Vec::new(),
            watch: None,
            watched_at: None,
            tolerated: Vec::new(),
            lease,
        })
    }

    /// [`new`](Self::new) on a freshly leased domain; `what` names the graph's owner in the
    /// lease (`cowork domain list`).
    pub fn leased(what: &str, logs: &Path) -> Result<Self> {
        Self::new(DomainLease::acquire(what)?, logs)
    }

    /// This graph's id (`COWORK_GRAPH_ID` of its nodes).
    pub fn id(&self) -> &str {
        &self.id
    }

    /// The lease of the graph's domain.
    pub fn lease(&self) -> &DomainLease {
        &self.lease
    }

    /// Processes start in `dir` (e.g. the repository root, where the config paths are relative
    /// to); by default in the caller's working directory.
    pub fn with_working_dir(mut self, dir: &Path) -> Self {
        self.cwd = Some(dir.to_owned());
        self
    }

    /// The DDS domain id.
    pub fn domain(&self) -> u16 {
        self.domain
    }

    /// The log directory.
    pub fn log_dir(&self) -> &Path {
        &self.logs
    }

    /// Starts `program` with `args` as node `name`, logging to `<logs>/<name>.log` (a name
    /// started twice overwrites its log).
    pub fn spawn<S: AsRef<OsStr>>(&mut self, name: &str, program: &Path, args: &[S]) -> Result<()> {
        let args: Vec<std::ffi::OsString> = args.iter().map(|a| a.as_ref().to_owned()).collect();
        self.start(name, program, args, false)
    }

    /// Kills node `name` at once (SIGKILL, as a crash or `kill -9` would: nothing saved, no
    /// goodbye to its DDS peers) and waits for it; `None` when no process has that name.
    /// [`restart`](Self::restart) starts it again with the same binary and arguments.
    pub fn kill(&mut self, name: &str) -> Option<Killed> {
        let i = self.procs.iter().position(|p| p.name == name)?;
        let mut p = self.procs.remove(i);
        let _ = p.child.kill();
        let _ = p.child.wait();
        Some(Killed { name: p.name, program: p.program, args: p.args })
    }

    /// Starts a node [`kill`](Self::kill)ed before, as a launcher's respawn would; its log goes
    /// on in the same file after a line saying so.
    pub fn restart(&mut self, killed: Killed) -> Result<()> {
        self.start(&killed.name, &killed.program, killed.args, true)
    }

    /// Sends `signal` (e.g. SIGSTOP, SIGCONT) to node `name`; `false` when no process has that
    /// name or it has exited.
    pub fn signal(&mut self, name: &str, sig: nix::sys::signal::Signal) -> bool {
        let Some(p) = self.procs.iter_mut().find(|p| p.name == name) else { return false };
        if !running(p) {
            return false;
        }
        signal(p, sig);
        true
    }

    fn start(&mut self, name: &str, program: &Path, args: Vec<std::ffi::OsString>, again: bool) -> Result<()> {
        let log = self.log_path(name);
        let out = if again {
            let mut f = std::fs::OpenOptions::new().append(true).create(true).open(&log).map_err(|source| Error::Log { path: log.clone(), source })?;
            use std::io::Write as _;
            writeln!(f, "==== cowork_graph: {name} started again after it was killed ====").map_err(|source| Error::Log { path: log.clone(), source })?;
            f
        } else {
            File::create(&log).map_err(|source| Error::Log { path: log.clone(), source })?
        };
        let err = out.try_clone().map_err(|source| Error::Log { path: log.clone(), source })?;
        let mut cmd = Command::new(program);
        cmd.args(&args)
            .env("ROS_DOMAIN_ID", self.domain.to_string())
            .env("COWORK_GRAPH_ID", &self.id)
            .stdin(Stdio::null())
            .stdout(out)
            .stderr(err);
        if let Some(dir) = &self.cwd {
            cmd.current_dir(dir);
        }
        let child = cmd
            .spawn()
            .map_err(|source| Error::Spawn { name: name.to_owned(), program: program.to_owned(), source })?;
        self.procs.push(Proc { name: name.to_owned(), child, log, program: program.to_owned(), args });
        Ok(())
    }

    /// `<logs>/<name>.log`.
    pub fn log_path(&self, name: &str) -> PathBuf {
        self.logs.join(format!("{name}.log"))
    }

    /// The log of `name` so far (empty when it has none).
    pub fn log(&self, name: &str) -> String {
        std::fs::read_to_string(self.log_path(name)).unwrap_or_default()
    }

    /// Names and process ids of the running processes.
    pub fn pids(&self) -> Vec<(String, u32)> {
        self.procs.iter().map(|p| (p.name.clone(), p.child.id())).collect()
    }

    /// The first process that has exited, with its status and the last 15 lines of its log.
    pub fn exited(&mut self) -> Option<Error> {
        for p in &mut self.procs {
            if let Ok(Some(status)) = p.child.try_wait() {
                return Some(Error::Exited {
                    name: p.name.clone(),
                    status: describe(status),
                    log: p.log.clone(),
                    tail: tail(&std::fs::read_to_string(&p.log).unwrap_or_default(), 15),
                });
            }
        }
        None
    }

    /// `Err` naming the first process that exited, or the participants writing on the graph's
    /// topics that it did not start ([`strangers`](Self::strangers)).
    pub fn check_alive(&mut self) -> Result<()> {
        if let Some(e) = self.exited() {
            return Err(e);
        }
        self.check_strangers()
    }

    /// Participants on the graph's domain that it did not start (neither its nodes nor this
    /// process's) and that write on its topics; the first call starts watching the domain.
    pub fn strangers(&mut self) -> Result<Vec<Stranger>> {
        let (node, watch) = match &mut self.watch {
            Some(w) => w,
            None => {
                let domain = self.domain;
                let config = cowork_ros::NodeConfig { domain_id: Some(domain), ..Default::default() };
                let created = cowork_ros::RosNode::new(&cowork_ros::graph::graph_marker_name(&self.id), &config)
                    .and_then(|mut node| node.stranger_watch(&self.id).map(|watch| (node, watch)))
                    .map_err(|e| Error::Watch { domain, message: format!("{e:#}") })?;
                self.watch.insert(created)
            }
        };
        Ok(watch.strangers(node))
    }

    /// `Err` when [`strangers`](Self::strangers) are on the domain (looked at every
    /// 0.5 s of wall time at most); with `COWORK_ALLOW_STRANGERS=1` each is only warned about once.
    fn check_strangers(&mut self) -> Result<()> {
        if self.watched_at.is_some_and(|t| t.elapsed().as_secs_f64() < STRANGER_CHECK_PERIOD_S) {
            return Ok(());
        }
        self.watched_at = Some(Instant::now());
        let strangers = self.strangers()?;
        if strangers.is_empty() {
            return Ok(());
        }
        if std::env::var("COWORK_ALLOW_STRANGERS").is_ok_and(|v| v.trim() == "1") {
            for s in strangers {
                let text = s.to_string();
                if !self.tolerated.contains(&text) {
                    tracing::warn!("DDS domain {}: {text} (allowed: COWORK_ALLOW_STRANGERS=1)", self.domain);
                    self.tolerated.push(text);
                }
            }
            return Ok(());
        }
        Err(Error::Strangers { domain: self.domain, strangers })
    }

    /// Stops one process by name (SIGINT, SIGTERM after [`SIGTERM_AFTER_S`], SIGKILL after
    /// [`STOP_GRACE_S`]); `false` when no process has that name.
    pub fn stop_one(&mut self, name: &str) -> bool {
        let Some(i) = self.procs.iter().position(|p| p.name == name) else { return false };
        let mut p = self.procs.remove(i);
        stop_all(std::slice::from_mut(&mut p));
        true
    }

    /// Stops every process: SIGINT to all, SIGTERM to those still running after
    /// [`SIGTERM_AFTER_S`], SIGKILL after [`STOP_GRACE_S`].
    pub fn stop(&mut self) {
        stop_all(&mut self.procs);
        self.procs.clear();
    }
}

impl Drop for Graph {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Whether `p` is still running.
fn running(p: &mut Proc) -> bool {
    matches!(p.child.try_wait(), Ok(None))
}

fn signal(p: &mut Proc, signal: nix::sys::signal::Signal) {
    if running(p)
        && let Ok(pid) = i32::try_from(p.child.id())
    {
        let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), signal);
    }
}

/// SIGINT to every process of `procs`, SIGTERM to those running after [`SIGTERM_AFTER_S`],
/// SIGKILL to those running after [`STOP_GRACE_S`]; returns when all have exited.
fn stop_all(procs: &mut [Proc]) {
    use nix::sys::signal::Signal;
    let start = Instant::now();
    procs.iter_mut().for_each(|p| signal(p, Signal::SIGINT));
    let mut termed = false;
    loop {
        let left = procs.iter_mut().map(running).filter(|r| *r).count();
        let waited = start.elapsed().as_secs_f64();
        if left == 0 {
            break;
        }
        if waited >= STOP_GRACE_S {
            for p in procs.iter_mut() {
                if running(p) {
                    tracing::warn!("{} did not stop within {STOP_GRACE_S} s of SIGINT and SIGTERM; killing it", p.name);
                    let _ = p.child.kill();
                }
            }
            break;
        }
        if !termed && waited >= SIGTERM_AFTER_S {
            termed = true;
            for p in procs.iter_mut() {
                if running(p) {
                    tracing::warn!("{} did not stop within {SIGTERM_AFTER_S} s of SIGINT; sending SIGTERM", p.name);
                    signal(p, Signal::SIGTERM);
                }
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    for p in procs.iter_mut() {
        let _ = p.child.wait();
    }
}

fn describe(status: ExitStatus) -> String {
    status.to_string()
}

/// The last `n` lines of `text`.
pub fn tail(text: &str, n: usize) -> String {
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(n)..].join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh() -> PathBuf {
        PathBuf::from("/bin/sh")
    }

    #[test]
    fn a_process_that_dies_is_named_with_its_status_and_log() {
        let dir = tempfile::tempdir().unwrap();
        let mut g = Graph::leased("cowork_graph unit test", dir.path()).unwrap();
        g.spawn("sleeper", &sh(), &["-c", "exec sleep 30"]).unwrap();
        g.spawn("crasher", &sh(), &["-c", "echo \"domain $ROS_DOMAIN_ID\"; echo boom >&2; exit 3"]).unwrap();
        let until = Instant::now() + Duration::from_secs(10);
        let err = loop {
            if let Some(e) = g.exited() {
                break e;
            }
            assert!(Instant::now() < until, "the crash was not seen");
            std::thread::sleep(Duration::from_millis(10));
        };
        let text = err.to_string();
        assert!(text.starts_with("crasher exited"), "{text}");
        assert!(text.contains('3') && text.contains("boom") && text.contains(&format!("domain {}", g.domain())), "{text}");
        g.stop();
        assert!(g.pids().is_empty());
    }

    #[test]
    fn stop_escalates_to_sigterm_then_sigkill() {
        let dir = tempfile::tempdir().unwrap();
        let mut g = Graph::leased("cowork_graph unit test", dir.path()).unwrap();
        g.spawn("stubborn", &sh(), &["-c", "trap '' INT TERM; exec sleep 60"]).unwrap();
        // Started with SIGINT ignored, as `nohup … &` from a script leaves a child.
        g.spawn("deaf", &sh(), &["-c", "trap '' INT; exec sleep 60"]).unwrap();
        g.spawn("polite", &sh(), &["-c", "exec sleep 60"]).unwrap();
        std::thread::sleep(Duration::from_millis(200));
        let t = Instant::now();
        assert!(g.stop_one("polite"));
        assert!(t.elapsed() < Duration::from_secs_f64(SIGTERM_AFTER_S + 1.0), "SIGINT or SIGTERM stopped the polite one");
        assert!(!g.stop_one("polite"));
        let t = Instant::now();
        assert!(g.stop_one("deaf"));
        let took = t.elapsed().as_secs_f64();
        assert!((SIGTERM_AFTER_S - 0.5..STOP_GRACE_S - 0.5).contains(&took), "SIGTERM stopped the deaf one: {took} s");
        let t = Instant::now();
        g.stop();
        let took = t.elapsed().as_secs_f64();
        assert!((STOP_GRACE_S - 0.5..STOP_GRACE_S + 5.0).contains(&took), "killed after the grace period: {took} s");
        assert!(g.check_alive().is_ok());
    }

    /// A killed node is gone at once (not an exit `check_alive` reports), starts again with its
    /// arguments and its log goes on; a stopped one is continued.
    #[test]
    fn a_node_is_killed_and_restarted_with_its_log_kept() {
        let dir = tempfile::tempdir().unwrap();
        let mut g = Graph::leased("cowork_graph unit test", dir.path()).unwrap();
        g.spawn("counter", &sh(), &["-c", "echo \"run $1\"; exec sleep 60", "sh", "A"]).unwrap();
        std::thread::sleep(Duration::from_millis(200));
        assert!(g.signal("counter", Signal::SIGSTOP) && g.signal("counter", Signal::SIGCONT));
        let killed = g.kill("counter").expect("running");
        assert_eq!(killed.name(), "counter");
        assert!(g.pids().is_empty() && g.check_alive().is_ok());
        assert!(!g.signal("counter", Signal::SIGCONT) && g.kill("counter").is_none());
        g.restart(killed).unwrap();
        std::thread::sleep(Duration::from_millis(200));
        assert_eq!(g.pids().len(), 1);
        let log = g.log("counter");
        assert_eq!(log.matches("run A").count(), 2, "{log}");
        assert!(log.contains("started again"), "{log}");
        g.stop();
    }

    #[test]
    fn a_missing_binary_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let mut g = Graph::leased("cowork_graph unit test", dir.path()).unwrap();
        let e = g.spawn::<&str>("ghost", Path::new("/no/such/bin"), &[]).unwrap_err().to_string();
        assert!(e.contains("ghost") && e.contains("/no/such/bin"), "{e}");
    }
}
