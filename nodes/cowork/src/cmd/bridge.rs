//! `cowork bridge`: the live graph over the Foxglove WebSocket protocol, so the Foxglove app (or
//! Lichtblick) connected to `ws://localhost:8765` sees every topic without a ROS installation.
//!
//! Every topic discovered on the DDS domain (now or later) whose type `cowork_msgs` knows is
//! advertised as a channel with its `ros2msg` schema (the text the bags carry) and `cdr`
//! encoding. Payloads are forwarded as DDS delivered them, encapsulation header included, never
//! decoded and re-encoded. A topic of an unknown type is skipped with one log line. Messages
//! of latched (transient-local) topics, such as `/robot_description`, are kept and sent to a
//! client when it subscribes, as a ROS subscriber would get them. Message times are the DDS
//! receive time (wall clock), or with `--use-sim-time` the graph's `/clock`, which the server
//! then also announces (the protocol's `time` capability). Mesh files the robot description
//! names (`file://` URIs under the config directory) are served as assets, so the robot shows
//! in the 3D panel of the web app too.
//!
//! With `--wm-page PORT` the bridge also serves the supervisor's working memory as a live,
//! collapsible tree on `http://HOST:PORT/` ([`wm_page`]), each behaviour with its state and the
//! reason of each decision ([`wm_tree`]): a page any browser opens, without a node-count cap.

mod wm_page;
mod wm_tree;

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use anyhow::{Context as _, Result, bail};
use clap::Args;
use cowork_ros::raw::RawSubscription;
use cowork_ros::{NodeConfig, RosNode, Warnings, shutdown};
use foxglove::websocket::{Capability, ChannelView, Client, ServerListener};
use foxglove::{ChannelId, Context, PartialMetadata, RawChannel, Schema, WebSocketServer};

use super::bridge_stats::{TopicStats, TopicSummary, table};

/// Topics never served unless named: ROS 2 infrastructure, not data.
const INFRASTRUCTURE: &[&str] = &["/rosout", "/parameter_events"];

/// Largest asset (mesh file) served, bytes.
const MAX_ASSET_BYTES: u64 = 64 << 20;

/// Arguments of `cowork bridge`.
#[derive(Debug, Args)]
pub struct BridgeArgs {
    /// TCP port of the WebSocket server (0: any free port; the port is printed).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Address to listen on (0.0.0.0 lets other machines connect).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: String,
    /// Topics to serve; every discovered topic (except /rosout, /parameter_events) if none.
    pub topics: Vec<String>,
    /// Stamp messages with the graph's /clock (sim time) and announce it to the app, as
    /// foxglove_bridge does with use_sim_time; otherwise with the DDS receive time.
    #[arg(long)]
    pub use_sim_time: bool,
    /// Stop after this many seconds (wall clock); default: until Ctrl-C.
    #[arg(long)]
    pub duration: Option<f64>,
    /// How often to look for new topics, s.
    #[arg(long, default_value_t = 0.5)]
    pub discovery_interval: f64,
    /// History depth of each DDS subscription (samples buffered between polls).
    #[arg(long, default_value_t = 100)]
    pub depth: usize,
    /// Write the per-topic figures (forwarded, rate, latency) to this JSON file at the end.
    #[arg(long)]
    pub stats_json: Option<PathBuf>,
    /// Also serve the working memory (`/supervisor/working_memory`) as a live tree page on
    /// http://HOST:PORT/ (its data at /wm.json; 0: any free port; the URL is printed).
    #[arg(long, value_name = "PORT")]
    pub wm_page: Option<u16>,
}

/// The last message of a latched topic, replayed to each client that subscribes.
struct LastSample {
    channel: Arc<RawChannel>,
    data: Vec<u8>,
    log_time_ns: u64,
}

/// Sends a latched topic's last message to a client when it subscribes.
#[derive(Default)]
struct LatchedReplay {
    last: Mutex<HashMap<ChannelId, LastSample>>,
}

impl LatchedReplay {
    fn keep(&self, channel: &Arc<RawChannel>, data: &[u8], log_time_ns: u64) {
        let mut last = self.last.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        last.insert(channel.id(), LastSample { channel: Arc::clone(channel), data: data.to_vec(), log_time_ns });
    }
}

impl ServerListener for LatchedReplay {
    fn on_subscribe(&self, client: Client, channel: ChannelView<'_>) {
        let last = self.last.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(s) = last.get(&channel.id()) {
            s.channel.log_with_meta_to_sink(&s.data, PartialMetadata { log_time: Some(s.log_time_ns) }, client.sink_id());
        }
    }
}

/// One topic the bridge serves.
struct Served {
    sub: RawSubscription,
    channel: Arc<RawChannel>,
    type_name: String,
    latched: bool,
    stats: TopicStats,
}

/// The bytes of `uri` for a WebSocket client: only `file://` URIs of files under `root` (the
/// canonical config directory), at most [`MAX_ASSET_BYTES`]; anything else is refused with a
/// message naming it.
fn fetch_asset(root: &Path, uri: &str) -> Result<Vec<u8>, String> {
    let Some(path) = uri.strip_prefix("file://") else {
        return Err(format!("{uri}: only file:// URIs under the cowork config directory are served"));
    };
    let path = Path::new(path)
        .canonicalize()
        .map_err(|e| format!("{uri}: {e}"))?;
    if !path.starts_with(root) {
        return Err(format!("{uri}: outside the cowork config directory {}", root.display()));
    }
    let meta = std::fs::metadata(&path).map_err(|e| format!("{uri}: {e}"))?;
    if !meta.is_file() || meta.len() > MAX_ASSET_BYTES {
        return Err(format!("{uri}: not a file of at most {MAX_ASSET_BYTES} bytes"));
    }
    std::fs::read(&path).map_err(|e| format!("{uri}: {e}"))
}

fn now_ns() -> u64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

/// Serves the graph until `--duration` or Ctrl-C, then prints the per-topic figures.
pub fn run(args: &BridgeArgs) -> Result<()> {
    if let Some(d) = args.duration
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration {d}: must be a finite number of seconds > 0");
    }
    if !(args.discovery_interval.is_finite() && args.discovery_interval > 0.0) {
        bail!("--discovery-interval {}: must be > 0 s", args.discovery_interval);
    }
    shutdown::install();
    let mut node = RosNode::new(
        &format!("cowork_bridge_{}", std::process::id()),
        &NodeConfig { use_sim_time: args.use_sim_time, ..NodeConfig::default() },
    )?;
    let ctx = Context::new();
    let latched = Arc::new(LatchedReplay::default());
    let mut server = WebSocketServer::new()
        .name("cowork")
        .bind(args.host.clone(), args.port)
        .context(&ctx)
        .listener(Arc::clone(&latched) as Arc<dyn ServerListener>);
    if args.use_sim_time {
        server = server.capabilities([Capability::Time]);
    }
    match cowork_ros::config::config_dir().and_then(|d| d.canonicalize().map_err(|_| cowork_ros::config::ConfigDirError::NotFound { tried: vec![d] })) {
        Ok(root) => {
            server = server.fetch_asset_handler_blocking_fn(move |_client, uri: String| fetch_asset(&root, &uri));
        }
        Err(e) => tracing::warn!("no mesh assets served: {e}"),
    }
    let handle = server
        .start_blocking()
        .with_context(|| format!("cannot serve on ws://{}:{} (port in use? try --port)", args.host, args.port))?;
    // The first line of stdout, read by scripts that start the bridge on `--port 0`.
    let banner = format!("cowork bridge: ws://{}:{} (Foxglove: Open connection → Foxglove WebSocket)\n", args.host, handle.port());
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(banner.as_bytes()).and_then(|()| out.flush());
    drop(out);
    let wm = match args.wm_page {
        Some(port) => Some(serve_wm_page(&mut node, &args.host, port)?),
        None => None,
    };

    let named: BTreeSet<String> = args.topics.iter().cloned().collect();
    let mut served: BTreeMap<String, Served> = BTreeMap::new();
    let mut skipped: BTreeSet<String> = BTreeSet::new();
    let mut warn = Warnings::new(10.0);
    let start = Instant::now();
    let end = args.duration.map(|d| start + cowork_ros::duration_s(d));
    let interval = cowork_ros::duration_s(args.discovery_interval);
    let mut next_discovery = start;
    let mut next_time = start;
    while !shutdown::requested() && end.is_none_or(|e| Instant::now() < e) {
        let now = Instant::now();
        if now >= next_discovery {
            discover(&mut node, &ctx, &named, args.depth.max(1), &mut served, &mut skipped);
            next_discovery = now + interval;
        }
        if args.use_sim_time && now >= next_time && node.clock_started() {
            handle.broadcast_time(node.now().to_nanos().max(0) as u64);
            next_time = now + Duration::from_millis(20);
        }
        let mut got = 0usize;
        if let Some((sub, shared)) = &wm
            && let Some(msg) = sub.take_latest()
        {
            got += 1;
            shared.update(&msg);
        }
        for (topic, s) in &mut served {
            while let Some(sample) = s.sub.take() {
                got += 1;
                // Foxglove's `cdr` decoder reads the encapsulation header: plain CDR only.
                if !matches!(sample.data.get(..2), Some([0, 0] | [0, 1])) {
                    warn.warn_text(cowork_ros::monotonic_s(), topic, &format!("{topic}: a sample without a plain CDR encapsulation header was not forwarded"));
                    continue;
                }
                let log_time_ns = if args.use_sim_time && node.clock_started() {
                    node.now().to_nanos().max(0) as u64
                } else {
                    sample.receive_time_ns
                };
                if s.latched {
                    latched.keep(&s.channel, &sample.data, log_time_ns);
                }
                if !s.channel.has_sinks() {
                    s.stats.unsubscribed += 1;
                    continue;
                }
                s.channel.log_with_meta(&sample.data, PartialMetadata { log_time: Some(log_time_ns) });
                let queued = now_ns();
                s.stats.forwarded(sample.data.len(), queued.saturating_sub(sample.receive_time_ns), Instant::now());
            }
        }
        if got == 0 {
            std::thread::sleep(Duration::from_micros(500));
        }
    }
    handle.stop().wait_blocking();
    let summaries: Vec<TopicSummary> = served.iter().map(|(t, s)| s.stats.summary(t, &s.type_name)).collect();
    if let Some(path) = &args.stats_json {
        let json = serde_json::to_vec_pretty(&summaries)?;
        crate::cmd::output::write(path, json)?;
    }
    let mut text = table(&summaries);
    for t in named.iter().filter(|t| !served.contains_key(*t)) {
        text.push_str(&format!("{t}: never served (not seen with a writer, or of an unknown type)\n"));
    }
    // A closed stdout (`cowork bridge | head -1`) is no reason to fail at the end.
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e).context("writing the figures to stdout"),
        _ => Ok(()),
    }
}

/// Starts the working-memory page on `host:port` and subscribes to the working memory for it;
/// prints the page's URL (the second line of stdout, after the WebSocket banner).
fn serve_wm_page(
    node: &mut RosNode,
    host: &str,
    port: u16,
) -> Result<(cowork_ros::Subscription<cowork_msgs::msg::WorkingMemory>, Arc<wm_page::WmShared>)> {
    let listener = std::net::TcpListener::bind((host, port))
        .with_context(|| format!("cannot serve the working-memory page on http://{host}:{port} (port in use? try --wm-page 0)"))?;
    let port = listener.local_addr().context("the working-memory page's address")?.port();
    let sub = node
        .subscribe(&cowork_msgs::topics::WORKING_MEMORY)
        .with_context(|| format!("subscribing to {}", cowork_msgs::topics::WORKING_MEMORY.name))?;
    let shared = Arc::new(wm_page::WmShared::default());
    let domain = cowork_ros::domain_id_from_env().unwrap_or(0);
    wm_page::spawn(listener, Arc::clone(&shared), domain).context("starting the working-memory page")?;
    let line = format!("cowork bridge: working memory http://{host}:{port}/ (JSON: /wm.json)\n");
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(line.as_bytes()).and_then(|()| out.flush());
    Ok((sub, shared))
}

/// Advertises every wanted topic seen with a writer and not served yet. The type is the
/// writers' (every ros2-client node reads `/clock` with a type of its own); a topic of a type
/// without a schema in `cowork_msgs` is skipped with one log line.
fn discover(
    node: &mut RosNode,
    ctx: &Arc<Context>,
    named: &BTreeSet<String>,
    depth: usize,
    served: &mut BTreeMap<String, Served>,
    skipped: &mut BTreeSet<String>,
) {
    let topics: BTreeSet<String> = node.discovered_topics().into_iter().map(|t| t.name).collect();
    for topic in topics {
        let wanted = if named.is_empty() { !INFRASTRUCTURE.contains(&topic.as_str()) } else { named.contains(&topic) };
        if !wanted || served.contains_key(&topic) || skipped.contains(&topic) {
            continue;
        }
        let mut types = node.writer_type_names(&topic);
        if types.is_empty() {
            continue;
        }
        if types.len() > 1 {
            tracing::warn!("{topic} is published with several types ({}); serving {}", types.join(", "), types[0]);
        }
        let type_name = types.swap_remove(0);
        let Some(info) = cowork_msgs::find_type(&type_name) else {
            tracing::warn!("{topic}: type {type_name} has no ros2msg schema in cowork_msgs; not served");
            skipped.insert(topic);
            continue;
        };
        let Some(qos) = node.offered_qos(&topic, depth) else { continue };
        let latched = cowork_ros::qos::is_latched(&qos);
        let schema = Schema::new(info.type_name(), "ros2msg", (info.definition)().into_bytes());
        let channel = match ctx.channel_builder(topic.clone()).message_encoding("cdr").schema(schema).build_raw() {
            Ok(c) => c,
            Err(e) => {
                tracing::warn!("{topic}: cannot advertise it: {e}; not served");
                skipped.insert(topic);
                continue;
            }
        };
        match node.raw_subscription(&topic, &type_name, &qos) {
            Ok(sub) => {
                tracing::info!("serving {topic} ({})", info.type_name());
                served.insert(
                    topic,
                    Served { sub, channel, type_name: info.type_name(), latched, stats: TopicStats::default() },
                );
            }
            Err(e) => {
                channel.close();
                tracing::warn!("{topic}: cannot subscribe: {e:#}; not served");
                skipped.insert(topic);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn topic_type(topic: &str) -> Option<String> {
        cowork_bag::graph_topic_type(topic)
    }

    fn leaves(node: &serde_json::Value, out: &mut Vec<String>) {
        match node {
            serde_json::Value::String(id) => out.push(id.clone()),
            serde_json::Value::Object(o) => {
                for k in ["first", "second"] {
                    if let Some(child) = o.get(k) {
                        leaves(child, out);
                    }
                }
            }
            _ => {}
        }
    }

    fn root() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
    }

    /// The simulator of `scene` as the graph runs it: its TF frames are the frames a layout
    /// can name, its robot descriptions what the URDF layers draw.
    fn simulator(scene: &str) -> lwr_sim::LwrSim {
        let config: lwr_sim::LwrSimConfig = cowork_ros::params::load(&root().join("config/lwr_sim.yaml"), "lwr_sim").unwrap();
        let model = cowork_robot::RobotModel::from_urdf_file(root().join("config/robot/lwr4plus.urdf")).unwrap();
        let scene = cowork_sim::Scene::from_file(&root().join(scene)).unwrap();
        lwr_sim::LwrSim::new(cowork_sim::Simulator::new(model, scene, config.simulation.clone()).unwrap(), config)
    }

    /// `/topic.field[:]{key=="v"}.more` → (`/topic`, `field`, filter keys).
    fn split_path(p: &str) -> (&str, Option<&str>, Vec<&str>) {
        let Some((topic, rest)) = p.split_once('.') else { return (p, None, Vec::new()) };
        let field = rest.split(['.', '[', '{']).next();
        let filters = rest.split('{').skip(1).filter_map(|f| f.split(['=', '!', '<', '>', '}']).next()).map(str::trim).collect();
        (topic, field, filters)
    }

    /// A bundled Foxglove layout: every panel of the tree is configured; every topic and message
    /// path it names is one the graph of `scene` publishes (a per-arm topic under one of the
    /// scene's arm namespaces), of a type the bridge serves and with the fields its schema
    /// declares; every frame it names is on the simulator's TF; and there is one URDF layer per
    /// arm, whose links (with the layer's frame prefix) are frames of that TF, so each robot is
    /// drawn where it is.
    fn check_layout(file: &str, scene: &str, needed: &[&str]) {
        let path = root().join("config").join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        let layout: serde_json::Value = serde_json::from_str(&text).unwrap();
        let configs = layout["configById"].as_object().expect("configById");
        let mut panels = Vec::new();
        leaves(&layout["layout"], &mut panels);
        assert!(panels.len() >= 5, "{file}: {panels:?}");
        for p in &panels {
            assert!(configs.contains_key(p), "{file}: panel {p} has no configuration");
        }
        let mut paths: Vec<String> = Vec::new();
        let mut frames: Vec<String> = Vec::new();
        let mut urdfs: Vec<(String, String)> = Vec::new();
        for (id, c) in configs {
            assert!(!id.is_empty());
            if let Some(t) = c["topics"].as_object() {
                paths.extend(t.keys().cloned());
                paths.extend(t.values().filter_map(|v| v["cameraInfoTopic"].as_str().map(str::to_owned)));
            }
            for key in ["topicPath", "imageTopic", "calibrationTopic"] {
                if let Some(p) = c[key].as_str().or_else(|| c["imageMode"][key].as_str()) {
                    paths.push(p.to_owned());
                }
            }
            if let Some(list) = c["paths"].as_array() {
                paths.extend(list.iter().filter_map(|p| p["value"].as_str().map(str::to_owned)));
            }
            if let Some(f) = c["followTf"].as_str() {
                frames.push(f.to_owned());
            }
            for layer in c["layers"].as_object().into_iter().flat_map(|l| l.values()) {
                if let Some(f) = layer["frameId"].as_str() {
                    frames.push(f.to_owned());
                }
                if let Some(t) = layer["topic"].as_str() {
                    paths.push(t.to_owned());
                    if layer["layerId"] == "foxglove.Urdf" {
                        urdfs.push((t.to_owned(), layer["framePrefix"].as_str().unwrap_or("").to_owned()));
                    }
                }
            }
        }
        for needed in needed {
            assert!(paths.iter().any(|p| split_path(p).0 == *needed), "{file} does not show {needed}: {paths:?}");
        }
        let lwr = simulator(scene);
        let arms = lwr.simulator().arms().len();
        let namespaces: Vec<String> = (0..arms).map(|a| lwr.namespace(a)).collect();
        for p in &paths {
            let (topic, field, filters) = split_path(p);
            let (root_name, ty, _) = cowork_msgs::topics::find(topic).unwrap_or_else(|| panic!("{file}: {topic}: not a topic of the graph"));
            if root_name != topic {
                let ns = &topic[..topic.len() - root_name.len()];
                assert!(namespaces.iter().any(|n| n == ns), "{file}: {topic}: {ns} is no arm of {scene} ({namespaces:?})");
            }
            assert_eq!(topic_type(topic).as_deref(), Some(ty.as_str()));
            let info = cowork_msgs::find_type(&ty).unwrap_or_else(|| panic!("{topic}: {ty} has no schema"));
            let def = (info.definition)();
            if let Some(field) = field {
                let top = def.split("\n=").next().unwrap_or("");
                assert!(top.lines().any(|l| l.split_whitespace().nth(1) == Some(field)), "{file}: {p}: {ty} has no field {field}");
            }
            for f in filters {
                assert!(def.lines().any(|l| l.split_whitespace().nth(1) == Some(f)), "{file}: {p}: no field {f} to filter on");
            }
        }
        let tf = [lwr.tf(), lwr.tf_static()];
        let tf_frames: BTreeSet<&str> =
            tf.iter().flat_map(|m| &m.transforms).flat_map(|t| [t.header.frame_id.as_str(), t.child_frame_id.as_str()]).collect();
        for f in &frames {
            assert!(tf_frames.contains(f.as_str()), "{file}: frame {f} is not on the TF of {scene}: {tf_frames:?}");
        }
        assert_eq!(urdfs.len(), arms, "{file}: one URDF layer per arm of {scene}: {urdfs:?}");
        for (arm, ns) in namespaces.iter().enumerate() {
            let topic = cowork_msgs::topics::ROBOT_DESCRIPTION.name_in(ns);
            let (_, prefix) = urdfs.iter().find(|(t, _)| *t == topic).unwrap_or_else(|| panic!("{file}: no URDF layer of {topic}"));
            let urdf = lwr.robot_description(arm).unwrap().data;
            let links: Vec<&str> = urdf.split("<link name=\"").skip(1).filter_map(|l| l.split('"').next()).collect();
            assert!(links.len() >= 8, "{topic}: {links:?}");
            for link in links {
                let frame = format!("{prefix}{link}");
                assert!(tf_frames.contains(frame.as_str()), "{file}: {topic}'s link {frame} is not on the TF of {scene}");
            }
        }
    }

    #[test]
    fn the_foxglove_layout_names_only_topics_frames_and_fields_the_graph_has() {
        check_layout(
            "foxglove-layout.json",
            "config/scenes/kitchen.yaml",
            &["/robot_description", "/tf", "/camera/depth/image_raw", "/fded/markers", "/human/markers", "/supervisor/working_memory"],
        );
    }

    /// The two-arm layout (the pizza graph): both robots, each arm's fDED markers, working
    /// memory and motion; the one-arm layout names no robot there.
    #[test]
    fn the_dual_arm_layout_shows_both_arms_of_the_pizza_graph() {
        check_layout(
            "foxglove-layout-dual.json",
            "config/scenes/pizza.yaml",
            &[
                "/left/robot_description",
                "/right/robot_description",
                "/tf",
                "/camera/depth/image_raw",
                "/left/fded/markers",
                "/right/fded/markers",
                "/human/markers",
                "/supervisor/working_memory",
                "/left/motion/status",
                "/right/motion/status",
            ],
        );
        let one_arm = std::panic::catch_unwind(|| check_layout("foxglove-layout.json", "config/scenes/pizza.yaml", &[]));
        assert!(one_arm.is_err(), "the one-arm layout should not pass for the pizza graph");
    }

    #[test]
    fn assets_only_from_files_under_the_config_directory() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("config");
        std::fs::create_dir_all(root.join("robot")).unwrap();
        std::fs::write(root.join("robot/link.stl"), b"solid x").unwrap();
        std::fs::write(dir.path().join("secret"), b"no").unwrap();
        let root = root.canonicalize().unwrap();
        let uri = format!("file://{}", root.join("robot/link.stl").display());
        assert_eq!(fetch_asset(&root, &uri).unwrap(), b"solid x");
        let outside = format!("file://{}/robot/../../secret", root.display());
        assert!(fetch_asset(&root, &outside).unwrap_err().contains("outside"));
        assert!(fetch_asset(&root, "package://lwr/meshes/x.stl").unwrap_err().contains("only file://"));
        assert!(fetch_asset(&root, &format!("file://{}/robot/none.stl", root.display())).is_err());
        assert!(fetch_asset(&root, &format!("file://{}/robot", root.display())).is_err());
    }
}
