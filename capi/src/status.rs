//! The one error enum of the C API and its messages.

use core::ffi::{CStr, c_char, c_int};

use reynoldsflow_core::Error;

/// What a call did: `RF_OK`, or why it refused. A refused call changed
/// nothing (no output written, the engine as before).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[allow(non_camel_case_types)]
pub enum rf_status {
    /// Success.
    RF_OK = 0,
    /// A pointer that must not be NULL was NULL.
    RF_ERR_NULL_POINTER = 1,
    /// A `float` buffer is not aligned to 4 bytes.
    RF_ERR_MISALIGNED = 2,
    /// The engine or cue handle was not made by `rf_init` / `rf_cues_init`
    /// (or its memory was overwritten).
    RF_ERR_BAD_HANDLE = 3,
    /// Width or height is zero.
    RF_ERR_EMPTY_FRAME = 4,
    /// Width or height exceeds 65535, or a buffer size overflows `size_t`.
    RF_ERR_FRAME_TOO_LARGE = 5,
    /// A row stride is smaller than the frame width.
    RF_ERR_STRIDE_TOO_SMALL = 6,
    /// A buffer (frame, output, row or working memory) is shorter than needed.
    RF_ERR_BUFFER_TOO_SHORT = 7,
    /// The intensity scale is not in `[6144 / 2^32, 1]`.
    RF_ERR_SCALE_OUT_OF_RANGE = 8,
    /// λ is not a number, or out of the range the 2x2 solve takes at this scale.
    RF_ERR_LAMBDA_OUT_OF_RANGE = 9,
    /// A fixed gain is not a number in `[0, 65536)`.
    RF_ERR_GAIN_OUT_OF_RANGE = 10,
    /// `scaling` is not an `rf_scaling`.
    RF_ERR_BAD_SCALING = 11,
    /// `variant` is not an `rf_variant`.
    RF_ERR_BAD_VARIANT = 12,
    /// `tile_width` is wider than the frame.
    RF_ERR_BAD_TILE_WIDTH = 13,
    /// `flags` has a bit no `RF_FLAG_*` defines.
    RF_ERR_BAD_FLAGS = 14,
    /// A stream is in progress: push its remaining rows or cancel it first.
    RF_ERR_STREAM_ACTIVE = 15,
    /// No stream is in progress (`rf_stream_begin` first; a stream ends by
    /// itself with the frame's last row).
    RF_ERR_NO_STREAM = 16,
    /// Streaming needs working memory for the full frame width (`tile_width` 0).
    RF_ERR_STREAM_NEEDS_FULL_WIDTH = 17,
    /// Streaming needs scales known before the frame: `RF_SCALING_FIXED` or
    /// `RF_SCALING_PREVIOUS_FRAME_MINMAX`, not per-frame min-max.
    RF_ERR_STREAM_NEEDS_KNOWN_SCALE = 18,
    /// A motion-cue parameter is out of range (see `rf_cue_params`).
    RF_ERR_BAD_CUE_PARAMS = 19,
    /// The cues were made for another frame size than the engine's.
    RF_ERR_SIZE_MISMATCH = 20,
    /// The frame is larger than motion cues cover (2048 px a side).
    RF_ERR_CUES_FRAME_TOO_LARGE = 21,
    /// The engine is busy: called from one of its own row callbacks.
    RF_ERR_BUSY = 22,
}

pub use rf_status::*;

impl From<Error> for rf_status {
    fn from(e: Error) -> Self {
        match e {
            Error::EmptyFrame => RF_ERR_EMPTY_FRAME,
            Error::FrameTooLarge => RF_ERR_FRAME_TOO_LARGE,
            Error::SizeMismatch => RF_ERR_SIZE_MISMATCH,
            Error::StrideTooSmall => RF_ERR_STRIDE_TOO_SMALL,
            Error::BufferTooShort { .. } => RF_ERR_BUFFER_TOO_SHORT,
            Error::ScaleOutOfRange => RF_ERR_SCALE_OUT_OF_RANGE,
            Error::LambdaOutOfRange => RF_ERR_LAMBDA_OUT_OF_RANGE,
            Error::TileOutOfFrame => RF_ERR_BAD_TILE_WIDTH,
            Error::TileTooWide { .. } => RF_ERR_STREAM_NEEDS_FULL_WIDTH,
            Error::StreamFinished => RF_ERR_NO_STREAM,
        }
    }
}

/// Every status with its message, in code order (the table `rf_strerror`
/// reads and the tests walk).
pub(crate) const MESSAGES: [(rf_status, &CStr); 23] = [
    (RF_OK, c"success"),
    (RF_ERR_NULL_POINTER, c"a required pointer is NULL"),
    (
        RF_ERR_MISALIGNED,
        c"a float buffer is not aligned to 4 bytes",
    ),
    (
        RF_ERR_BAD_HANDLE,
        c"not a handle made by rf_init or rf_cues_init (or its memory was overwritten)",
    ),
    (
        RF_ERR_EMPTY_FRAME,
        c"frame width and height must be at least 1",
    ),
    (
        RF_ERR_FRAME_TOO_LARGE,
        c"frame side exceeds 65535, or a buffer size overflows size_t",
    ),
    (
        RF_ERR_STRIDE_TOO_SMALL,
        c"row stride is smaller than the frame width",
    ),
    (
        RF_ERR_BUFFER_TOO_SHORT,
        c"a buffer is shorter than needed (see the size queries)",
    ),
    (
        RF_ERR_SCALE_OUT_OF_RANGE,
        c"intensity scale must lie in [6144/2^32, 1] (e.g. 1/255)",
    ),
    (
        RF_ERR_LAMBDA_OUT_OF_RANGE,
        c"lambda is not a number, zero at this precision, or too large for the 2x2 solve",
    ),
    (
        RF_ERR_GAIN_OUT_OF_RANGE,
        c"a fixed gain must be a number in [0, 65536)",
    ),
    (RF_ERR_BAD_SCALING, c"scaling is not one of RF_SCALING_*"),
    (RF_ERR_BAD_VARIANT, c"variant is not one of RF_VARIANT_*"),
    (RF_ERR_BAD_TILE_WIDTH, c"tile_width is wider than the frame"),
    (RF_ERR_BAD_FLAGS, c"flags has bits no RF_FLAG_* defines"),
    (
        RF_ERR_STREAM_ACTIVE,
        c"a stream is in progress: push its remaining rows or call rf_stream_cancel",
    ),
    (
        RF_ERR_NO_STREAM,
        c"no stream in progress: call rf_stream_begin first",
    ),
    (
        RF_ERR_STREAM_NEEDS_FULL_WIDTH,
        c"streaming needs working memory for the full frame width (tile_width 0)",
    ),
    (
        RF_ERR_STREAM_NEEDS_KNOWN_SCALE,
        c"streaming needs RF_SCALING_FIXED or RF_SCALING_PREVIOUS_FRAME_MINMAX",
    ),
    (
        RF_ERR_BAD_CUE_PARAMS,
        c"a motion-cue parameter is out of range",
    ),
    (
        RF_ERR_SIZE_MISMATCH,
        c"the cues were made for another frame size than the engine's",
    ),
    (
        RF_ERR_CUES_FRAME_TOO_LARGE,
        c"motion cues cover frames up to 2048 px a side",
    ),
    (
        RF_ERR_BUSY,
        c"the engine is busy: not callable from its own row callback",
    ),
];

/// A static, NUL-terminated English message for a status code (any `int`:
/// an unknown code gets "unknown rf_status code"). Never NULL.
#[unsafe(no_mangle)]
pub extern "C" fn rf_strerror(status: c_int) -> *const c_char {
    let message = usize::try_from(status)
        .ok()
        .and_then(|i| MESSAGES.get(i))
        .map_or(c"unknown rf_status code", |&(_, m)| m);
    message.as_ptr()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_message_table_is_in_code_order() {
        for (i, (status, message)) in MESSAGES.iter().enumerate() {
            assert_eq!(*status as usize, i);
            assert!(!message.is_empty());
            // SAFETY: rf_strerror returns a static NUL-terminated string.
            let got = unsafe { CStr::from_ptr(rf_strerror(i as c_int)) };
            assert_eq!(got, *message);
        }
        for unknown in [-1, MESSAGES.len() as c_int, c_int::MAX] {
            // SAFETY: as above.
            let got = unsafe { CStr::from_ptr(rf_strerror(unknown)) };
            assert_eq!(got, c"unknown rf_status code");
        }
    }
}
