//! A request to stop, passed to each operation that may be stopped (a run,
//! a dataset's items): no new pair is started once it is set, pairs in
//! flight finish, and the operation reports the interruption. A front end
//! holds a clone and sets it (the CLI from its Ctrl-C handler); two
//! operations given different tokens stop independently.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A shared stop flag: every clone sees one [`Stop::stop`].
#[derive(Clone, Debug, Default)]
pub struct Stop(Arc<AtomicBool>);

impl Stop {
    /// A token not yet set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Ask every holder to stop; `true` when it was already asked.
    pub fn stop(&self) -> bool {
        self.0.swap(true, Ordering::SeqCst)
    }

    /// Whether a stop was asked.
    pub fn is_stopped(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clones_share_one_flag_and_tokens_are_independent() {
        let (a, b) = (Stop::new(), Stop::new());
        let a2 = a.clone();
        assert!(!a.stop());
        assert!(a2.is_stopped() && a.stop());
        assert!(!b.is_stopped());
    }
}
