//! NumPy arrays in: uint8 frames of any strides and flow arrays, checked
//! (`TypeError` for the type, dtype or number of dimensions, `ValueError`
//! for the shape) and read without the GIL into the host's [`Gray`].

use numpy::ndarray::{ArrayViewD, Ix3};
use numpy::{
    PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArray,
    PyUntypedArrayMethods, dtype,
};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use reynoldsflow_host::{Gray, HostError};

use crate::errors::value_error;

/// A checked uint8 array of one frame `(H, W[, 1])` or a clip `(T, H, W[, 1])`.
pub struct Frames<'py> {
    array: PyReadonlyArrayDyn<'py, u8>,
    /// 1 for a frame, 0 for a clip (the axis of H).
    rows_axis: usize,
}

/// `obj` as an ndarray, or a `TypeError` naming `name`.
fn ndarray<'a, 'py>(
    obj: &'a Bound<'py, PyAny>,
    name: &str,
) -> PyResult<&'a Bound<'py, PyUntypedArray>> {
    obj.cast::<PyUntypedArray>().map_err(|_| {
        PyTypeError::new_err(format!(
            "{name}: expected a numpy.ndarray, got {}",
            obj.get_type()
                .name()
                .map_or_else(|_| "an object".to_owned(), |n| n.to_string())
        ))
    })
}

impl<'py> Frames<'py> {
    fn check(obj: &Bound<'py, PyAny>, name: &str, dims: usize, what: &str) -> PyResult<Self> {
        let array = ndarray(obj, name)?;
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

/// One frame's view (`(H, W)` or `(H, W, 1)`, any strides) as a [`Gray`].
pub fn gray(view: ArrayViewD<'_, u8>) -> Result<Gray, HostError> {
    let (h, w) = (view.shape()[0], view.shape()[1]);
    let pixels = match view.as_slice() {
        Some(contiguous) => contiguous.to_vec(),
        None => view.iter().copied().collect(),
    };
    Gray::new(w, h, pixels)
}

/// An `(H, W, 2)` float32 or float64 array as `(H, W, x plane, y plane)`.
pub fn flow_planes(obj: &Bound<'_, PyAny>) -> PyResult<(usize, usize, Vec<f64>, Vec<f64>)> {
    let array = ndarray(obj, "flow")?;
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
