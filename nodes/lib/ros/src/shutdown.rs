//! Clean stop on Ctrl-C (SIGINT) and SIGTERM.

use std::sync::Arc;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

static FLAG: OnceLock<Arc<AtomicBool>> = OnceLock::new();

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

/// Whether a stop was requested.
pub fn requested() -> bool {
    FLAG.get().is_some_and(|f| f.load(Ordering::SeqCst))
}
