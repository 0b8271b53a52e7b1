//! Cancellation of long calls: a [`Cancel`] token shared between the
//! caller, who may [`Cancel::cancel`] it from any thread (a front end on
//! Ctrl-C), and the work, which checks it between levels (the pipeline's
//! sweeps) or between slice chunks (the renderer) and stops with
//! [`Interrupted`].

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use thiserror::Error;

/// A shared cancellation flag. The default token is never cancelled and
/// costs nothing to check; [`Cancel::new`] makes one that can be.
#[derive(Clone, Debug, Default)]
pub struct Cancel(Option<Arc<AtomicBool>>);

/// The error of work stopped by its [`Cancel`] token.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Error)]
#[error("interrupted")]
pub struct Interrupted;

impl Cancel {
    /// A token that [`Cancel::cancel`] can set.
    pub fn new() -> Self {
        Cancel(Some(Arc::new(AtomicBool::new(false))))
    }

    /// Asks the work holding a clone of this token to stop.
    pub fn cancel(&self) {
        if let Some(f) = &self.0 {
            f.store(true, Ordering::Relaxed);
        }
    }

    /// Whether the work was asked to stop.
    #[inline]
    pub fn is_cancelled(&self) -> bool {
        self.0.as_ref().is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// `Err(Interrupted)` once the work was asked to stop.
    #[inline]
    pub fn check(&self) -> Result<(), Interrupted> {
        match self.is_cancelled() {
            true => Err(Interrupted),
            false => Ok(()),
        }
    }
}

/// Stops the work from inside a loop that has no early exit (the sweeps'
/// per-level callbacks): once `c` is cancelled, unwinds with an
/// [`Interrupted`] payload, which [`catch_interrupt`] turns back into an
/// error. No panic message is printed (`resume_unwind` skips the hook);
/// rayon carries the payload across its threads. The state unwound
/// through must be the run's own (dropped, never reused).
pub(crate) fn stop_if_cancelled(c: &Cancel) {
    if c.is_cancelled() {
        std::panic::resume_unwind(Box::new(Interrupted));
    }
}

/// Runs `f`, returning `Err(Interrupted)` when it was stopped by
/// [`stop_if_cancelled`]; any other panic goes on unwinding.
pub(crate) fn catch_interrupt<T>(f: impl FnOnce() -> T) -> Result<T, Interrupted> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(v) => Ok(v),
        Err(p) if p.is::<Interrupted>() => Err(Interrupted),
        Err(p) => std::panic::resume_unwind(p),
    }
}

/// Two tokens are equal when they are the same flag (or both the default).
impl PartialEq for Cancel {
    fn eq(&self, other: &Self) -> bool {
        match (&self.0, &other.0) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        }
    }
}

impl Eq for Cancel {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clone_sees_the_cancel_and_the_default_never_does() {
        let c = Cancel::new();
        let d = c.clone();
        assert!(d.check().is_ok());
        c.cancel();
        assert_eq!(d.check(), Err(Interrupted));
        let none = Cancel::default();
        none.cancel();
        assert!(!none.is_cancelled());
        assert_eq!(c, d);
        assert_ne!(c, Cancel::new());
    }

    #[test]
    fn a_stop_inside_a_parallel_loop_comes_back_as_interrupted() {
        use rayon::prelude::*;
        let c = Cancel::new();
        c.cancel();
        let r = catch_interrupt(|| {
            (0..64).into_par_iter().for_each(|_| stop_if_cancelled(&c));
        });
        assert_eq!(r, Err(Interrupted));
        assert_eq!(catch_interrupt(|| 3), Ok(3));
        let other = std::panic::catch_unwind(|| catch_interrupt(|| panic!("boom")));
        assert!(
            other.is_err(),
            "another panic is not taken for an interrupt"
        );
    }
}
