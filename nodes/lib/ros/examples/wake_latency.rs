//! How long a message waits between arriving over DDS and reaching a node's handler (a bench,
//! not a test), for the loop shapes the nodes had and the one they have now:
//!
//! - `sleep 2ms`, `sleep 1ms`, `sleep 500us`: poll every subscription, sleep that long when
//!   nothing was waiting (human_observer, fded_distance, ds_controller / robot_manager before);
//! - `waitset`: block on the subscriptions ([`cowork_ros::WaitSet`] through
//!   [`cowork_ros::DdsSource`]) until a message arrives.
//!
//! `cargo run --release -p cowork_ros --example wake_latency [-- MESSAGES]`
//!
//! Two nodes in this process on a private domain over loopback; the writer sends
//! `std_msgs/String` at 100 Hz with its sequence number, the reader notes when its loop gets
//! each one (same clock). Prints median, p99 and max in µs per mode, and the reader's CPU time.

use std::sync::Arc;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use cowork_msgs::std_msgs::String as RosString;
use cowork_msgs::topics::{Delivery, Topic};
use cowork_ros::{DdsSource, Event, InputSource, NodeConfig, RosNode, RunOptions};

const TOPIC: Topic<RosString> = Topic::new("/wake_latency", Delivery::Reliable { depth: 100 });

fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { f64::NAN } else { v[((v.len() - 1) as f64 * q).round() as usize] }
}

fn thread_cpu_s() -> f64 {
    // CLOCK_THREAD_CPUTIME_ID through /proc would need the tid; the process CPU time of an
    // otherwise idle process is close enough to compare the loop shapes.
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

fn measure(mode: &str, domain: u16, count: usize) -> anyhow::Result<()> {
    let config = NodeConfig { domain_id: Some(domain), ..Default::default() };
    let sent: Arc<Mutex<Vec<Option<Instant>>>> = Arc::new(Mutex::new(vec![None; count]));
    let mut writer_node = RosNode::new("latency_writer", &config)?;
    let writer = writer_node.advertise(&TOPIC)?;
    let mut reader_node = RosNode::new("latency_reader", &config)?;
    let mut latencies = Vec::with_capacity(count);
    let cpu0;
    {
        // Discovery first.
        let probe = reader_node.subscribe(&TOPIC)?;
        let t = Instant::now();
        while writer.subscription_count(&writer_node) == 0 && t.elapsed() < Duration::from_secs(20) {
            std::thread::sleep(Duration::from_millis(20));
        }
        drop(probe);
    }
    let sent_w = Arc::clone(&sent);
    let feeder = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(500));
        for i in 0..count {
            sent_w.lock().expect("lock")[i] = Some(Instant::now());
            let _ = writer.publish(RosString::new(&i.to_string()));
            std::thread::sleep(Duration::from_millis(10));
        }
        std::thread::sleep(Duration::from_millis(300));
        drop(writer_node);
    });
    let deadline = Instant::now() + Duration::from_secs_f64(count as f64 * 0.01 + 5.0);
    let note = |m: RosString, latencies: &mut Vec<f64>| {
        let now = Instant::now();
        if let Ok(i) = m.data.parse::<usize>()
            && let Some(Some(t)) = sent.lock().expect("lock").get(i)
        {
            latencies.push(now.duration_since(*t).as_secs_f64() * 1e6);
        }
    };
    cpu0 = thread_cpu_s();
    let started = Instant::now();
    if mode == "waitset" {
        let mut source = DdsSource::new(reader_node, RunOptions::for_duration(Some(count as f64 * 0.01 + 2.0)).start())?;
        source.add(&TOPIC, |m| m)?;
        loop {
            match source.next(f64::INFINITY) {
                Event::Input(m) => note(m, &mut latencies),
                Event::Deadline => {}
                Event::End => break,
            }
            if latencies.len() >= count || Instant::now() > deadline {
                break;
            }
        }
    } else {
        let sleep = match mode {
            "sleep 2ms" => Duration::from_millis(2),
            "sleep 1ms" => Duration::from_millis(1),
            _ => Duration::from_micros(500),
        };
        let sub = reader_node.subscribe(&TOPIC)?;
        while latencies.len() < count && Instant::now() < deadline {
            let mut any = false;
            while let Some(m) = sub.take() {
                note(m, &mut latencies);
                any = true;
            }
            if !any {
                std::thread::sleep(sleep);
            }
        }
    }
    let wall = started.elapsed().as_secs_f64();
    let cpu = thread_cpu_s() - cpu0;
    let _ = feeder.join();
    let n = latencies.len();
    println!(
        "| {mode} | {n}/{count} | {:.0} | {:.0} | {:.0} | {:.1} % |",
        percentile(&mut latencies, 0.5),
        percentile(&mut latencies, 0.99),
        percentile(&mut latencies, 1.0),
        100.0 * cpu / wall
    );
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let count: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1000);
    println!("| loop | received | median µs | p99 µs | max µs | CPU (both nodes) |");
    println!("|---|---|---|---|---|---|");
    for mode in ["sleep 2ms", "sleep 1ms", "sleep 500us", "waitset"] {
        let lease = cowork_ros::domain::DomainLease::acquire("cowork_ros wake_latency example")?;
        measure(mode, lease.id(), count)?;
    }
    Ok(())
}
