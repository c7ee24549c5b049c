//! Magnitudes to bytes (SPEC §4): `byte = min(255, ⌊x · k + ½⌋)`.

use fixed::types::{U16F16, U32F32};

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

impl Scaling {
    /// The byte maps of `|v_d|` and `|v_c|`; `extremes` is asked for the
    /// frame's extremes only when the mode needs them (however the caller
    /// gathers them: an engine pass, kept pixels, parallel strips).
    #[inline(always)]
    pub fn byte_scales<E>(
        self,
        extremes: impl FnOnce() -> Result<crate::ExtremesSink, E>,
    ) -> Result<(ByteScale, ByteScale), E> {
        Ok(match self {
            Scaling::Fixed { k_d, k_c } => (ByteScale::fixed(k_d), ByteScale::fixed(k_c)),
            Scaling::PerFrameMinMax => extremes()?.byte_scales(),
        })
    }
}

/// The largest min–max range treated as flat: `⌊1e-9 · 2³²⌋ = 4` Q32.32 steps.
pub const FLAT_RANGE_Q32: u64 = 4;

/// One channel's map from a Q32.32 magnitude to a byte:
/// `byte = min(255, ⌊x · gain / 2^frac + ½⌋)` with `x = (m − offset) >> shift`
/// in integer bits, so that `x · gain / 2^frac = (m − offset) · k`.
///
/// Bounds: `x < 2³²` (a larger `x` is a byte of 255 whatever the gain), and
/// `gain < 2³²`, so the product is one 32×32→64 multiply on every target.
/// A zero gain maps everything to 0 (its offset makes every `x` 0).
///
/// Where 255 starts (`below_255`) is prepared once, so that 32-bit targets
/// shift only the product's high word (no 64-bit shift by a variable
/// amount, see [`Self::byte`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ByteScale {
    offset: u64,
    shift: u32,
    gain: u32,
    /// Largest `m − offset` whose byte is below 255: `x` reaches the least
    /// `x` that makes 255 (at most 2³²) above it. `u64::MAX`: never.
    below_255: u64,
    frac: u32,
    /// Made by [`Self::fixed`] with a nonzero gain: `offset = 0`,
    /// `shift = 16`, `frac = 32`, which [`Self::byte`] takes as constants.
    fixed: bool,
}

impl ByteScale {
    #[inline(always)]
    fn new(offset: u64, shift: u32, gain: u32, frac: u32) -> Self {
        // Everything maps to 0: an offset no magnitude exceeds makes x = 0.
        let offset = if gain == 0 { u64::MAX } else { offset };
        // ⌊(x·g + 2^(f−1)) / 2^f⌋ ≥ 255 ⇔ x·g ≥ 509 · 2^(f−1); frac ≤ 55
        // (min–max: 32 bits of range + 23), so 509 · 2^54 < 2⁶³.
        let saturate = match gain {
            0 => 1 << 32,
            _ => (509u64 << (frac - 1))
                .div_ceil(u64::from(gain))
                .min(1 << 32),
        };
        // x ≥ saturate ⇔ m − offset ≥ saturate · 2^shift (2⁶⁴ or more: never).
        let below_255 = u64::try_from((u128::from(saturate) << shift) - 1).unwrap_or(u64::MAX);
        // Below `saturate`, `x · 2^(32 − frac) < 509 · 2³¹ / gain ≤ 2³²` needs
        // `gain ≥ 255`: min–max's gain is above 2³⁰, Fixed has frac = 32.
        debug_assert!(gain == 0 || frac >= 32 || gain >= 255);
        Self {
            offset,
            shift,
            gain,
            below_255,
            frac,
            fixed: false,
        }
    }

    /// `Fixed(k)`: `m` cut to 2⁻¹⁶ px (`x = m >> 16 < 2³²`: magnitudes stay
    /// below 2¹⁶ px) times `k` in Q16.16 (`frac = 32`), so the byte is
    /// `min(255, ⌊m·k + ½⌋)` except within `k · 2⁻¹⁶` of a tie.
    #[inline(always)]
    pub fn fixed(k: U16F16) -> Self {
        // A zero gain keeps the general form (its offset maps all to 0).
        Self {
            fixed: k != U16F16::ZERO,
            ..Self::new(0, 16, k.to_bits(), 32)
        }
    }

    /// Per-frame min–max from the frame's extremes (`min ≤ max`): the range
    /// cut to 32 significant bits `r`, `gain = round(255 · 2^frac / r)` with
    /// `frac = bitlen(r) + 23` (so `2³⁰ < gain < 2³²`): the byte differs from
    /// the exact formula only within 2⁻²⁰ of a tie. A range below 1e-9 px
    /// (SPEC §4: residue, not motion; 4 Q32.32 steps or fewer) maps every
    /// magnitude to 0.
    pub fn min_max(min: U32F32, max: U32F32) -> Self {
        let (lo, hi) = (min.to_bits(), max.to_bits());
        let range = hi.saturating_sub(lo);
        let shift = (u64::BITS - range.leading_zeros()).saturating_sub(32);
        let r = range >> shift;
        let frac = u64::BITS - r.leading_zeros() + 23;
        let gain = match range {
            0..=FLAT_RANGE_Q32 => 0,
            // < 255 · 2^(b+23) / 2^(b−1) = 255 · 2²⁴ < 2³².
            _ => (((255u64 << frac) + r / 2) / r) as u32,
        };
        Self::new(lo, shift, gain, frac)
    }

    /// The byte of magnitude `m`: `⌊(x·g + 2^(f−1)) / 2^f⌋` from the
    /// product's high word, so no 64-bit shift by a variable amount (which
    /// 32-bit targets build from several instructions).
    #[inline(always)]
    pub fn byte(&self, m: U32F32) -> u8 {
        if self.fixed && !crate::VECTOR_ROWS {
            return self.fixed_byte(m);
        }
        let d = m.to_bits().saturating_sub(self.offset);
        if d > self.below_255 {
            return 255;
        }
        let x = (d >> self.shift) as u32;
        // With F = max(frac, 32), x is raised by 32 − min(frac, 32) bits;
        // x < saturate ≤ 2³², and that raised x < 2³² (see `new`):
        // ⌊(x·2^(F−frac)·g + 2^(F−1)) / 2^F⌋ = ⌊(x·g + 2^(f−1)) / 2^f⌋ ≤ 254,
        // the sum below 509 · 2⁵⁴ + 2⁵⁴ < 2⁶⁴; only its high word is shifted.
        let wide = self.frac.max(32);
        let raised = x << (wide - self.frac);
        let product = u64::from(raised) * u64::from(self.gain) + (1 << (wide - 1));
        ((product >> 32) as u32 >> (wide - 32)) as u8
    }

    /// [`Self::byte`] of `N` magnitudes, in the form vector lanes take
    /// ([`rgb_batch`](crate::rgb_batch): the RGB sink where rows take lanes,
    /// the host's per-frame min–max byte step): every step in 64-bit lanes with
    /// shifts common to all lanes, no early return. Where `d ≤ below_255`,
    /// `x = (d >> shift) << (wide − frac) < 2³²` as in [`Self::byte`], so its
    /// low word is all of it (one 32×32→64 multiply, `vpmuludq`) and
    /// `(x·g + 2^(wide−1)) >> wide` is the high word shifted by
    /// `wide − 32`; above, the lane's value is unused (wrapping).
    #[inline(always)]
    pub fn bytes<const N: usize>(&self, m: &[U32F32; N]) -> [u8; N] {
        let wide = self.frac.max(32);
        let (up, half) = (wide - self.frac, 1u64 << (wide - 1));
        let gain = u64::from(self.gain);
        let mut out = [0u8; N];
        // Selections as masks (all ones or zero), which lanes take as they
        // are; a branch here kept the loop scalar.
        let mask = |condition: bool| 0u64.wrapping_sub(u64::from(condition));
        for (out, m) in out.iter_mut().zip(m) {
            let m = m.to_bits();
            let d = m.wrapping_sub(self.offset) & mask(m >= self.offset);
            let x = ((d >> self.shift) << up) & u64::from(u32::MAX);
            // A saturated lane's product is all ones: `≥ 2⁹ − 1` after the
            // shift (`wide ≤ 55`), 255 after the cap, which is 32-bit wide.
            let product = (x * gain).wrapping_add(half) | mask(d > self.below_255);
            *out = ((product >> wide) as u32).min(255) as u8;
        }
        out
    }

    /// [`Self::byte`] of a [`Self::fixed`] scale, its constants known: no
    /// offset, a constant shift, the product's high word. On the M4 (where
    /// the sink runs in the engine's loop, short of registers) 56 → 20
    /// instructions per pixel for the two bytes (`scripts/embedded-check`).
    /// Not where the row loops vectorise: the branch kept the x86-64 AVX2
    /// pass's byte loop scalar (+12.6 per pixel, `scripts/profile-stages`).
    #[inline(always)]
    fn fixed_byte(&self, m: U32F32) -> u8 {
        let m = m.to_bits();
        if m > self.below_255 {
            return 255;
        }
        // `fixed` made `below_255 < 2⁴⁸`, so `x < 2³²`; `x·g + 2³¹ < 2⁶⁴`.
        let x = (m >> 16) as u32;
        ((u64::from(x) * u64::from(self.gain) + (1 << 31)) >> 32) as u8
    }
}

/// The extremes of a magnitude over a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Extremes {
    /// Smallest value seen.
    pub min: U32F32,
    /// Largest value seen.
    pub max: U32F32,
}

impl Extremes {
    /// Nothing seen yet (`min > max`).
    pub const EMPTY: Self = Self {
        min: U32F32::MAX,
        max: U32F32::ZERO,
    };

    /// Take one more value into account.
    #[inline(always)]
    pub fn add(&mut self, m: U32F32) {
        self.min = self.min.min(m);
        self.max = self.max.max(m);
    }

    /// Take every value of `row` into account, both extremes in one loop.
    /// Compared as signed integers with the top bit flipped (the same
    /// order): AVX2 has a signed 64-bit compare only, and the flip is then
    /// once per value instead of once per value and extreme.
    #[inline(always)]
    pub fn add_all(&mut self, row: &[U32F32]) {
        const FLIP: u64 = 1 << 63;
        let signed = |m: U32F32| (m.to_bits() ^ FLIP) as i64;
        let (mut min, mut max) = (signed(self.min), signed(self.max));
        for &m in row {
            let m = signed(m);
            (min, max) = (min.min(m), max.max(m));
        }
        let unsigned = |m: i64| U32F32::from_bits(m as u64 ^ FLIP);
        (self.min, self.max) = (unsigned(min), unsigned(max));
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

    /// Exact for magnitudes on the 2⁻¹⁶ px grid, within one elsewhere.
    #[test]
    fn fixed_gain_rounds_like_the_spec() {
        for k in [0.0, 0.5, 1.0, 8.0, 32.0, 1000.25, 65535.0] {
            let scale = ByteScale::fixed(U16F16::from_num(k));
            let bits = [
                0u64,
                1,
                4095,
                1 << 31,
                65535 << 16,
                1 << 32,
                1 << 40,
                0xFF_0000_0000,
                1 << 47,
                (1 << 48) - 1,
            ];
            for bits in bits.into_iter().filter(|&b| b < 1 << 48) {
                let grid = U32F32::from_bits(bits & !0xffff);
                assert_eq!(
                    scale.byte(grid),
                    reference(grid.to_num(), k),
                    "k={k} m={grid}"
                );
                let m = U32F32::from_bits(bits);
                let want = reference(m.to_num(), k);
                assert!(scale.byte(m).abs_diff(want) <= 1, "k={k} m={m}");
            }
        }
    }

    /// The byte by its definition: a 64-bit shift by `frac`, an `x` of 2³²
    /// or more 255 whatever the gain.
    fn by_definition(scale: &ByteScale, m: U32F32) -> u8 {
        let x = m.to_bits().saturating_sub(scale.offset) >> scale.shift;
        let Ok(x) = u32::try_from(x) else {
            return 255;
        };
        let product = u64::from(x) * u64::from(scale.gain);
        (((product >> (scale.frac - 1)) + 1) >> 1).min(255) as u8
    }

    /// The high-word byte (and its lane form) is the definition's for every
    /// scale the two constructors make, at random magnitudes and around
    /// saturation.
    #[test]
    fn byte_is_the_definition() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        for case in 0..20_000 {
            let scale = if case % 2 == 0 {
                ByteScale::fixed(U16F16::from_bits(next() as u32 >> (next() % 32)))
            } else {
                let lo = next() >> (next() % 64);
                let hi = lo.saturating_add(next() >> (next() % 64));
                ByteScale::min_max(U32F32::from_bits(lo), U32F32::from_bits(hi))
            };
            let edge = scale.offset.wrapping_add(scale.below_255).wrapping_add(1);
            let ms = [
                next(),
                next() >> (next() % 64),
                scale.offset.wrapping_add(next() >> (next() % 64)),
                edge,
                edge.wrapping_sub(1),
                edge.wrapping_sub(1 << scale.shift),
                edge.wrapping_add(1 << scale.shift),
                0,
                u64::MAX,
            ];
            let ms = ms.map(U32F32::from_bits);
            let lanes = scale.bytes(&ms);
            for (m, lane) in ms.into_iter().zip(lanes) {
                let want = by_definition(&scale, m);
                assert_eq!(scale.byte(m), want, "{scale:?} m={m}");
                assert_eq!(lane, want, "lanes: {scale:?} m={m}");
                if scale.fixed {
                    assert_eq!(scale.fixed_byte(m), want, "{scale:?} m={m}");
                }
            }
        }
    }

    /// A row's extremes in one call are those of its values one by one,
    /// across the top bit (the flipped compare) and from empty.
    #[test]
    fn extremes_of_a_row_are_its_values_one_by_one() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for len in 0..40 {
            let row: std::vec::Vec<U32F32> = (0..len)
                .map(|_| {
                    s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                    U32F32::from_bits(s >> (s % 61))
                })
                .collect();
            let (mut by_row, mut by_value) = (Extremes::EMPTY, Extremes::EMPTY);
            by_row.add_all(&row[..len / 2]);
            by_row.add_all(&row[len / 2..]);
            for &m in &row {
                by_value.add(m);
            }
            assert_eq!(by_row, by_value, "{row:?}");
        }
    }

    #[test]
    fn min_max_spans_0_to_255() {
        let (lo, hi) = (U32F32::from_num(1.25), U32F32::from_num(19.5));
        let scale = ByteScale::min_max(lo, hi);
        assert_eq!(scale.byte(lo), 0);
        assert_eq!(scale.byte(hi), 255);
        for mid in [2.0, 10.0, 10.376, 17.125] {
            let byte = scale.byte(U32F32::from_num(mid));
            assert_eq!(byte, reference(mid - 1.25, 255.0 / 18.25), "{mid}");
        }
        let flat = ByteScale::min_max(hi, hi);
        assert_eq!(flat.byte(hi), 0);
        // Below 1e-9 px of range: flat. Just above: full scale.
        let residue = ByteScale::min_max(U32F32::from_bits(7), U32F32::from_bits(11));
        assert_eq!(residue.byte(U32F32::from_bits(11)), 0);
        let tiny = ByteScale::min_max(U32F32::from_bits(7), U32F32::from_bits(12));
        assert_eq!(tiny.byte(U32F32::from_bits(12)), 255);
        assert_eq!(tiny.byte(U32F32::from_bits(7)), 0);
        assert_eq!(tiny.byte(U32F32::MAX), 255);
        // A range of 0.01 px keeps full byte precision.
        let (lo, hi) = (U32F32::from_num(0.0003), U32F32::from_num(0.0103));
        let small = ByteScale::min_max(lo, hi);
        for i in 0..=1000 {
            let m = U32F32::from_num(0.0003 + 0.01 * i as f64 / 1000.0);
            let want = (m - lo).to_num::<f64>() * 255.0 / (hi - lo).to_num::<f64>();
            assert!((small.byte(m) as f64 - want).abs() <= 0.5 + 1e-6, "{m}");
        }
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
        self.scales = self.seen.byte_scales();
        self.seen = crate::ExtremesSink::default();
    }
}
