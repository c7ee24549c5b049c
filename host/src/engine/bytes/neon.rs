//! The second step of per-frame min–max (each pixel's kept magnitudes and
//! its `fⁿ` byte to its three RGB bytes) in NEON lanes on aarch64: the
//! core's byte row ([`rgb_row`]), which there is its NEON kernel set's
//! (`core/src/kernels/neon.rs`: sixteen pixels a step, both magnitudes'
//! bytes by `FCVTZU` and saturating narrowings, interleaved with `fⁿ` by
//! one `ST3`), the last pixels one at a time. The same bytes as
//! [`bytes_from_kept`](super::portable::bytes_from_kept), the portable
//! step, for every length and magnitude (tested in `engine::lane` under
//! `qemu-aarch64`, `scripts/test-resample-aarch64`; the core's
//! `kernel_check` holds its kernel to the portable pixels).
//!
//! One NEON byte kernel serves the core's `represent` and this step: the
//! intrinsics and their `unsafe` stay in the core, so there is none here.
//! Compiled from the portable step, the interleaving loop stayed scalar
//! (docs/PERFORMANCE.md, aarch64: the step's instructions a pixel).

use reynoldsflow_core::{ByteScale, Pixels, rgb_row};

/// [`bytes_from_kept`](super::portable::bytes_from_kept) in NEON lanes:
/// as many pixels as the shortest of the rows and `rgb`'s whole pixels.
pub(crate) fn kept_to_bytes(
    [m_d, m_c]: [&[f32]; 2],
    luma: &[u8],
    rgb: &mut [u8],
    [scale_d, scale_c]: &[ByteScale; 2],
) {
    let pixels = Pixels {
        m_d,
        m_c,
        luma,
        fields: None,
    };
    rgb_row(pixels, scale_d, scale_c, rgb.as_chunks_mut::<3>().0);
}
