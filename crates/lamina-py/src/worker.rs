//! Running lamina's long calls (renders, sensors) from Python: the work on a thread of its
//! own with the GIL released, the calling thread waiting for it, and every 50 ms (or when
//! the work sends a message) taking the GIL back for a moment to pass the message on and to
//! let Python handle signals. Ctrl-C, or an exception from the message handler, sets the
//! work's cancel flag (it stops at its next check, well under a second) and is raised once
//! the work has returned.

use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::time::Duration;

/// How often the waiting thread looks at Python's signals.
const POLL: Duration = Duration::from_millis(50);

/// What the worker sends the waiting thread.
pub(crate) enum Event<M, T> {
    /// A message for the handler (progress).
    Message(M),
    /// The work's result.
    Done(Result<T, String>),
}

/// The channel the worker and the waiting thread share.
pub(crate) type Channel<M, T> = (mpsc::Sender<Event<M, T>>, mpsc::Receiver<Event<M, T>>);

/// Runs `work` (named `what` in messages: "render", "sensors") on its own thread while this
/// one, the GIL released, receives on `rx` and hands each [`Event::Message`] to
/// `on_message` with the GIL held. `tx` is `rx`'s sender, for the result (the work keeps
/// its own clones for messages). A panic in the work becomes an error naming it a bug.
/// Returns the work's result, or the Python exception that cancelled it.
pub(crate) fn run_detached<M: Send, T: Send>(
    py: Python<'_>,
    what: &str,
    cancel: &AtomicBool,
    (tx, rx): Channel<M, T>,
    work: impl FnOnce() -> Result<T, String> + Send,
    mut on_message: impl FnMut(Python<'_>, M) -> PyResult<()> + Send,
) -> PyResult<Result<T, String>> {
    let (result, pending) = py.detach(move || {
        let mut pending: Option<PyErr> = None;
        let stop = |e: PyErr, pending: &mut Option<PyErr>| {
            cancel.store(true, Ordering::Relaxed);
            *pending = Some(e);
        };
        let r = std::thread::scope(|s| {
            s.spawn(move || {
                let r = lamina_leaf::guard::catch_panic(work).unwrap_or_else(|m| {
                    Err(format!(
                        "the {what} failed instead of returning an error (a bug in lamina; \
                         please report it): {m}"
                    ))
                });
                let _ = tx.send(Event::Done(r));
            });
            loop {
                match rx.recv_timeout(POLL) {
                    Ok(Event::Done(r)) => return r,
                    Ok(Event::Message(m)) => {
                        if pending.is_none()
                            && let Err(e) = Python::attach(|py| on_message(py, m))
                        {
                            stop(e, &mut pending);
                        }
                    }
                    Err(mpsc::RecvTimeoutError::Timeout) => {}
                    Err(mpsc::RecvTimeoutError::Disconnected) => {
                        return Err(format!("the {what} thread ended without a result"));
                    }
                }
                if pending.is_none()
                    && let Err(e) = Python::attach(|py| py.check_signals())
                {
                    stop(e, &mut pending);
                }
            }
        });
        (r, pending)
    });
    match pending {
        Some(e) => Err(e),
        None => Ok(result),
    }
}
