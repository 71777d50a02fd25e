//! Cooperative cancellation of a run ([`crate::SampleOptions::cancel`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// A flag another thread sets to stop a run: the sampler checks it between
/// generations, before wrap-up and the geometry phase, and every few
/// thousand wrap-up or geometry expansions, and then returns
/// [`crate::SampleError::Cancelled`] (never a partial model).
///
/// Clones share the flag. Two tokens are equal when they share it (so that
/// [`crate::SampleOptions`] stays comparable).
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    /// A token that is not cancelled.
    pub fn new() -> CancelToken {
        CancelToken::default()
    }

    /// Ask every run holding this token (or a clone) to stop. Idempotent.
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }

    /// Whether [`CancelToken::cancel`] was called.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

impl PartialEq for CancelToken {
    fn eq(&self, other: &CancelToken) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// `Err(Cancelled)` if the run's token is set.
pub(crate) fn check(token: Option<&CancelToken>) -> Result<(), crate::SampleError> {
    match token {
        Some(t) if t.is_cancelled() => Err(crate::SampleError::Cancelled),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clones_share_the_flag() {
        let a = CancelToken::new();
        let b = a.clone();
        assert!(!b.is_cancelled());
        assert_eq!(a, b);
        assert_ne!(a, CancelToken::new());
        a.cancel();
        assert!(b.is_cancelled());
        assert_eq!(check(Some(&b)), Err(crate::SampleError::Cancelled));
        assert_eq!(check(None), Ok(()));
    }
}
