//! Crash-safe writes of everything cowork writes: learned data (LTM schemas, motion models, the
//! primitive database) and every command's output (bags, CSV, JSON, reports).
//!
//! [`write_atomic`] writes a temporary file in the target's directory, syncs it to disk, renames
//! it over the target and syncs the directory, so that a crash or `kill -9` at any instant
//! leaves either the old file or the new one, complete, and a completed write survives a power
//! loss. [`AtomicFile`] does the same for output written piece by piece (a bag, a CSV): the
//! target appears whole when [`AtomicFile::commit`] is called, and a command that fails before
//! it leaves the target as it was (an existing file untouched, a new one never created).
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
    let dir = parent_dir(path);
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

/// A file written piece by piece that replaces `path` only when [`commit`](Self::commit) is
/// called: until then the bytes go to a temporary file beside the target
/// (`.tmp-<pid>-<name>-<random>`, in the same directory so the rename is atomic), and dropping
/// it uncommitted (an error, a panic) removes the temporary. A process killed before the commit
/// leaves the temporary behind ([`partial_path`](Self::partial_path); a recorder's bag there is
/// readable up to its last flushed chunk) and the target untouched. Implements `Write` and
/// `Seek` (the `mcap` writer seeks).
#[derive(Debug)]
pub struct AtomicFile {
    path: std::path::PathBuf,
    tmp: tempfile::NamedTempFile,
}

impl AtomicFile {
    /// Starts writing `path`. The error names the directory when the temporary cannot be
    /// created there (missing directory, no permission).
    pub fn create(path: impl AsRef<Path>) -> std::io::Result<Self> {
        let path = path.as_ref().to_path_buf();
        let dir = parent_dir(&path);
        let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let tmp = tempfile::Builder::new()
            .prefix(&format!("{TEMP_PREFIX}{}-{name}-", std::process::id()))
            .tempfile_in(dir)
            .map_err(|e| std::io::Error::new(e.kind(), format!("creating a temporary file in {}: {e}", dir.display())))?;
        Ok(Self { path, tmp })
    }

    /// The file this writes (once committed).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Where the bytes are until the commit.
    pub fn partial_path(&self) -> &Path {
        self.tmp.path()
    }

    /// Syncs the bytes to disk and renames the temporary onto the target (then syncs the
    /// directory). Flush any buffered writer around it first.
    pub fn commit(self) -> std::io::Result<()> {
        let Self { path, tmp } = self;
        let named = |step: &str, e: std::io::Error| std::io::Error::new(e.kind(), format!("{step} {}: {e}", path.display()));
        tmp.as_file().sync_all().map_err(|e| named("syncing the temporary file of", e))?;
        tmp.persist(&path).map_err(|e| named("renaming a temporary file onto", e.error))?;
        sync_dir(parent_dir(&path)).map_err(|e| named("syncing the directory of", e))
    }
}

impl std::io::Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.tmp.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.tmp.flush()
    }
}

impl std::io::Seek for AtomicFile {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        self.tmp.seek(pos)
    }
}

fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// Names of [`write_atomic`]'s temporary files start with this, then the writer's pid and `-`.
pub const TEMP_PREFIX: &str = ".tmp-";

/// Removes the temporary files that killed writers left beside `target` (a `kill -9` between
/// creating and renaming one): `.tmp-<pid>-*` files in `target`'s directory whose process is
/// gone (Linux: no `/proc/<pid>`; elsewhere, or without a pid: older than an hour). A live
/// writer's temporary is never touched. Returns the removed paths, for the caller's log.
pub fn remove_orphan_temporaries(target: &Path) -> std::io::Result<Vec<std::path::PathBuf>> {
    let dir = parent_dir(target);
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
    fn an_uncommitted_file_leaves_the_old_target_untouched_and_no_temporary() {
        use std::io::Write as _;
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("run.mcap");
        std::fs::write(&path, b"the old bag").expect("old");
        {
            let mut f = AtomicFile::create(&path).expect("create");
            f.write_all(b"half of a new one").expect("write");
            assert!(f.partial_path().exists());
            assert_eq!(std::fs::read(&path).expect("read"), b"the old bag", "untouched while writing");
        } // dropped: the command failed
        assert_eq!(std::fs::read(&path).expect("read"), b"the old bag");
        let names: Vec<_> = std::fs::read_dir(dir.path()).expect("dir").map(|e| e.expect("entry").file_name()).collect();
        assert_eq!(names, vec![std::ffi::OsString::from("run.mcap")]);
        let fresh = dir.path().join("new.csv");
        drop(AtomicFile::create(&fresh).expect("create"));
        assert!(!fresh.exists(), "a failed first write creates nothing");
        let mut f = AtomicFile::create(&fresh).expect("create");
        f.write_all(b"a,b\n").expect("write");
        f.commit().expect("commit");
        assert_eq!(std::fs::read(&fresh).expect("read"), b"a,b\n");
    }

    #[test]
    fn a_missing_directory_is_an_error_naming_it() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("no/such/dir/model.json");
        let e = write_atomic(&path, b"x").expect_err("missing directory");
        assert!(e.to_string().contains("no/such/dir"), "{e}");
        let e = AtomicFile::create(&path).expect_err("missing directory");
        assert!(e.to_string().contains("no/such/dir"), "{e}");
    }
}
