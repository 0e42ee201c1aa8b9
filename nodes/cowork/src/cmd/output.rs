//! Files a command writes: each appears whole or not at all, and an existing one is never
//! touched by a run that fails ([`cowork_store::AtomicFile`]: written beside the target, renamed
//! onto it at the end).

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use cowork_store::AtomicFile;

/// A buffered output file that replaces its path on [`commit`](Self::commit); dropped without
/// it (the command failed), it leaves nothing behind.
#[derive(Debug)]
pub struct Output {
    path: PathBuf,
    file: BufWriter<AtomicFile>,
}

impl Output {
    /// Starts writing `path`.
    pub fn create(path: &Path) -> Result<Self> {
        let file = AtomicFile::create(path).with_context(|| format!("cannot create {}", path.display()))?;
        Ok(Self { path: path.to_path_buf(), file: BufWriter::new(file) })
    }

    /// Flushes and moves the file to its path.
    pub fn commit(self) -> Result<()> {
        let path = self.path;
        let file = self.file.into_inner().map_err(|e| e.into_error()).with_context(|| format!("cannot write {}", path.display()))?;
        file.commit().with_context(|| format!("cannot write {}", path.display()))
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

/// Writes `bytes` to `path` whole or not at all ([`cowork_store::write_atomic`]).
pub fn write(path: &Path, bytes: impl AsRef<[u8]>) -> Result<()> {
    cowork_store::write_atomic(path, bytes.as_ref()).with_context(|| format!("cannot write {}", path.display()))
}

/// A CSV writer over an [`Output`].
pub fn csv(path: &Path) -> Result<csv::Writer<Output>> {
    Ok(csv::Writer::from_writer(Output::create(path)?))
}

/// Flushes a CSV from [`csv`] and moves it to its path.
pub fn commit_csv(w: csv::Writer<Output>) -> Result<()> {
    w.into_inner().map_err(|e| e.into_error()).context("flushing a CSV")?.commit()
}
