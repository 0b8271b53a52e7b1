//! Rust errors to Python exceptions: files that cannot be read or written
//! raise `OSError` (its errno subclass, e.g. `FileNotFoundError`), bad
//! arguments and bad grids `ValueError`, GPU faults `RuntimeError`. A panic
//! is caught ([`guard`]) and raised as `RuntimeError`, never unwound into
//! Python. Every message has its control characters escaped as the CLI
//! escapes its errors ([`escape_control`]), so that printing a message that
//! quotes a file name or file content never sends raw control bytes.

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::PyErr;
use pyo3::exceptions::{PyMemoryError, PyOSError, PyRuntimeError, PyValueError};

use crate::io::checks::escape_control;

/// `ValueError(msg)`, control characters escaped; `MemoryError` when the
/// message says an allocation failed ([`out_of_memory`]).
pub fn invalid(msg: impl AsRef<str>) -> PyErr {
    out_of_memory(msg.as_ref())
        .unwrap_or_else(|| PyValueError::new_err(escape_control(msg.as_ref())))
}

/// `RuntimeError(msg)`, control characters escaped; `MemoryError` when the
/// message says an allocation failed ([`out_of_memory`]).
pub fn runtime(msg: impl AsRef<str>) -> PyErr {
    out_of_memory(msg.as_ref())
        .unwrap_or_else(|| PyRuntimeError::new_err(escape_control(msg.as_ref())))
}

/// `MemoryError(msg)` when `msg` carries a failed allocation
/// ([`crate::mem::AllocError`], whose message starts with
/// [`crate::mem::OUT_OF_MEMORY`]), wherever an error chain put it.
fn out_of_memory(msg: &str) -> Option<PyErr> {
    let marker = format!("{}: ", crate::mem::OUT_OF_MEMORY);
    msg.contains(&marker)
        .then(|| PyMemoryError::new_err(escape_control(msg)))
}

/// Runs `f`, turning a panic into `RuntimeError` (the last resort: every
/// expected failure is already an error value).
pub fn guard<T>(f: impl FnOnce() -> Result<T, PyErr>) -> Result<T, PyErr> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(p) => {
            let msg = p
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("unknown panic");
            Err(runtime(format!(
                "internal error (a bug in stratasweep): {msg}"
            )))
        }
    }
}

/// The first `std::io::Error` in an error's source chain.
fn io_cause<'a>(e: &'a (dyn std::error::Error + 'static)) -> Option<&'a std::io::Error> {
    let mut cur = Some(e);
    while let Some(c) = cur {
        if let Some(io) = c.downcast_ref::<std::io::Error>() {
            return Some(io);
        }
        cur = c.source();
    }
    None
}

/// `OSError(errno, message)` (Python picks the errno's subclass);
/// `MemoryError` for an allocation that failed.
pub fn os_error(msg: String, io: &std::io::Error) -> PyErr {
    if io.kind() == std::io::ErrorKind::OutOfMemory {
        return PyMemoryError::new_err(escape_control(&msg));
    }
    let msg = escape_control(&msg);
    match io.raw_os_error() {
        Some(code) => PyOSError::new_err((code, msg)),
        None => PyOSError::new_err(msg),
    }
}

/// `ValueError` with the error's message.
pub fn value_error(e: &dyn std::fmt::Display) -> PyErr {
    invalid(e.to_string())
}

/// A load error: `OSError` when a file could not be read, else `ValueError`
/// (the reader's message names the file, line and keyword).
pub fn load_error(e: crate::io::LoadError) -> PyErr {
    match io_cause(&e) {
        Some(io) => os_error(e.to_string(), io),
        None => value_error(&e),
    }
}

/// A write error: `OSError` when the file system refused, else `ValueError`.
pub fn write_error(e: crate::io::writers::WriteError) -> PyErr {
    match io_cause(&e) {
        Some(io) => os_error(e.to_string(), io),
        None => value_error(&e),
    }
}

/// A GPU error: `RuntimeError`.
pub fn gpu_error(e: &dyn std::fmt::Display) -> PyErr {
    runtime(e.to_string())
}
