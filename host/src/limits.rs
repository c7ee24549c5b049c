//! Resource limits on input. A header states a frame's size before its
//! pixels arrive; a corrupt or hostile one (`W100000 H100000`) must be
//! refused before anything of that size is allocated, not after the
//! allocator gives up. Every reader checks the size it is told against
//! [`max_pixels`] first.
//!
//! The limit is one setting of the process, made once from the command
//! line (`--max-pixels`) before any input is opened, so the readers deep
//! in the sequence sources need no extra parameter.

use std::sync::atomic::{AtomicU64, Ordering};

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

/// `Err(message)` when a `width × height` frame exceeds the limit (or
/// its pixel count overflows).
pub fn check_frame_size(width: usize, height: usize) -> Result<(), String> {
    let max = max_pixels();
    match (width as u64).checked_mul(height as u64) {
        Some(n) if n <= max => Ok(()),
        n => Err(format!(
            "frame size {width}x{height} ({} pixels) exceeds the limit of {max} pixels; \
             if the input really is that large, raise it with --max-pixels",
            n.map_or_else(|| "too many".to_owned(), |n| n.to_string())
        )),
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
        assert!(err.contains("8192x8193 (67117056 pixels)"), "{err}");
        assert!(err.contains("--max-pixels"), "{err}");
        assert!(check_frame_size(usize::MAX, usize::MAX).is_err());
    }
}
