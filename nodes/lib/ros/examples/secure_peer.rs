//! A `std_msgs/String` peer for checking DDS Security from outside (the stranger test's
//! `secure` mode, `tests/crosscheck/check_stranger.sh secure`). It joins the domain as any
//! cowork node does, so `ROS_SECURITY_*` apply.
//!
//!     secure_peer listen TOPIC SECONDS      # prints `{"received": {"<first word>": count, ...}}`
//!     secure_peer talk TOPIC NAME SECONDS   # publishes "NAME i" at 100 Hz, prints `{"sent": n}`
//!
//! Build: `cargo build --release -p cowork_ros --features security --example secure_peer`.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result, bail};
use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{NodeConfig, RosNode, qos};

fn main() -> std::process::ExitCode {
    cowork_ros::init_logging();
    cowork_ros::exit_code(run())
}

fn run() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seconds = |s: &str| -> Result<Duration> {
        let v: f64 = s.parse().with_context(|| format!("SECONDS {s:?} is not a number"))?;
        Ok(cowork_ros::duration_s(v))
    };
    cowork_ros::shutdown::install();
    let mut node = RosNode::new(&format!("secure_peer_{}", std::process::id()), &NodeConfig::default())?;
    match args.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
        ["listen", topic, secs] => {
            let sub = node.subscription::<RosString>(topic, &qos::reliable_depth(1000))?;
            let end = Instant::now() + seconds(secs)?;
            let mut counts = BTreeMap::<String, usize>::new();
            while Instant::now() < end && !cowork_ros::shutdown::requested() {
                if let Some(m) = sub.recv_timeout(Duration::from_millis(50)) {
                    let who = m.data.split_whitespace().next().unwrap_or("").chars().take(32).collect();
                    *counts.entry(who).or_default() += 1;
                }
            }
            let body: Vec<String> = counts.iter().map(|(k, v)| format!("{k:?}: {v}")).collect();
            println!("{{\"received\": {{{}}}}}", body.join(", "));
        }
        ["talk", topic, name, secs] => {
            let publisher = node.publisher::<RosString>(topic, &qos::reliable_depth(1000))?;
            let end = Instant::now() + seconds(secs)?;
            let mut sent = 0u64;
            while Instant::now() < end && !cowork_ros::shutdown::requested() {
                publisher.publish(RosString { data: format!("{name} {sent}") })?;
                sent += 1;
                std::thread::sleep(Duration::from_millis(10));
            }
            println!("{{\"sent\": {sent}}}");
        }
        _ => bail!("usage: secure_peer listen TOPIC SECONDS | secure_peer talk TOPIC NAME SECONDS"),
    }
    Ok(())
}
