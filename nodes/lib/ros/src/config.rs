//! Where the bundled `config/` directory is, so every binary finds its parameter files, the
//! robot description and the task schemas from any working directory, as a ROS 2 package finds
//! its `share/` directory.
//!
//! The lookup, first match wins:
//! 1. `COWORK_CONFIG_DIR` (an error if it is set but is not a directory: a typo must not
//!    silently pick another tree);
//! 2. `config/` in the working directory (running from the repository root, as before);
//! 3. next to the executable's workspace: `<exe>/../../config` (`target/release/NAME` or
//!    `target/debug/NAME` of this repository; also `target/<triple>/release` two levels up) and
//!    `<exe>/../share/cowork/config` (an install prefix: `PREFIX/bin/NAME`).
//!
//! [`resolve`] applies it to a path given on the command line: a path that exists as given,
//! an absolute path, or one that does not start with `config/` is returned unchanged; otherwise
//! `config/REST` becomes `<config dir>/REST`.
//!
//! **The rule, for every command and node**: a path that starts with `config/` (or is `config`)
//! and does not exist from the working directory names the file in the config directory. Every
//! binary applies it to its whole command line ([`resolve_args`], before parsing) and to its
//! defaults ([`path_arg`], a clap value parser), so `cowork primitives list`, `cowork bag synth
//! gestures`, `cowork supervisor run --ltm config/tasks/kitchen.schema` and the nodes work from
//! any directory.
//!
//! ```no_run
//! let urdf = cowork_ros::config::resolve("config/robot/lwr4plus.urdf");
//! println!("{}", urdf.display());
//! ```

use std::path::{Path, PathBuf};

/// The environment variable that names the config directory.
pub const ENV: &str = "COWORK_CONFIG_DIR";

/// A file every bundled config directory holds (how a candidate is recognised).
const MARKER: &str = "robot/lwr4plus.urdf";

/// Why no config directory was found.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigDirError {
    /// `COWORK_CONFIG_DIR` is set but is not a directory.
    #[error("{ENV}={path}: not a directory")]
    EnvNotADirectory {
        /// The value of the variable.
        path: PathBuf,
    },
    /// No candidate holds the bundled files.
    #[error(
        "no cowork config directory found (looked in: {}); set {ENV} to the repository's config/ \
         directory or run from the repository root",
        .tried.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    )]
    NotFound {
        /// Every directory looked at, in order.
        tried: Vec<PathBuf>,
    },
}

/// The directories looked at, in order, for an executable at `exe` and working directory
/// `cwd` (without the environment variable).
fn candidates(cwd: &Path, exe: Option<&Path>) -> Vec<PathBuf> {
    let mut out = vec![cwd.join("config")];
    if let Some(dir) = exe.and_then(Path::parent) {
        // target/release/NAME → repository root; target/release/deps/NAME (tests) and
        // target/<triple>/release/NAME one level more.
        for up in [2usize, 3] {
            if let Some(root) = dir.ancestors().nth(up) {
                out.push(root.join("config"));
            }
        }
        if let Some(prefix) = dir.parent() {
            out.push(prefix.join("share/cowork/config"));
        }
    }
    out
}

/// The config directory (see the module docs).
pub fn config_dir() -> Result<PathBuf, ConfigDirError> {
    if let Some(v) = std::env::var_os(ENV).filter(|v| !v.is_empty()) {
        let path = PathBuf::from(v);
        return if path.is_dir() { Ok(path) } else { Err(ConfigDirError::EnvNotADirectory { path }) };
    }
    let cwd = std::env::current_dir().unwrap_or_default();
    let exe = std::env::current_exe().ok().map(|e| e.canonicalize().unwrap_or(e));
    let tried = candidates(&cwd, exe.as_deref());
    match tried.iter().find(|d| d.join(MARKER).is_file()) {
        Some(d) => Ok(d.clone()),
        None => Err(ConfigDirError::NotFound { tried }),
    }
}

/// `path` with a leading `config/` mapped to the config directory when `path` does not exist
/// as given (see the module docs). Without a config directory the path is returned unchanged,
/// so the error the caller reports names the path the user gave.
pub fn resolve(path: impl AsRef<Path>) -> PathBuf {
    let path = path.as_ref();
    if path.is_absolute() || path.exists() {
        return path.to_path_buf();
    }
    let Ok(rest) = path.strip_prefix("config") else { return path.to_path_buf() };
    match config_dir() {
        Ok(dir) => dir.join(rest),
        Err(e) => {
            tracing::warn!("{}: not found from {}; {e}", path.display(), std::env::current_dir().unwrap_or_default().display());
            path.to_path_buf()
        }
    }
}

/// [`resolve`] as a clap value parser, for path arguments with a `config/...` default:
/// `#[arg(long, default_value = "config/x.yaml", value_parser = cowork_ros::config::path_arg)]`.
pub fn path_arg(value: &str) -> Result<PathBuf, std::convert::Infallible> {
    Ok(resolve(value))
}

/// `args` (a binary's command line, program name first) with every argument that is a path
/// under `config/` resolved ([`resolve`]), also in the `--flag=config/...` form. Arguments after
/// a `--` (another program's command line) are left as they are.
pub fn resolve_args(args: impl IntoIterator<Item = std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let mut rest_is_foreign = false;
    args.into_iter()
        .enumerate()
        .map(|(i, arg)| {
            if i == 0 || rest_is_foreign {
                return arg;
            }
            let Some(text) = arg.to_str() else { return arg };
            if text == "--" {
                rest_is_foreign = true;
                return arg;
            }
            let (flag, value) = match text.split_once('=') {
                Some((f, v)) if f.starts_with("--") => (Some(f), v),
                _ => (None, text),
            };
            if value != "config" && !value.starts_with("config/") {
                return arg;
            }
            let path = resolve(value);
            match flag {
                Some(f) => format!("{f}={}", path.display()).into(),
                None => path.into_os_string(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_cover_the_workspace_target_dir_and_an_install_prefix() {
        let c = candidates(Path::new("/home/u"), Some(Path::new("/repo/target/release/lwr_sim")));
        assert_eq!(c[0], Path::new("/home/u/config"));
        assert!(c.contains(&PathBuf::from("/repo/config")), "{c:?}");
        let c = candidates(Path::new("/x"), Some(Path::new("/opt/cowork/bin/cowork")));
        assert!(c.contains(&PathBuf::from("/opt/cowork/share/cowork/config")), "{c:?}");
    }

    #[test]
    fn paths_outside_config_and_absolute_paths_are_unchanged() {
        assert_eq!(resolve("/abs/config/x.yaml"), Path::new("/abs/config/x.yaml"));
        assert_eq!(resolve("out/missing.yaml"), Path::new("out/missing.yaml"));
    }

    #[test]
    fn command_lines_resolve_config_paths_and_leave_the_rest() {
        let os = |v: &[&str]| v.iter().map(std::ffi::OsString::from).collect::<Vec<_>>();
        let out = resolve_args(os(&["cowork", "supervisor", "run", "--ltm", "config/tasks/kitchen.schema", "--x=config/lwr_sim.yaml", "out/a", "--", "config/no"]));
        let out: Vec<String> = out.into_iter().map(|a| a.to_string_lossy().into_owned()).collect();
        assert_eq!(&out[..3], ["cowork", "supervisor", "run"]);
        assert!(Path::new(&out[4]).is_file(), "{}", out[4]);
        let x = out[5].strip_prefix("--x=").expect("flag kept");
        assert!(Path::new(x).is_file(), "{x}");
        assert_eq!(&out[6..], ["out/a", "--", "config/no"]);
    }

    #[test]
    fn config_paths_resolve_to_the_bundled_directory_from_anywhere() {
        // The test binary lives in target/<profile>/deps: its workspace's config/ is found
        // whatever the working directory (cargo runs tests in the crate directory).
        let urdf = resolve("config/robot/lwr4plus.urdf");
        assert!(urdf.is_file(), "{}", urdf.display());
    }
}
