//! The loaders' last line of defence: a panic inside a dependency (an image decoder, a
//! parser) on crafted input becomes an error that names the file, instead of taking the
//! program down.
//!
//! Every loader validates its input before handing it on, so this should never trigger;
//! when it does, the message says so (a bug worth reporting). While [`catch_panic`] runs a
//! closure, the panic hook prints nothing for panics *on the calling thread* (the error
//! carries the message instead); panics on other threads (a decoder's worker threads) are
//! still reported by the previous hook, and still come back as the error.

use std::any::Any;
use std::cell::Cell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

thread_local! {
    /// How many [`catch_panic`] calls are active on this thread.
    static QUIET: Cell<u32> = const { Cell::new(0) };
}

static HOOK: Once = Once::new();

/// When set, [`catch_panic`] lets panics through (see [`propagate_panics`]).
static PROPAGATE: AtomicBool = AtomicBool::new(false);

/// Makes [`catch_panic`] let panics through (`true`) instead of turning them into errors:
/// for fuzz targets and debugging, where a panic that the loaders' checks let through should
/// crash loudly. Process-wide; off by default.
pub fn propagate_panics(yes: bool) {
    PROPAGATE.store(yes, Ordering::Relaxed);
}

/// Runs `f`; a panic inside it becomes `Err(message)` (the panic's own message). The
/// default panic hook stays silent for panics on this thread while `f` runs.
pub fn catch_panic<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    if PROPAGATE.load(Ordering::Relaxed) {
        return Ok(f());
    }
    HOOK.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if QUIET.with(Cell::get) == 0 {
                previous(info);
            }
        }));
    });
    QUIET.with(|q| q.set(q.get() + 1));
    let result = panic::catch_unwind(AssertUnwindSafe(f));
    QUIET.with(|q| q.set(q.get().saturating_sub(1)));
    result.map_err(|payload| panic_message(payload.as_ref()))
}

/// The text of a panic payload (`panic!("...")` gives a `&str` or a `String`).
pub fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "(no message)".to_string()
    }
}

/// The message a loader gives for a caught panic: what failed and that it is a bug.
pub fn panic_error_message(message: &str) -> String {
    format!(
        "the reader failed on this file instead of rejecting it (a bug in lamina or a library it uses; please report it): {message}"
    )
}

thread_local! {
    /// The fault point armed on this thread ([`with_fault`]), if any.
    static FAULT: Cell<Option<&'static str>> = const { Cell::new(None) };
}

/// A place where a test can make a loader panic ([`with_fault`]), to prove that the guard
/// around the loader turns the panic into an error. Every crate's loaders share this one
/// mechanism; unless a test armed `name` on this thread it does nothing (one thread-local
/// read per file loaded).
#[inline]
pub fn fault_point(name: &'static str) {
    if FAULT.with(Cell::get) == Some(name) {
        panic!("injected fault at {name}");
    }
}

/// Runs `f` with fault point `name` armed on this thread (for tests of the guards).
#[doc(hidden)]
pub fn with_fault<T>(name: &'static str, f: impl FnOnce() -> T) -> T {
    FAULT.with(|c| c.set(Some(name)));
    let r = f();
    FAULT.with(|c| c.set(None));
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_an_error_and_nesting_works() {
        assert_eq!(catch_panic(|| 3), Ok(3));
        let e = catch_panic(|| -> u32 { panic!("boom {}", 7) }).unwrap_err();
        assert_eq!(e, "boom 7");
        let inner = catch_panic(|| catch_panic(|| -> u32 { panic!("inner") }));
        assert_eq!(inner, Ok(Err("inner".to_string())));
        // Still quiet-counted correctly after nesting.
        assert_eq!(QUIET.with(Cell::get), 0);
    }
}
