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
    let mut tmp = tempfile::Builder::new()
        .prefix(".tmp-")
        .tempfile_in(dir)
        .map_err(at("creating a temporary file in", dir))?;
    tmp.write_all(bytes).map_err(at("writing a temporary file for", path))?;
    tmp.as_file().sync_all().map_err(at("syncing a temporary file for", path))?;
    tmp.persist(path).map_err(|e| at("renaming a temporary file onto", path)(e.error))?;
    sync_dir(dir).map_err(at("syncing the directory", dir))
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
    fn a_missing_directory_is_an_error_naming_it() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("no/such/dir/model.json");
        let e = write_atomic(&path, b"x").expect_err("missing directory");
        assert!(e.to_string().contains("no/such/dir"), "{e}");
    }
}
