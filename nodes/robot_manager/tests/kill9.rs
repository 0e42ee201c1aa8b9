//! The primitive database at node level under `kill -9`: a child process runs the node
//! ([`RobotManagerNode`], bundled parameters) through its message handlers — `/speech_command`
//! `teach`, `/lwr/world` reports of the tool guided into the bottle's sphere and out again,
//! `done` — and saves with the node's own save path ([`RobotManagerNode::save_if_changed`],
//! as `run` does) after every teaching session, so the file grows by three primitives a
//! session and the child spends much of its time saving. The test kills it with SIGKILL at
//! pseudo-random moments and checks, every round:
//! - the file (when one was written) loads; a reload saved again is the same bytes (the text
//!   is canonical, nothing half-written);
//! - nothing saved is lost: the file holds at least the primitives of the last save the child
//!   finished before the kill;
//! - a new node starts on the directory without a problem and with those primitives.
//!
//! The next round's child starts on what the last one left (a node restarted after a crash).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use cowork_manager::{Database, Stamp};
use cowork_msgs::builtin_interfaces::Time;
use cowork_msgs::geometry_msgs::{Point, Pose, Quaternion};
use cowork_msgs::msg::{WorldObject, WorldState};
use cowork_msgs::std_msgs::{Header, String as RosString};
use robot_manager::{Outbox, Params, RobotManagerNode};

const CHILD_DIR: &str = "COWORK_ROBOT_MANAGER_KILL9_DIR";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn params(dir: &Path) -> Params {
    let mut p: Params = cowork_ros::params::load(&root().join("config/robot_manager.yaml"), "robot_manager").expect("bundled parameters");
    p.database_dir = dir.display().to_string();
    p.validate("robot_manager.yaml").expect("valid");
    p
}

/// The kitchen's bottle and cup; the tool at `tool` (m, base frame, pointing down).
fn world(t: f64, tool: [f64; 3]) -> WorldState {
    let pose = |p: [f64; 3]| Pose { position: Point { x: p[0], y: p[1], z: p[2] }, orientation: Quaternion { x: 1.0, y: 0.0, z: 0.0, w: 0.0 } };
    // Distance from the tool to the object's surface, as lwr_sim reports it (shapes as balls).
    let dist = |c: [f64; 3], r: f64| (((tool[0] - c[0]).powi(2) + (tool[1] - c[1]).powi(2) + (tool[2] - c[2]).powi(2)).sqrt() - r).max(0.0);
    let (bottle, cup) = ([0.45, 0.35, 0.11], [0.60, 0.0, 0.05]);
    WorldState {
        header: Header { stamp: Time::from_secs_f64(t), frame_id: "lwr_base_link".into() },
        gripper_state: WorldState::GRIPPER_OPEN,
        held_object: String::new(),
        tool_pose: pose(tool),
        objects: vec![
            WorldObject { name: "bottle".into(), pose: pose(bottle), tool_distance: dist(bottle, 0.035), ..Default::default() },
            WorldObject { name: "cup".into(), pose: pose(cup), tool_distance: dist(cup, 0.04), ..Default::default() },
        ],
    }
}

/// Child side: teaching sessions through the node's handlers, a save after each, until killed.
/// Appends `saving N` / `saved N` (primitives) to `DIR/progress` around every save.
#[test]
fn teaching_child() {
    let Ok(dir) = std::env::var(CHILD_DIR) else { return };
    let dir = PathBuf::from(dir);
    let (mut node, problem) = RobotManagerNode::new(params(&dir.join("db")), 1);
    assert!(problem.is_none(), "{problem:?}");
    let mut progress = std::fs::OpenOptions::new().create(true).append(true).open(dir.join("progress")).expect("progress");
    let mut out = Outbox::default();
    let mut t = 0.0;
    let say = |node: &mut RobotManagerNode, out: &mut Outbox, t: f64, w: &str| {
        node.on_speech(&RosString { data: w.into() }, Stamp { t, unix_s: 1 }, out);
    };
    let (far, near) = ([0.30, 0.0, 0.50], [0.45, 0.35, 0.24]);
    let lerp = |a: [f64; 3], b: [f64; 3], s: f64| [a[0] + (b[0] - a[0]) * s, a[1] + (b[1] - a[1]) * s, a[2] + (b[2] - a[2]) * s];
    std::fs::write(dir.join("ready"), b"1").expect("ready flag");
    loop {
        node.on_world(&world(t, far), Stamp { t, unix_s: 1 }, &mut out);
        say(&mut node, &mut out, t, "teach");
        // Into the bottle's sphere (0.12 m) and out again, 100 Hz, smooth.
        for (a, b) in [(far, near), (near, far)] {
            for k in 1..=80 {
                t += 0.01;
                let s = f64::from(k) / 80.0;
                let s = s * s * (3.0 - 2.0 * s);
                node.on_world(&world(t, lerp(a, b, s)), Stamp { t, unix_s: 1 }, &mut out);
            }
        }
        t += 0.01;
        say(&mut node, &mut out, t, "done");
        out.clear();
        let n = node.manager().database().primitives.len();
        assert!(node.database_dirty(), "a session learns primitives");
        writeln!(progress, "saving {n}").expect("progress");
        node.save_if_changed().expect("save");
        writeln!(progress, "saved {n}").expect("progress");
        t += 0.5;
    }
}

#[test]
fn kill_9_of_the_node_while_it_saves_never_loses_or_corrupts_the_database() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = tmp.path();
    let db_file = Database::path(&dir.join("db"), "lwr");
    let exe = std::env::current_exe().expect("test binary");
    let started = Instant::now();
    // Deterministic pseudo-random kill moments, 15-250 ms after the child is ready.
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    let mut rounds = 0;
    let (mut loads, mut mid_save, mut max_primitives) = (0, 0, 0);
    while rounds < 14 && started.elapsed() < Duration::from_secs(15) {
        rounds += 1;
        let _ = std::fs::remove_file(dir.join("ready"));
        let _ = std::fs::remove_file(dir.join("progress"));
        let mut child = Command::new(&exe)
            .args(["--exact", "teaching_child", "--nocapture", "--test-threads=1"])
            .env(CHILD_DIR, dir)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn the child");
        let t0 = Instant::now();
        while !dir.join("ready").exists() {
            if let Ok(Some(status)) = child.try_wait() {
                panic!("round {rounds}: the child exited before teaching ({status}); the database left was {:?}", std::fs::read_to_string(&db_file).ok().map(|s| s.len()));
            }
            assert!(t0.elapsed() < Duration::from_secs(30), "round {rounds}: the child never started");
            std::thread::sleep(Duration::from_millis(2));
        }
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        std::thread::sleep(Duration::from_millis(15 + seed % 236));
        child.kill().expect("SIGKILL");
        child.wait().expect("reap");
        // What the child had finished saving, and whether it was inside a save when killed.
        let progress = std::fs::read_to_string(dir.join("progress")).unwrap_or_default();
        let last_saved = progress.lines().filter_map(|l| l.strip_prefix("saved ")).filter_map(|n| n.parse::<usize>().ok()).max();
        mid_save += usize::from(progress.lines().last().is_some_and(|l| l.starts_with("saving ")));
        if !db_file.exists() {
            assert!(last_saved.is_none(), "round {rounds}: a save finished ({last_saved:?}) but there is no file");
            continue;
        }
        let bytes = std::fs::read(&db_file).expect("read");
        let db = Database::from_bytes(&bytes, &db_file).unwrap_or_else(|e| panic!("round {rounds}: the file does not load: {e}"));
        assert!(db.to_bytes() == bytes, "round {rounds}: the reload saved again differs from the file");
        if let Some(n) = last_saved {
            assert!(db.primitives.len() >= n, "round {rounds}: {} primitives in the file, {n} were saved", db.primitives.len());
        }
        assert!(db.primitives.len() >= max_primitives, "round {rounds}: primitives lost across restarts");
        max_primitives = db.primitives.len();
        // The node restarted on it (as after a crash) starts cleanly with what was saved.
        let (node, problem) = RobotManagerNode::new(params(&dir.join("db")), 2);
        assert!(problem.is_none(), "round {rounds}: {problem:?}");
        assert_eq!(node.manager().database(), &db);
        loads += 1;
    }
    // Every restart above removed the temporaries of the save it was killed in; so does this one.
    let _ = RobotManagerNode::new(params(&dir.join("db")), 3);
    let leftovers = std::fs::read_dir(dir.join("db")).map(|d| d.filter_map(|e| e.ok()).filter(|e| e.file_name().to_string_lossy().starts_with(".tmp-")).count()).unwrap_or(0);
    eprintln!(
        "kill -9 of the node: {rounds} rounds in {:.1} s, a database file in {loads}, killed inside a save in {mid_save}, \
         {max_primitives} primitives at the end, {leftovers} temporary files left by killed saves",
        started.elapsed().as_secs_f64()
    );
    assert!(rounds >= 6, "too few rounds ({rounds})");
    assert_eq!(leftovers, 0, "temporary files of killed saves survive a restart");
    assert!(loads * 2 >= rounds, "the child saved in most rounds ({loads} of {rounds})");
    assert!(max_primitives >= 6, "several sessions were saved across the rounds ({max_primitives} primitives)");
}
