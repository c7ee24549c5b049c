//! Borrowed input frames: two 8-bit gray images of one size, with a stride.

use crate::{Config, Error};

/// One 8-bit gray frame borrowed from the caller: `height` rows of `width`
/// pixels, row `y` starting at `y · stride`.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    pixels: &'a [u8],
    width: usize,
    height: usize,
    stride: usize,
}

impl<'a> Frame<'a> {
    /// Check that `pixels` holds `height` rows of `width` pixels at `stride`.
    pub fn new(
        pixels: &'a [u8],
        width: usize,
        height: usize,
        stride: usize,
    ) -> Result<Self, Error> {
        if width == 0 || height == 0 {
            return Err(Error::EmptyFrame);
        }
        if stride < width {
            return Err(Error::StrideTooSmall);
        }
        let needed = (height - 1)
            .checked_mul(stride)
            .and_then(|n| n.checked_add(width))
            .ok_or(Error::FrameTooLarge)?;
        if pixels.len() < needed {
            return Err(Error::BufferTooShort {
                needed,
                got: pixels.len(),
            });
        }
        Ok(Self {
            pixels,
            width,
            height,
            stride,
        })
    }

    /// A tightly packed frame (`stride = width`).
    pub fn packed(pixels: &'a [u8], width: usize, height: usize) -> Result<Self, Error> {
        Self::new(pixels, width, height, width)
    }

    /// Width in pixels.
    pub const fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub const fn height(&self) -> usize {
        self.height
    }

    /// Row `y` clamped into the frame (SPEC §2: reads outside replicate the
    /// nearest pixel). Always `width` long.
    pub fn clamped_row(&self, y: isize) -> &'a [u8] {
        // max/min, not clamp: clamp asserts min ≤ max, a panic path.
        let y = y.min(self.height as isize - 1).max(0) as usize;
        let start = y * self.stride;
        // In range by construction (`new` checked `(h−1)·stride + w ≤ len`).
        self.pixels.get(start..start + self.width).unwrap_or(&[])
    }
}

/// Frames `fⁿ` (previous) and `fⁿ⁺¹` (next) of one size, checked against a
/// [`Config`].
#[derive(Clone, Copy, Debug)]
pub struct FramePair<'a> {
    prev: Frame<'a>,
    next: Frame<'a>,
}

impl<'a> FramePair<'a> {
    /// Pair two frames; both must have the configuration's size.
    pub fn new(config: &Config, prev: Frame<'a>, next: Frame<'a>) -> Result<Self, Error> {
        let size = (config.width(), config.height());
        if (prev.width, prev.height) != size || (next.width, next.height) != size {
            return Err(Error::SizeMismatch);
        }
        Ok(Self { prev, next })
    }

    /// Pair two tightly packed frames of the configuration's size.
    pub fn packed(config: &Config, prev: &'a [u8], next: &'a [u8]) -> Result<Self, Error> {
        let (w, h) = (config.width(), config.height());
        Self::new(
            config,
            Frame::packed(prev, w, h)?,
            Frame::packed(next, w, h)?,
        )
    }

    /// Frame `fⁿ`.
    pub const fn prev(&self) -> &Frame<'a> {
        &self.prev
    }

    /// Frame `fⁿ⁺¹`.
    pub const fn next(&self) -> &Frame<'a> {
        &self.next
    }
}
