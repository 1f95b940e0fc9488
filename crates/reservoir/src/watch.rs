//! Watching long work from outside: stopping it, and seeing how far it got.
//!
//! A caller that may want to stop a training, a validation or free runs
//! half-way (an interactive session answering Ctrl-C), or show their
//! progress, owns a [`Watch`] and runs the work on threads that carry it
//! ([`set_for_this_thread`]; `cpg_lab::in_pool` passes the calling thread's
//! watch to every thread of its pool). Every free run's step loop looks at
//! the watch once every [`CHECK_EVERY_STEPS`] steps: it adds the steps its
//! columns took to [`Watch::steps`], and stops when [`Watch::cancel`] is
//! raised; the functions that started the loops then return
//! [`Error::Cancelled`] instead of a result. Work on
//! a thread without a watch is never cancelled, and a watch changes nothing
//! else: a run that is not cancelled gives the same bits.

use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Steps between two looks at the watch in a free run's loop.
pub const CHECK_EVERY_STEPS: usize = 1024;

/// What a caller watches long work through.
#[derive(Debug, Default)]
pub struct Watch {
    /// Raised by the caller: the work stops at its next check.
    pub cancel: AtomicBool,
    /// Free-run steps taken so far, summed over the runs (counted in
    /// [`CHECK_EVERY_STEPS`] at a time, the rest when a loop ends).
    pub steps: AtomicU64,
}

impl Watch {
    /// Raises the cancel flag.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::SeqCst);
    }

    /// Whether the cancel flag is raised.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// Free-run steps taken so far.
    pub fn steps_done(&self) -> u64 {
        self.steps.load(Ordering::Relaxed)
    }
}

thread_local! {
    static WATCH: RefCell<Option<Arc<Watch>>> = const { RefCell::new(None) };
}

/// Work on this thread from now on reports to `watch` and stops when it is cancelled (`None`: never).
pub fn set_for_this_thread(watch: Option<Arc<Watch>>) {
    WATCH.with(|f| *f.borrow_mut() = watch);
}

/// This thread's watch, if it has one (what a loop captures once before its steps).
pub fn current() -> Option<Arc<Watch>> {
    WATCH.with(|f| f.borrow().clone())
}

/// Whether this thread's watch is cancelled.
pub fn requested() -> bool {
    WATCH.with(|f| f.borrow().as_ref().is_some_and(|w| w.cancelled()))
}

/// [`Error::Cancelled`] when this thread's watch is cancelled: the check a
/// function makes after the loops it started, before it returns a result.
pub fn check() -> Result<()> {
    if requested() { Err(Error::Cancelled) } else { Ok(()) }
}

/// At step `s` of a loop advancing `columns` runs that captured `watch`:
/// every [`CHECK_EVERY_STEPS`] steps, counts them and says whether to stop.
#[inline(always)]
pub(crate) fn stop_at(watch: &Option<Arc<Watch>>, s: usize, columns: usize) -> bool {
    if !s.is_multiple_of(CHECK_EVERY_STEPS) {
        return false;
    }
    let Some(w) = watch else { return false };
    if s > 0 {
        w.steps.fetch_add((CHECK_EVERY_STEPS * columns) as u64, Ordering::Relaxed);
    }
    w.cancelled()
}

/// At the end of a loop that ran `steps` steps of `columns` runs: counts the
/// steps since its last check.
pub(crate) fn finish(watch: &Option<Arc<Watch>>, steps: usize, columns: usize) {
    if let Some(w) = watch {
        w.steps.fetch_add(((steps % CHECK_EVERY_STEPS) * columns) as u64, Ordering::Relaxed);
    }
}
