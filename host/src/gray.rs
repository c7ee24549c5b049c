//! An 8-bit gray frame, and the BT.601 luma that turns colour into one
//! (SPEC §1).

use crate::HostError;

/// An 8-bit gray frame: `height` rows of `width` pixels, row-major, packed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Gray {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width · height` pixels, row `y` at `y · width`.
    pub pixels: Vec<u8>,
}

impl Gray {
    /// A frame from its pixels; refused unless `pixels.len() == width · height`
    /// and both sides are at least 1.
    pub fn new(width: usize, height: usize, pixels: Vec<u8>) -> Result<Self, HostError> {
        if width == 0 || height == 0 || width.checked_mul(height) != Some(pixels.len()) {
            return Err(HostError::BadFrame {
                width,
                height,
                len: pixels.len(),
            });
        }
        Ok(Self {
            width,
            height,
            pixels,
        })
    }

    /// A frame from packed RGB8 pixels (`3 · width · height` bytes), each
    /// converted with [`luma_bt601`]. Same checks as [`Gray::new`].
    pub fn from_rgb8(width: usize, height: usize, rgb: &[u8]) -> Result<Self, HostError> {
        if !rgb.len().is_multiple_of(3) {
            // Not whole pixels: report the pixel count rounded up, which cannot match.
            return Err(HostError::BadFrame {
                width,
                height,
                len: rgb.len().div_ceil(3),
            });
        }
        let pixels = rgb
            .chunks_exact(3)
            .map(|p| luma_bt601(p[0], p[1], p[2]))
            .collect();
        Self::new(width, height, pixels)
    }

    /// `(width, height)`.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// The pixel at `(x, y)`, or the nearest one inside the frame when
    /// `(x, y)` lies outside it (SPEC §2, replicate border).
    pub fn clamped(&self, x: isize, y: isize) -> u8 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.pixels[y * self.width + x]
    }
}

/// BT.601 luma, `Y = ⌊0.299 R + 0.587 G + 0.114 B + ½⌋` (SPEC §1), in exact
/// integer arithmetic: the f64 expression misrounds some exact halves.
pub fn luma_bt601(r: u8, g: u8, b: u8) -> u8 {
    let sum = 299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b);
    // sum ≤ 255 000, so the quotient is at most 255.
    ((sum + 500) / 1000) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SPEC's formula over exact rationals: `Y = ⌊(299R + 587G + 114B)/1000 + ½⌋`,
    /// i.e. the largest `y` with `1000·y ≤ 299R + 587G + 114B + 500`.
    fn exact(r: u8, g: u8, b: u8) -> u8 {
        let twice = 2 * (299 * u64::from(r) + 587 * u64::from(g) + 114 * u64::from(b)) + 1000;
        (0..=255u8)
            .rev()
            .find(|&y| 2000 * u64::from(y) <= twice)
            .unwrap()
    }

    #[test]
    fn bt601_matches_the_exact_formula_on_every_colour() {
        let mut float_misses = 0u32;
        for r in 0..=255u8 {
            for g in 0..=255u8 {
                for b in 0..=255u8 {
                    let y = luma_bt601(r, g, b);
                    if r == g && g == b || (r ^ g ^ b) & 0x0f == 0 {
                        // The slow reference on a sixteenth of the cube plus the grays.
                        assert_eq!(y, exact(r, g, b), "rgb = ({r}, {g}, {b})");
                    }
                    let f = 0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(b);
                    float_misses += u32::from((f + 0.5).floor() as u8 != y);
                }
            }
        }
        // Gray stays gray, and the extremes are exact.
        assert_eq!(luma_bt601(0, 0, 0), 0);
        assert_eq!(luma_bt601(255, 255, 255), 255);
        assert_eq!(luma_bt601(255, 0, 0), 76); // 76.245
        assert_eq!(luma_bt601(0, 255, 0), 150); // 149.685
        assert_eq!(luma_bt601(0, 0, 255), 29); // 29.07
        assert_eq!(luma_bt601(0, 0, 25), 3); // 2.85
        println!(
            "f64 formula differs from the exact integer one on {float_misses} of 2^24 colours"
        );
    }

    #[test]
    fn exact_halves_round_up() {
        // A colour whose luma is exactly k + ½ must give k + 1.
        let half = (0..=255u8)
            .flat_map(|r| (0..=255u8).map(move |g| (r, g)))
            .flat_map(|(r, g)| (0..=255u8).map(move |b| (r, g, b)))
            .find(|&(r, g, b)| {
                (299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b)) % 1000 == 500
            })
            .expect("an exact half exists");
        let (r, g, b) = half;
        let sum = 299 * u32::from(r) + 587 * u32::from(g) + 114 * u32::from(b);
        assert_eq!(
            u32::from(luma_bt601(r, g, b)),
            sum / 1000 + 1,
            "rgb = {half:?}"
        );
    }

    #[test]
    fn clamped_reads_replicate_the_border() {
        let g = Gray::new(3, 2, vec![1, 2, 3, 4, 5, 6]).unwrap();
        assert_eq!(g.clamped(-5, -5), 1);
        assert_eq!(g.clamped(7, 0), 3);
        assert_eq!(g.clamped(1, 9), 5);
        assert_eq!(g.clamped(9, 9), 6);
        assert!(Gray::new(3, 2, vec![0; 5]).is_err());
        assert!(Gray::new(0, 2, vec![]).is_err());
        let rgb = Gray::from_rgb8(2, 1, &[255, 0, 0, 10, 10, 10]).unwrap();
        assert_eq!(rgb.pixels, vec![76, 10]);
    }
}
