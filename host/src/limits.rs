//! Resource limits on input. A header states a frame's size before its
//! pixels arrive; a corrupt or hostile one (`W100000 H100000`) must be
//! refused before anything of that size is allocated, not after the
//! allocator gives up. Every reader checks the size it is told against
//! [`max_pixels`] first.
//!
//! The limit is one setting of the process ([`Setting::MaxPixels`]), made
//! once by the front end (the CLI's `--max-pixels`, Python's
//! `set_max_pixels`) before any input is opened, so the readers deep in the
//! sequence sources need no extra parameter.

use std::sync::atomic::{AtomicU64, Ordering};

use crate::HostError;
use crate::settings::Setting;

/// The default limit: 8192 × 8192 pixels (an 8K UHD frame, 7680 × 4320,
/// is half of it). A gray frame of that size is 64 MiB.
pub const DEFAULT_MAX_PIXELS: u64 = 8192 * 8192;

static MAX_PIXELS: AtomicU64 = AtomicU64::new(DEFAULT_MAX_PIXELS);

/// The largest frame (width × height) any reader accepts.
pub fn max_pixels() -> u64 {
    MAX_PIXELS.load(Ordering::Relaxed)
}

/// Set the limit for every reader of this process (at least 1).
pub fn set_max_pixels(n: u64) {
    MAX_PIXELS.store(n.max(1), Ordering::Relaxed);
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

/// `Err` when a `width × height` frame exceeds the limit (or its pixel
/// count overflows).
pub fn check_frame_size(width: usize, height: usize) -> Result<(), TooLarge> {
    let limit = max_pixels();
    match (width as u64).checked_mul(height as u64) {
        Some(n) if n <= limit => Ok(()),
        _ => Err(TooLarge {
            width,
            height,
            limit,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_above_the_default_and_overflowing_sizes() {
        assert_eq!(max_pixels(), DEFAULT_MAX_PIXELS);
        assert!(check_frame_size(8192, 8192).is_ok());
        let err = check_frame_size(8192, 8193).unwrap_err();
        assert_eq!(
            err.about("a.png").to_string(),
            "max_pixels: a.png: frame size 8192x8193 (67117056 pixels) exceeds the limit of \
             67108864 pixels; raise the limit if the input really is that large"
        );
        let err = check_frame_size(usize::MAX, usize::MAX).unwrap_err();
        assert!(err.to_string().contains("(too many pixels)"), "{err}");
    }
}
