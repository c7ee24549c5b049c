//! Magnitudes to bytes (SPEC §4): `byte = min(255, ⌊x · k + ½⌋)`.

use fixed::types::U16F16;

/// How the two magnitudes become the representation's R and G bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Scaling {
    /// `x = m − min(m)`, `k = 255 / (max(m) − min(m))` over the whole frame
    /// (all zero when the frame's magnitude is constant). Needs the frame's
    /// extremes first, so it costs a second pass over the pair.
    PerFrameMinMax,
    /// `x = m`, a constant gain per channel: streams in one pass.
    Fixed {
        /// Gain of `|v_d|` (R).
        k_d: U16F16,
        /// Gain of `|v_c|` (G).
        k_c: U16F16,
    },
}

/// One channel's affine map from a Q16.16 magnitude to a byte:
/// `byte = min(255, ⌊x · gain / 2³² + ½⌋)` with `x` the Q16.16 bits of
/// `m − offset` and `gain = k · 2¹⁶` (`x · gain / 2³²` is then `(m − offset) · k`).
///
/// Bound: `x < 2³²` and below `limit = ⌈2⁴⁰ / gain⌉`, so the product stays
/// under `2⁴⁰ + gain < 2⁶⁴` (`gain ≤ 255 · 2³²`); at or above `limit` the
/// byte is 255.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ByteScale {
    offset: u32,
    gain: u64,
    limit: u64,
}

impl ByteScale {
    fn new(offset: u32, gain: u64) -> Self {
        let limit = match gain {
            0 => u64::MAX,
            g => (1u64 << 40).div_ceil(g),
        };
        Self {
            offset,
            gain,
            limit,
        }
    }

    /// `Fixed(k)`: exact, since `m` and `k` are both Q16.16.
    pub fn fixed(k: U16F16) -> Self {
        Self::new(0, u64::from(k.to_bits()))
    }

    /// Per-frame min–max from the frame's extremes (`min ≤ max`): `gain =
    /// round(255 · 2³² / range)` with `range` in Q16.16 bits, so the byte
    /// differs from the exact formula only within 2⁻²⁴ of a rounding tie.
    pub fn min_max(min: U16F16, max: U16F16) -> Self {
        let (lo, hi) = (min.to_bits(), max.to_bits());
        let range = u64::from(hi.saturating_sub(lo));
        let gain = match range {
            0 => 0,
            r => ((255u64 << 32) + r / 2) / r,
        };
        Self::new(lo, gain)
    }

    /// The byte of magnitude `m`.
    #[inline(always)]
    pub fn byte(&self, m: U16F16) -> u8 {
        let x = u64::from(m.to_bits().saturating_sub(self.offset));
        if x >= self.limit {
            return 255;
        }
        (((x * self.gain) >> 31).div_ceil(2)).min(255) as u8
    }
}

/// The extremes of a magnitude over a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Extremes {
    /// Smallest value seen.
    pub min: U16F16,
    /// Largest value seen.
    pub max: U16F16,
}

impl Extremes {
    /// Nothing seen yet (`min > max`).
    pub const EMPTY: Self = Self {
        min: U16F16::MAX,
        max: U16F16::ZERO,
    };

    /// Take one more value into account.
    #[inline(always)]
    pub fn add(&mut self, m: U16F16) {
        self.min = self.min.min(m);
        self.max = self.max.max(m);
    }

    /// Merge the extremes of another part of the frame.
    pub fn merge(&mut self, other: Extremes) {
        self.min = self.min.min(other.min);
        self.max = self.max.max(other.max);
    }

    /// The per-frame min–max byte map of these extremes.
    pub fn byte_scale(&self) -> ByteScale {
        ByteScale::min_max(self.min, self.max)
    }
}

impl Default for Extremes {
    fn default() -> Self {
        Self::EMPTY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(x: f64, k: f64) -> u8 {
        (x * k + 0.5).floor().min(255.0) as u8
    }

    #[test]
    fn fixed_gain_rounds_like_the_spec() {
        for k in [0.0, 0.5, 1.0, 8.0, 32.0, 1000.25, 65535.0] {
            let scale = ByteScale::fixed(U16F16::from_num(k));
            for bits in [
                0u32,
                1,
                4095,
                4096,
                32768,
                65535,
                65536,
                1 << 20,
                16_711_680,
                u32::MAX,
            ] {
                let m = U16F16::from_bits(bits);
                assert_eq!(scale.byte(m), reference(m.to_num(), k), "k={k} m={m}");
            }
        }
    }

    #[test]
    fn min_max_spans_0_to_255() {
        let (lo, hi) = (U16F16::from_num(1.25), U16F16::from_num(19.5));
        let scale = ByteScale::min_max(lo, hi);
        assert_eq!(scale.byte(lo), 0);
        assert_eq!(scale.byte(hi), 255);
        for mid in [2.0, 10.0, 10.376, 17.125] {
            let byte = scale.byte(U16F16::from_num(mid));
            assert_eq!(byte, reference(mid - 1.25, 255.0 / 18.25), "{mid}");
        }
        let flat = ByteScale::min_max(hi, hi);
        assert_eq!(flat.byte(hi), 0);
        let tiny = ByteScale::min_max(U16F16::from_bits(7), U16F16::from_bits(8));
        assert_eq!(tiny.byte(U16F16::from_bits(8)), 255);
        assert_eq!(tiny.byte(U16F16::MAX), 255);
    }
}

/// Streaming min–max (not the SPEC's `PerFrameMinMax`): each frame's bytes
/// use the extremes of the frame before it, so bytes leave in one pass. The
/// first frame uses the scales given at construction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PreviousFrameMinMax {
    scales: (ByteScale, ByteScale),
    seen: crate::ExtremesSink,
}

impl PreviousFrameMinMax {
    /// Start with these scales of `|v_d|` and `|v_c|` for the first frame.
    pub fn new(first_d: ByteScale, first_c: ByteScale) -> Self {
        Self {
            scales: (first_d, first_c),
            seen: crate::ExtremesSink::default(),
        }
    }

    /// The scales of `|v_d|` and `|v_c|` for the frame being computed.
    pub fn scales(&self) -> (ByteScale, ByteScale) {
        self.scales
    }

    /// Feed this sink every pixel of the frame being computed.
    pub fn tracker(&mut self) -> &mut crate::ExtremesSink {
        &mut self.seen
    }

    /// The frame is complete: its extremes become the next frame's scales.
    pub fn end_frame(&mut self) {
        self.scales = (self.seen.m_d.byte_scale(), self.seen.m_c.byte_scale());
        self.seen = crate::ExtremesSink::default();
    }
}
