//! Helpers shared by the graph-level tests in `tests/tests/`.

use std::path::{Path, PathBuf};

pub use cowork_graph::{FeedSummary, TeachingFeed};

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A DDS domain leased for this test (no other graph on the machine has it while the lease or
/// a clone of it lives), so parallel tests and test runs never see each other.
pub fn private_domain() -> cowork_graph::DomainLease {
    let test = std::thread::current().name().unwrap_or("graph test").to_owned();
    cowork_graph::DomainLease::acquire(&format!("cowork test {test}")).unwrap_or_else(|e| panic!("{e}"))
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
/// from the repository root (the config paths are relative to it): [`cowork_graph::Graph`]
/// with the node binaries of `bin_dir` and panics instead of errors. Dropping it stops them all
/// (SIGINT, then SIGKILL after 5 s), so a failing test leaves nothing running.
#[derive(Debug)]
pub struct Processes {
    graph: cowork_graph::Graph,
    bin_dir: PathBuf,
}

impl Processes {
    /// No process yet, on the leased `domain`; `logs` is created.
    pub fn new(domain: &cowork_graph::DomainLease, bin_dir: &Path, logs: &Path) -> Self {
        let graph = cowork_graph::Graph::new(domain.clone(), logs).expect("log directory").with_working_dir(&repo_root());
        Self { graph, bin_dir: bin_dir.to_owned() }
    }

    /// Starts `name` (a binary of the bin dir) with `args`.
    pub fn spawn(&mut self, name: &str, args: &[&str]) {
        let program = self.bin_dir.join(name);
        self.graph.spawn(name, &program, args).unwrap_or_else(|e| panic!("{e}"));
    }

    /// Starts `binary` (of the bin dir) with `args` in the ROS namespace `/<arm>`
    /// (`--ros-args -r __ns:=/<arm>`), as process `<binary>_<arm>` (its log
    /// `<binary>_<arm>.log`): the same node once per arm.
    pub fn spawn_in(&mut self, binary: &str, arm: &str, args: &[&str]) {
        let program = self.bin_dir.join(binary);
        let ns = format!("__ns:=/{arm}");
        let args: Vec<&str> = args.iter().copied().chain(["--ros-args", "-r", &ns, "--"]).collect();
        self.graph.spawn(&format!("{binary}_{arm}"), &program, &args).unwrap_or_else(|e| panic!("{e}"));
    }

    /// The log of `name` so far (empty when it has none).
    pub fn log(&self, name: &str) -> String {
        self.graph.log(name)
    }

    /// `Err` naming the first process that exited, with its status and the end of its log.
    pub fn check_alive(&mut self) -> Result<(), String> {
        self.graph.check_alive().map_err(|e| e.to_string())
    }

    /// The processes themselves (to kill one and start it again, stop and continue one).
    pub fn graph(&mut self) -> &mut cowork_graph::Graph {
        &mut self.graph
    }

    /// Stops every process: SIGINT (nodes save and stop cleanly), SIGKILL after 5 s.
    pub fn stop(&mut self) {
        self.graph.stop();
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

/// A copy of the scene `config/scenes/<file>` at `out` whose depth camera renders 320 × 240
/// instead of 640 × 480: the same pin-hole camera with half the pixels per axis, so fDED keeps
/// a loaded 2-core machine's watchdogs fed in the graph tests.
pub fn half_resolution_scene(file: &str, out: &Path) -> PathBuf {
    config_set(
        &format!("scenes/{file}"),
        &[("width", "320"), ("height", "240"), ("fx", "262.5"), ("fy", "262.5"), ("cx", "159.5"), ("cy", "119.5")],
        out,
    )
}
