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

/// The largest min–max range treated as flat (SPEC §4): 1e-9 px.
pub const FLAT_RANGE: f32 = 1e-9;

/// One channel's map from a magnitude to a byte,
/// `byte = min(255, ⌊(m − offset) · gain + ½⌋)` in `f32` (0 below
/// `offset`): the SPEC's `min(255, ⌊x · k + ½⌋)` with one rounding in each
/// of the subtraction, the product and the sum, so the byte differs from
/// the exact formula only within a few units of 2⁻²⁴ of a tie. One
/// expression without a branch: rows take it in vector lanes, and the
/// scalar boards take it in a few FPU instructions.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ByteScale {
    offset: f32,
    gain: f32,
}

impl ByteScale {
    /// `Fixed(k)`: `x = m`, the gain `k` rounded to `f32`.
    #[inline(always)]
    pub fn fixed(k: U16F16) -> Self {
        Self {
            offset: 0.0,
            gain: k.to_num::<f32>(),
        }
    }

    /// Per-frame min–max from the frame's extremes: `x = m − min`,
    /// `k = 255 / (max − min)`. A range below 1e-9 px (`FLAT_RANGE`; SPEC
    /// §4: residue, not motion) maps every magnitude to 0, as does an empty
    /// range (`min > max`).
    pub fn min_max(min: f32, max: f32) -> Self {
        let range = max - min;
        // Written so that a NaN (which no magnitude is) also maps to 0.
        let gain = if range >= FLAT_RANGE {
            255.0 / range
        } else {
            0.0
        };
        Self { offset: min, gain }
    }

    /// The byte of magnitude `m`: `⌊t⌋` of `t = (m − offset) · gain + ½`
    /// clamped to `[0, 255]` (truncated toward zero).
    #[inline(always)]
    pub fn byte(&self, m: f32) -> u8 {
        crate::kernels::fpu::byte((m - self.offset) * self.gain + 0.5)
    }

    /// `[offset, gain]`: [`ByteScale::byte`] is `⌊t⌋` of
    /// `t = (m − offset) · gain + ½` (each operation rounded to `f32`)
    /// clamped to `[0, 255]`, for a byte step written elsewhere (the host's,
    /// a kernel set's in `kernels/`).
    #[inline(always)]
    pub fn parts(&self) -> [f32; 2] {
        [self.offset, self.gain]
    }
}

/// The extremes of a magnitude over a frame.
///
/// Magnitudes are non-negative (the engine's are `+0.0` or positive, never
/// NaN), and on those the order of `f32` values is the order of their bits
/// as `u32`: the extremes compare bits, which vector lanes take as integer
/// minima and maxima (a float minimum over a row does not vectorise: the
/// compiler must keep NaN's order).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Extremes {
    /// Smallest value seen.
    pub min: f32,
    /// Largest value seen.
    pub max: f32,
}

impl Extremes {
    /// Nothing seen yet (`min > max`).
    pub const EMPTY: Self = Self {
        min: f32::MAX,
        max: 0.0,
    };

    /// Take one more value into account.
    #[inline(always)]
    pub fn add(&mut self, m: f32) {
        self.add_all(&[m]);
    }

    /// Take every value of `row` into account, both extremes in one loop.
    #[inline(always)]
    pub fn add_all(&mut self, row: &[f32]) {
        let (mut min, mut max) = (self.min.to_bits(), self.max.to_bits());
        for m in row {
            let m = m.to_bits();
            (min, max) = (min.min(m), max.max(m));
        }
        (self.min, self.max) = (f32::from_bits(min), f32::from_bits(max));
    }

    /// Merge the extremes of another part of the frame.
    pub fn merge(&mut self, other: Extremes) {
        let bits = |a: f32, b: f32| (a.to_bits(), b.to_bits());
        let (min, other_min) = bits(self.min, other.min);
        let (max, other_max) = bits(self.max, other.max);
        self.min = f32::from_bits(min.min(other_min));
        self.max = f32::from_bits(max.max(other_max));
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
        (x * k + 0.5).floor().clamp(0.0, 255.0) as u8
    }

    /// Within one of the definition everywhere, and equal to it except
    /// within 2⁻²⁰ (relative) of a tie.
    #[test]
    fn fixed_gain_rounds_like_the_spec() {
        let mut s = 0x9e37_79b9u32;
        for k in [0.0, 0.5, 1.0, 8.0, 32.0, 1000.25, 65535.0] {
            let scale = ByteScale::fixed(U16F16::from_num(k));
            for _ in 0..20_000 {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                let m = f32::from_bits(s & 0x3FFF_FFFF) * 1e-20;
                let (got, want) = (scale.byte(m), reference(f64::from(m), k));
                assert!(got.abs_diff(want) <= 1, "k={k} m={m}");
                let t = f64::from(m) * k + 0.5;
                if (t - t.round()).abs() > t * 2f64.powi(-20) {
                    assert_eq!(got, want, "k={k} m={m}");
                }
            }
            assert_eq!(scale.byte(0.0), 0);
            assert_eq!(scale.byte(f32::MAX), if k == 0.0 { 0 } else { 255 });
        }
    }

    /// A row's extremes in one call are those of its values one by one,
    /// and from empty.
    #[test]
    fn extremes_of_a_row_are_its_values_one_by_one() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for len in 0..40 {
            let row: std::vec::Vec<f32> = (0..len)
                .map(|_| {
                    s = s.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                    f32::from_bits((s >> 33) as u32 & 0x7F7F_FFFF)
                })
                .collect();
            let (mut by_row, mut by_value) = (Extremes::EMPTY, Extremes::EMPTY);
            by_row.add_all(&row[..len / 2]);
            by_row.add_all(&row[len / 2..]);
            for &m in &row {
                by_value.add(m);
            }
            assert_eq!(by_row, by_value, "{row:?}");
            let mut merged = Extremes::EMPTY;
            merged.merge(by_row);
            assert_eq!(merged, by_row, "{row:?}");
        }
    }

    #[test]
    fn min_max_spans_0_to_255() {
        let (lo, hi) = (1.25f32, 19.5f32);
        let scale = ByteScale::min_max(lo, hi);
        assert_eq!(scale.byte(lo), 0);
        assert_eq!(scale.byte(hi), 255);
        for mid in [2.0f32, 10.0, 10.376, 17.125] {
            let byte = scale.byte(mid);
            assert_eq!(
                byte,
                reference(f64::from(mid) - 1.25, 255.0 / 18.25),
                "{mid}"
            );
        }
        assert_eq!(scale.byte(0.5), 0, "below the minimum");
        assert_eq!(scale.byte(1e30), 255, "above the maximum");
        let flat = ByteScale::min_max(hi, hi);
        assert_eq!(flat.byte(hi), 0);
        assert_eq!(Extremes::EMPTY.byte_scale().byte(3.0), 0);
        // Below 1e-9 px of range: flat. Just above: full scale.
        let residue = ByteScale::min_max(7e-9, 7.9e-9);
        assert_eq!(residue.byte(7.9e-9), 0);
        let tiny = ByteScale::min_max(7e-9, 8.1e-9);
        assert_eq!(tiny.byte(8.1e-9), 255);
        assert_eq!(tiny.byte(7e-9), 0);
        // A range of 0.01 px keeps full byte precision.
        let (lo, hi) = (0.0003f32, 0.0103f32);
        let small = ByteScale::min_max(lo, hi);
        for i in 0..=1000 {
            let m = 0.0003 + 0.01 * i as f32 / 1000.0;
            let want = f64::from(m - lo) * 255.0 / f64::from(hi - lo);
            assert!((f64::from(small.byte(m)) - want).abs() <= 0.5 + 1e-4, "{m}");
        }
    }
}

/// Streaming min–max (not the SPEC's `PerFrameMinMax`): each frame's bytes
/// use the extremes of the frame before it, so bytes leave in one pass. The
/// first frame uses the scales given at construction.
#[derive(Clone, Copy, Debug, PartialEq)]
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
