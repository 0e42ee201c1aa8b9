//! The primitive database: byte-identical reload, errors naming the file and field, and
//! `kill -9` in the middle of saving never leaving a file that fails to load.

mod common;

use std::process::Command;
use std::time::Duration;

use common::*;
use cowork_manager::{Database, Manager, ManagerConfig, ManagerError};

fn learned_db() -> Database {
    let mut d = Driver::new(Manager::new(ManagerConfig::default(), Database::new("lwr")));
    teach_pour(&mut d);
    d.manager.database().clone()
}

#[test]
fn reload_equals_save_byte_for_byte() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = Database::path(dir.path(), "lwr");
    let db = learned_db();
    db.save(&path).expect("save");
    let saved = std::fs::read(&path).expect("read");
    let back = Database::load(&path).expect("load");
    assert_eq!(back, db);
    assert_eq!(back.to_bytes(), saved, "reload → save writes the same bytes");
    back.save(&path).expect("save again");
    assert_eq!(std::fs::read(&path).expect("read"), saved);
}

#[test]
fn corrupt_files_are_refused_naming_file_line_and_field() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = Database::path(dir.path(), "lwr");
    let db = learned_db();
    let text = String::from_utf8(db.to_bytes()).expect("utf-8");
    // Truncated.
    std::fs::write(&path, &text[..text.len() / 2]).expect("write");
    let e = Database::load(&path).expect_err("truncated");
    assert!(matches!(e, ManagerError::Parse { .. }) && e.to_string().contains("lwr.primitives.json"), "{e}");
    // A misspelt field.
    std::fs::write(&path, text.replacen("\"linear_gain\"", "\"linear_gian\"", 1)).expect("write");
    let e = Database::load(&path).expect_err("unknown field").to_string();
    assert!(e.contains("linear_gian") && e.contains("line"), "{e}");
    // A value out of range: the primitive and field are named.
    let mut bad = db.clone();
    bad.primitives.get_mut("foa1").expect("foa1").linear_gain = Some(-1.0);
    std::fs::write(&path, bad.to_bytes()).expect("write");
    let e = Database::load(&path).expect_err("gain").to_string();
    assert!(e.contains("`foa1`") && e.contains("linear_gain"), "{e}");
    let mut bad = db.clone();
    bad.primitives.get_mut("noa2").expect("noa2").dmp.as_mut().expect("dmp").weights.pop();
    std::fs::write(&path, bad.to_bytes()).expect("write");
    let e = Database::load(&path).expect_err("weights").to_string();
    assert!(e.contains("`noa2`") && e.contains("dmp"), "{e}");
    // A missing file is an empty database; a missing directory on save names it.
    let other = Database::path(dir.path(), "nobody");
    assert!(Database::load_or_new(&other, "nobody").expect("new").primitives.is_empty());
    let e = db.save(&dir.path().join("no/dir/x.json")).expect_err("no dir").to_string();
    assert!(e.contains("no/dir"), "{e}");
}

/// Child side of the kill test: saves growing databases in a loop until killed.
#[test]
fn saver_child() {
    let Ok(path) = std::env::var("COWORK_MANAGER_SAVER_PATH") else { return };
    let mut db = learned_db();
    let template = db.primitives.values().next().cloned().expect("a primitive");
    std::fs::write(format!("{path}.ready"), b"1").expect("ready flag");
    for i in 0u32.. {
        let mut p = template.clone();
        p.id = format!("foa{}", 100 + i);
        p.label = format!("foa{}(water)", 100 + i);
        p.kind = cowork_manager::ActionKind::Foa;
        p.dmp = None;
        p.orientation_dmp = None;
        p.gripper = None;
        p.linear_gain = Some(2.0);
        db.insert(p);
        db.save(std::path::Path::new(&path)).expect("save");
    }
}

#[test]
fn kill_9_while_saving_never_leaves_a_file_that_fails_to_load() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = Database::path(dir.path(), "lwr");
    let exe = std::env::current_exe().expect("test binary");
    let mut loads = 0;
    for round in 0..12u64 {
        let _ = std::fs::remove_file(format!("{}.ready", path.display()));
        let mut child = Command::new(&exe)
            .args(["--exact", "saver_child", "--nocapture", "--test-threads=1"])
            .env("COWORK_MANAGER_SAVER_PATH", &path)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("spawn the saver");
        let ready = format!("{}.ready", path.display());
        let t0 = std::time::Instant::now();
        while !std::path::Path::new(&ready).exists() && t0.elapsed() < Duration::from_secs(60) {
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(20 + 17 * round));
        child.kill().expect("SIGKILL");
        child.wait().expect("reap");
        if path.exists() {
            let db = Database::load(&path).unwrap_or_else(|e| panic!("round {round}: {e}"));
            assert!(db.primitives.len() >= 9);
            loads += 1;
        }
    }
    assert!(loads >= 6, "the saver wrote a file in most rounds ({loads} of 12)");
}
