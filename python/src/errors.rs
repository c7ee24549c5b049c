//! Errors as Python sees them: the host's errors as `ValueError` (a value
//! the computation refuses), `MemoryError` (memory the system does not
//! give) or `OSError` and its subclasses (a file), and
//! a panic, which must never reach Python as one, as `RuntimeError`.

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::PyErr;
use pyo3::exceptions::{
    PyFileNotFoundError, PyMemoryError, PyOSError, PyPermissionError, PyRuntimeError, PyValueError,
};
use reynoldsflow_host::settings::Setting;
use reynoldsflow_host::{HostError, panic_message};

/// What went wrong inside a computation.
pub enum Failure {
    /// The host refused or failed.
    Host(HostError),
    /// A bug: the panic's message.
    Panic(String),
}

/// `f`, with a panic caught and kept as its message.
pub fn guarded<T>(f: impl FnOnce() -> Result<T, HostError>) -> Result<T, Failure> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(result) => result.map_err(Failure::Host),
        Err(payload) => Err(Failure::Panic(panic_message(payload.as_ref()))),
    }
}

/// A `ValueError` with `message`.
pub fn value_error(message: impl Into<String>) -> PyErr {
    PyValueError::new_err(message.into())
}

/// The keyword that sets `setting`.
fn keyword(setting: Setting) -> &'static str {
    match setting {
        Setting::Lambda => "lam",
        Setting::Rep => "rep=False",
        Setting::MaxPixels => "set_max_pixels",
        setting => setting.name(),
    }
}

/// The host's error as a Python exception.
pub fn host_error(e: HostError) -> PyErr {
    let message = match &e {
        HostError::Setting { setting, problem } => format!("{}: {problem}", keyword(*setting)),
        e => e.to_string(),
    };
    match e {
        HostError::Io { source, .. } => match source.kind() {
            std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
            std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
            std::io::ErrorKind::InvalidData => PyValueError::new_err(message),
            std::io::ErrorKind::OutOfMemory => PyMemoryError::new_err(message),
            _ => PyOSError::new_err(message),
        },
        _ => PyValueError::new_err(message),
    }
}

impl Failure {
    /// As a Python exception.
    pub fn into_pyerr(self) -> PyErr {
        match self {
            Failure::Host(e) => host_error(e),
            Failure::Panic(message) => PyRuntimeError::new_err(format!(
                "internal error in reynoldsflow (a bug; please report it): {message}"
            )),
        }
    }
}

impl From<HostError> for Failure {
    fn from(e: HostError) -> Self {
        Failure::Host(e)
    }
}
