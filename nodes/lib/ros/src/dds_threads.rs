//! Whether this process's DDS participants still have their threads.
//!
//! RustDDS 0.15 runs each participant on two threads (the event loop, `RustDDS Participant N
//! event loop`, and discovery, `RustDDS discovery thread`) and ends both on any error of their
//! `poll`, `EINTR` included. Linux returns `EINTR` from `epoll_wait` to a process that was
//! stopped and continued (SIGSTOP or Ctrl-Z, then SIGCONT; a debugger attaching), with or
//! without a signal handler (signal(7)). Such a node stays up but neither receives nor sends
//! anything again: fded_distance and human_observer went silent after a 2 s SIGSTOP in 2 of 4
//! chaos runs (tests/reliability/README.md). [`lost`] notices it; [`crate::node_main`] then
//! restarts the node in its process, as a launcher's respawn would.
//!
//! Counted by thread name (`/proc/self/task/*/comm`, the kernel's first 15 bytes): every
//! [`crate::RosNode`] alive must be matched by one event-loop and one discovery thread.
//! Participants made without a `RosNode` only add threads, so they never raise a false alarm.

use std::sync::atomic::{AtomicUsize, Ordering};

/// `RosNode`s created and not yet dropped (each owns one participant).
static LIVE: AtomicUsize = AtomicUsize::new(0);

/// The kernel's (15-byte) names of RustDDS's two threads per participant.
const EVENT_LOOP: &str = "RustDDS Partici";
const DISCOVERY: &str = "RustDDS discove";

/// Counts a participant alive from creation until drop; held by [`crate::RosNode`] as its
/// first field, so the count drops before the participant's threads are joined.
#[derive(Debug)]
pub(crate) struct Live(());

impl Live {
    /// Call once the participant exists (its threads are running).
    pub(crate) fn counted() -> Self {
        LIVE.fetch_add(1, Ordering::SeqCst);
        Self(())
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        LIVE.fetch_sub(1, Ordering::SeqCst);
    }
}

/// What is missing when fewer RustDDS threads run than participants are alive (None while
/// all are there, or on a system without `/proc`).
pub fn lost() -> Option<String> {
    let live = LIVE.load(Ordering::SeqCst);
    if live == 0 {
        return None;
    }
    let (mut event_loops, mut discovery) = (0, 0);
    for task in std::fs::read_dir("/proc/self/task").ok()?.flatten() {
        let Ok(name) = std::fs::read_to_string(task.path().join("comm")) else {
            continue;
        };
        match name.trim_end() {
            EVENT_LOOP => event_loops += 1,
            DISCOVERY => discovery += 1,
            _ => {}
        }
    }
    // Read again: a node dropped meanwhile lowers the count before its threads end.
    let live = live.min(LIVE.load(Ordering::SeqCst));
    (event_loops < live || discovery < live).then(|| {
        format!("{live} DDS participant(s) alive but {event_loops} event-loop and {discovery} discovery thread(s) running")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_node_with_its_threads_is_not_lost_and_none_alive_is_not_either() {
        // No RosNode in this test binary's unit tests at first: nothing to miss.
        if LIVE.load(Ordering::SeqCst) == 0 {
            assert_eq!(lost(), None);
        }
        // A participant counted without threads (as after RustDDS ended them) is missed.
        let fake = Live::counted();
        let missing = lost().expect("a participant without threads");
        assert!(missing.contains("event-loop"), "{missing}");
        drop(fake);
    }
}
