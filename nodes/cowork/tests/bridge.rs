//! `cowork bridge` wiring, over DDS and the Foxglove WebSocket protocol: a talker on a private
//! domain publishes `/chatter` and a latched `/robot_description` (before anyone connects); a
//! plain WebSocket client speaking the Foxglove protocol (`foxglove.sdk.v1`) sees both advertised with their
//! `ros2msg` schema and `cdr` encoding, subscribes, and gets the payloads byte for byte as DDS
//! carried them — the latched one too. The Foxglove client packages check the same against the
//! simulator in the cross-check group (`tests/crosscheck/check_bridge.sh`).

use std::io::{BufRead, BufReader};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use cowork_msgs::RosMessage;
use cowork_msgs::std_msgs::String as RosString;
use cowork_ros::{NodeConfig, RosNode, qos};
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket, stream::MaybeTlsStream};

const URDF: &str = "<robot name=\"bridge_test\"><link name=\"base\"/></robot>";

/// A domain for this test run, away from the other tests and a running graph.
fn domain() -> u16 {
    cowork_ros::domain::test_domain("cowork bridge test")
}

/// Stops the bridge with SIGINT (so it prints its figures) when the test ends, even on failure.
struct Bridge(Child);

impl Drop for Bridge {
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-INT", &self.0.id().to_string()]).status();
        let deadline = Instant::now() + Duration::from_secs(5);
        while Instant::now() < deadline {
            if matches!(self.0.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn connect(port: u16) -> WebSocket<MaybeTlsStream<TcpStream>> {
    let mut request = format!("ws://127.0.0.1:{port}").into_client_request().expect("request");
    request.headers_mut().insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1, foxglove.websocket.v1".parse().expect("header"));
    let (mut ws, response) = tungstenite::connect(request).expect("connect to the bridge");
    assert_eq!(
        response.headers().get("Sec-WebSocket-Protocol").and_then(|v| v.to_str().ok()),
        Some("foxglove.sdk.v1")
    );
    if let MaybeTlsStream::Plain(s) = ws.get_mut() {
        s.set_read_timeout(Some(Duration::from_millis(200))).expect("timeout");
    }
    ws
}

#[test]
fn bridge_advertises_and_forwards_cdr_with_ros2msg_schemas() {
    let domain = domain();
    let stop = Arc::new(AtomicBool::new(false));
    let stop_talker = Arc::clone(&stop);
    let talker = std::thread::spawn(move || {
        let mut node = RosNode::new("bridge_talker", &NodeConfig { domain_id: Some(domain), ..Default::default() }).expect("node");
        let description = node.publisher::<RosString>("/robot_description", &qos::latched()).expect("publisher");
        description.publish(RosString { data: URDF.into() }).expect("publish");
        let chatter = node.publisher::<RosString>("/chatter", &qos::reliable()).expect("publisher");
        let mut i = 0u32;
        while !stop_talker.load(Ordering::Relaxed) {
            chatter.publish(RosString { data: format!("hello {i}") }).expect("publish");
            i += 1;
            std::thread::sleep(Duration::from_millis(50));
        }
    });

    let dir = tempfile::tempdir().expect("tempdir");
    let stats = dir.path().join("stats.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_cowork"))
        .args(["bridge", "--port", "0", "--duration", "40", "--stats-json"])
        .arg(&stats)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RUST_LOG", "warn,rustdds=off")
        .stdout(Stdio::piped())
        .spawn()
        .expect("start cowork bridge");
    let stdout = child.stdout.take().expect("stdout");
    let bridge = Bridge(child);
    let mut stdout = BufReader::new(stdout);
    let mut first = String::new();
    stdout.read_line(&mut first).expect("read the bridge's first line");
    // Keep reading, so the figures it prints at the end find an open pipe.
    let rest = std::thread::spawn(move || std::io::read_to_string(stdout).unwrap_or_default());
    let port: u16 = first
        .trim()
        .strip_prefix("cowork bridge: ws://127.0.0.1:")
        .and_then(|r| r.split_whitespace().next())
        .and_then(|p| p.parse().ok())
        .unwrap_or_else(|| panic!("no port in {first:?}"));

    let mut ws = connect(port);
    let mut channels: std::collections::HashMap<u64, String> = std::collections::HashMap::new();
    let mut received: std::collections::HashMap<String, Vec<u8>> = std::collections::HashMap::new();
    let deadline = Instant::now() + Duration::from_secs(25);
    while Instant::now() < deadline && !(received.contains_key("/chatter") && received.contains_key("/robot_description")) {
        let msg = match ws.read() {
            Ok(m) => m,
            Err(tungstenite::Error::Io(e)) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) => continue,
            Err(e) => panic!("websocket: {e}"),
        };
        match msg {
            Message::Text(text) => {
                let v: serde_json::Value = serde_json::from_str(text.as_str()).expect("JSON");
                // The foxglove SDK (0.30) sends a channel's advertisement before it records
                // the channel for the client: a subscription that arrives in between is
                // refused with "Unknown channel ID: N" (a status message). Foxglove's app
                // would lose it the same way; this client subscribes again.
                if v["op"] == "status" {
                    let refused = v["message"].as_str().and_then(|m| m.strip_prefix("Unknown channel ID: ")).and_then(|id| id.trim().parse::<u64>().ok());
                    if let Some(id) = refused.filter(|id| channels.contains_key(id)) {
                        std::thread::sleep(Duration::from_millis(100));
                        let sub = serde_json::json!({"op": "subscribe", "subscriptions": [{"id": id, "channelId": id}]});
                        ws.send(Message::Text(sub.to_string().into())).expect("subscribe again");
                    }
                    continue;
                }
                if v["op"] != "advertise" {
                    continue;
                }
                for ch in v["channels"].as_array().expect("channels") {
                    let topic = ch["topic"].as_str().expect("topic").to_owned();
                    if topic != "/chatter" && topic != "/robot_description" {
                        continue;
                    }
                    assert_eq!(ch["encoding"], "cdr", "{ch}");
                    assert_eq!(ch["schemaEncoding"], "ros2msg", "{ch}");
                    assert_eq!(ch["schemaName"], "std_msgs/msg/String", "{ch}");
                    assert_eq!(ch["schema"].as_str(), Some(RosString::ros2msg_definition().as_str()), "{ch}");
                    let id = ch["id"].as_u64().expect("id");
                    let sub = serde_json::json!({"op": "subscribe", "subscriptions": [{"id": id, "channelId": id}]});
                    ws.send(Message::Text(sub.to_string().into())).expect("subscribe");
                    channels.insert(id, topic);
                }
            }
            Message::Binary(b) => {
                // Message data: opcode 1, subscription id (u32 LE), log time (u64 LE), payload.
                assert!(b.len() >= 13 && b[0] == 1, "not a message-data frame: {:?}", &b[..b.len().min(16)]);
                let sub = u64::from(u32::from_le_bytes(b[1..5].try_into().expect("id")));
                let topic = channels.get(&sub).unwrap_or_else(|| panic!("data for unknown subscription {sub}"));
                received.entry(topic.clone()).or_insert_with(|| b[13..].to_vec());
            }
            _ => {}
        }
    }
    let description = received.get("/robot_description").expect("the latched /robot_description was replayed on subscribe");
    let description: RosString = cowork_msgs::from_cdr(description).expect("decodes");
    assert_eq!(description.data, URDF);
    let chatter: RosString = cowork_msgs::from_cdr(received.get("/chatter").expect("/chatter forwarded")).expect("decodes");
    assert!(chatter.data.starts_with("hello "), "{}", chatter.data);
    let _ = ws.close(None);
    drop(bridge);
    stop.store(true, Ordering::Relaxed);
    talker.join().expect("talker");

    let table = rest.join().expect("stdout reader");
    assert!(table.lines().any(|l| l.starts_with("/chatter")), "figures printed at the end: {table}");
    let stats: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).expect("the bridge wrote its figures")).expect("JSON");
    let chatter = stats.as_array().expect("list").iter().find(|t| t["topic"] == "/chatter").expect("/chatter in the figures");
    assert!(chatter["forwarded"].as_u64().unwrap_or(0) >= 1, "{chatter}");
    assert!(chatter["latency_median_ms"].as_f64().is_some_and(|ms| (0.0..1000.0).contains(&ms)), "{chatter}");
}
