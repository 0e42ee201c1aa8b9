//! Crash-safe writes of learned data (LTM schemas, motion models, the primitive database).
//!
//! [`write_atomic`] writes a temporary file in the target's directory, syncs it to disk, renames
//! it over the target and syncs the directory, so that a crash or `kill -9` at any instant
//! leaves either the old file or the new one, complete, and a completed write survives a power
//! loss.
//!
//! ```
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("model.json");
//! cowork_store::write_atomic(&path, b"{\"kind\": \"dmp\"}")?;
//! assert_eq!(std::fs::read(&path)?, b"{\"kind\": \"dmp\"}");
//! # Ok::<(), std::io::Error>(())
//! ```

use std::io::Write;
use std::path::Path;

/// Replaces `path` with `bytes` atomically and durably (temporary file in the same directory,
/// `fsync`, rename, `fsync` of the directory). The error names the step and the file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let at = |step: &str, file: &Path| {
        let file = file.display().to_string();
        let step = step.to_owned();
        move |e: std::io::Error| std::io::Error::new(e.kind(), format!("{step} {file}: {e}"))
    };
    // The writer's pid in the name tells a later start which temporaries are orphans.
    let prefix = format!("{TEMP_PREFIX}{}-", std::process::id());
    let mut tmp = tempfile::Builder::new()
        .prefix(&prefix)
        .tempfile_in(dir)
        .map_err(at("creating a temporary file in", dir))?;
    tmp.write_all(bytes).map_err(at("writing a temporary file for", path))?;
    tmp.as_file().sync_all().map_err(at("syncing a temporary file for", path))?;
    tmp.persist(path).map_err(|e| at("renaming a temporary file onto", path)(e.error))?;
    sync_dir(dir).map_err(at("syncing the directory", dir))
}

/// Names of [`write_atomic`]'s temporary files start with this, then the writer's pid and `-`.
pub const TEMP_PREFIX: &str = ".tmp-";

/// Removes the temporary files that killed writers left beside `target` (a `kill -9` between
/// creating and renaming one): `.tmp-<pid>-*` files in `target`'s directory whose process is
/// gone (Linux: no `/proc/<pid>`; elsewhere, or without a pid: older than an hour). A live
/// writer's temporary is never touched. Returns the removed paths, for the caller's log.
pub fn remove_orphan_temporaries(target: &Path) -> std::io::Result<Vec<std::path::PathBuf>> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(std::io::Error::new(e.kind(), format!("listing {}: {e}", dir.display()))),
    };
    let mut removed = Vec::new();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(rest) = name.to_str().and_then(|n| n.strip_prefix(TEMP_PREFIX)) else { continue };
        if !entry.file_type().is_ok_and(|t| t.is_file()) {
            continue;
        }
        let pid: Option<u32> = rest.split('-').next().and_then(|p| p.parse().ok());
        let orphan = match pid {
            Some(pid) if cfg!(target_os = "linux") => {
                pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists()
            }
            _ => entry
                .metadata()
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .is_some_and(|age| age.as_secs() > 3600),
        };
        if orphan && std::fs::remove_file(entry.path()).is_ok() {
            removed.push(entry.path());
        }
    }
    Ok(removed)
}

#[cfg(unix)]
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    std::fs::File::open(dir)?.sync_all()
}

#[cfg(not(unix))]
fn sync_dir(_dir: &Path) -> std::io::Result<()> {
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_the_file_and_leaves_no_temporary_behind() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("ltm.schema");
        write_atomic(&path, b"old").expect("first write");
        write_atomic(&path, b"new").expect("second write");
        assert_eq!(std::fs::read(&path).expect("read"), b"new");
        let names: Vec<_> = std::fs::read_dir(dir.path()).expect("dir").map(|e| e.expect("entry").file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("ltm.schema")], "only the target remains");
    }

    #[test]
    fn orphan_temporaries_of_dead_writers_are_removed_and_live_ones_kept() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("lwr.primitives.json");
        write_atomic(&target, b"kept").expect("write");
        // A pid above the kernel's pid_max (2^22) is never alive; ours is.
        let dead = dir.path().join(".tmp-4194305-abc");
        let live = dir.path().join(format!(".tmp-{}-def", std::process::id()));
        let other = dir.path().join("notes.tmp");
        for p in [&dead, &live, &other] {
            std::fs::write(p, b"partial").expect("write");
        }
        let removed = remove_orphan_temporaries(&target).expect("clean");
        if cfg!(target_os = "linux") {
            assert_eq!(removed, vec![dead.clone()]);
            assert!(!dead.exists());
        }
        assert!(live.exists() && other.exists() && target.exists());
        assert_eq!(std::fs::read(&target).expect("read"), b"kept");
        let none = remove_orphan_temporaries(&dir.path().join("missing/x.json")).expect("missing dir is empty");
        assert!(none.is_empty());
    }

    #[test]
    fn a_missing_directory_is_an_error_naming_it() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("no/such/dir/model.json");
        let e = write_atomic(&path, b"x").expect_err("missing directory");
        assert!(e.to_string().contains("no/such/dir"), "{e}");
    }
}
