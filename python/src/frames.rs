//! Arrays in: uint8 frames of any strides and flow arrays, checked
//! (`TypeError` for the type, dtype or number of dimensions, `ValueError`
//! for the shape) and read without the GIL into the host's [`Gray`]; and
//! arrays out: the `out=` array results are written into, checked the same
//! way.
//!
//! Besides `numpy.ndarray`, anything that exports its memory to NumPy
//! without a copy: an object with `__dlpack__` on the CPU (a torch tensor,
//! a JAX or CuPy array in host memory) through `numpy.from_dlpack`, or one
//! with `__array_interface__` / `__array_struct__` through `numpy.asarray`.
//! Either gives a view of the same memory with the object's strides, read
//! exactly as an ndarray of those strides is.

use numpy::ndarray::{ArrayViewD, Ix3};
use numpy::{
    PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyReadwriteArrayDyn,
    PyUntypedArray, PyUntypedArrayMethods, dtype,
};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use reynoldsflow_host::{Gray, HostError};

use crate::errors::{host_error, value_error};

/// A checked uint8 array of one frame `(H, W[, 1])` or a clip `(T, H, W[, 1])`.
pub struct Frames<'py> {
    array: PyReadonlyArrayDyn<'py, u8>,
    /// 1 for a frame, 0 for a clip (the axis of H).
    rows_axis: usize,
}

/// DLPack's device types of memory the CPU reads: `kDLCPU`, `kDLCUDAHost`
/// (pinned host memory), `kDLROCMHost`.
const HOST_DEVICES: [i64; 3] = [1, 3, 11];

/// `obj` as an ndarray viewing its memory (no copy), or a `TypeError`
/// naming `name`.
pub fn ndarray<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyUntypedArray>> {
    if let Ok(array) = obj.cast::<PyUntypedArray>() {
        return Ok(array.clone());
    }
    let type_name = || {
        obj.get_type()
            .name()
            .map_or_else(|_| "an object".to_owned(), |n| n.to_string())
    };
    let py = obj.py();
    let numpy = py.import("numpy")?;
    let converted = if obj.hasattr("__dlpack__")? {
        if obj.hasattr("__dlpack_device__")? {
            // A device DLPack has no number for (torch's "meta") is no host memory either.
            let (device, id): (i64, i64) = obj
                .call_method0("__dlpack_device__")
                .and_then(|d| d.extract())
                .map_err(|e| {
                    PyTypeError::new_err(format!(
                        "{name}: a {} on a device DLPack cannot name ({e}), not in host memory; \
                         give a CPU array",
                        type_name()
                    ))
                })?;
            if !HOST_DEVICES.contains(&device) {
                return Err(PyTypeError::new_err(format!(
                    "{name}: a {} on DLPack device ({device}, {id}), not in host memory; \
                     copy it to the CPU first (tensor.cpu(), cupy.asnumpy(array))",
                    type_name()
                )));
            }
        }
        match numpy.getattr("from_dlpack") {
            Ok(from_dlpack) => from_dlpack.call1((obj,)),
            // NumPy before 1.22: the array interface, where the object has one.
            Err(_) => numpy.call_method1("asarray", (obj,)),
        }
    } else if obj.hasattr("__array_interface__")? || obj.hasattr("__array_struct__")? {
        numpy.call_method1("asarray", (obj,))
    } else {
        return Err(PyTypeError::new_err(format!(
            "{name}: expected a numpy.ndarray or an array exporting __dlpack__ or \
             __array_interface__ (e.g. a CPU torch tensor), got {}",
            type_name()
        )));
    };
    let converted = converted.map_err(|e| {
        PyTypeError::new_err(format!(
            "{name}: cannot view the {} as an array: {e}",
            type_name()
        ))
    })?;
    Ok(converted.cast::<PyUntypedArray>()?.clone())
}

impl<'py> Frames<'py> {
    fn check(obj: &Bound<'py, PyAny>, name: &str, dims: usize, what: &str) -> PyResult<Self> {
        let array = ndarray(obj, name)?;
        let array = &array;
        let py = obj.py();
        if !array.dtype().is_equiv_to(&dtype::<u8>(py)) {
            return Err(PyTypeError::new_err(format!(
                "{name}: dtype {} is not uint8; frames are 8-bit gray (e.g. frame.astype(numpy.uint8))",
                array.dtype()
            )));
        }
        let shape = array.shape().to_vec();
        if shape.len() != dims && shape.len() != dims + 1 {
            return Err(PyTypeError::new_err(format!(
                "{name}: {} dimensions; expected {what}",
                shape.len()
            )));
        }
        if shape.len() == dims + 1 && shape[dims] != 1 {
            return Err(value_error(format!(
                "{name}: shape {shape:?} has {} channels; expected {what} (one gray channel: convert colour to gray first)",
                shape[dims]
            )));
        }
        // The frame-size limit of every entry point (set_max_pixels), as
        // the readers and Stream apply it: before anything of that size is
        // allocated.
        let (h, w) = (shape[dims - 2], shape[dims - 1]);
        crate::frame_limits()
            .check_frame_size(w, h)
            .map_err(|too_large| host_error(too_large.about(name)))?;
        let array = array
            .cast::<PyArrayDyn<u8>>()?
            .try_readonly()
            .map_err(|e| value_error(format!("{name}: {e}")))?;
        Ok(Self {
            array,
            rows_axis: dims - 2,
        })
    }

    /// One frame, `(H, W)` or `(H, W, 1)`.
    pub fn single(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Self> {
        Self::check(obj, name, 2, "a frame of shape (H, W) or (H, W, 1)")
    }

    /// A clip, `(T, H, W)` or `(T, H, W, 1)`.
    pub fn clip(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Self> {
        Self::check(obj, name, 3, "a clip of shape (T, H, W) or (T, H, W, 1)")
    }

    /// `(H, W)` of each frame.
    pub fn frame_shape(&self) -> (usize, usize) {
        let shape = self.array.shape();
        (shape[self.rows_axis], shape[self.rows_axis + 1])
    }

    /// Frames in the clip.
    pub fn count(&self) -> usize {
        self.array.shape()[0]
    }

    /// The pixels, readable without the GIL while `self` lives.
    pub fn view(&self) -> ArrayViewD<'_, u8> {
        self.array.as_array()
    }
}

/// The array a result is written into: `out=` (checked: uint8, the
/// result's shape, C-contiguous, writable) or a new one.
pub struct Output<'py> {
    /// What the function returns: `out` itself, or the new array.
    pub object: Bound<'py, PyAny>,
    array: PyReadwriteArrayDyn<'py, u8>,
}

impl<'py> Output<'py> {
    /// `out` if given (checked against `shape`), else a new zeroed array
    /// of `shape` (zeroed by the system's untouched pages, not by a pass).
    pub fn new(py: Python<'py>, out: Option<Bound<'py, PyAny>>, shape: &[usize]) -> PyResult<Self> {
        let Some(obj) = out else {
            let array = PyArrayDyn::<u8>::zeros(py, shape, false);
            return Ok(Self {
                object: array.clone().into_any(),
                array: array
                    .try_readwrite()
                    .map_err(|e| value_error(format!("out: {e}")))?,
            });
        };
        let array = ndarray(&obj, "out")?;
        if !array.dtype().is_equiv_to(&dtype::<u8>(py)) {
            return Err(PyTypeError::new_err(format!(
                "out: dtype {} is not uint8; give a uint8 array of shape {}",
                array.dtype(),
                shape_text(shape)
            )));
        }
        if array.shape() != shape {
            return Err(value_error(format!(
                "out: shape {}; the result has shape {}",
                shape_text(array.shape()),
                shape_text(shape)
            )));
        }
        if !array.is_c_contiguous() {
            return Err(value_error(format!(
                "out: not C-contiguous (strides {:?}); give a contiguous array \
                 (numpy.empty(shape, numpy.uint8), torch.empty(shape, dtype=torch.uint8))",
                array.strides()
            )));
        }
        let array = array
            .cast::<PyArrayDyn<u8>>()?
            .try_readwrite()
            .map_err(|e| value_error(format!("out: {e}; give a writable array")))?;
        Ok(Self { object: obj, array })
    }

    /// Its bytes, writable without the GIL while `self` lives.
    pub fn bytes(&mut self) -> &mut [u8] {
        self.array
            .as_slice_mut()
            .expect("C-contiguous: checked or made so")
    }
}

/// `shape` as Python writes a tuple: `(2, 3, 4)`, `(5,)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(usize::to_string)
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// One frame's view (`(H, W)` or `(H, W, 1)`, any strides) as a [`Gray`];
/// memory the system does not give is an error (`MemoryError`), not an
/// abort.
pub fn gray(view: ArrayViewD<'_, u8>) -> Result<Gray, HostError> {
    let (h, w) = (view.shape()[0], view.shape()[1]);
    let mut pixels = Vec::new();
    pixels
        .try_reserve_exact(view.len())
        .map_err(|_| HostError::io("a frame's copy", std::io::ErrorKind::OutOfMemory.into()))?;
    match view.as_slice() {
        Some(contiguous) => pixels.extend_from_slice(contiguous),
        None => pixels.extend(view.iter().copied()),
    }
    Gray::new(w, h, pixels)
}

/// An `(H, W, 2)` float32 or float64 array as `(H, W, x plane, y plane)`.
pub fn flow_planes(obj: &Bound<'_, PyAny>) -> PyResult<(usize, usize, Vec<f64>, Vec<f64>)> {
    let array = ndarray(obj, "flow")?;
    let array = &array;
    let shape = array.shape().to_vec();
    if shape.len() != 3 {
        return Err(PyTypeError::new_err(format!(
            "flow: {} dimensions; expected shape (H, W, 2)",
            shape.len()
        )));
    }
    if shape[2] != 2 {
        return Err(value_error(format!(
            "flow: shape {shape:?}; expected (H, W, 2), last axis (x, y)"
        )));
    }
    let planes = |xy: Vec<f64>| {
        let (x, y) = xy.chunks_exact(2).map(|p| (p[0], p[1])).unzip();
        (shape[0], shape[1], x, y)
    };
    if let Ok(a) = array.cast::<PyArrayDyn<f32>>() {
        let a = a
            .try_readonly()
            .map_err(|e| value_error(format!("flow: {e}")))?;
        let v = a
            .as_array()
            .into_dimensionality::<Ix3>()
            .expect("3 dimensions checked");
        return Ok(planes(v.iter().map(|&f| f64::from(f)).collect()));
    }
    if let Ok(a) = array.cast::<PyArrayDyn<f64>>() {
        let a = a
            .try_readonly()
            .map_err(|e| value_error(format!("flow: {e}")))?;
        return Ok(planes(a.as_array().iter().copied().collect()));
    }
    Err(PyTypeError::new_err(format!(
        "flow: dtype {} is not float32 or float64",
        array.dtype()
    )))
}
