//! Resource limits on input. A header states a frame's size before its
//! pixels arrive; a corrupt or hostile one (`W100000 H100000`) must be
//! refused before anything of that size is allocated, not after the
//! allocator gives up. Every reader is given the [`Limits`] of its
//! operation and checks the size it is told against them first.
//!
//! The limits are a value passed to each operation that reads input (as
//! image-rs passes its `Limits` to a decoder), not a setting of the
//! process: two operations of one process may read under different limits.
//! A front end maps its own name onto [`Setting::MaxPixels`] (the CLI's
//! `--max-pixels`, Python's `set_max_pixels`).

use crate::HostError;
use crate::settings::Setting;

/// The default limit: 8192 × 8192 pixels (an 8K UHD frame, 7680 × 4320,
/// is half of it). A gray frame of that size is 64 MiB.
pub const DEFAULT_MAX_PIXELS: u64 = 8192 * 8192;

/// What one operation's readers accept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    max_pixels: u64,
}

impl Default for Limits {
    /// [`DEFAULT_MAX_PIXELS`].
    fn default() -> Self {
        Self {
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}

impl Limits {
    /// Frames of at most `max_pixels` pixels (width × height; at least 1).
    pub fn new(max_pixels: u64) -> Self {
        Self {
            max_pixels: max_pixels.max(1),
        }
    }

    /// The largest frame (width × height) a reader accepts.
    pub fn max_pixels(self) -> u64 {
        self.max_pixels
    }

    /// `Err` when a `width × height` frame exceeds the limit (or its pixel
    /// count overflows).
    pub fn check_frame_size(self, width: usize, height: usize) -> Result<(), TooLarge> {
        let limit = self.max_pixels;
        match (width as u64).checked_mul(height as u64) {
            Some(n) if n <= limit => Ok(()),
            _ => Err(TooLarge {
                width,
                height,
                limit,
            }),
        }
    }
}

/// A frame larger than the limit: what a reader was told, refused before
/// anything of its size was allocated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TooLarge {
    /// The size the input states.
    pub width: usize,
    /// The size the input states.
    pub height: usize,
    /// The limit in force.
    pub limit: u64,
}

impl TooLarge {
    /// The host's error about `subject` (the input that states the size):
    /// the [`Setting::MaxPixels`] at fault, which each front end names as
    /// its users set it (the CLI's `--max-pixels`).
    pub fn about(self, subject: impl std::fmt::Display) -> HostError {
        HostError::setting(
            Setting::MaxPixels,
            format!("{subject}: {self}; raise the limit if the input really is that large"),
        )
    }
}

impl std::fmt::Display for TooLarge {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (width, height) = (self.width, self.height);
        match (width as u64).checked_mul(height as u64) {
            Some(n) => write!(f, "frame size {width}x{height} ({n} pixels)"),
            None => write!(f, "frame size {width}x{height} (too many pixels)"),
        }?;
        write!(f, " exceeds the limit of {} pixels", self.limit)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_above_the_default_and_overflowing_sizes() {
        let limits = Limits::default();
        assert_eq!(limits.max_pixels(), DEFAULT_MAX_PIXELS);
        assert!(limits.check_frame_size(8192, 8192).is_ok());
        let err = limits.check_frame_size(8192, 8193).unwrap_err();
        assert_eq!(
            err.about("a.png").to_string(),
            "max_pixels: a.png: frame size 8192x8193 (67117056 pixels) exceeds the limit of \
             67108864 pixels; raise the limit if the input really is that large"
        );
        let err = limits.check_frame_size(usize::MAX, usize::MAX).unwrap_err();
        assert!(err.to_string().contains("(too many pixels)"), "{err}");
    }
}
