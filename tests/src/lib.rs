//! Helpers shared by the graph-level tests in `tests/tests/`.

use std::path::{Path, PathBuf};

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A DDS domain id private to this test process, so parallel test runs never see each other.
pub fn private_domain(offset: u16) -> u16 {
    100 + ((std::process::id() as u16).wrapping_mul(7).wrapping_add(offset) % 120)
}

/// A working directory for a graph test: `$COWORK_TEST_DIR/<name>` (kept, for the logs) when
/// that variable is set, else a temporary directory removed at the end.
pub fn test_dir(name: &str) -> (Option<tempfile::TempDir>, PathBuf) {
    match std::env::var_os("COWORK_TEST_DIR") {
        Some(d) => {
            let p = PathBuf::from(d).join(name);
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(&p).expect("COWORK_TEST_DIR");
            (None, p)
        }
        None => {
            let t = tempfile::tempdir().expect("tempdir");
            let p = t.path().to_owned();
            (Some(t), p)
        }
    }
}

/// The directory holding the node binaries built beside the running test (`target/<profile>`:
/// the test executable lives in its `deps/`). Panics naming the missing ones and the command
/// that builds them.
pub fn node_bin_dir(names: &[&str]) -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable's path");
    let dir = exe.parent().and_then(Path::parent).map(Path::to_path_buf).expect("target/<profile>/deps/<test>");
    let missing: Vec<&str> = names.iter().copied().filter(|n| !dir.join(n).is_file()).collect();
    assert!(
        missing.is_empty(),
        "node binaries missing in {}: {} — build them first (cargo build --bins {}; a workspace `cargo test` builds them)",
        dir.display(),
        missing.join(", "),
        missing.iter().map(|n| format!("-p {n}")).collect::<Vec<_>>().join(" ")
    );
    dir
}

/// Node processes of one graph on one DDS domain, each logging to `<logs>/<name>.log`, run
/// from the repository root (the config paths are relative to it). Dropping it stops them all
/// (SIGINT, then SIGKILL after 5 s), so a failing test leaves nothing running.
#[derive(Debug)]
pub struct Processes {
    domain: u16,
    bin_dir: PathBuf,
    logs: PathBuf,
    children: Vec<(String, std::process::Child)>,
}

impl Processes {
    /// No process yet; `logs` is created.
    pub fn new(domain: u16, bin_dir: &Path, logs: &Path) -> Self {
        std::fs::create_dir_all(logs).expect("log directory");
        Self { domain, bin_dir: bin_dir.to_owned(), logs: logs.to_owned(), children: Vec::new() }
    }

    /// Starts `name` (a binary of the bin dir) with `args`.
    pub fn spawn(&mut self, name: &str, args: &[&str]) {
        let log = std::fs::File::create(self.logs.join(format!("{name}.log"))).expect("log file");
        let err = log.try_clone().expect("log file");
        let child = std::process::Command::new(self.bin_dir.join(name))
            .args(args)
            .current_dir(repo_root())
            .env("ROS_DOMAIN_ID", self.domain.to_string())
            .stdin(std::process::Stdio::null())
            .stdout(log)
            .stderr(err)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name}: {e}"));
        self.children.push((name.to_owned(), child));
    }

    /// The log of `name` so far (empty when it has none).
    pub fn log(&self, name: &str) -> String {
        std::fs::read_to_string(self.logs.join(format!("{name}.log"))).unwrap_or_default()
    }

    /// `Err` naming the first process that exited, with its status and the end of its log.
    pub fn check_alive(&mut self) -> Result<(), String> {
        for (name, child) in &mut self.children {
            if let Ok(Some(status)) = child.try_wait() {
                let log = std::fs::read_to_string(self.logs.join(format!("{name}.log"))).unwrap_or_default();
                let tail: String = log.lines().rev().take(15).collect::<Vec<_>>().into_iter().rev().collect::<Vec<_>>().join("\n");
                return Err(format!("{name} exited ({status}); its log ends:\n{tail}"));
            }
        }
        Ok(())
    }

    /// Stops every process: SIGINT (nodes save and stop cleanly), SIGKILL after 5 s.
    pub fn stop(&mut self) {
        for (_, child) in &self.children {
            let _ = std::process::Command::new("kill").arg("-INT").arg(child.id().to_string()).status();
        }
        let until = std::time::Instant::now() + std::time::Duration::from_secs(5);
        for (_, child) in &mut self.children {
            while std::time::Instant::now() < until && matches!(child.try_wait(), Ok(None)) {
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            if matches!(child.try_wait(), Ok(None)) {
                let _ = child.kill();
            }
            let _ = child.wait();
        }
        self.children.clear();
    }
}

impl Drop for Processes {
    fn drop(&mut self) {
        self.stop();
    }
}

/// A copy of the parameter file `config/<file>` with each `(from, to)` text replaced once, at
/// `out`; panics when a `from` is not in the file (the file changed: the override would be
/// silently lost).
pub fn config_with(file: &str, replacements: &[(&str, &str)], out: &Path) -> PathBuf {
    let path = repo_root().join("config").join(file);
    let mut text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    for (from, to) in replacements {
        assert!(text.contains(from), "{} has no {from:?} to override", path.display());
        text = text.replacen(from, to, 1);
    }
    std::fs::write(out, text).expect("write the parameter copy");
    out.to_owned()
}

/// A copy of the parameter file `config/<file>` at `out` with the value of each `(key, value)`
/// set on the first line whose key is `key` (indentation kept, its comment dropped); panics
/// when a key is not in the file (the override would be silently lost).
pub fn config_set(file: &str, values: &[(&str, &str)], out: &Path) -> PathBuf {
    let path = repo_root().join("config").join(file);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    for (key, value) in values {
        let prefix = format!("{key}:");
        let line = lines
            .iter_mut()
            .find(|l| l.trim_start().starts_with(&prefix))
            .unwrap_or_else(|| panic!("{} has no `{key}` to override", path.display()));
        let indent = line.len() - line.trim_start().len();
        *line = format!("{}{key}: {value}", &line[..indent]);
    }
    std::fs::write(out, lines.join("\n") + "\n").expect("write the parameter copy");
    out.to_owned()
}

/// A kinesthetic-teaching bag's `/external_wrench` and `/speech_command`, published into the
/// graph on the simulated clock ([`TeachingFeed::play`]).
#[derive(Debug)]
pub struct TeachingFeed {
    items: Vec<(f64, TeachingItem)>,
    wrench: cowork_ros::Publisher<cowork_msgs::geometry_msgs::WrenchStamped>,
    speech: cowork_ros::Publisher<cowork_msgs::std_msgs::String>,
}

#[derive(Debug)]
enum TeachingItem {
    Wrench(cowork_msgs::geometry_msgs::WrenchStamped),
    Speech(cowork_msgs::std_msgs::String),
}

impl TeachingFeed {
    /// Reads the two topics of `bag` (bag time, s) and creates their publishers on `node`.
    pub fn new(node: &mut cowork_ros::RosNode, bag: &Path) -> Result<Self, String> {
        let reader = cowork_bag::BagReader::open(bag).map_err(|e| format!("{}: {e}", bag.display()))?;
        let mut items = Vec::new();
        for m in reader.messages() {
            let m = m.map_err(|e| format!("{}: {e}", bag.display()))?;
            let t = m.log_time_ns as f64 * 1e-9;
            match &*m.topic {
                "/external_wrench" => items.push((t, TeachingItem::Wrench(m.decode().map_err(|e| format!("wrench: {e}"))?))),
                "/speech_command" => items.push((t, TeachingItem::Speech(m.decode().map_err(|e| format!("speech: {e}"))?))),
                _ => {}
            }
        }
        // Deep enough that a write never meets a full queue (the teacher's forces are never
        // dropped), and a replay's write waits rather than drops.
        let q = cowork_ros::qos::replay(4096);
        Ok(Self {
            items,
            wrench: node.publisher("/external_wrench", &q).map_err(|e| e.to_string())?,
            speech: node.publisher("/speech_command", &q).map_err(|e| e.to_string())?,
        })
    }

    /// Bag time of the last message, s.
    pub fn duration_s(&self) -> f64 {
        self.items.last().map_or(0.0, |(t, _)| *t)
    }

    /// Whether at least `wrench` readers of `/external_wrench` and `speech` of
    /// `/speech_command` are matched.
    pub fn matched(&self, node: &cowork_ros::RosNode, wrench: usize, speech: usize) -> bool {
        self.wrench.subscription_count(node) >= wrench && self.speech.subscription_count(node) >= speech
    }

    /// Plays the teacher into an `lwr_sim` that follows wrench stamps
    /// (`--follow-wrench-stamps`): every wrench is stamped with its due simulated time `t0` +
    /// bag time and published up to `lead_s` ahead of `/clock` (of `node`, which must use sim
    /// time), so the simulator applies it exactly then and waits whenever this feed falls
    /// behind; each speech word is published when `/clock` reaches its due time (the manager
    /// relays `gripper close|open` to the simulator; the demonstration holds still around them).
    /// A last zero wrench at `settle_s` after the bag lets the simulator run on that long.
    /// `alive` is polled while waiting (a dead node ends the feed with its error); `limit`
    /// bounds the wall time.
    pub fn play(
        self,
        node: &cowork_ros::RosNode,
        t0: f64,
        lead_s: f64,
        settle_s: f64,
        limit: std::time::Duration,
        alive: &mut dyn FnMut() -> Result<(), String>,
    ) -> Result<FeedSummary, String> {
        use cowork_msgs::builtin_interfaces::Time;
        let start = std::time::Instant::now();
        let mut polls = 0u32;
        let mut summary = FeedSummary { last_s: t0, ..FeedSummary::default() };
        let end = t0 + self.duration_s() + settle_s;
        let (mut wrenches, mut words) = (std::collections::VecDeque::new(), std::collections::VecDeque::new());
        for (t, item) in self.items {
            match item {
                TeachingItem::Wrench(w) => wrenches.push_back((t0 + t, w)),
                TeachingItem::Speech(s) => words.push_back((t0 + t, s)),
            }
        }
        let mut closing = Some(cowork_msgs::geometry_msgs::WrenchStamped::default());
        loop {
            let now = node.now().to_secs_f64();
            let mut progressed = false;
            while let Some((due, _)) = wrenches.front()
                && *due <= now + lead_s
            {
                let Some((due, mut w)) = wrenches.pop_front() else { break };
                w.header.stamp = Time::from_secs_f64(due);
                self.wrench.publish(w).map_err(|e| e.to_string())?;
                summary.published += 1;
                progressed = true;
            }
            while let Some((due, _)) = words.front()
                && *due <= now
            {
                let Some((due, s)) = words.pop_front() else { break };
                summary.max_late_s = summary.max_late_s.max(now - due);
                if now - due > 0.05 {
                    summary.late_50ms += 1;
                }
                self.speech.publish(s).map_err(|e| e.to_string())?;
                summary.last_s = due;
                summary.published += 1;
                progressed = true;
            }
            if wrenches.is_empty()
                && let Some(mut w) = closing.take()
            {
                w.header.stamp = Time::from_secs_f64(end);
                self.wrench.publish(w).map_err(|e| e.to_string())?;
            }
            if closing.is_none() && words.is_empty() && now >= end - 1e-6 {
                break;
            }
            if start.elapsed() > limit {
                return Err(format!("the teaching feed did not finish in {limit:?} (sim time {now:.2} s)"));
            }
            polls += 1;
            if polls.is_multiple_of(500) {
                alive()?;
            }
            if !progressed {
                std::thread::sleep(std::time::Duration::from_micros(500));
            }
        }
        summary.dropped = self.wrench.dropped() + self.speech.dropped();
        Ok(summary)
    }
}

/// What [`TeachingFeed::play`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FeedSummary {
    /// Simulated time of the last message, s.
    pub last_s: f64,
    /// Messages published.
    pub published: u64,
    /// Messages a full reliable queue dropped (must be 0).
    pub dropped: u64,
    /// Largest lateness of a speech word behind its due simulated time, s.
    pub max_late_s: f64,
    /// Speech words more than 50 ms of simulated time late.
    pub late_50ms: u64,
}
