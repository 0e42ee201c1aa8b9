//! Crash consistency of what the product learns, under `kill -9` in a loop: a child process
//! saves, as fast as it can, new versions of the three learned files with the product's own
//! save paths — the LTM (`Ltm::save`, a task schema more each version), the primitive database
//! (`Database::save`, a primitive more each version) and a motion model (`Model::save`, a DMP
//! refitted on a demonstration that changes each version) — logging `saving K N H` /
//! `saved K N H` (kind, version, hash of the bytes) around every save. The parent kills it at
//! pseudo-random moments and checks every file after every kill:
//! - it loads with the product's loader (`Ltm::load`, `Database::load`, `Model::load`);
//! - its bytes are exactly the last version the child finished saving, or the one it was
//!   saving when killed: old or new, never a mix, and no finished save is lost;
//! - the next child (a restart) starts on what is there: it reloads the three files and
//!   removes the temporaries of killed writers (`cowork_store::remove_orphan_temporaries`).
//!
//! Prints `N kills, M mid-save, F file checks, 0 corrupt, 0 lost`. Longer runs:
//! `COWORK_CRASH_STORE_KILLS=500 cargo test -p cowork_reliability --test crash_store -- --nocapture`.

use std::hash::{Hash, Hasher};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use cowork_manager::Database;
use cowork_motion::Demonstration;
use cowork_motion::model::{FitOptions, Model, ModelKind};
use cowork_supervisor::Ltm;

const DIR_VAR: &str = "COWORK_CRASH_STORE_DIR";
const FIRST_VAR: &str = "COWORK_CRASH_STORE_FIRST";
const KINDS: [&str; 3] = ["ltm", "database", "model"];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn file(dir: &Path, kind: &str) -> PathBuf {
    match kind {
        "ltm" => dir.join("kitchen.learned.schema"),
        "database" => Database::path(dir, "lwr"),
        _ => dir.join("model.json"),
    }
}

fn hash(bytes: &[u8]) -> u64 {
    let mut h = std::hash::DefaultHasher::new();
    bytes.hash(&mut h);
    h.finish()
}

/// Loads `kind`'s file with the product's loader; its bytes.
fn load(dir: &Path, kind: &str) -> Result<Vec<u8>, String> {
    let p = file(dir, kind);
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", p.display());
    match kind {
        "ltm" => Ltm::load(&p).map(|_| ()).map_err(|e| err(&e))?,
        "database" => Database::load(&p).map(|_| ()).map_err(|e| err(&e))?,
        _ => Model::load(&p).map(|_| ()).map_err(|e| err(&e))?,
    }
    std::fs::read(&p).map_err(|e| err(&e))
}

/// Version `n` of each file, with the bytes its save writes.
struct Versions {
    ltm_base: String,
    db: Database,
    template: cowork_manager::Primitive,
}

impl Versions {
    fn new() -> Self {
        let ltm_base = std::fs::read_to_string(root().join("config/learned/kitchen.learned.schema")).expect("bundled LTM");
        let db = Database::load(&root().join("config/learned/primitives/lwr.primitives.json")).expect("bundled database");
        let template = db.primitives.values().find(|p| p.id.starts_with("foa")).cloned().expect("a foa primitive");
        Self { ltm_base, db, template }
    }

    fn ltm(&self, first: u64, n: u64) -> Ltm {
        let mut text = self.ltm_base.clone();
        for i in first..=n {
            text.push_str(&format!("schema(task{i}, [\n    (add(water), true)\n], water.added).\n"));
        }
        Ltm::parse(&text).expect("valid LTM version")
    }

    fn database(&mut self, n: u64) -> &Database {
        let mut p = self.template.clone();
        p.id = format!("foa{}", 10_000 + n);
        p.label = format!("foa{}(water)", 10_000 + n);
        self.db.insert(p);
        &self.db
    }

    fn model(n: u64) -> Model {
        let amp = 0.1 + 1e-4 * (n % 10_000) as f64;
        let t: Vec<f64> = (0..100).map(|i| i as f64 * 0.02).collect();
        let pos: Vec<f64> = t.iter().flat_map(|&s| [amp * (1.0 - (-2.0 * s).exp()), 0.05 * (s * 1.5).sin()]).collect();
        let demo = Demonstration::new(2, t, pos, None).expect("demonstration");
        Model::fit(ModelKind::Dmp, &[demo], &FitOptions::default()).expect("DMP fit")
    }
}

/// Child side: reload what is there (as a restarted node), remove orphans, then save new
/// versions until killed.
#[test]
fn saver_child() {
    let Ok(dir) = std::env::var(DIR_VAR) else { return };
    let dir = PathBuf::from(dir);
    let first: u64 = std::env::var(FIRST_VAR).expect("first version").parse().expect("number");
    for kind in KINDS {
        let p = file(&dir, kind);
        cowork_store::remove_orphan_temporaries(&p).expect("orphans");
        if p.exists() && let Err(e) = load(&dir, kind) {
            println!("RELOAD FAILED {e}");
            std::process::exit(2);
        }
    }
    let mut log = std::fs::OpenOptions::new().create(true).append(true).open(dir.join("progress")).expect("progress log");
    let mut v = Versions::new();
    writeln!(log, "ready").expect("log");
    for n in first.. {
        let ltm = v.ltm(first, n);
        let bytes = ltm.to_text().into_bytes();
        writeln!(log, "saving ltm {n} {}", hash(&bytes)).expect("log");
        ltm.save(&file(&dir, "ltm")).expect("save LTM");
        writeln!(log, "saved ltm {n} {}", hash(&bytes)).expect("log");

        let db = v.database(n);
        let bytes = db.to_bytes();
        writeln!(log, "saving database {n} {}", hash(&bytes)).expect("log");
        db.save(&file(&dir, "database")).expect("save database");
        writeln!(log, "saved database {n} {}", hash(&bytes)).expect("log");

        let model = Versions::model(n);
        let bytes = serde_json::to_string_pretty(&model).expect("json").into_bytes();
        writeln!(log, "saving model {n} {}", hash(&bytes)).expect("log");
        model.save(&file(&dir, "model")).expect("save model");
        writeln!(log, "saved model {n} {}", hash(&bytes)).expect("log");
    }
}

/// For `kind`: the hash of the last finished save and of a save in progress, from the log.
fn expected(log: &str, kind: &str) -> (Option<u64>, Option<u64>) {
    let (mut saved, mut saving) = (None, None);
    for line in log.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() == 4 && f[1] == kind {
            let h: u64 = f[3].parse().expect("hash");
            if f[0] == "saved" {
                saved = Some(h);
                saving = None;
            } else {
                saving = Some(h);
            }
        }
    }
    (saved, saving)
}

#[test]
fn kill_9_while_saving_the_ltm_database_and_models_leaves_old_or_new_never_corrupt() {
    let kills: u64 = std::env::var("COWORK_CRASH_STORE_KILLS").ok().and_then(|s| s.parse().ok()).unwrap_or(24);
    let dir = tempfile::tempdir().expect("tempdir");
    let exe = std::env::current_exe().expect("test binary");
    let (mut mid_save, mut checks, mut corrupt, mut lost, mut orphans_seen) = (0, 0, 0, 0, 0);
    let mut problems = Vec::new();
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let t0 = Instant::now();
    for round in 0..kills {
        let progress = dir.path().join("progress");
        let _ = std::fs::remove_file(&progress);
        let mut child = Command::new(&exe)
            .args(["--exact", "saver_child", "--nocapture", "--test-threads=1"])
            .env(DIR_VAR, dir.path())
            .env(FIRST_VAR, (round * 100_000).to_string())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("spawn the saver");
        let start = Instant::now();
        while !std::fs::read_to_string(&progress).is_ok_and(|s| s.contains("ready")) {
            if let Ok(Some(status)) = child.try_wait() {
                let mut out = String::new();
                std::io::Read::read_to_string(child.stdout.as_mut().expect("stdout"), &mut out).ok();
                panic!("round {round}: the restarted saver exited ({status}) before saving: {out}");
            }
            assert!(start.elapsed() < Duration::from_secs(60), "round {round}: saver never ready");
            std::thread::sleep(Duration::from_millis(2));
        }
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        std::thread::sleep(Duration::from_millis(3 + rng % 120));
        child.kill().expect("SIGKILL");
        child.wait().expect("reap");
        let log = std::fs::read_to_string(&progress).expect("progress");
        let mut in_save = false;
        for kind in KINDS {
            let (saved, saving) = expected(&log, kind);
            in_save |= saving.is_some();
            let p = file(dir.path(), kind);
            if !p.exists() {
                if saved.is_some() {
                    lost += 1;
                    problems.push(format!("round {round}: {kind}: file gone after a finished save"));
                }
                continue;
            }
            checks += 1;
            match load(dir.path(), kind) {
                Err(e) => {
                    corrupt += 1;
                    problems.push(format!("round {round}: {kind}: {e}"));
                }
                Ok(bytes) => {
                    let h = hash(&bytes);
                    if Some(h) != saved && Some(h) != saving && saved.is_some() {
                        lost += 1;
                        problems.push(format!("round {round}: {kind}: neither the last saved version nor the one being saved"));
                    }
                }
            }
        }
        mid_save += u64::from(in_save);
        orphans_seen += std::fs::read_dir(dir.path())
            .expect("dir")
            .filter(|e| e.as_ref().is_ok_and(|e| e.file_name().to_string_lossy().starts_with(cowork_store::TEMP_PREFIX)))
            .count();
    }
    // The last restart's cleanup: no temporary of a killed writer stays.
    for kind in KINDS {
        cowork_store::remove_orphan_temporaries(&file(dir.path(), kind)).expect("orphans");
    }
    let left = std::fs::read_dir(dir.path())
        .expect("dir")
        .filter(|e| e.as_ref().is_ok_and(|e| e.file_name().to_string_lossy().starts_with(cowork_store::TEMP_PREFIX)))
        .count();
    eprintln!(
        "crash_store: {kills} kills ({mid_save} inside a save), {checks} file checks (LTM, primitive database, DMP model), \
         {corrupt} corrupt, {lost} lost saves; {orphans_seen} temporaries of killed writers seen, {left} left after restart cleanup; {:.1} s",
        t0.elapsed().as_secs_f64()
    );
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    assert_eq!(left, 0, "orphan temporaries left");
    assert!(checks >= kills, "the saver wrote its files in most rounds ({checks} checks)");
    assert!(mid_save > 0, "no kill landed inside a save: the test did not test anything");
}
