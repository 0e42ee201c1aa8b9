//! DDS domains leased per machine, so that two graphs on one machine can never share one.
//!
//! DDS ports are machine-wide: two graphs on one `ROS_DOMAIN_ID` read each other's messages.
//! Every graph therefore runs on a domain it holds a [`DomainLease`] on, and every cowork node
//! says it is on a domain while it runs ([`Membership`]). Both are `flock(2)` locks on files in
//! [`lock_dir`] (`/tmp/cowork-dds-domains`, or `COWORK_DOMAIN_LOCKS`):
//!
//! - `<N>.lease`: held exclusively by the graph's owner (the `cowork experiment` process, a test,
//!   `cowork domain run` for `graph.sh`) for the graph's life; its text says who holds it;
//! - `<N>.members`: held shared by every cowork node on domain N ([`crate::RosNode::new`] takes
//!   it), whoever started it (an owner's graph, `ros2 launch`, a node started by hand).
//!
//! A domain is leased only when its lease is free *and* no cowork node is on it (the members
//! lock can be taken exclusively for a moment). The kernel drops a lock when its process ends,
//! however it ends, so a crashed owner never leaves a domain taken; a graph whose owner died
//! keeps its domain while any of its nodes runs. Locks are per open file, so two threads of one
//! process (parallel tests) exclude each other as two processes do.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read as _, Seek as _, Write as _};
use std::os::unix::fs::{DirBuilderExt as _, OpenOptionsExt as _, PermissionsExt as _};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The largest valid `ROS_DOMAIN_ID` (UDP ports of higher ones overflow).
pub const MAX_DOMAIN: u16 = 232;
/// Domains [`DomainLease::acquire`] picks from: every valid one but 0, ROS 2's default, where a
/// user's own tools and robots live.
pub const AUTO_DOMAINS: std::ops::RangeInclusive<u16> = 1..=MAX_DOMAIN;

/// Why no domain could be leased.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DomainError {
    /// The lock directory or a lock file could not be opened.
    #[error("DDS domain locks in {}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The domain asked for is leased by another graph.
    #[error("DDS domain {domain} is taken by another graph ({holder}); choose another ROS_DOMAIN_ID, or let cowork pick a free one")]
    Leased {
        /// The domain.
        domain: u16,
        /// Who holds it, as its lease file says.
        holder: String,
    },
    /// Cowork nodes that no lease owns run on the domain asked for (started by hand or by
    /// `ros2 launch`).
    #[error("DDS domain {domain} already has cowork nodes running on it (started by hand or by ros2 launch); stop them or choose another ROS_DOMAIN_ID")]
    Occupied {
        /// The domain.
        domain: u16,
    },
    /// The domain id is not a valid one.
    #[error("DDS domain {domain} is out of range (0..={MAX_DOMAIN})")]
    OutOfRange {
        /// The domain.
        domain: u16,
    },
    /// Every domain of [`AUTO_DOMAINS`] is leased or has nodes on it.
    #[error("no free DDS domain: all of {}..={} are taken by graphs on this machine (see `cowork domain list`)", AUTO_DOMAINS.start(), AUTO_DOMAINS.end())]
    NoneFree,
}

/// The directory of the lock files: `COWORK_DOMAIN_LOCKS`, else `/tmp/cowork-dds-domains`
/// (machine-wide, as DDS ports are; created world-writable with the sticky bit, as `/tmp`).
pub fn lock_dir() -> PathBuf {
    match std::env::var_os("COWORK_DOMAIN_LOCKS") {
        Some(d) if !d.is_empty() => PathBuf::from(d),
        _ => PathBuf::from("/tmp/cowork-dds-domains"),
    }
}

fn ensure_dir(dir: &Path) -> Result<(), DomainError> {
    if dir.is_dir() {
        return Ok(());
    }
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(0o1777)
        .create(dir)
        .map_err(|source| DomainError::Io { path: dir.to_owned(), source })?;
    // The umask took bits away; other users' graphs must be able to create their locks too.
    let _ = std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o1777));
    Ok(())
}

/// Opens (creating) a lock file; read-only when another user created it (flock needs no write).
fn open_lock(path: &Path) -> Result<(File, bool), DomainError> {
    let rw = OpenOptions::new().read(true).write(true).create(true).truncate(false).mode(0o666).open(path);
    match rw {
        Ok(f) => {
            let _ = f.set_permissions(std::fs::Permissions::from_mode(0o666));
            Ok((f, true))
        }
        Err(_) => File::open(path).map(|f| (f, false)).map_err(|source| DomainError::Io { path: path.to_owned(), source }),
    }
}

fn lease_path(dir: &Path, domain: u16) -> PathBuf {
    dir.join(format!("{domain}.lease"))
}

fn members_path(dir: &Path, domain: u16) -> PathBuf {
    dir.join(format!("{domain}.members"))
}

/// An exclusive right to one DDS domain on this machine, held until its last clone is dropped
/// (or the process ends). Start every graph on [`id`](Self::id).
#[derive(Debug, Clone)]
pub struct DomainLease {
    id: u16,
    /// Holds the exclusive lock.
    _file: std::sync::Arc<File>,
}

impl DomainLease {
    /// Leases a free domain of [`AUTO_DOMAINS`]; `what` (e.g. `cowork experiment pouring`) is
    /// written in the lease so that `cowork domain list` and refusals can name the holder.
    /// Tries the domains from a per-process starting point, so that parallel owners rarely
    /// contend for the same one; each is taken atomically, so they never share one.
    pub fn acquire(what: &str) -> Result<Self, DomainError> {
        Self::acquire_in(&lock_dir(), what)
    }

    fn acquire_in(dir: &Path, what: &str) -> Result<Self, DomainError> {
        ensure_dir(dir)?;
        let n = u32::from(AUTO_DOMAINS.end() - AUTO_DOMAINS.start()) + 1;
        let start = std::process::id().wrapping_mul(7919) % n;
        for k in 0..n {
            let domain = AUTO_DOMAINS.start() + ((start + k) % n) as u16;
            match Self::try_take(dir, domain, what) {
                Ok(lease) => return Ok(lease),
                Err(DomainError::Leased { .. } | DomainError::Occupied { .. }) => continue,
                Err(e) => return Err(e),
            }
        }
        Err(DomainError::NoneFree)
    }

    /// Leases exactly `domain` (a user's `ROS_DOMAIN_ID`); the error names the graph holding it.
    pub fn take(domain: u16, what: &str) -> Result<Self, DomainError> {
        if domain > MAX_DOMAIN {
            return Err(DomainError::OutOfRange { domain });
        }
        let dir = lock_dir();
        ensure_dir(&dir)?;
        Self::try_take(&dir, domain, what)
    }

    fn try_take(dir: &Path, domain: u16, what: &str) -> Result<Self, DomainError> {
        let path = lease_path(dir, domain);
        let (mut file, writable) = open_lock(&path)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => return Err(DomainError::Leased { domain, holder: holder_of(&path) }),
            Err(TryLockError::Error(source)) => return Err(DomainError::Io { path, source }),
        }
        // Nodes on the domain that no lease owns: not ours to take.
        let members = members_path(dir, domain);
        let (m, _) = open_lock(&members)?;
        match m.try_lock() {
            Ok(()) => drop(m),
            Err(TryLockError::WouldBlock) => return Err(DomainError::Occupied { domain }),
            Err(TryLockError::Error(source)) => return Err(DomainError::Io { path: members, source }),
        }
        if writable {
            let text = format!("{what} (pid {})\n", std::process::id());
            let _ = file.set_len(0).and_then(|()| file.rewind()).and_then(|()| file.write_all(text.as_bytes()));
        }
        Ok(Self { id: domain, _file: std::sync::Arc::new(file) })
    }

    /// The leased `ROS_DOMAIN_ID`.
    pub fn id(&self) -> u16 {
        self.id
    }

    /// Keeps the lease until this process ends (a test binary's domain) and returns its id.
    pub fn hold_until_exit(self) -> u16 {
        static HELD: std::sync::Mutex<Vec<DomainLease>> = std::sync::Mutex::new(Vec::new());
        let id = self.id;
        HELD.lock().unwrap_or_else(std::sync::PoisonError::into_inner).push(self);
        id
    }
}

/// A domain leased for the rest of this process (see [`DomainLease::hold_until_exit`]), for a
/// test: panics when none is free.
pub fn test_domain(what: &str) -> u16 {
    DomainLease::acquire(what).unwrap_or_else(|e| panic!("{e}")).hold_until_exit()
}

/// Who holds a lease, as its file says.
fn holder_of(path: &Path) -> String {
    let mut text = String::new();
    let _ = File::open(path).and_then(|mut f| f.read_to_string(&mut text));
    let text = text.trim();
    if text.is_empty() { "holder unknown".to_owned() } else { text.to_owned() }
}

/// A lease held now, as `cowork domain list` shows it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Held {
    /// The domain.
    pub domain: u16,
    /// Who holds the lease (`None`: no lease, but cowork nodes run on it).
    pub holder: Option<String>,
}

/// Every domain that is leased or has cowork nodes on it, in order.
pub fn held() -> Vec<Held> {
    let dir = lock_dir();
    let mut out = Vec::new();
    for domain in 0..=MAX_DOMAIN {
        let lease = lease_path(&dir, domain);
        let members = members_path(&dir, domain);
        let locked = |p: &Path| p.exists() && open_lock(p).is_ok_and(|(f, _)| matches!(f.try_lock(), Err(TryLockError::WouldBlock)));
        if locked(&lease) {
            out.push(Held { domain, holder: Some(holder_of(&lease)) });
        } else if locked(&members) {
            out.push(Held { domain, holder: None });
        }
    }
    out
}

/// A node's shared hold on its domain's members lock, kept while the node runs: no graph can
/// lease the domain meanwhile.
#[derive(Debug)]
pub struct Membership {
    _file: File,
}

/// Joins `domain` as a member; `None` (with a debug log) when the lock cannot be had within 2 s
/// (an owner holds it exclusively only for an instant while it checks the domain is free).
pub fn join(domain: u16) -> Option<Membership> {
    join_in(&lock_dir(), domain)
}

fn join_in(dir: &Path, domain: u16) -> Option<Membership> {
    ensure_dir(dir).ok()?;
    let (file, _) = open_lock(&members_path(dir, domain)).ok()?;
    let until = Instant::now() + Duration::from_secs(2);
    loop {
        match file.try_lock_shared() {
            Ok(()) => return Some(Membership { _file: file }),
            Err(TryLockError::WouldBlock) if Instant::now() < until => std::thread::sleep(Duration::from_millis(5)),
            Err(e) => {
                tracing::debug!("DDS domain {domain}: members lock not taken: {e}");
                return None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parallel_owners_never_share_a_domain_and_a_dropped_lease_frees_it() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        // 8 threads × 20 leases at once: 160, more than any fixed span of 100 could hold.
        let leases: Vec<DomainLease> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..8)
                .map(|t| s.spawn(move || (0..20).map(|i| DomainLease::acquire_in(dir, &format!("test {t}.{i}")).unwrap()).collect::<Vec<_>>()))
                .collect();
            handles.into_iter().flat_map(|h| h.join().unwrap()).collect()
        });
        let mut ids: Vec<u16> = leases.iter().map(DomainLease::id).collect();
        ids.sort_unstable();
        ids.dedup();
        assert_eq!(ids.len(), 160, "two owners got one domain");
        assert!(ids.iter().all(|d| AUTO_DOMAINS.contains(d)));
        let taken = leases[0].id();
        let e = DomainLease::try_take(dir, taken, "second").unwrap_err().to_string();
        assert!(e.contains(&format!("domain {taken} is taken")) && e.contains("test 0.0") && e.contains("pid"), "{e}");
        drop(leases);
        DomainLease::try_take(dir, taken, "again").unwrap();
    }

    #[test]
    fn a_domain_with_nodes_on_it_is_not_leased_and_the_pool_runs_out_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let dir = dir.path();
        let member = join_in(dir, 9).expect("joined");
        let e = DomainLease::try_take(dir, 9, "owner").unwrap_err();
        assert!(matches!(e, DomainError::Occupied { domain: 9 }), "{e}");
        drop(member);
        let lease = DomainLease::try_take(dir, 9, "owner").unwrap();
        // The owner's own nodes join the domain it leased.
        assert!(join_in(dir, 9).is_some());
        drop(lease);
        let all: Vec<DomainLease> = std::iter::from_fn(|| DomainLease::acquire_in(dir, "fill").ok()).take(300).collect();
        assert_eq!(all.len(), AUTO_DOMAINS.count());
        assert!(matches!(DomainLease::acquire_in(dir, "one more"), Err(DomainError::NoneFree)));
        assert!(matches!(DomainLease::take(500, "x"), Err(DomainError::OutOfRange { domain: 500 })));
    }
}
