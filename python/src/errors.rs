//! Errors as Python sees them: the host's errors as `ValueError` (a value
//! the computation refuses) or `OSError` and its subclasses (a file), and
//! a panic, which must never reach Python as one, as `RuntimeError`.

use std::panic::{AssertUnwindSafe, catch_unwind};

use pyo3::PyErr;
use pyo3::exceptions::{
    PyFileNotFoundError, PyOSError, PyPermissionError, PyRuntimeError, PyValueError,
};
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

/// The command line's flag names in a host message, as this API's keywords.
fn pythonic(message: &str) -> String {
    [
        ("--intensity-scale", "intensity_scale"),
        ("--lambda", "lam"),
        ("--engine", "engine"),
        ("--scale", "scale"),
        ("--tile", "tile"),
        ("--no-rep", "rep=False"),
        ("--viz", "viz"),
        ("--npy-dtype", "npy_dtype"),
        ("--image-format", "image_format"),
        ("--jpeg-quality", "jpeg_quality"),
        ("--short-side", "short_side"),
        ("--resize", "resize"),
        ("--step", "step"),
        ("--fps", "fps"),
        ("--npy", "npy"),
        ("--flo", "flo"),
    ]
    .iter()
    .fold(message.to_owned(), |m, (flag, keyword)| {
        m.replace(flag, keyword)
    })
}

/// The host's error as a Python exception.
pub fn host_error(e: HostError) -> PyErr {
    let message = pythonic(&e.to_string());
    match e {
        HostError::Io { source, .. } => match source.kind() {
            std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
            std::io::ErrorKind::PermissionDenied => PyPermissionError::new_err(message),
            std::io::ErrorKind::InvalidData => PyValueError::new_err(message),
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
