//! Long native calls that Ctrl-C can stop: the work runs on a helper
//! thread without the GIL while the calling thread polls Python's signal
//! handlers; a `KeyboardInterrupt` (or any exception a handler raises)
//! cancels the work's [`Cancel`] token, waits for the work to stop (the
//! pipeline checks the token after every level) and is raised. Limits on
//! the arguments come from [`crate::limits`], as the CLI's do.

use std::sync::mpsc;
use std::time::Duration;

use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;

use crate::cancel::Cancel;
use crate::limits::LimitError;

use super::errors::invalid;

/// How often the calling thread runs Python's signal handlers.
const POLL: Duration = Duration::from_millis(20);

/// Runs `work` on a helper thread (see the module), with `cancel` set
/// when a signal handler raises.
pub fn interruptible<T: Send>(
    py: Python<'_>,
    cancel: &Cancel,
    work: impl FnOnce() -> PyResult<T> + Send,
) -> PyResult<T> {
    std::thread::scope(|s| {
        let (tx, mut rx) = mpsc::channel();
        s.spawn(move || {
            // The receiver may be gone (an interrupt already raised).
            let _ = tx.send(work());
        });
        loop {
            let (got, back) = py.detach(move || (rx.recv_timeout(POLL), rx));
            rx = back;
            match got {
                Ok(r) => return r,
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    return Err(super::errors::runtime(
                        "internal error (a bug in stratasweep): the worker thread ended without a result",
                    ));
                }
                Err(mpsc::RecvTimeoutError::Timeout) => {}
            }
            if let Err(e) = py.check_signals() {
                cancel.cancel();
                // The scope joins the worker, which stops at its next level.
                py.detach(move || drop(rx.recv()));
                return Err(e);
            }
        }
    })
}

/// A limit error as Python's `ValueError` (it names the keyword argument).
pub fn limit_error(e: LimitError) -> PyErr {
    invalid(e.to_string())
}

/// Issues each of `warnings` as a Python `UserWarning` (control characters
/// escaped, as errors are).
pub fn warn_all(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    for w in warnings {
        let text = crate::io::checks::escape_control(w).replace('\0', " ");
        let msg = std::ffi::CString::new(text).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &msg, 1)?;
    }
    Ok(())
}
