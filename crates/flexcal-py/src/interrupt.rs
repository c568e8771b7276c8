//! Long calls without the GIL, interruptible with Ctrl-C, and without a
//! panic crossing into Python.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::mpsc::{RecvTimeoutError, channel};
use std::time::Duration;

use flexcal::calib::CancelToken;
use pyo3::prelude::*;

use crate::errors::{Failure, InternalError, panic_message};

/// How often the waiting thread looks for a signal (Ctrl-C).
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Runs `work` on a worker thread while the calling thread, GIL released,
/// waits for it and checks for signals every 50 ms. On Ctrl-C the call
/// raises `KeyboardInterrupt` at once; the worker cannot be stopped from
/// outside, so it runs to its end in the background and its result is
/// dropped. Work with a cancellation hook uses [`run_cancellable`].
///
/// A panic in `work` becomes `flexcal.InternalError`.
pub fn run_interruptible<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, Failure> + Send + 'static,
{
    run_cancellable(py, None, work)
}

/// [`run_interruptible`] for work that watches `cancel`: on Ctrl-C the
/// token is cancelled, so the worker stops at its next check (the
/// identification: within one solver iteration) instead of running on in
/// the background.
pub fn run_cancellable<T, F>(py: Python<'_>, cancel: Option<CancelToken>, work: F) -> PyResult<T>
where
    T: Send + 'static,
    F: FnOnce() -> Result<T, Failure> + Send + 'static,
{
    let (sender, receiver) = channel();
    std::thread::Builder::new()
        .name("flexcal-worker".into())
        .spawn(move || {
            let result = catch_unwind(AssertUnwindSafe(work))
                .unwrap_or_else(|payload| Err(Failure::Panic(panic_message(payload))));
            // The caller may have gone (Ctrl-C): nothing to do then.
            let _ = sender.send(result);
        })
        .map_err(|e| InternalError::new_err(format!("cannot start a worker thread: {e}")))?;
    let mut receiver = receiver;
    loop {
        // The receiver is Send but not Sync: it goes into the GIL-free
        // closure and comes back out.
        let (received, back) = py.detach(move || (receiver.recv_timeout(SIGNAL_POLL), receiver));
        receiver = back;
        match received {
            Ok(result) => return result.map_err(PyErr::from),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(interrupt) = py.check_signals() {
                    if let Some(token) = &cancel {
                        token.cancel();
                    }
                    return Err(interrupt);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(InternalError::new_err(
                    "the worker thread ended without a result",
                ));
            }
        }
    }
}

/// Runs `work` with the GIL released on the calling thread, turning a panic
/// into `flexcal.InternalError`. For short pieces of a longer loop, between
/// which the caller checks for signals.
pub fn run_detached<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce() -> Result<T, Failure> + Send,
{
    py.detach(|| {
        catch_unwind(AssertUnwindSafe(work))
            .unwrap_or_else(|payload| Err(Failure::Panic(panic_message(payload))))
    })
    .map_err(PyErr::from)
}

/// Runs `work` holding the GIL (for calls too short to be worth releasing
/// it), turning a panic into `flexcal.InternalError`.
pub fn run_here<T, F>(work: F) -> PyResult<T>
where
    F: FnOnce() -> Result<T, Failure>,
{
    catch_unwind(AssertUnwindSafe(work))
        .unwrap_or_else(|payload| Err(Failure::Panic(panic_message(payload))))
        .map_err(PyErr::from)
}
