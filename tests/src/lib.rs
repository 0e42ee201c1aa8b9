//! Helpers shared by the graph-level tests in `tests/tests/`.

use std::path::{Path, PathBuf};

/// The repository root.
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A DDS domain id private to this test process, so parallel test runs never see each other.
pub fn private_domain(offset: u16) -> u16 {
    100 + ((std::process::id() as u16).wrapping_mul(7).wrapping_add(offset) % 120)
}
