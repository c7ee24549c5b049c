//! The host's one error type. Every message names what it is about (a file,
//! a setting) and the problem, so a front end shows it as one actionable
//! line; a setting is named by [`Setting`], which each front end prints
//! under its own name.

use std::io;
use std::path::PathBuf;

use crate::settings::Setting;

/// Why an input image was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ImageProblem {
    /// Neither PNM, PNG nor JPEG by its first bytes.
    #[error("not a PGM, PPM, PNG or JPEG image")]
    UnknownFormat,
    /// Samples wider than 8 bits.
    #[error("{bits}-bit samples; only 8-bit images are supported")]
    NotEightBit {
        /// Bits per sample.
        bits: u8,
    },
    /// A PNM whose maxval is not 255: its samples would need rescaling.
    #[error("PNM maxval is {maxval}; only 8-bit images with maxval 255 are supported")]
    Maxval {
        /// The header's maxval.
        maxval: u32,
    },
    /// The decoder refused the data.
    #[error("cannot decode: {0}")]
    Decode(String),
    /// The header states a frame larger than the pixel limit
    /// ([`crate::limits`]); nothing of its size was allocated. Reading a
    /// file, the host reports it as [`TooLarge::about`] the file.
    ///
    /// [`TooLarge::about`]: crate::limits::TooLarge::about
    #[error("{0}")]
    TooLarge(crate::limits::TooLarge),
}

/// Everything that can go wrong on the host side.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HostError {
    /// Reading, writing or renaming a file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        source: io::Error,
    },
    /// An input image was refused.
    #[error("{}: {problem}", path.display())]
    Image {
        /// The image file.
        path: PathBuf,
        /// Why.
        problem: ImageProblem,
    },
    /// A `.npy` file could not be read or is not a 2-D float64 array.
    #[error("{}: {problem}", path.display())]
    Npy {
        /// The `.npy` file.
        path: PathBuf,
        /// Why.
        problem: String,
    },
    /// Two frames of different sizes, known by their files.
    #[error(
        "{}: size {}x{} differs from {} ({}x{})",
        next_path.display(), next.0, next.1, prev_path.display(), prev.0, prev.1
    )]
    FrameSizes {
        /// File of frame n.
        prev_path: PathBuf,
        /// Its `(width, height)`.
        prev: (usize, usize),
        /// File of frame n + 1.
        next_path: PathBuf,
        /// Its `(width, height)`.
        next: (usize, usize),
    },
    /// Two frames of different sizes.
    #[error("frames differ in size: {}x{} and {}x{}", prev.0, prev.1, next.0, next.1)]
    SizeMismatch {
        /// `(width, height)` of frame n.
        prev: (usize, usize),
        /// `(width, height)` of frame n + 1.
        next: (usize, usize),
    },
    /// A frame's pixel count does not match its size, or the size is empty.
    #[error(
        "{len} pixels cannot make a {width}x{height} frame (sides at least 1, pixels = width x height)"
    )]
    BadFrame {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
        /// Pixels given.
        len: usize,
    },
    /// A setting's value outside its domain.
    #[error("{setting}: {problem}")]
    Setting {
        /// The setting at fault.
        setting: Setting,
        /// What is wrong and what is accepted.
        problem: String,
    },
    /// A value outside its domain that is no setting (an image's size to
    /// encode, a frame of a run).
    #[error("{name}: {problem}")]
    InvalidParameter {
        /// What the value is.
        name: String,
        /// What is wrong and what is accepted.
        problem: String,
    },
    /// The fixed-point core refused the configuration, frames or tiling.
    #[error("{0}")]
    Core(#[from] reynoldsflow_core::Error),
}

impl HostError {
    /// An [`HostError::Io`] about `path`.
    pub fn io(path: impl Into<PathBuf>, source: io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A [`HostError::Setting`].
    pub fn setting(setting: Setting, problem: impl Into<String>) -> Self {
        Self::Setting {
            setting,
            problem: problem.into(),
        }
    }

    /// An [`HostError::InvalidParameter`].
    pub fn invalid(name: impl Into<String>, problem: impl Into<String>) -> Self {
        Self::InvalidParameter {
            name: name.into(),
            problem: problem.into(),
        }
    }

    /// A panic caught on a worker while `doing` something for `name` (a
    /// bug, not bad input): the run ends with this error, and whoever waits
    /// on the worker is not left waiting.
    pub(crate) fn internal_panic(name: impl Into<String>, doing: &str) -> Self {
        Self::invalid(name, format!("internal error (panic) while {doing}"))
    }
}
