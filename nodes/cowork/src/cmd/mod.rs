//! One module per top-level subcommand.

pub mod bag;
pub mod bag_synth;
pub mod bench_control;
pub mod bench_lasa;
pub mod bridge;
pub mod bridge_stats;
pub mod domain;
pub mod experiment;
pub mod kitchen;
pub mod pizza;
pub mod fded;
pub mod keystore;
pub mod learn;
pub mod observe;
pub mod output;
pub mod report;
pub mod primitives;
pub mod refine;
pub mod refine_elbow;
pub mod robot;
pub mod say;
pub mod scenario;
pub mod supervisor;
pub mod teach;
pub mod topic;

/// The directory whose `config/` the experiments read (scenes, URDF, parameters): the working
/// directory when it has one, else the parent of the config directory found by
/// [`cowork_ros::config::config_dir`] (the repository of this binary, or `COWORK_CONFIG_DIR`).
pub fn config_root() -> anyhow::Result<std::path::PathBuf> {
    let marker = "config/robot/lwr4plus.urdf";
    if std::path::Path::new(marker).is_file() {
        return Ok(".".into());
    }
    let dir = cowork_ros::config::config_dir()?;
    match dir.parent() {
        Some(root) if dir.file_name().is_some_and(|n| n == "config") && root.join(marker).is_file() => Ok(root.to_path_buf()),
        _ => anyhow::bail!("the config directory {} must be named `config` for the experiments (they read config/scenes/…)", dir.display()),
    }
}

/// `--bin-dir` (the node binaries): as given when it exists; otherwise, for a relative path
/// (the default `target/release` from outside the repository), the directory of this `cowork`
/// binary, where cargo builds the nodes beside it.
pub fn bin_dir_arg(value: &str) -> Result<std::path::PathBuf, std::convert::Infallible> {
    let given = std::path::PathBuf::from(value);
    if given.is_dir() || given.is_absolute() {
        return Ok(given);
    }
    let beside = std::env::current_exe().ok().and_then(|e| e.canonicalize().ok()).and_then(|e| e.parent().map(std::path::Path::to_path_buf));
    Ok(beside.filter(|d| d.join("lwr_sim").is_file()).unwrap_or(given))
}
