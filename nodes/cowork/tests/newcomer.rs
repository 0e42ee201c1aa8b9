//! What a newcomer meets first, as they would type it (issue "the newcomer's path"): a failed
//! command never destroys or half-writes a file, `topic pub` refuses a misspelt field and takes
//! the ros2cli YAML form, `config/...` paths work from any directory, and the small things
//! (`say "left: teach"`, a closed pipe, an empty domain, a bag with no demonstration).

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

type TestResult = anyhow::Result<()>;

fn cowork() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_cowork"));
    // Plain errors (no backtrace) whatever the developer's shell says.
    c.env_remove("RUST_BACKTRACE").env_remove("COWORK_CONFIG_DIR").env("RUST_LOG", "warn");
    c
}

fn run_in(dir: &Path, args: &[&str]) -> anyhow::Result<Output> {
    Ok(cowork().current_dir(dir).args(args).output()?)
}

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

fn repo_config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config")
}

/// Item 1: `bag synth` with a length the scenario cannot have, onto an existing bag, and
/// `fded run` on a bag that does not exist: both fail, the existing file is untouched and no
/// new one appears.
#[test]
fn a_failed_command_leaves_existing_outputs_untouched_and_creates_none() -> TestResult {
    let dir = tempfile::tempdir()?;
    let bag = dir.path().join("X.mcap");
    std::fs::write(&bag, b"a bag the user cares about")?;
    let o = run_in(dir.path(), &["bag", "synth", "static-scene", "-o", "X.mcap", "--duration", "1"])?;
    assert!(!o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("needs at least"), "{}", text(&o));
    assert_eq!(std::fs::read(&bag)?, b"a bag the user cares about", "the failed synth touched the existing bag");

    let o = run_in(dir.path(), &["fded", "run", "/nonexistent.mcap", "-o", "f.csv"])?;
    assert!(!o.status.success(), "{}", text(&o));
    assert!(!dir.path().join("f.csv").exists(), "a failed fded run left a CSV");
    let names: Vec<_> = std::fs::read_dir(dir.path())?.map(|e| e.map(|e| e.file_name())).collect::<Result<_, _>>()?;
    assert_eq!(names, vec![std::ffi::OsString::from("X.mcap")], "no temporary left behind");
    Ok(())
}

/// Item 2: a misspelt field is refused naming it and the type, before anything is published;
/// the ros2cli YAML form is published and printed.
#[test]
fn topic_pub_refuses_unknown_fields_and_takes_the_ros2_yaml_form() -> TestResult {
    let dir = tempfile::tempdir()?;
    let o = run_in(
        dir.path(),
        &["topic", "pub", "/motion/command", "cowork_msgs/msg/MotionCommand", r#"{"goal":{"positon":{"x":0.5}},"nominal_sped":0.3}"#],
    )?;
    assert!(!o.status.success(), "a misspelt field was published: {}", text(&o));
    assert!(text(&o).contains("`goal.positon`") && text(&o).contains("MotionCommand"), "{}", text(&o));

    let domain = cowork_ros::domain::test_domain("cowork newcomer test: topic pub");
    let o = cowork()
        .current_dir(dir.path())
        .env("ROS_DOMAIN_ID", domain.to_string())
        .args(["topic", "pub", "/lwr/gripper_command", "std_msgs/msg/String", "{data: close}", "--wait", "0"])
        .output()?;
    assert!(o.status.success(), "{}", text(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("publishing #1 on /lwr/gripper_command") && out.contains(r#"{"data":"close"}"#), "{out}");
    Ok(())
}

/// Item 3: from a directory that is not the repository, with and without `COWORK_CONFIG_DIR`,
/// the commands that read `config/...` find it.
#[test]
fn config_paths_are_found_from_any_directory() -> TestResult {
    let dir = tempfile::tempdir()?;
    let o = run_in(dir.path(), &["supervisor", "show", "--ltm", "config/tasks/kitchen.schema", "--task", "prepareCoffee"])?;
    assert!(o.status.success() && text(&o).contains("add(water)"), "{}", text(&o));
    let o = run_in(dir.path(), &["primitives", "list", "--dir", "config/learned/primitives"])?;
    assert!(o.status.success(), "{}", text(&o));
    let o = run_in(dir.path(), &["robot", "fk", "--joints", "0,0,0,0,0,0,0"])?;
    assert!(o.status.success(), "{}", text(&o));
    let o = cowork()
        .current_dir(dir.path())
        .env("COWORK_CONFIG_DIR", repo_config())
        .args(["bag", "synth", "gestures", "-o", "g.mcap", "--no-depth"])
        .output()?;
    assert!(o.status.success(), "{}", text(&o));
    assert!(dir.path().join("g.mcap").is_file());
    Ok(())
}

/// Item 7: the documented two-arm words; a reader that goes away (`| head -1`); an empty
/// domain said so; a bag with no demonstration is an error, not an empty table.
#[test]
fn paper_cuts() -> TestResult {
    let dir = tempfile::tempdir()?;
    let domain = cowork_ros::domain::test_domain("cowork newcomer test: paper cuts");
    let on_domain = |args: &[&str]| -> anyhow::Result<Output> {
        Ok(cowork().current_dir(dir.path()).env("ROS_DOMAIN_ID", domain.to_string()).args(args).output()?)
    };
    let o = on_domain(&["say", "left: teach", "--wait", "0"])?;
    assert!(o.status.success(), "{}", text(&o));

    // The reader closes the pipe before the command writes: it ends quietly (SIGPIPE), no panic.
    let mut child = cowork()
        .current_dir(dir.path())
        .args(["robot", "fk", "--joints", "0,0,0,0,0,0,0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()?;
    drop(child.stdout.take());
    let o = child.wait_with_output()?;
    assert_ne!(o.status.code(), Some(101), "panicked on a closed pipe: {}", text(&o));
    assert!(!text(&o).contains("panicked"), "{}", text(&o));

    let o = on_domain(&["topic", "list", "--wait", "0.5"])?;
    assert!(o.status.success() && text(&o).contains("no topics seen on DDS domain"), "{}", text(&o));
    let o = on_domain(&["node", "list", "--wait", "0.5"])?;
    assert!(o.status.success() && text(&o).contains("no nodes seen on DDS domain"), "{}", text(&o));

    let o = run_in(dir.path(), &["bag", "synth", "static-scene", "-o", "still.mcap", "--no-depth", "--duration", "6"])?;
    assert!(o.status.success(), "{}", text(&o));
    let o = run_in(dir.path(), &["primitives", "learn", "--bag", "still.mcap"])?;
    assert!(!o.status.success() && text(&o).contains("no demonstration in this bag"), "{}", text(&o));
    Ok(())
}
