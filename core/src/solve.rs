//! Per-pixel integer arithmetic after the stencils: the regularised 2×2
//! solve (SPEC §3 step 9), the fields in Q16.16 pixels and the magnitudes
//! in Q32.32 pixels.
//!
//! Every routine is a fixed sequence of integer operations on 32-bit
//! operands with 64-bit products: shifts, multiplies, one exact reciprocal
//! and exact square roots of integers below 2⁵⁰. Exact floors make the
//! result independent of how a target computes them (hardware divide,
//! Newton steps, or an `f64` divide or root, which is exact in that range).
//!
//! Formats (`·2^e` marks a per-pixel exponent, a block float):
//!
//! | quantity | form | bound |
//! |---|---|---|
//! | `a4 = 4A + Λ4`, `c4` | i32 | `4 · 266 342 400 + 2³⁰ < 2³¹` |
//! | `b4 = 4B` | i32 | `|b4| ≤ √(a4·c4) < 2³⁰·…`, `|4B| ≤ 2³⁰` |
//! | `det = a4·c4 − b4²` | u64 | `Λ4² ≤ det < 2⁶²` (Cauchy–Schwarz: `B² ≤ AC`) |
//! | `P = Ph·2¹⁴ + Pl`, `Q` | i64 | `256 · 1020 · 2²⁷ < 2⁴⁵` |
//! | `P′, Q′ = (P, Q) / 2^τ` toward zero | i32 range | `< 2³¹` |
//! | `N = (c4·P′ − b4·Q′, a4·Q′ − b4·P′)` | i64 | `< 2⁶² + 2⁶¹` |
//! | `rd = ⌊(2⁶³−1) / top32(det)⌋` | u32 | `[2³¹, 2³²)`, `1/det ≈ rd · 2^(−31−e)` |
//! | `r·2^μ = √(x² + y²)`, `r = ⌊√(x′² + y′²)⌋` | u32 | `x′, y′ < 2²⁴`, `r ∈ [2²³, 2^24.5)` |
//!
//! `v_d = N · 2^τ / det · 2^σ · s / 192` (see `params`). Relative errors:
//! `v_d` components about 2⁻²⁹, magnitudes about 2⁻²² (the root's floor at
//! 23 bits dominates): far inside the tolerances, and the only inexact step
//! before the sums is `Dn′` (see `stages`).

use crate::Config;
use crate::isqrt::mul;

/// Fields saturate at ±(2³¹ − 1) in Q16.16 (±32 768 px), so they fit `I16F16`.
pub const FIELD_MAX_Q16: u64 = i32::MAX as u64;

/// Magnitudes saturate at 2⁴⁸ − 1 in Q32.32 (65 536 px).
pub const MAGNITUDE_MAX_Q32: u64 = (1 << 48) - 1;

/// `x.leading_zeros()` for `x < 2²⁴` (32 for 0). On x86-64 from the
/// exponent of `x` as an `f32` (exact below 2²⁴): `vcvtdq2ps` takes eight
/// lanes, where AVX2 has no vector count and the compiler builds one from
/// nibble lookups. `CLZ` elsewhere (the scalar boards, and NEON's vector
/// form). Equal on the whole domain (`leading_zeros_below_2_24_is_clz`).
#[inline(always)]
fn leading_zeros_below_2_24(x: u32) -> u32 {
    debug_assert!(x < 1 << 24);
    if cfg!(target_arch = "x86_64") {
        // Biased exponent `126 + bitlen(x)` for x > 0, 0 for x = 0; the
        // conversion from `i32` is the one with a vector form.
        let biased = (x as i32 as f32).to_bits() >> 23;
        (158 - biased).min(32)
    } else {
        x.leading_zeros()
    }
}

/// `x.leading_zeros()` for `x < 2⁶³` (64 for 0), on x86-64 from an `f64`
/// exponent as [`leading_zeros_below_2_24`]: `t = 2·(x >> s) + 1 < 2⁵²`
/// (`s = 12` from 2⁵¹ on, else 0) is exact as the bits of `2⁵² + t` less
/// 2⁵² (AVX2 converts no 64-bit integer; this is an `or` and a subtract),
/// and `bitlen(x) = bitlen(t) − 1 + s`. Equal on the whole domain
/// (`leading_zeros_below_2_63_is_clz`, around every power of two).
#[inline(always)]
fn leading_zeros_below_2_63(x: u64) -> u32 {
    debug_assert!(x < 1 << 63);
    if cfg!(target_arch = "x86_64") {
        const TWO_52: u64 = 0x4330_0000_0000_0000;
        // 64-bit lanes throughout (a signed compare: x < 2⁶³), no packing.
        let s = if x as i64 >= 1 << 51 { 12 } else { 0 };
        let t = ((x >> s) << 1) | 1;
        let exact = f64::from_bits(TWO_52 | t) - f64::from_bits(TWO_52);
        // Biased exponent `1022 + bitlen(t)`.
        let bitlen_t = exact.to_bits() >> 52;
        (1087 - bitlen_t - s) as u32
    } else {
        x.leading_zeros()
    }
}

/// `prod · 2^shift` rounded to nearest (half up), saturating at `max`.
#[inline(always)]
fn scaled(prod: u64, shift: i32, max: u64) -> u64 {
    if shift >= 0 {
        let fits = shift < 64 && prod <= max >> shift;
        return if fits { prod << shift } else { max };
    }
    scaled_down(prod, shift.unsigned_abs(), max)
}

/// `prod / 2^k` rounded to nearest (half up), saturating at `max`, for
/// `k ≥ 1`: [`scaled`] where the shift is known to be to the right.
#[inline(always)]
fn scaled_down(prod: u64, k: u32, max: u64) -> u64 {
    // floor((floor(2x) + 1) / 2) = floor(x + 1/2) with x = prod / 2^k.
    let half = prod.checked_shr(k.wrapping_sub(1)).unwrap_or(0);
    ((half + 1) >> 1).min(max)
}

/// Reapply a sign to a magnitude of at most `i32::MAX`.
#[inline(always)]
fn signed(negative: bool, mag: u64) -> i32 {
    let mag = mag as i32;
    core::hint::select_unpredictable(negative, -mag, mag)
}

/// `v_c` component in Q16.16 bits from `V` (`|V| ≤ 6 854 400 < 2²³`):
/// `round(V · s · 2¹⁶ / 768)`, half away from zero. `|V| · c.mant < 2⁵⁵`;
/// `c.exp ≥ 24`, and the result is below `85.4 · 2²³ < 2³¹`.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn curl_free_q16(config: &Config, v: i32) -> i32 {
    let prod = mul(v.unsigned_abs(), config.c.mant);
    signed(v < 0, scaled(prod, -(config.c.exp as i32), FIELD_MAX_Q16))
}

/// `x² + y²` prepared for its root, `√(x² + y²) = ⌊√radicand⌋ · 2^μ`:
/// both cut (or raised) by one shift to 24 bits, so the root
/// `r ∈ [2²³, 2^24.5)` (0 for the zero vector) and the radicand lies in
/// `{0} ∪ [2⁴⁶, 2⁵⁰)`, the domain of [`isqrt`](crate::isqrt::isqrt).
/// Relative error of `r · 2^μ` below 2⁻²² (truncation and floor).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Squares {
    /// `x′² + y′²`.
    pub radicand: u64,
    /// The shift `μ` that undoes the cut.
    pub mu: i32,
}

impl Squares {
    /// The squares of `(x, y)`.
    #[inline(always)]
    pub fn of(x: u64, y: u64) -> Self {
        // `& 63`: the zero vector shifts by 0 and stays 0.
        let lz = leading_zeros_below_2_63(x | y) & 63;
        let (x, y) = (((x << lz) >> 40) as u32, ((y << lz) >> 40) as u32);
        Self {
            radicand: mul(x, x) + mul(y, y),
            mu: 64 - lz as i32 - 24,
        }
    }

    /// Of `V` (for `|v_c|`): [`Self::of`] in 32-bit lanes (`V` fits them),
    /// which vectorise twice as wide and need no 64-bit shifts on 32-bit
    /// targets. The same radicand and `μ` for every nonzero `V` within its
    /// bound; the zero vector's `μ` differs, and does not matter (its root
    /// is 0).
    #[inline(always)]
    pub fn curl_free(v: [i32; 2]) -> Self {
        let [x, y] = v.map(i32::unsigned_abs);
        // Top bit to bit 23: `|V| ≤ 6 854 400 < 2²³` (`stages`), so
        // `lz ≥ 9` and the shift is up to the left (up to 24 for zero).
        let lz = leading_zeros_below_2_24(x | y);
        let (x, y) = (x << lz.saturating_sub(8), y << lz.saturating_sub(8));
        Self {
            radicand: mul(x, x) + mul(y, y),
            mu: 8 - lz as i32,
        }
    }

    /// Of the numerators `N` (for `|v_d|`).
    #[inline(always)]
    pub fn divergence_free(n: [i64; 2]) -> Self {
        Self::of(n[0].unsigned_abs(), n[1].unsigned_abs())
    }
}

/// `|v_c|` in Q32.32 bits from the root `r = ⌊√radicand⌋` of its
/// [`Squares::curl_free`]: `r · 2^μ · s / 768` with `r · c.mant < 2⁵⁷`.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn curl_free_magnitude_q32(config: &Config, r: u32, mu: i32) -> u64 {
    // r·2^μ · c.mant·2^(−c.exp) · 2⁻¹⁶ px, times 2³² for Q32.32: a shift
    // to the right by `c.exp − 16 − μ ≥ 24 − 16 + 1` (`μ ≤ −1` for `V`
    // within its bound, see [`Squares::curl_free`]).
    let k = (config.c.exp as i32 - 16 - mu).max(1) as u32;
    scaled_down(mul(r, config.c.mant), k, MAGNITUDE_MAX_Q32)
}

/// The structure sums of one pixel (SPEC §3 step 8), as the engine sums
/// them (formats in `stages`): `a = G256 ⋆ X²` …, and `p = G256 ⋆ (X · Dn′)`
/// in two words, `p = p[0] · 2¹⁴ + p[1]`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StructureSums {
    /// `G256 ⋆ X²`: `0 ≤ a ≤ 256 · 1020² = 266 342 400 < 2²⁸`.
    pub a: i32,
    /// `G256 ⋆ XY`: `b² ≤ a·c` (Cauchy–Schwarz).
    pub b: i32,
    /// `G256 ⋆ Y²`, bounded as `a`.
    pub c: i32,
    /// `G256 ⋆ (X · h)`, `G256 ⋆ (X · l)` with `Dn′ = h·2¹⁴ + l`: each `≤ 256 · 1020 · 2¹³ < 2³¹`.
    pub p: [i32; 2],
    /// `G256 ⋆ (Y · h)`, `G256 ⋆ (Y · l)`, bounded as `p`.
    pub q: [i32; 2],
}

/// The solve of one pixel up to its one division, `v_d = n · rd · 2^exp ·
/// s / 192` pixels with `rd = ⌊(2⁶³ − 1) / det32⌋`
/// ([`reciprocal`](crate::reciprocal::reciprocal)): the numerators, the
/// determinant's top 32 bits and one exponent shared by both components.
/// The reciprocal is left to the caller, which takes a batch of them side
/// by side (`tail.rs`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Solved {
    /// `N = (c4·P′ − b4·Q′, a4·Q′ − b4·P′)`, `|N| < 2⁶³`.
    pub n: [i64; 2],
    /// `top32(det) ∈ [2³¹, 2³²)`.
    pub det32: u32,
    /// `τ + σ − 31 − bitlen(det)`.
    pub exp: i32,
}

/// The regularised 2×2 solve `[a+λ, b; b, c+λ] v = [p; q]` up to the
/// division (bounds in the module table).
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn solve(config: &Config, s: StructureSums) -> Solved {
    let lambda = config.lambda4;
    let (a4, c4, b4) = (4 * s.a + lambda, 4 * s.c + lambda, 4 * s.b);
    let (a4, c4, b4) = (i64::from(a4), i64::from(c4), i64::from(b4));
    debug_assert!(s.a >= 0 && s.c >= 0 && b4 * b4 <= (a4 - lambda as i64) * (c4 - lambda as i64));
    let det = (a4 * c4 - b4 * b4) as u64;
    debug_assert!(
        det >= (lambda as u64).pow(2) && det < 1 << 62,
        "det = {det}"
    );
    let join = |[hi, lo]: [i32; 2]| (i64::from(hi) << 14) + i64::from(lo);
    let (p, q) = (join(s.p), join(s.q));
    // τ = max(0, bitlen(|p| | |q|) − 31), the bit length of the part above
    // bit 31, which fits 32-bit lanes (`|p| ≤ 2³¹·2¹⁴ + 2³¹ < 2⁴⁶` for any
    // words, `< 2⁴⁵` as the engine sums them, so `above < 2¹⁵`): twice as
    // wide as 64-bit ones in AVX2, and one `CLZ` on 32-bit targets.
    let above = ((p.unsigned_abs() | q.unsigned_abs()) >> 31) as u32;
    let tau = u32::BITS - leading_zeros_below_2_24(above);
    // Toward zero, so the solve stays odd in (p, q); `|P′|, |Q′| < 2³¹`, so
    // the products below are 32×32 → 64 (which targets and vectors have).
    let cut = |v: i64| -> i64 {
        let mag = (v.unsigned_abs() >> tau) as i32;
        i64::from(if v < 0 { -mag } else { mag })
    };
    let (p, q) = (cut(p), cut(q));
    // det's top 32 bits; det ≥ Λ4² ≥ 1, so the shift is below 64.
    let lz = leading_zeros_below_2_63(det);
    let d32 = (det << lz) >> 32;
    Solved {
        n: [c4 * p - b4 * q, a4 * q - b4 * p],
        det32: d32 as u32,
        exp: tau as i32 + config.dn_shift as i32 - 31 - (64 - lz as i32),
    }
}

/// `v_d` (x, y) in Q16.16 bits, to nearest, saturating at ±[`FIELD_MAX_Q16`],
/// with `rd = reciprocal(solved.det32)`. Each numerator normalised to
/// `n31 ∈ [2³⁰, 2³¹)`; `n31 · rd < 2⁶³`, its top 31 bits times
/// `k.mant < 2³²` stay below 2⁶³.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn divergence_free_q16(config: &Config, solved: &Solved, rd: u32) -> [i32; 2] {
    solved.n.map(|n| {
        let mag = n.unsigned_abs();
        let lz = leading_zeros_below_2_63(mag) & 63;
        let n31 = ((mag << lz) >> 33) as u32;
        let m1 = (mul(n31, rd) >> 32) as u32;
        // n = n31·2^(b−31); n31·rd ≈ m1·2³²; times 2^exp · k.mant·2^(−k.exp) · 2¹⁶.
        let shift = (64 - lz as i32) + 17 + solved.exp - config.k.exp as i32;
        signed(n < 0, scaled(mul(m1, config.k.mant), shift, FIELD_MAX_Q16))
    })
}

/// `|v_d|` in Q32.32 bits, from the numerators before any rounding: `r`
/// the root of their [`Squares::divergence_free`] (shift `mu`), `rd =
/// reciprocal(solved.det32)`. `r · rd < 2^56.5`, cut to `m32 < 2^31.5`;
/// `m32 · k.mant < 2^63.5`.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn divergence_free_magnitude_q32(config: &Config, exp: i32, rd: u32, r: u32, mu: i32) -> u64 {
    let m32 = (mul(r, rd) >> 25) as u32;
    // r·2^μ·rd ≈ m32·2^(25+μ); times 2^exp · k.mant·2^(−k.exp) · 2³².
    let shift = 25 + mu + exp - config.k.exp as i32 + 32;
    scaled(mul(m32, config.k.mant), shift, MAGNITUDE_MAX_Q32)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The count from the `f64` exponent is `CLZ` at zero and on both
    /// sides of every power of two below 2⁶³, and at random values.
    #[test]
    fn leading_zeros_below_2_63_is_clz() {
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        for bit in 0..63 {
            let p = 1u64 << bit;
            for v in [p - 1, p, p + 1, p | (p - 1), p | (p >> 1)] {
                assert_eq!(leading_zeros_below_2_63(v), v.leading_zeros(), "{v}");
            }
            for _ in 0..1000 {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                let v = x >> (1 + (x % 63));
                assert_eq!(leading_zeros_below_2_63(v), v.leading_zeros(), "{v}");
            }
        }
        assert_eq!(leading_zeros_below_2_63(0), 64);
        assert_eq!(leading_zeros_below_2_63((1 << 63) - 1), 1);
    }

    /// The count from the `f32` exponent is `CLZ` on its whole domain.
    #[test]
    fn leading_zeros_below_2_24_is_clz() {
        for x in 0..1u32 << 24 {
            assert_eq!(leading_zeros_below_2_24(x), x.leading_zeros(), "{x}");
        }
    }
    use crate::isqrt::isqrt;
    use crate::reciprocal::reciprocal;

    /// `√(x² + y²) = r · 2^μ` (see [`Squares`]).
    fn root_of_squares(x: u64, y: u64) -> (u32, i32) {
        let squares = Squares::of(x, y);
        (isqrt(squares.radicand), squares.mu)
    }

    /// `v_d` in Q16.16 of one pixel, its division taken.
    fn v_d(cfg: &Config, solved: &Solved) -> [i32; 2] {
        divergence_free_q16(cfg, solved, reciprocal(solved.det32))
    }

    /// `|v_d|` in Q32.32 of one pixel, its division and root taken.
    fn m_d(cfg: &Config, solved: &Solved) -> u64 {
        let squares = Squares::divergence_free(solved.n);
        let rd = reciprocal(solved.det32);
        divergence_free_magnitude_q32(cfg, solved.exp, rd, isqrt(squares.radicand), squares.mu)
    }

    /// `|v_c|` in Q32.32 of one pixel, its root taken.
    fn m_c(cfg: &Config, v: [i32; 2]) -> u64 {
        let squares = Squares::curl_free(v);
        curl_free_magnitude_q32(cfg, isqrt(squares.radicand), squares.mu)
    }
    use crate::{IntensityScale, Params};
    use fixed::types::U32F32;

    fn config() -> Config {
        Config::new(8, 8, Params::DEFAULT).unwrap()
    }

    fn small_scale() -> Config {
        let scale = IntensityScale::new(1, 1024).unwrap();
        let lambda = U32F32::from_num(1e-6);
        Config::new(8, 8, Params { scale, lambda }).unwrap()
    }

    /// The f64 oracle of the solve in the SPEC's own units, with λ as the
    /// configuration rounded it (`Λ4`), so only the arithmetic is tested.
    fn oracle(cfg: &Config, s: StructureSums) -> [f64; 2] {
        let sc = f64::from(cfg.params().scale.num()) / f64::from(cfg.params().scale.den());
        let ua = sc * sc / 16384.0;
        let up = 2f64.powi(cfg.dn_shift as i32) * sc * sc * sc / (8.0 * 6144.0 * 256.0);
        let lambda = f64::from(cfg.lambda4) / 4.0 * ua;
        let (a, b, c) = (
            f64::from(s.a) * ua + lambda,
            f64::from(s.b) * ua,
            f64::from(s.c) * ua + lambda,
        );
        let join = |[h, l]: [i32; 2]| (f64::from(h) * 16384.0 + f64::from(l)) * up;
        let (p, q) = (join(s.p), join(s.q));
        let det = a * c - b * b;
        [(c * p - b * q) / det, (a * q - b * p) / det]
    }

    /// Largest component error in Q16 steps, the magnitude's relative error
    /// (beyond half a Q32.32 step, the output format's own rounding), and
    /// `|v|` in Q16 steps.
    fn errors(cfg: &Config, s: StructureSums) -> (f64, f64, f64) {
        let solved = solve(cfg, s);
        let got = v_d(cfg, &solved);
        let want = oracle(cfg, s);
        let limit = FIELD_MAX_Q16 as f64;
        let err = got.iter().zip(want).fold(0.0f64, |e, (g, w)| {
            e.max((f64::from(*g) - (w * 65536.0).clamp(-limit, limit)).abs())
        });
        let norm = want[0].hypot(want[1]);
        let m = m_d(cfg, &solved) as f64 / 2f64.powi(32);
        let m_err = if norm * 65536.0 < limit && norm > 0.0 {
            ((m - norm).abs() - 2f64.powi(-33)).max(0.0) / norm
        } else {
            0.0
        };
        (err, m_err, 65536.0 * norm)
    }

    /// Sums built from 25 pixels of gradients and residuals, as the engine
    /// builds them (so `b² ≤ ac` holds and the words stay in range).
    pub(crate) fn pixel_sums(seed: &mut u64, gmax: i64, dmax: i64) -> StructureSums {
        let g = [1i64, 4, 6, 4, 1];
        let mut next = |range: i64| {
            *seed ^= *seed << 13;
            *seed ^= *seed >> 7;
            *seed ^= *seed << 17;
            (*seed % (2 * range as u64 + 1)) as i64 - range
        };
        let mut s = StructureSums::default();
        for j in 0..25 {
            let w = g[j / 5] * g[j % 5];
            let (x, y, dn) = (next(gmax), next(gmax), next(dmax));
            let l = (dn << 50) >> 50;
            let h = (dn - l) >> 14;
            s.a += (w * x * x) as i32;
            s.b += (w * x * y) as i32;
            s.c += (w * y * y) as i32;
            s.p[0] += (w * x * h) as i32;
            s.p[1] += (w * x * l) as i32;
            s.q[0] += (w * y * h) as i32;
            s.q[1] += (w * y * l) as i32;
        }
        s
    }

    #[test]
    fn solve_of_pixel_sums_is_accurate() {
        for cfg in [config(), small_scale()] {
            let mut seed = 0x2545_f491_4f6c_dd1du64;
            let (mut worst, mut worst_m) = (0.0f64, 0.0f64);
            for case in 0..4000 {
                let (gmax, dmax) = [
                    (1020, 1i64 << 27),
                    (30, 1 << 20),
                    (3, 1 << 27),
                    (1020, 1000),
                    (0, 1 << 27),
                    (1, 1),
                ][case % 6];
                let s = pixel_sums(&mut seed, gmax, dmax);
                let (err, m_err, norm) = errors(&cfg, s);
                assert!(err <= 1.0 + 1e-7 * norm, "{s:?}: error {err}");
                assert!(m_err < 2f64.powi(-20), "{s:?}: magnitude error {m_err}");
                worst = worst.max(err / norm.max(1.0));
                worst_m = worst_m.max(m_err);
            }
            std::println!("solve: worst {worst:e} of |v|, magnitude {worst_m:e}");
        }
    }

    #[test]
    fn extreme_sums_saturate_or_stay_accurate() {
        let cfg = config();
        let amax = 266_342_400i32;
        let wmax = 2_139_095_040i32;
        for a in [0, 1, 1000, amax] {
            for c in [0, 7, amax] {
                let bmax = ((f64::from(a) * f64::from(c)).sqrt()) as i32;
                for b in [-bmax, 0, bmax / 2, bmax] {
                    for p in [[-8192 * 261_120, -wmax], [0, 1], [8192 * 261_120, wmax]] {
                        let s = StructureSums {
                            a,
                            b,
                            c,
                            p,
                            q: [0, -5],
                        };
                        let (err, _, norm) = errors(&cfg, s);
                        assert!(err <= 2.0 + 1e-7 * norm, "{s:?}: error {err}");
                    }
                }
            }
        }
    }

    #[test]
    fn solve_is_odd_in_the_right_hand_side() {
        let cfg = config();
        let s = StructureSums {
            a: 5000,
            b: -1200,
            c: 900,
            p: [7535, 1234],
            q: [-60, -4321],
        };
        let neg = StructureSums {
            p: s.p.map(|v| -v),
            q: s.q.map(|v| -v),
            ..s
        };
        let [x, y] = v_d(&cfg, &solve(&cfg, s));
        assert_eq!(v_d(&cfg, &solve(&cfg, neg)), [-x, -y]);
        assert!(x != 0 && y != 0);
    }

    #[test]
    fn curl_free_conversion_rounds_to_nearest() {
        let cfg = config();
        for v in [0, 1, -1, 195_840, -195_840, 6_854_400, -6_854_400, 12_345] {
            let want = (f64::from(v) * 65536.0 / 195_840.0).round();
            assert_eq!(f64::from(curl_free_q16(&cfg, v)), want, "{v}");
        }
    }

    #[test]
    fn magnitudes_are_the_norm_to_2e21() {
        let cfg = config();
        let unit = 2f64.powi(32) / 195_840.0;
        assert_eq!(m_c(&cfg, [0, 0]), 0);
        let mut s = 12345u64;
        for case in 0..100_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let x = (s as i32 >> (case % 23 + 9)).clamp(-6_854_400, 6_854_400);
            let y = ((s >> 32) as i32 >> (case % 17 + 9)).clamp(-6_854_400, 6_854_400);
            let want = f64::from(x).hypot(f64::from(y)) * unit;
            let got = m_c(&cfg, [x, y]) as f64;
            assert!((got - want).abs() <= want * 2f64.powi(-21) + 0.5, "{x} {y}");
        }
    }

    /// The 32-bit form of `V`'s squares is the 64-bit one.
    #[test]
    fn curl_free_squares_are_the_squares_of_v() {
        let mut s = 0x0123_4567_89ab_cdefu64;
        for case in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let bound = |x: i32| x.clamp(-6_854_400, 6_854_400);
            let v = [s as i32 >> (case % 31), (s >> 32) as i32 >> (case % 29)].map(bound);
            let v = if case % 7 == 0 { [v[0], 0] } else { v };
            let wide = Squares::of(
                u64::from(v[0].unsigned_abs()),
                u64::from(v[1].unsigned_abs()),
            );
            let narrow = Squares::curl_free(v);
            assert_eq!(narrow.radicand, wide.radicand, "{v:?}");
            if v != [0, 0] {
                assert_eq!(narrow.mu, wide.mu, "{v:?}");
            }
        }
        assert_eq!(Squares::curl_free([0, 0]).radicand, 0);
        let extreme = [6_854_400, -6_854_400];
        assert_eq!(
            Squares::curl_free(extreme),
            Squares::of(6_854_400, 6_854_400)
        );
    }

    #[test]
    fn root_of_squares_keeps_24_bits_at_every_scale() {
        assert_eq!(root_of_squares(0, 0).0, 0);
        for (x, y) in [
            (3u64, 4u64),
            (1, 1),
            (1 << 40, 0),
            (u64::MAX >> 1, 12_345),
            (7, 1 << 62),
        ] {
            let (r, mu) = root_of_squares(x, y);
            let got = f64::from(r) * 2f64.powi(mu);
            let want = (x as f64).hypot(y as f64);
            assert!(
                (got / want - 1.0).abs() < 2f64.powi(-22),
                "{x} {y}: {got} {want}"
            );
            assert!(r >= 1 << 23);
        }
    }
}
