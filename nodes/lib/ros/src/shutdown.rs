//! Clean stop on Ctrl-C (SIGINT) and SIGTERM, and the stop [`crate::node_main`] asks for to
//! restart a node whose DDS threads ended ([`crate::dds_threads`]).

use std::sync::Arc;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// Raised by [`request_restart`]: the node's loops end as on Ctrl-C, and `node_main` runs the
/// node again instead of exiting.
static RESTART: AtomicBool = AtomicBool::new(false);

/// Installs the signal handler once and returns the flag it raises. Loops poll
/// [`requested`]; dropping the node afterwards lets DDS tell its peers that it left.
pub fn install() -> Arc<AtomicBool> {
    FLAG.get_or_init(|| {
        let flag = Arc::new(AtomicBool::new(false));
        let raised = Arc::clone(&flag);
        if let Err(e) = ctrlc::set_handler(move || raised.store(true, Ordering::SeqCst)) {
            tracing::warn!("cannot install the Ctrl-C handler ({e}); stop with SIGKILL only");
        }
        flag
    })
    .clone()
}

/// Whether a stop was requested (by a signal, or for a restart).
pub fn requested() -> bool {
    signalled() || RESTART.load(Ordering::SeqCst)
}

/// Whether Ctrl-C or SIGTERM asked the process to stop.
pub fn signalled() -> bool {
    FLAG.get().is_some_and(|f| f.load(Ordering::SeqCst))
}

/// Whether the node's loops are ending for [`crate::node_main`] to run it again in this
/// process (its DDS threads were lost), not for a stop: what it holds in memory may be kept
/// for the next run, and a stop's goodbyes (e.g. aborting the robot's action) are not due.
pub fn restarting() -> bool {
    RESTART.load(Ordering::SeqCst) && !signalled()
}

/// Ends the running node's loops (as [`requested`] says) so that `node_main` can run it again.
pub(crate) fn request_restart() {
    RESTART.store(true, Ordering::SeqCst);
}

/// Whether a restart was requested; clears the request.
pub(crate) fn take_restart() -> bool {
    RESTART.swap(false, Ordering::SeqCst)
}
