//! The working-memory page of `cowork bridge --wm-page PORT`: a small HTTP/1.1 server (std
//! only, one short-lived thread per connection) with two resources,
//!
//! * `/` — a self-contained HTML page (no external script, style or font: it works offline)
//!   that polls `/wm.json` and draws the tree, collapsible, with each node's state and reason;
//! * `/wm.json` — the latest `/supervisor/working_memory` as the nested tree of
//!   [`wm_tree::tree`](super::wm_tree::tree), plus how old it is.
//!
//! Polling a small JSON document keeps the server stateless and works through any proxy and in
//! a headless browser; the working memory changes at the supervisor's 10 Hz at most.

use std::io::{Read as _, Write as _};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use cowork_msgs::msg::WorkingMemory;
use serde::Serialize;

use super::wm_tree::{Decision, DecisionLog, Tree, tree};

/// The page, compiled in.
const PAGE: &str = include_str!("wm.html");

/// Connections served at once; more are answered 503 and closed.
const MAX_CONNECTIONS: usize = 32;

/// Longest request head read, bytes.
const MAX_REQUEST_BYTES: usize = 8192;

/// How long a connection may take to send its request.
const READ_TIMEOUT: Duration = Duration::from_secs(5);

/// The latest working memory, shared between the bridge's loop and the HTTP threads.
#[derive(Debug, Default)]
pub struct WmShared {
    latest: Mutex<Latest>,
}

#[derive(Debug, Default)]
struct Latest {
    tree: Option<(Arc<Tree>, Instant)>,
    received: u64,
    log: DecisionLog,
}

/// The document `/wm.json` serves.
#[derive(Debug, Serialize)]
struct WmDocument<'a> {
    /// The topic read.
    topic: &'a str,
    /// `ROS_DOMAIN_ID` of the bridge (where the page says to look when nothing arrives).
    domain: u16,
    /// Messages received so far; the page redraws when it changes.
    received: u64,
    /// Wall seconds since the latest message; null before the first.
    age_s: Option<f64>,
    /// The tree; null before the first message.
    tree: Option<&'a Tree>,
    /// The decisions seen since the bridge started, newest first.
    decisions: Vec<Decision>,
}

impl WmShared {
    /// Keeps `wm` as the latest working memory, as a tree, and logs what it decided. Called
    /// for every message (10 Hz), so that no decision between two polls of the page is lost.
    pub fn update(&self, wm: &WorkingMemory) {
        let t = Arc::new(tree(wm));
        let mut l = self.latest.lock().unwrap_or_else(PoisonError::into_inner);
        l.log.observe(&t);
        l.tree = Some((t, Instant::now()));
        l.received += 1;
    }

    /// The JSON document of `/wm.json`.
    fn document(&self, domain: u16) -> String {
        let (t, received, decisions) = {
            let l = self.latest.lock().unwrap_or_else(PoisonError::into_inner);
            (l.tree.clone(), l.received, l.log.recent())
        };
        let doc = WmDocument {
            topic: cowork_msgs::topics::WORKING_MEMORY.name,
            domain,
            received,
            age_s: t.as_ref().map(|(_, at)| at.elapsed().as_secs_f64()),
            tree: t.as_ref().map(|(t, _)| &**t),
            decisions,
        };
        serde_json::to_string(&doc).unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"))
    }
}

/// Serves the page on `listener` from a background thread until the process ends.
pub fn spawn(listener: TcpListener, shared: Arc<WmShared>, domain: u16) -> std::io::Result<()> {
    std::thread::Builder::new().name("wm-page".into()).spawn(move || {
        let open = Arc::new(AtomicUsize::new(0));
        for stream in listener.incoming() {
            let Ok(mut stream) = stream else { continue };
            if open.fetch_add(1, Ordering::AcqRel) >= MAX_CONNECTIONS {
                open.fetch_sub(1, Ordering::AcqRel);
                let _ = respond(&mut stream, "503 Service Unavailable", "text/plain", b"too many connections\n");
                continue;
            }
            let (shared, open) = (Arc::clone(&shared), Arc::clone(&open));
            let spawned = std::thread::Builder::new().name("wm-page-conn".into()).spawn(move || {
                if let Err(e) = handle(stream, &shared, domain) {
                    tracing::debug!("working-memory page: {e}");
                }
                open.fetch_sub(1, Ordering::AcqRel);
            });
            if let Err(e) = spawned {
                tracing::warn!("working-memory page: cannot start a connection thread: {e}");
            }
        }
    })?;
    Ok(())
}

/// Reads one request and answers it; the connection is closed after the answer.
fn handle(mut stream: TcpStream, shared: &WmShared, domain: u16) -> std::io::Result<()> {
    stream.set_read_timeout(Some(READ_TIMEOUT))?;
    let mut head = Vec::with_capacity(1024);
    let mut buf = [0u8; 1024];
    while !head.windows(4).any(|w| w == b"\r\n\r\n") {
        let n = stream.read(&mut buf)?;
        if n == 0 {
            break;
        }
        head.extend_from_slice(&buf[..n]);
        if head.len() > MAX_REQUEST_BYTES {
            return respond(&mut stream, "431 Request Header Fields Too Large", "text/plain", b"request too large\n");
        }
    }
    let line = head.split(|&b| b == b'\r' || b == b'\n').next().unwrap_or_default();
    let line = String::from_utf8_lossy(line);
    let mut parts = line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
    let path = target.split(['?', '#']).next().unwrap_or("");
    match (method, path) {
        ("GET", "/" | "/index.html") => respond(&mut stream, "200 OK", "text/html; charset=utf-8", PAGE.as_bytes()),
        ("GET", "/wm.json") => respond(&mut stream, "200 OK", "application/json", shared.document(domain).as_bytes()),
        ("GET", _) => respond(&mut stream, "404 Not Found", "text/plain", b"not found: the page is at / and the data at /wm.json\n"),
        _ => respond(&mut stream, "405 Method Not Allowed", "text/plain", b"only GET\n"),
    }
}

fn respond(stream: &mut TcpStream, status: &str, content_type: &str, body: &[u8]) -> std::io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    );
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    stream.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use cowork_msgs::msg::WmNode;

    fn get(port: u16, request: &str) -> (String, String) {
        let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        s.write_all(request.as_bytes()).unwrap();
        let mut out = String::new();
        s.read_to_string(&mut out).unwrap();
        let (head, body) = out.split_once("\r\n\r\n").unwrap();
        (head.to_owned(), body.to_owned())
    }

    fn serve() -> (u16, Arc<WmShared>) {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let shared = Arc::new(WmShared::default());
        spawn(listener, Arc::clone(&shared), 42).unwrap();
        (port, shared)
    }

    #[test]
    fn the_json_endpoint_serves_the_latest_working_memory_as_a_tree() {
        let (port, shared) = serve();
        let (head, body) = get(port, "GET /wm.json HTTP/1.1\r\nHost: x\r\n\r\n");
        assert!(head.starts_with("HTTP/1.1 200") && head.contains("application/json"), "{head}");
        let doc: serde_json::Value = serde_json::from_str(&body).unwrap();
        assert_eq!(doc["received"], 0);
        assert_eq!(doc["domain"], 42);
        assert_eq!(doc["topic"], "/supervisor/working_memory");
        assert!(doc["tree"].is_null() && doc["age_s"].is_null());

        let node = |parent: i32, name: &str| WmNode { parent, name: name.into(), releaser: "true".into(), releaser_value: true, enabled: true, ..WmNode::default() };
        let mut running = node(0, "foa1(water)");
        running.concrete = true;
        running.assigned_to = WmNode::ASSIGNED_ROBOT;
        shared.update(&WorkingMemory { nodes: vec![node(-1, "alive"), node(0, "prepareCoffee"), node(7, "lost"), running], ..WorkingMemory::default() });
        let (_, body) = get(port, "GET /wm.json?t=1 HTTP/1.1\r\n\r\n");
        let doc: serde_json::Value = serde_json::from_str(&body).unwrap();
        assert_eq!(doc["received"], 1);
        assert!(doc["age_s"].as_f64().unwrap() >= 0.0);
        let roots = doc["tree"]["roots"].as_array().unwrap();
        assert_eq!(roots.len(), 2);
        assert_eq!(roots[0]["children"][0]["name"], "prepareCoffee");
        assert_eq!(roots[0]["children"][1]["state"], "running");
        assert_eq!(roots[1]["name"], "lost");
        assert_eq!(doc["tree"]["problems"].as_array().unwrap().len(), 1);
        assert_eq!(doc["decisions"][0]["name"], "foa1(water)");
        assert_eq!(doc["decisions"][0]["state"], "running");
    }

    #[test]
    fn the_page_is_self_contained_and_other_requests_are_refused() {
        let (port, _) = serve();
        let (head, body) = get(port, "GET / HTTP/1.1\r\n\r\n");
        assert!(head.starts_with("HTTP/1.1 200") && head.contains("text/html"), "{head}");
        assert!(body.contains("/wm.json"));
        // Offline: nothing is loaded from anywhere else.
        for external in ["src=\"http", "href=\"http", "src=\"//", "@import", "url(http"] {
            assert!(!body.contains(external), "the page loads {external}…");
        }
        let (head, _) = get(port, "GET /nothing HTTP/1.1\r\n\r\n");
        assert!(head.starts_with("HTTP/1.1 404"), "{head}");
        let (head, _) = get(port, "POST /wm.json HTTP/1.1\r\nContent-Length: 0\r\n\r\n");
        assert!(head.starts_with("HTTP/1.1 405"), "{head}");
        let (head, _) = get(port, &format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(MAX_REQUEST_BYTES)));
        assert!(head.starts_with("HTTP/1.1 431"), "{head}");
    }
}
