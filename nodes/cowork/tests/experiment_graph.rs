//! `cowork experiment` in the real graph: node processes over DDS on a private domain, sim
//! clock. One short stacking-hri trial (a few simulated seconds), one round of refine-goal
//! (Sec. 4.1.3), and a node that dies at
//! start-up. Each checks that nothing is left running afterwards.
//!
//! Needs the node binaries beside `cowork` (a workspace `cargo test` or `cargo build --bins`
//! builds them).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn bin_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_BIN_EXE_cowork"))
        .parent()
        .unwrap()
        .to_path_buf();
    for b in [
        "lwr_sim",
        "fded_distance",
        "ds_controller",
        "human_observer",
    ] {
        assert!(
            dir.join(b).is_file(),
            "{} missing: build the node binaries first (cargo build --bins -p lwr_sim -p fded_distance -p ds_controller -p human_observer)",
            dir.join(b).display()
        );
    }
    dir
}

/// Runs `cowork experiment ...` with a wall-clock limit; returns (success, stdout + stderr).
fn cowork(args: &[&str], limit: Duration) -> (bool, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_cowork"))
        .args(args)
        .current_dir(root())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if let Some(_status) = child.try_wait().unwrap() {
            let out = child.wait_with_output().unwrap();
            let text = String::from_utf8_lossy(&out.stdout).to_string()
                + &String::from_utf8_lossy(&out.stderr);
            return (out.status.success(), text);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "cowork {args:?} still running after {limit:?}:\n{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// Every pid the runner listed is gone (and it listed at least `at_least`).
fn nothing_left(logs: &Path, at_least: usize) {
    let mut n = 0;
    for entry in std::fs::read_dir(logs).unwrap() {
        let pids = entry.unwrap().path().join("pids.txt");
        let Ok(text) = std::fs::read_to_string(&pids) else {
            continue;
        };
        for line in text.lines() {
            let (name, pid) = line.split_once(' ').unwrap();
            n += 1;
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            // Gone, or a zombie nobody waits for would show as 'Z'; both mean not running.
            let running = stat.split(' ').nth(2).is_some_and(|s| s != "Z");
            assert!(
                !running,
                "{name} (pid {pid}) is still running after the experiment"
            );
        }
    }
    assert!(n >= at_least, "pids.txt lists the graph's processes ({n})");
}

#[test]
fn one_short_stacking_trial_runs_in_the_graph_and_stops_it() {
    let bins = bin_dir();
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("run.json");
    let logs = dir.path().join("logs");
    let (ok, out) = cowork(
        &[
            "experiment",
            "stacking-hri",
            "--seed",
            "1",
            "--time-limit",
            "4",
            "--rate",
            "0.25",
            "--json",
            json.to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap(),
            "--bin-dir",
            bins.to_str().unwrap(),
        ],
        Duration::from_secs(110),
    );
    assert!(ok, "{out}");
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let t = &run["trials"][0];
    assert_eq!(run["experiment"], "stacking-hri");
    assert_eq!(t["seed"], 1);
    // The person of seed 1 starts walking in at 2.8 s.
    assert!(t["variant"]["enter_s"].as_f64().unwrap() < 3.0, "{t}");
    // 4 simulated seconds cannot stack two blocks: failed, with the reason.
    assert_eq!(t["success"], false, "{t}");
    assert!(t["reason"].as_str().unwrap().contains("time limit"), "{t}");
    assert!(t["duration_s"].as_f64().unwrap() >= 4.0, "{t}");
    // The chain ran: fDED distances from the rendered depth reached the runner, ds_controller
    // took the first motion over DDS and reports on it, the person was judged against the
    // robot geometry. (Whether the arm moves in 4 s depends on how fast this machine renders
    // and runs fDED — stale distances hold it — so it is not asserted here.)
    assert!(
        t["processing_ms"]["n"].as_u64().unwrap() >= 5,
        "fDED frames: {t}"
    );
    assert_eq!(t["backend"], "cpu");
    // How far the task got in 4 s depends on the machine (held on stale distances or not):
    // some command was taken and reported on, and the task did not finish.
    let status = t["last_status"].as_str().unwrap();
    assert!(status.starts_with("command "), "{t}");
    let (done, total) = (t["steps_done"].as_u64().unwrap(), t["steps_total"].as_u64().unwrap());
    assert!(done < total, "{t}");
    assert!(t["min_distance_m"].as_f64().unwrap() > 0.0, "{t}");
    assert_eq!(t["collisions"], 0);
    nothing_left(&logs, 4);
}

#[test]
fn a_node_that_dies_fails_the_trial_and_stops_the_graph() {
    let bins = bin_dir();
    let dir = tempfile::tempdir().unwrap();
    let fake = dir.path().join("bin");
    std::fs::create_dir(&fake).unwrap();
    for b in ["lwr_sim", "ds_controller", "human_observer"] {
        std::os::unix::fs::symlink(bins.join(b), fake.join(b)).unwrap();
    }
    // fded_distance dies one second after it started.
    let script = fake.join("fded_distance");
    std::fs::write(
        &script,
        "#!/bin/sh\nsleep 1\necho 'fded_distance: simulated crash' >&2\nexit 3\n",
    )
    .unwrap();
    let mut perm = std::fs::metadata(&script).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o755);
    std::fs::set_permissions(&script, perm).unwrap();
    let json = dir.path().join("run.json");
    let logs = dir.path().join("logs");
    let (ok, out) = cowork(
        &[
            "experiment",
            "stacking-hri",
            "--json",
            json.to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap(),
            "--bin-dir",
            fake.to_str().unwrap(),
        ],
        Duration::from_secs(60),
    );
    assert!(ok, "{out}");
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let t = &run["trials"][0];
    assert_eq!(t["success"], false);
    let reason = t["reason"].as_str().unwrap();
    assert!(
        reason.contains("fded_distance exited") && reason.contains("simulated crash"),
        "{reason}"
    );
    nothing_left(&logs, 4);
}

#[test]
fn unknown_experiment_and_bad_scene_fail_before_anything_starts() {
    let (ok, out) = cowork(&["experiment", "stacking"], Duration::from_secs(30));
    assert!(
        !ok && out.contains("unknown experiment") && out.contains("stacking-hri"),
        "{out}"
    );
    let (ok, out) = cowork(
        &[
            "experiment",
            "stacking-hri",
            "--scene",
            "config/scenes/kitchen.yaml",
        ],
        Duration::from_secs(30),
    );
    assert!(!ok && out.contains("block1"), "{out}");
}

#[test]
fn one_short_gestures_trial_starts_on_a_recognised_come() {
    let bins = bin_dir();
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("run.json");
    let logs = dir.path().join("logs");
    // Seed 1: the person walks in from 0.6 s and beckons (`come`) at about 8-11 s; the
    // observer must recognise it from the skeleton and the runner then starts the task.
    let (ok, out) = cowork(
        &[
            "experiment",
            "gestures-hri",
            "--seed",
            "1",
            "--time-limit",
            "12",
            "--rate",
            "0.5",
            "--json",
            json.to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap(),
            "--bin-dir",
            bins.to_str().unwrap(),
        ],
        Duration::from_secs(150),
    );
    assert!(ok, "{out}");
    let run: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let t = &run["trials"][0];
    assert_eq!(run["experiment"], "gestures-hri");
    assert_eq!(t["success"], false, "12 s cannot finish the task: {t}");
    assert!(t["reason"].as_str().unwrap().contains("time limit"), "{t}");
    // The come was recognised from the skeleton (not injected) ...
    let gestures: Vec<&str> = t["gestures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g.as_str().unwrap())
        .collect();
    assert!(gestures.contains(&"come"), "{t}");
    // ... matched to the performed one, and it started the task: the wait step finished and
    // ds_controller took a motion command.
    let reactions = t["gesture_reactions"].as_array().unwrap();
    assert!(
        reactions
            .iter()
            .any(|r| r["label"] == "come" && r["performed_end_s"].is_number()
                && r["recognised_s"].is_number()),
        "{t}"
    );
    assert!(t["steps_done"].as_u64().unwrap() >= 1, "{t}");
    let status = t["last_status"].as_str().unwrap();
    assert!(
        status.starts_with("command ") && !status.starts_with("command 0 "),
        "{t}"
    );
    assert_eq!(t["collisions"], 0);
    nothing_left(&logs, 4);
}

/// One round of refine-goal (thesis Sec. 4.1.3) in the graph: the learned pick-and-place alone,
/// once with the person pushing towards g′ from 3 s on, once alone after the refinement. Judged
/// from what lwr_sim reported (the tool on /lwr/world, the push on /lwr/external_wrench) and
/// from the primitive database the runner saved.
#[test]
fn one_refinement_round_moves_the_pick_and_place_towards_the_new_goal() {
    let bins = bin_dir();
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("run.json");
    let logs = dir.path().join("logs");
    let (ok, out) = cowork(
        &[
            "experiment",
            "refine-goal",
            "--seed",
            "2",
            "--refinements",
            "1",
            "--json",
            json.to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap(),
            "--bin-dir",
            bins.to_str().unwrap(),
        ],
        Duration::from_secs(240),
    );
    assert!(ok, "{out}");
    let run: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let t = &run["trials"][0];
    let ex = t["executions"].as_array().unwrap_or_else(|| panic!("{t}"));
    assert_eq!(ex.len(), 3, "{out}");
    let f = |e: &serde_json::Value, k: &str| e[k].as_f64().unwrap_or_else(|| panic!("{k}: {e}"));
    // Alone, the learned primitive ends far from g′ (g and g′ are 167 mm apart).
    assert!(f(&ex[0], "error_at_new_goal_mm") > 120.0, "{}", ex[0]);
    // The person's push reached lwr_sim from 3 s on and took the tool to g′.
    assert_eq!(ex[1]["pushed"], true);
    let contact = f(&ex[1], "first_contact_s");
    assert!((2.9..3.3).contains(&contact), "{}", ex[1]);
    assert!(f(&ex[1], "max_push_n") >= 15.0, "{}", ex[1]);
    assert!(f(&ex[1], "error_at_new_goal_mm") < 5.0, "{}", ex[1]);
    // Alone after one refinement the robot ends at most half as far from g′ (η = 0.7: 30 % of
    // the distance is left). How much the motion before the contact moved is reported, not
    // judged here: 5–12 mm on a quiet machine, but 49 mm once with the other graph tests
    // beside it (execution 0 itself, the reference, ran differently under that load).
    assert_eq!(ex[2]["pushed"], false);
    assert_eq!(ex[2]["version"], 2);
    assert!(f(&ex[2], "error_at_new_goal_mm") < 0.5 * f(&ex[0], "error_at_new_goal_mm"), "{out}");
    assert!(f(&ex[2], "max_path_offset_before_contact_mm").is_finite(), "{out}");
    // The database the runner saved holds the refined model with its history.
    let db = cowork_manager::Database::load(Path::new(t["database"].as_str().unwrap())).unwrap();
    let e = db.hmm("pick_place").unwrap();
    assert_eq!((e.version, e.history.len()), (2, 1));
    assert!((e.history[0].t_contact_s - contact).abs() < 1e-9);
    assert!(!e.history[0].kept_states.is_empty(), "{:?}", e.history[0]);
    // `cowork primitives` shows it with its history.
    let db_dir = Path::new(t["database"].as_str().unwrap()).parent().unwrap().to_str().unwrap().to_owned();
    let (ok, listing) = cowork(&["primitives", "list", "--dir", &db_dir, "--robot", "lwr"], Duration::from_secs(30));
    assert!(ok && listing.contains("pick_place") && listing.contains("HMM v2"), "{listing}");
    let (ok, shown) = cowork(&["primitives", "show", "--dir", &db_dir, "--robot", "lwr", "pick_place"], Duration::from_secs(30));
    assert!(ok && shown.contains("version 2") && shown.contains("v2: seed 2 execution 1"), "{shown}");
    nothing_left(&logs, 2);
}

/// refine-elbow (Sec. 4.1.3, Fig. 4.5), one round at half speed: the elbow primitive runs in
/// the null space, the person's push on the upper arm reaches lwr_sim and ds_controller keeps
/// it below the tool ([T_ee, T_ic]), and the elbow alone afterwards keeps farther from the
/// obstacle than before while the tool stays on its path.
#[test]
fn one_elbow_refinement_round_moves_the_elbow_away_from_the_obstacle() {
    let bins = bin_dir();
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("run.json");
    let logs = dir.path().join("logs");
    let (ok, out) = cowork(
        &[
            "experiment",
            "refine-elbow",
            "--seed",
            "1",
            "--refinements",
            "1",
            "--rate",
            "0.5",
            "--json",
            json.to_str().unwrap(),
            "--logs",
            logs.to_str().unwrap(),
            "--bin-dir",
            bins.to_str().unwrap(),
        ],
        Duration::from_secs(400),
    );
    assert!(ok, "{out}");
    let run: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let t = &run["trials"][0];
    let ex = t["executions"].as_array().unwrap_or_else(|| panic!("{t}"));
    assert_eq!(ex.len(), 3, "{out}");
    let f = |e: &serde_json::Value, k: &str| e[k].as_f64().unwrap_or_else(|| panic!("{k}: {e}"));
    // Execution 0 goes through the obstacle (placed on its elbow path).
    assert!(f(&ex[0], "min_clearance_mm") < 0.0, "{}", ex[0]);
    // The push reached lwr_sim from 2.5 s on, below f_s, and ds_controller ran [T_ee, T_ic].
    assert_eq!(ex[1]["pushed"], true);
    let contact = f(&ex[1], "first_contact_s");
    // The person starts at 2.5 s, once the force it wants reaches f_i (2.50–3.07 s measured).
    assert!((2.4..3.6).contains(&contact), "{}", ex[1]);
    assert!(f(&ex[1], "max_push_n") < 15.0, "{}", ex[1]);
    let guided = ex[1]["guided"].to_string();
    assert!(guided.contains("lwr_link_3") && guided.contains("[T_ee, T_ic]") && !guided.contains("[T_ic, T_ee]"), "{guided}");
    // Measured (release binaries, seeds 1-3): -13.4 to -13.9 mm, then 51-53 mm pushed and
    // 54-57 mm alone; the tool within 0.3-2.6 mm of its path.
    assert_eq!(ex[2]["pushed"], false);
    assert_eq!(ex[2]["version"], 2);
    assert!(f(&ex[2], "min_clearance_mm") > f(&ex[0], "min_clearance_mm") + 20.0, "{out}");
    assert!(f(&ex[2], "tool_path_offset_mm") < 5.0, "{out}");
    let db = cowork_manager::Database::load(Path::new(t["database"].as_str().unwrap())).unwrap();
    let e = db.hmm("pick_place_elbow").unwrap();
    assert_eq!((e.version, e.history.len()), (2, 1));
    assert_eq!(db.hmm("pick_place").unwrap().version, 1, "the end-effector primitive is not refined");
    nothing_left(&logs, 2);
}
