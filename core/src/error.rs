//! The one error type of the crate: everything that can be wrong is found when
//! a configuration, a frame pair or a tile is validated, never while computing.

use core::fmt;

/// Why a configuration, a frame pair, a tile or an output buffer was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// Width or height is zero.
    EmptyFrame,
    /// Width or height exceeds [`MAX_SIDE`](crate::MAX_SIDE).
    FrameTooLarge,
    /// The two frames, or a frame and its output, differ in size.
    SizeMismatch,
    /// A row stride is smaller than the frame width.
    StrideTooSmall,
    /// A buffer holds fewer elements than the geometry needs.
    BufferTooShort {
        /// Elements needed.
        needed: usize,
        /// Elements given.
        got: usize,
    },
    /// The intensity scale is zero, above 1, or so small that `6144 / s`
    /// exceeds 2³² (the residual's integer bound, see `params`).
    ScaleOutOfRange,
    /// λ rounds to zero or exceeds the solve's integer bound at this scale.
    LambdaOutOfRange,
    /// A tile has no pixels, or does not lie inside the frame.
    TileOutOfFrame,
    /// A tile is wider than the engine's capacity.
    TileTooWide {
        /// The engine's widest tile.
        max: usize,
    },
    /// A row was pushed after the stream had received the whole frame.
    StreamFinished,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::EmptyFrame => f.write_str("frame width and height must be at least 1"),
            Error::FrameTooLarge => write!(f, "frame side exceeds {}", crate::MAX_SIDE),
            Error::SizeMismatch => f.write_str("frames differ in size"),
            Error::StrideTooSmall => f.write_str("row stride is smaller than the frame width"),
            Error::BufferTooShort { needed, got } => {
                write!(f, "buffer too short: {needed} elements needed, {got} given")
            }
            Error::ScaleOutOfRange => {
                f.write_str("intensity scale must lie in [6144/2^32, 1] (e.g. 1/255)")
            }
            Error::LambdaOutOfRange => {
                f.write_str("lambda is zero at this precision or too large for the 2x2 solve")
            }
            Error::TileOutOfFrame => f.write_str("tile is empty or not inside the frame"),
            Error::TileTooWide { max } => write!(f, "tile wider than the engine's {max} columns"),
            Error::StreamFinished => f.write_str("stream already received every row"),
        }
    }
}

impl core::error::Error for Error {}
