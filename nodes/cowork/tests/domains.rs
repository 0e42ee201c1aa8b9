//! `cowork domain run`: many graphs started at once on one machine each get a DDS domain of
//! their own (more than the old fixed span of 100 domains could give without collisions); a
//! domain held by one is refused to another, naming the holder; `cowork domain list` shows them.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const COWORK: &str = env!("CARGO_BIN_EXE_cowork");

/// Releases the waiting graphs when the test ends, even on failure.
struct Release(std::path::PathBuf);

impl Drop for Release {
    fn drop(&mut self) {
        let _ = std::fs::write(&self.0, "");
    }
}

#[test]
fn graphs_started_at_once_never_share_a_domain() {
    const GRAPHS: usize = 120;
    let dir = tempfile::tempdir().expect("tempdir");
    let go = dir.path().join("go");
    let _release = Release(go.clone());
    let wait = format!("echo $ROS_DOMAIN_ID; while [ ! -e '{}' ]; do sleep 0.1; done", go.display());
    // Each "graph" holds its lease, reports its domain and waits until all are up.
    let children: Vec<_> = (0..GRAPHS)
        .map(|k| {
            Command::new(COWORK)
                .args(["domain", "run", "--what", &format!("domains test graph {k}"), "--", "sh", "-c", &wait])
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .expect("cowork domain run")
        })
        .collect();
    // While they all run: the list shows them, and one of their domains is refused to a newcomer.
    let until = Instant::now() + Duration::from_secs(90);
    let (list, listed) = loop {
        let list = Command::new(COWORK).args(["domain", "list"]).output().expect("cowork domain list");
        let list = String::from_utf8_lossy(&list.stdout).into_owned();
        let listed = list.lines().filter(|l| l.contains("domains test graph")).count();
        if listed == GRAPHS || Instant::now() > until {
            break (list, listed);
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    let taken: u16 = list
        .lines()
        .find(|l| l.contains("domains test graph"))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|d| d.parse().ok())
        .unwrap_or_else(|| panic!("no test graph listed:\n{list}"));
    let t = Instant::now();
    let refused = Command::new(COWORK)
        .args(["domain", "run", "--domain", &taken.to_string(), "--", "true"])
        .output()
        .expect("cowork domain run --domain");
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success(), "a held domain was given twice");
    assert!(err.contains(&format!("DDS domain {taken} is taken by another graph (domains test graph")), "{err}");
    assert!(t.elapsed() < Duration::from_secs(10), "refused at once, not after a wait");
    std::fs::write(&go, "").expect("release the graphs");

    let mut domains: Vec<u16> = children
        .into_iter()
        .map(|c| {
            let out = c.wait_with_output().expect("wait");
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            String::from_utf8_lossy(&out.stdout).trim().parse().expect("a domain id")
        })
        .collect();
    assert_eq!(listed, GRAPHS, "cowork domain list shows every running graph:\n{list}");
    assert!(domains.iter().all(|d| (1..=232).contains(d)), "{domains:?}");
    domains.sort_unstable();
    domains.dedup();
    assert_eq!(domains.len(), GRAPHS, "two graphs got one domain");
}

#[test]
fn the_command_s_exit_status_is_passed_on() {
    let out = Command::new(COWORK).args(["domain", "run", "--", "sh", "-c", "exit 7"]).output().expect("run");
    assert_eq!(out.status.code(), Some(7));
}
