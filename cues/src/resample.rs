//! Resizing 8-bit gray frames by one integer definition (docs/resample.md),
//! so a resized frame has the same bytes on every target: the host's
//! `--resize` / `--short-side`, the Python package, and a device that
//! shrinks its sensor's frames before the engine.
//!
//! Each axis is resampled on its own, by the rule its sizes call for:
//!
//! - **Down or equal** (`dst ≤ src`): area averaging. Output pixel `i`
//!   covers the source interval `[i·src/dst, (i+1)·src/dst)`; each source
//!   pixel weighs by how much of it lies inside, in units of `1/dst` of a
//!   pixel (integers that sum to `src`).
//! - **Up** (`dst > src`): bilinear between pixel centres (half-pixel
//!   alignment, as OpenCV's `INTER_LINEAR` and PIL): output centre `i` sits at
//!   source position `(i + ½)·src/dst − ½`, clamped to `[0, src − 1]`; the two
//!   neighbours weigh by their distance in units of `1/(2·dst)` of a pixel
//!   (fixed point with denominator `2·dst`, exact).
//!
//! The output pixel is the weighted sum over both axes divided by the
//! product of the two weight totals, rounded half up, in `u64`: no float,
//! no rounding before the last step. An axis of equal sizes has one weight
//! per pixel, so a frame resized to its own size is unchanged.
//!
//! No allocation: [`Resize::frame`] writes a whole frame, and
//! [`Resize::row`] one output row from the source rows
//! [`Resize::source_rows`] names, for a device that holds only a band of
//! the source.

use core::fmt;
use core::ops::Range;

/// The largest side either frame may have (weights and sums stay far inside
/// `u64`; any camera frame fits).
pub const MAX_SIDE: usize = 1 << 16;

/// Why a resize was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResizeError {
    /// A side is 0 or above [`MAX_SIDE`].
    BadSize {
        /// Columns.
        width: usize,
        /// Rows.
        height: usize,
    },
    /// A buffer does not hold the frame or row it is for.
    BadBuffer {
        /// Bytes needed.
        needed: usize,
        /// Bytes given.
        given: usize,
    },
}

impl fmt::Display for ResizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ResizeError::BadSize { width, height } => write!(
                f,
                "cannot resize a {width}x{height} frame: sides must be 1 to {MAX_SIDE}"
            ),
            ResizeError::BadBuffer { needed, given } => {
                write!(f, "resize buffer holds {given} bytes; {needed} needed")
            }
        }
    }
}

impl core::error::Error for ResizeError {}

/// One axis: `src` pixels to `dst`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Axis {
    src: usize,
    dst: usize,
}

/// The taps of one output position along an axis: source pixels
/// `first..first + weights.len()` and their weights, which sum to
/// [`Axis::total`].
struct Taps {
    first: usize,
    /// At most two for bilinear; for area, up to `⌈src/dst⌉ + 1`.
    count: usize,
    axis: Axis,
    out: usize,
    /// Bilinear between two centres: how far past the first, in units of
    /// `1/(2·dst)` (0 otherwise).
    frac: u64,
}

impl Axis {
    /// The sum of the weights of every output position.
    const fn total(self) -> u64 {
        if self.dst <= self.src {
            self.src as u64
        } else {
            2 * self.dst as u64
        }
    }

    /// The source pixels output position `i` reads.
    fn taps(self, i: usize) -> Taps {
        let (s, d) = (self.src as u64, self.dst as u64);
        let i = i as u64;
        let (first, count, frac) = if d <= s {
            // [i·s, (i+1)·s) in units of 1/d: pixels ⌊i·s/d⌋ ..= ⌈(i+1)·s/d⌉ − 1.
            let first = i * s / d;
            let end = ((i + 1) * s).div_ceil(d);
            (first, end - first, 0)
        } else {
            match self.centre(i) {
                Centre::Low => (0, 1, 0),
                Centre::High => (s - 1, 1, 0),
                Centre::Between(j, f) => (j, 2, f),
            }
        };
        Taps {
            first: first as usize,
            count: count as usize,
            axis: self,
            out: i as usize,
            frac,
        }
    }

    /// Bilinear: where output centre `i` falls, in units of `1/(2d)`.
    fn centre(self, i: u64) -> Centre {
        let (s, d) = (self.src as u64, self.dst as u64);
        // (i + ½)·s/d − ½ in units of 1/(2d): (2i + 1)·s − d.
        let c = (2 * i + 1) * s;
        if c <= d {
            return Centre::Low;
        }
        let c = c - d;
        if c >= (s - 1) * 2 * d {
            return Centre::High;
        }
        Centre::Between(c / (2 * d), c % (2 * d))
    }
}

/// A bilinear output centre: before the first pixel's centre, past the
/// last one's, or between pixel `j` and `j + 1` at `f / (2·dst)` of the way.
enum Centre {
    Low,
    High,
    Between(u64, u64),
}

impl Taps {
    /// The weight of the `k`-th tap (source pixel `first + k`).
    fn weight(&self, k: usize) -> u64 {
        let Axis { src, dst } = self.axis;
        let (s, d) = (src as u64, dst as u64);
        if d <= s {
            let j = (self.first + k) as u64;
            let i = self.out as u64;
            let lo = (i * s).max(j * d);
            let hi = ((i + 1) * s).min((j + 1) * d);
            hi - lo
        } else if self.count == 1 {
            2 * d
        } else if k == 0 {
            2 * d - self.frac
        } else {
            self.frac
        }
    }
}

/// A resize from `src_width × src_height` to `dst_width × dst_height`,
/// checked once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resize {
    x: Axis,
    y: Axis,
}

impl Resize {
    /// The resize of a `src_width × src_height` frame to `dst_width ×
    /// dst_height`; every side from 1 to [`MAX_SIDE`].
    pub fn new(
        src_width: usize,
        src_height: usize,
        dst_width: usize,
        dst_height: usize,
    ) -> Result<Self, ResizeError> {
        for (width, height) in [(src_width, src_height), (dst_width, dst_height)] {
            let bad = |n: usize| n == 0 || n > MAX_SIDE;
            if bad(width) || bad(height) {
                return Err(ResizeError::BadSize { width, height });
            }
        }
        Ok(Self {
            x: Axis {
                src: src_width,
                dst: dst_width,
            },
            y: Axis {
                src: src_height,
                dst: dst_height,
            },
        })
    }

    /// `(width, height)` of the output.
    pub fn output_size(&self) -> (usize, usize) {
        (self.x.dst, self.y.dst)
    }

    /// `(width, height)` of the input.
    pub fn input_size(&self) -> (usize, usize) {
        (self.x.src, self.y.src)
    }

    /// The source rows output row `y` reads (at most `⌈src/dst⌉ + 1`).
    pub fn source_rows(&self, y: usize) -> Range<usize> {
        let taps = self.y.taps(y);
        taps.first..taps.first + taps.count
    }

    /// Output row `y` into `out` (`dst_width` bytes), from `rows`: the
    /// source rows `first_row..`, packed (`src_width` bytes each), which
    /// must include [`Self::source_rows`]`(y)`; a whole frame is `rows`
    /// with `first_row = 0`.
    pub fn row(
        &self,
        y: usize,
        rows: &[u8],
        first_row: usize,
        out: &mut [u8],
    ) -> Result<(), ResizeError> {
        let (sw, dw) = (self.x.src, self.x.dst);
        let need = self.source_rows(y);
        let rows_needed = (need.end.saturating_sub(first_row)) * sw;
        if need.start < first_row || rows.len() < rows_needed {
            return Err(ResizeError::BadBuffer {
                needed: rows_needed.max(sw),
                given: rows.len(),
            });
        }
        if out.len() != dw {
            return Err(ResizeError::BadBuffer {
                needed: dw,
                given: out.len(),
            });
        }
        let total = self.x.total() * self.y.total();
        let half = total / 2;
        let ys = self.y.taps(y);
        for (x, o) in out.iter_mut().enumerate() {
            let xs = self.x.taps(x);
            let mut sum = 0u64;
            for ky in 0..ys.count {
                let row = (ys.first + ky - first_row) * sw;
                let line = &rows[row + xs.first..row + xs.first + xs.count];
                // ≤ 255 · src ≤ 255 · 2¹⁶ or 255 · 2·dst ≤ 255 · 2¹⁷: fits u32.
                let across: u32 = line
                    .iter()
                    .enumerate()
                    .map(|(kx, &p)| xs.weight(kx) as u32 * u32::from(p))
                    .sum();
                sum += u64::from(across) * ys.weight(ky);
            }
            // sum ≤ 255 · total, so the quotient is at most 255.
            *o = ((sum + half) / total) as u8;
        }
        Ok(())
    }

    /// The whole frame: `src` (`src_width · src_height` bytes, row-major)
    /// into `dst` (`dst_width · dst_height` bytes).
    pub fn frame(&self, src: &[u8], dst: &mut [u8]) -> Result<(), ResizeError> {
        let (sw, sh) = self.input_size();
        let (dw, dh) = self.output_size();
        for (buf, needed) in [(src.len(), sw * sh), (dst.len(), dw * dh)] {
            if buf != needed {
                return Err(ResizeError::BadBuffer { needed, given: buf });
            }
        }
        for (y, out) in dst.chunks_exact_mut(dw).enumerate() {
            self.row(y, src, 0, out)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    fn resize(src: &[u8], sw: usize, sh: usize, dw: usize, dh: usize) -> Vec<u8> {
        let mut out = vec![0; dw * dh];
        Resize::new(sw, sh, dw, dh)
            .unwrap()
            .frame(src, &mut out)
            .unwrap();
        out
    }

    fn texture(w: usize, h: usize) -> Vec<u8> {
        (0..w * h)
            .map(|i| ((i as u32).wrapping_mul(2_654_435_761) >> 24) as u8)
            .collect()
    }

    #[test]
    fn the_same_size_is_the_identity_and_flat_stays_flat() {
        let src = texture(13, 7);
        assert_eq!(resize(&src, 13, 7, 13, 7), src);
        for (dw, dh) in [(5, 3), (26, 14), (1, 1), (40, 2), (3, 21)] {
            assert!(
                resize(&[77; 13 * 7], 13, 7, dw, dh)
                    .iter()
                    .all(|&p| p == 77)
            );
        }
    }

    #[test]
    fn an_integer_factor_down_is_the_block_mean_rounded_half_up() {
        let src = texture(12, 8);
        let out = resize(&src, 12, 8, 4, 2);
        for (i, &o) in out.iter().enumerate() {
            let (bx, by) = (i % 4 * 3, i / 4 * 4);
            let sum: u32 = (by..by + 4)
                .flat_map(|y| (bx..bx + 3).map(move |x| (x, y)))
                .map(|(x, y)| u32::from(src[y * 12 + x]))
                .sum();
            assert_eq!(u32::from(o), (2 * sum + 12) / 24, "pixel {i}");
        }
    }

    #[test]
    fn area_weights_cover_each_source_pixel_once() {
        for (s, d) in [(7, 3), (10, 4), (5, 5), (9, 1), (100, 37)] {
            let axis = Axis { src: s, dst: d };
            let mut per_pixel = vec![0u64; s];
            for i in 0..d {
                let taps = axis.taps(i);
                let sum: u64 = (0..taps.count).map(|k| taps.weight(k)).sum();
                assert_eq!(sum, axis.total(), "{s}->{d} at {i}");
                for k in 0..taps.count {
                    per_pixel[taps.first + k] += taps.weight(k);
                }
            }
            assert!(per_pixel.iter().all(|&w| w == d as u64), "{s}->{d}");
        }
    }

    #[test]
    fn doubling_interpolates_between_centres() {
        // 2 -> 4: centres at -1/4, 1/4, 3/4, 5/4 of the source: 0 | 1/4 | 3/4 | 1.
        assert_eq!(resize(&[0, 200], 2, 1, 4, 1), [0, 50, 150, 200]);
        assert_eq!(resize(&[0, 200], 1, 2, 1, 4), [0, 50, 150, 200]);
        // Rounding half up: 1/4 of 2 is 0.5.
        assert_eq!(resize(&[0, 2], 2, 1, 4, 1), [0, 1, 2, 2]);
        // Mixed: down across, up down.
        let out = resize(&[0, 100, 200, 0], 2, 2, 1, 4);
        // Rows average to 50 and 100; 3/4 · 50 + 1/4 · 100 = 62.5 rounds up.
        assert_eq!(out, [50, 63, 88, 100]);
    }

    #[test]
    fn a_row_from_a_band_equals_the_row_from_the_frame() {
        let (sw, sh, dw, dh) = (31, 29, 12, 40);
        let src = texture(sw, sh);
        let r = Resize::new(sw, sh, dw, dh).unwrap();
        let whole = resize(&src, sw, sh, dw, dh);
        for y in 0..dh {
            let band = r.source_rows(y);
            let mut out = vec![0; dw];
            r.row(
                y,
                &src[band.start * sw..band.end * sw],
                band.start,
                &mut out,
            )
            .unwrap();
            assert_eq!(out, whole[y * dw..(y + 1) * dw], "row {y}");
        }
        let mut out = vec![0; dw];
        assert!(r.row(5, &src[..sw], 0, &mut out).is_err());
        assert!(Resize::new(0, 3, 2, 2).is_err());
        assert!(Resize::new(3, 3, MAX_SIDE + 1, 2).is_err());
        assert!(r.frame(&src[1..], &mut vec![0; dw * dh]).is_err());
    }

    proptest::proptest! {
        /// Any sizes: a weighted mean never leaves the source's range, and
        /// a row from a buffer of any length is a result, never a panic.
        #[test]
        fn any_resize_stays_in_range_and_never_panics(
            (sw, sh) in (1usize..40, 1usize..40),
            (dw, dh) in (1usize..60, 1usize..60),
            seed in 0u32..u32::MAX,
            cut in 0usize..2000,
            y in 0usize..80,
            first_row in 0usize..50,
        ) {
            let src: Vec<u8> = (0..sw * sh)
                .map(|i| ((i as u32 ^ seed).wrapping_mul(2_654_435_761) >> 24) as u8)
                .collect();
            let (lo, hi) = (*src.iter().min().unwrap(), *src.iter().max().unwrap());
            let out = resize(&src, sw, sh, dw, dh);
            proptest::prop_assert!(out.iter().all(|&p| (lo..=hi).contains(&p)));
            let r = Resize::new(sw, sh, dw, dh).unwrap();
            let mut row = vec![0; dw];
            let _ = r.row(y, &src[..cut.min(src.len())], first_row, &mut row);
        }
    }
}
