//! A node stopped and continued (SIGSTOP then SIGCONT: Ctrl-Z and `fg`, a debugger, the chaos
//! check) must talk again. RustDDS ends its participant's threads on the EINTR this gives
//! `epoll_wait`, which left fded_distance and human_observer silent until killed; `node_main`'s
//! watchdog now restarts such a node in its process. A child process runs a `node_main` node
//! publishing a counter at 50 Hz; the test stops it for 1 s, three times, and checks that
//! messages come again after each continue, printing how long that took and whether the node
//! was restarted.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{NodeConfig, RosNode, RunOptions, qos};

const ROLE: &str = "COWORK_STOP_CONTINUE_CHILD";
const TOPIC: &str = "/stop_continue_test";

fn domain() -> u16 {
    cowork_ros::domain::test_domain("cowork_ros stop/continue test")
}

/// The child's command line: the test harness's own arguments, which it ignores.
#[derive(clap::Parser)]
struct ChildArgs {
    #[arg(trailing_var_arg = true, allow_hyphen_values = true)]
    _harness: Vec<String>,
}

/// The child's node: publishes `RUN COUNT` every 20 ms until stopped (RUN counts the runs in
/// this process, so a restart shows).
fn heartbeat(_: ChildArgs) -> anyhow::Result<()> {
    static RUNS: AtomicU32 = AtomicU32::new(0);
    let run = RUNS.fetch_add(1, Ordering::SeqCst) + 1;
    let d: u16 = std::env::var("ROS_DOMAIN_ID")?.parse()?;
    cowork_ros::shutdown::install();
    let mut node = RosNode::new(
        "heartbeat",
        &NodeConfig {
            domain_id: Some(d),
            ..Default::default()
        },
    )?;
    let publisher = node.publisher::<RosString>(TOPIC, &qos::reliable())?;
    let stop = RunOptions::default().start();
    let mut count = 0u64;
    while !stop.requested() {
        publisher.publish(RosString {
            data: format!("{run} {count}"),
        })?;
        count += 1;
        std::thread::sleep(Duration::from_millis(20));
    }
    Ok(())
}

#[test]
#[ignore = "run by the test below as a child process"]
fn heartbeat_child() {
    if std::env::var(ROLE).is_ok() {
        let _ = cowork_ros::node_main(heartbeat);
    }
}

/// `(run, count)` of a heartbeat.
fn parse(m: &RosString) -> (u32, u64) {
    let mut it = m.data.split(' ').map(|s| s.parse::<u64>().expect("number"));
    (it.next().expect("run") as u32, it.next().expect("count"))
}

#[test]
fn a_node_stopped_and_continued_talks_again() {
    let d = domain();
    let mut child = Command::new(std::env::current_exe().expect("test binary"))
        .args([
            "heartbeat_child",
            "--exact",
            "--ignored",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(ROLE, "1")
        .env("ROS_DOMAIN_ID", d.to_string())
        .env("RUST_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("child");
    let log = BufReader::new(child.stderr.take().expect("stderr"));
    let log = std::thread::spawn(move || log.lines().map_while(Result::ok).collect::<Vec<_>>());
    let mut node = RosNode::new(
        "stop_continue_listener",
        &NodeConfig {
            domain_id: Some(d),
            ..Default::default()
        },
    )
    .expect("node");
    let sub = node
        .subscription::<RosString>(TOPIC, &qos::reliable())
        .expect("subscription");
    let t0 = Instant::now();
    let mut last = loop {
        if let Some(m) = sub.recv_timeout(Duration::from_millis(100)) {
            break parse(&m);
        }
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "the child never talked"
        );
    };
    let signal = |sig: &str| {
        assert!(
            Command::new("kill")
                .args([sig, &child.id().to_string()])
                .status()
                .expect("kill")
                .success()
        )
    };
    let mut rows = Vec::new();
    for cycle in 1..=3 {
        // Talking before the stop.
        let until = Instant::now() + Duration::from_millis(500);
        while Instant::now() < until {
            if let Some(m) = sub.recv_timeout(Duration::from_millis(50)) {
                last = parse(&m);
            }
        }
        signal("-STOP");
        std::thread::sleep(Duration::from_secs(1));
        while let Some(m) = sub.take() {
            last = parse(&m);
        }
        let before = last;
        signal("-CONT");
        let resumed = Instant::now();
        let (mut fresh, mut first) = (0, None);
        while fresh < 10 && resumed.elapsed() < Duration::from_secs(10) {
            if let Some(m) = sub.recv_timeout(Duration::from_millis(50)) {
                let now = parse(&m);
                if now > before {
                    first.get_or_insert(resumed.elapsed());
                    fresh += 1;
                    last = now;
                }
            }
        }
        println!(
            "cycle {cycle}: {fresh} new heartbeats, the first {:?} after SIGCONT; run {} -> {}",
            first, before.0, last.0
        );
        rows.push((fresh, first, before.0 != last.0));
    }
    signal("-INT");
    let _ = child.wait();
    let log = log.join().expect("log");
    for line in log.iter().filter(|l| l.contains("restart")) {
        println!("child: {line}");
    }
    for (i, (fresh, first, _)) in rows.iter().enumerate() {
        assert!(
            *fresh >= 10,
            "cycle {}: the node stayed silent after SIGCONT ({fresh} heartbeats, first {first:?}); child log:\n{}",
            i + 1,
            log.join("\n")
        );
    }
}
