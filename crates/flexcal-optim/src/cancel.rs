//! Cooperative cancellation of long computations.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A shared flag that asks a running computation to stop: clone it, hand
/// one clone to the computation (for the least-squares solvers,
/// [`crate::SolverOptions::cancel`]) and call [`CancelToken::cancel`] on
/// another from any thread. The solvers look at it once per iteration and
/// stop with [`crate::Termination::Cancelled`]; a set flag stays set.
///
/// Two tokens compare equal whatever their state: a token is a channel to
/// the computation, not one of its settings.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token not yet cancelled.
    pub fn new() -> Self {
        Self::default()
    }

    /// Asks every computation holding a clone of this token to stop.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`CancelToken::cancel`] was called on this token or a clone.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

impl PartialEq for CancelToken {
    fn eq(&self, _other: &Self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clone_sees_the_cancellation_from_another_thread() {
        let token = CancelToken::new();
        let seen_by_worker = token.clone();
        assert!(!seen_by_worker.is_cancelled());
        std::thread::spawn(move || token.cancel()).join().unwrap();
        assert!(seen_by_worker.is_cancelled());
    }
}
