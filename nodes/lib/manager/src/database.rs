//! The primitive database: one JSON file per robot, `<dir>/<robot>.primitives.json`, written
//! atomically and durably ([`cowork_store::write_atomic`]: temporary file, fsync, rename,
//! directory fsync), so a crash or `kill -9` at any instant leaves the old or the new file,
//! complete. The text is canonical (keys sorted, fixed field order, shortest round-trip floats):
//! loading a saved file and saving it again writes the same bytes.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{ManagerError, Result};
use crate::primitive::Primitive;
use crate::refine::HmmEntry;

/// Format version written in the file.
pub const FORMAT: u32 = 1;

/// The primitives of one robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Database {
    /// File format version ([`FORMAT`]).
    pub format: u32,
    /// Robot name.
    pub robot: String,
    /// Next label number (labels are unique across sessions: `foaN`, `noaN`, `closeN`, …).
    pub next_index: u32,
    /// Primitives by key (the label functor).
    pub primitives: BTreeMap<String, Primitive>,
    /// HMM primitives by key, each with its refinement history ([`crate::refine`]); absent
    /// from the file when there is none.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub hmm: BTreeMap<String, HmmEntry>,
}

impl Database {
    /// An empty database.
    pub fn new(robot: &str) -> Self {
        Self { format: FORMAT, robot: robot.to_owned(), next_index: 1, primitives: BTreeMap::new(), hmm: BTreeMap::new() }
    }

    /// The file of `robot` in `dir`.
    pub fn path(dir: &Path, robot: &str) -> PathBuf {
        dir.join(format!("{robot}.primitives.json"))
    }

    /// Canonical bytes (what [`save`](Self::save) writes).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = serde_json::to_vec_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}").into_bytes());
        b.push(b'\n');
        b
    }

    /// Parses and checks the bytes of a database file; errors name `path`, the line and
    /// column or the primitive and field.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self> {
        let db: Self = serde_json::from_slice(bytes).map_err(|e| ManagerError::Parse {
            path: path.to_owned(),
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        })?;
        let invalid = |id: &str, field: &str, reason: String| ManagerError::Invalid {
            path: path.to_owned(),
            id: id.to_owned(),
            field: field.to_owned(),
            reason,
        };
        if db.format != FORMAT {
            return Err(invalid("-", "format", format!("{} (this build reads format {FORMAT})", db.format)));
        }
        for (key, p) in &db.primitives {
            if *key != p.id {
                return Err(invalid(key, "id", format!("{:?} differs from its key", p.id)));
            }
            p.check().map_err(|(field, reason)| invalid(key, &field, reason))?;
            let n: Option<u32> = key.trim_start_matches(|c: char| c.is_ascii_alphabetic()).parse().ok();
            if n.is_some_and(|n| n >= db.next_index) {
                return Err(invalid(key, "next_index", format!("{} is not above this primitive's number", db.next_index)));
            }
        }
        crate::refine::check_entries(&db).map_err(|(id, field, reason)| invalid(&id, &field, reason))?;
        Ok(db)
    }

    /// Loads a database file.
    pub fn load(path: &Path) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|source| ManagerError::Io { op: "reading", path: path.to_owned(), source })?;
        Self::from_bytes(&bytes, path)
    }

    /// Loads `path`, or an empty database for `robot` when the file does not exist.
    pub fn load_or_new(path: &Path, robot: &str) -> Result<Self> {
        match std::fs::metadata(path) {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(Self::new(robot)),
            _ => Self::load(path),
        }
    }

    /// Writes the canonical text atomically and durably.
    pub fn save(&self, path: &Path) -> Result<()> {
        cowork_store::write_atomic(path, &self.to_bytes())
            .map_err(|source| ManagerError::Io { op: "saving", path: path.to_owned(), source })
    }

    /// Adds (or replaces) a primitive and moves `next_index` past its number.
    pub fn insert(&mut self, p: Primitive) {
        let n: Option<u32> = p.id.trim_start_matches(|c: char| c.is_ascii_alphabetic()).parse().ok();
        if let Some(n) = n {
            self.next_index = self.next_index.max(n + 1);
        }
        self.primitives.insert(p.id.clone(), p);
    }

    /// The primitive with key `id`.
    pub fn get(&self, id: &str) -> Option<&Primitive> {
        self.primitives.get(id)
    }

    /// The motions taught right after `p` in the same object's frame, in order (at most 4): the
    /// primitives numbered `n+1, n+2, …` after `p`'s number `n`, up to the first gripper action
    /// or other object. A motion previewed with them is previewed as it will be continued.
    pub fn chain_after(&self, p: &Primitive) -> Vec<&Primitive> {
        let number = |id: &str| id.trim_start_matches(|c: char| !c.is_ascii_digit()).parse::<u64>().ok();
        let mut out = Vec::new();
        let Some(mut n) = number(&p.id) else { return out };
        while out.len() < 4 {
            n += 1;
            match self.primitives.values().find(|q| number(&q.id) == Some(n)) {
                Some(q) if q.kind != crate::segment::ActionKind::Gripper && q.object == p.object => out.push(q),
                _ => break,
            }
        }
        out
    }

    /// Removes a primitive.
    pub fn remove(&mut self, id: &str) -> Result<Primitive> {
        self.primitives.remove(id).ok_or_else(|| ManagerError::NotFound { id: id.to_owned(), robot: self.robot.clone() })
    }
}
