//! Per-pixel integer arithmetic after the stencils: the fields in Q16.16
//! pixels, the regularised 2×2 solve (SPEC §3 step 9) and the magnitudes.
//!
//! Every routine here is a fixed sequence of integer operations (shifts,
//! 32×32→64 products, no divide), so every target that computes the same
//! integers gives the same bytes.

use crate::Config;
use crate::isqrt::{isqrt, mul};
use crate::reciprocal::reciprocal;

/// Fields saturate at ±(2³¹ − 1)·2¹⁶ in Q32.32, so their Q16.16 values fit `I16F16`.
const FIELD_MAX_Q32: u64 = (i32::MAX as u64) << 16;

/// `floor(mag / 2^shift + 1/2)` for any shift, without overflow.
#[inline(always)]
fn round_shift(mag: u64, shift: u32) -> u64 {
    match shift {
        0 => mag,
        // floor((floor(2x) + 1) / 2) = floor(x + 1/2) with x = mag / 2^shift.
        _ => (mag.checked_shr(shift - 1).unwrap_or(0) + 1) >> 1,
    }
}

/// Reapply a sign to a magnitude already limited to [`FIELD_MAX_Q32`].
#[inline(always)]
fn signed(negative: bool, mag: u64) -> i64 {
    let mag = mag.min(FIELD_MAX_Q32) as i64;
    if negative { -mag } else { mag }
}

/// A field component from Q32.32 to Q16.16 (`I16F16` bits), to nearest,
/// half away from zero: `(|v| + 2¹⁵) / 2¹⁶` with `|v|` limited to
/// [`FIELD_MAX_Q32`], so the result is at most 2³¹ − 1.
#[inline(always)]
pub fn q16(v: i64) -> i32 {
    let mag = (v.unsigned_abs().min(FIELD_MAX_Q32) + (1 << 15)) >> 16;
    core::hint::select_unpredictable(v < 0, -(mag as i32), mag as i32)
}

/// `v_c` in Q32.32 from `V` (units `s/768`, `|V| ≤ 1.02e7 < 2²⁴`):
/// `round(V · c · 2¹⁶)`, `c = s · 2¹⁶ / 768 < 86`, half away from zero.
/// `|V| · c_mant < 2²⁴ · 2³² = 2⁵⁶`, shifted by `c_exp − 16 ≥ 8`: below 2⁴⁸.
/// The shift `c_exp − 16` lies in `[8, 28]` for every admissible `s`, and
/// `|v_c| < 2⁴⁶` needs no saturation.
#[inline(always)]
pub fn curl_free_q32(config: &Config, v: i32) -> i64 {
    let mag = mul(v.unsigned_abs(), config.c_mant);
    let shift = config.c_exp - 16;
    let mag = ((mag + (1 << (shift - 1))) >> shift) as i64;
    core::hint::select_unpredictable(v < 0, -mag, mag)
}

/// The structure sums of one pixel (SPEC §3 step 8), as exact integers:
/// `a = G256 ⋆ X²` … and `p = G256 ⋆ (X · Dn)` … (formats in `stages`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StructureSums {
    /// `G256 ⋆ X²`: `0 ≤ a ≤ 256 · 1020² = 266 342 400 < 2²⁸`.
    pub a: i32,
    /// `G256 ⋆ XY`: `b² ≤ a·c` (Cauchy–Schwarz).
    pub b: i32,
    /// `G256 ⋆ Y²`, bounded as `a`.
    pub c: i32,
    /// `G256 ⋆ (X · Dn)`: `|p| ≤ 256 · 1020 · |Dn| < 2⁵⁹`.
    pub p: i64,
    /// `G256 ⋆ (Y · Dn)`, bounded as `p`.
    pub q: i64,
}

/// `v_d` in Q32.32: the solve of `[a+λ, b; b, c+λ] v = [p; q]` (SPEC step 9).
///
/// In eighths of the `a` unit (`a8 = 8a`, `Λ8` from [`Config`]) the SPEC's
/// solution is `v = c · 8 · N / det` (Q16.16) with
/// `det = (a8+Λ8)(c8+Λ8) − b8²` and `N = (c8+Λ8)·p − b8·q` (x; y alike). Bounds:
/// - `a8 + Λ8 < 2 130 739 200 + 2³¹ < 2³²`, so `det < 2⁶⁴` in `u64`; `det ≥ Λ8² ≥ 1`
///   because `b² ≤ a·c` exactly (Cauchy–Schwarz on non-negative weights).
/// - `p, q` are cut to `|p'|, |q'| < 2³⁰` by one shift `sp` shared by both,
///   so `|N| < 2³²·2³⁰ + 2³¹·2³⁰ < 2⁶³`.
/// - `1/det ≈ r · 2^−(31+e)`: `det`'s top 32 bits `d32 ∈ [2³¹, 2³²)` and
///   `r = ⌊(2⁶³−1)/d32⌋ ∈ [2³¹, 2³²)`, one reciprocal per pixel for both axes.
/// - `|N|` normalised to `n31 ∈ [2³⁰, 2³¹)`; `n31 · r < 2⁶³`; its top 31 bits
///   times `c_mant < 2³²` stay below 2⁶³. Relative error about 2⁻²⁸.
#[inline(always)]
pub fn divergence_free_q32(config: &Config, s: StructureSums) -> [i64; 2] {
    let lambda = config.lambda8;
    let a8 = (s.a as u32) * 8 + lambda;
    let c8 = (s.c as u32) * 8 + lambda;
    // |8b| ≤ 2 130 739 200 < 2³¹.
    let b8 = i64::from(s.b * 8);
    let det = mul(a8, c8) - (b8 * b8) as u64;

    let big = s.p.unsigned_abs().max(s.q.unsigned_abs());
    let sp = (u64::BITS - big.leading_zeros()).saturating_sub(30);
    // Truncate toward zero, so the solve stays odd in (p, q): |p'|, |q'| < 2³⁰.
    let cut = |v: i64| -> i64 {
        let mag = (v.unsigned_abs() >> sp) as i64;
        if v < 0 { -mag } else { mag }
    };
    let (p, q) = (cut(s.p), cut(s.q));
    // c8·p' with c8 < 2³² as one unsigned 32×32 product and a sign.
    let scaled = |k: u32, v: i64| -> i64 {
        let mag = mul(k, v.unsigned_abs() as u32) as i64;
        if v < 0 { -mag } else { mag }
    };
    let nx = scaled(c8, p) - b8 * q;
    let ny = scaled(a8, q) - b8 * p;

    let e = u64::BITS - det.leading_zeros();
    // det's top 32 bits (`det >> (e − 32)` or `det << (32 − e)`), without a branch.
    let d32 = (det << det.leading_zeros()) >> 32;
    let r = reciprocal(d32 as u32) as u32;
    // v = prod · 2^k in Q32.32, k = (bits − 31) + sp + 4 − e − c_exp + 16.
    let base = sp as i32 + 20 - e as i32 - config.c_exp as i32;
    let quotient = |n: i64| -> i64 {
        let mag = n.unsigned_abs();
        if mag == 0 {
            return 0;
        }
        let bits = (u64::BITS - mag.leading_zeros()) as i32;
        // `mag >> (bits − 31)` or `mag << (31 − bits)`, without a branch.
        let n31 = (mag << mag.leading_zeros()) >> 33;
        let m1 = (mul(n31 as u32, r) >> 32) as u32;
        let prod = mul(m1, config.c_mant);
        let k = base + bits - 31;
        let mag = if k >= 0 {
            FIELD_MAX_Q32
        } else {
            round_shift(prod, k.unsigned_abs())
        };
        signed(n < 0, mag)
    };
    [quotient(nx), quotient(ny)]
}

/// `|v|` in Q32.32 (`U32F32` bits) from Q32.32 components (`|x|, |y| ≤ 2⁴⁷`):
/// both cut by one shift to below 2²⁴ (the sum of squares then stays below
/// 2⁴⁹, where the root's seed is within one step of exact), the exact integer
/// root, shifted back. Relative error below 2⁻²¹.
#[inline(always)]
pub fn magnitude_q32(v: [i64; 2]) -> u64 {
    let [x, y] = [v[0].unsigned_abs(), v[1].unsigned_abs()];
    let shift = (u64::BITS - (x | y).leading_zeros()).saturating_sub(24);
    let (x, y) = ((x >> shift) as u32, (y >> shift) as u32);
    u64::from(isqrt(mul(x, x) + mul(y, y))) << shift
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Params;

    fn config() -> Config {
        Config::new(8, 8, Params::DEFAULT).unwrap()
    }

    /// The f64 oracle of the solve, in the SPEC's own units, with λ as the
    /// configuration rounded it (`Λ8`), so only the arithmetic is tested.
    fn oracle(s: StructureSums) -> [f64; 2] {
        let sc = 1.0 / 255.0;
        let ua = sc * sc / 16384.0;
        let up = sc * sc * sc / (8.0 * 6144.0 * 256.0);
        let lambda = f64::from(config().lambda8) / 8.0 * ua;
        let (a, b, c) = (
            s.a as f64 * ua + lambda,
            s.b as f64 * ua,
            s.c as f64 * ua + lambda,
        );
        let (p, q) = (s.p as f64 * up, s.q as f64 * up);
        let det = a * c - b * b;
        [(c * p - b * q) / det, (a * q - b * p) / det]
    }

    /// The solve's larger component error in Q16 steps, and `|v|` in Q16 steps.
    fn q16_error(cfg: &Config, s: StructureSums) -> (f64, f64) {
        let got = divergence_free_q32(cfg, s).map(q16);
        let want = oracle(s);
        let err = got.iter().zip(want).fold(0.0f64, |e, (g, w)| {
            let w16 = (w * 65536.0).clamp(-(i32::MAX as f64), i32::MAX as f64);
            e.max((*g as f64 - w16).abs())
        });
        (err, 65536.0 * want[0].hypot(want[1]))
    }

    #[test]
    fn solve_matches_f64_over_extremes() {
        let cfg = config();
        let amax = 266_342_400i32;
        let pmax = (1i64 << 59) - 1;
        let mut worst = 0.0f64;
        for a in [0, 1, 1000, 123_456, amax] {
            for c in [0, 7, 99_999, amax] {
                let bmax = ((a as f64) * (c as f64)).sqrt() as i64;
                for b in [-bmax, -bmax / 3, 0, bmax / 2, bmax] {
                    for p in [-pmax, -12_345_678_901, -1, 0, 1, 987_654_321, pmax] {
                        for q in [-pmax, -5, 0, 77_777_777_777, pmax] {
                            let s = StructureSums {
                                a,
                                b: b as i32,
                                c,
                                p,
                                q,
                            };
                            // p and q share one shift: a component whose own scale is far
                            // below the other's keeps only |v|'s precision. Sums that come
                            // from real pixels are tighter (next test).
                            let (err, norm) = q16_error(&cfg, s);
                            assert!(err <= 2.0 + 1e-5 * norm, "{s:?}: error {err}");
                            worst = worst.max(err);
                        }
                    }
                }
            }
        }
        std::println!("solve: worst error {worst} Q16 steps");
    }

    /// Sums built from 25 pixels of gradients and residuals, as the engine
    /// builds them (so `b² ≤ ac` and `|p| ≤ √(a · Σw·Dn²)` hold).
    #[test]
    fn solve_of_pixel_sums_is_accurate() {
        let cfg = config();
        let g = [1i64, 4, 6, 4, 1];
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = |range: i64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % (2 * range as u64 + 1)) as i64 - range
        };
        let mut worst = 0.0f64;
        for case in 0..2000 {
            let (gmax, dmax) = [
                (1020, 1i64 << 40),
                (30, 1 << 30),
                (3, 1 << 36),
                (1020, 1000),
            ][case % 4];
            let mut s = StructureSums::default();
            for j in 0..25 {
                let w = g[j / 5] * g[j % 5];
                let (x, y, dn) = (next(gmax), next(gmax), next(dmax));
                s.a += (w * x * x) as i32;
                s.b += (w * x * y) as i32;
                s.c += (w * y * y) as i32;
                s.p += w * x * dn;
                s.q += w * y * dn;
            }
            let (err, norm) = q16_error(&cfg, s);
            assert!(err <= 1.0 + 1e-7 * norm, "{s:?}: error {err}");
            worst = worst.max(err / norm.max(1.0));
        }
        std::println!("solve of pixel sums: worst error {worst:e} of |v|");
    }

    #[test]
    fn solve_is_odd_in_the_right_hand_side() {
        let cfg = config();
        let s = StructureSums {
            a: 5000,
            b: -1200,
            c: 900,
            p: 123_456_789,
            q: -987_654,
        };
        let neg = StructureSums {
            p: -s.p,
            q: -s.q,
            ..s
        };
        let [x, y] = divergence_free_q32(&cfg, s);
        assert_eq!(divergence_free_q32(&cfg, neg), [-x, -y]);
        assert!(x != 0 && y != 0);
    }

    #[test]
    fn curl_free_conversion_rounds_to_nearest() {
        let cfg = config();
        for v in [0, 1, -1, 195_840, -195_840, 10_180_000, -10_180_000, 12_345] {
            let want = (v as f64 * 65536.0 / 195_840.0).round();
            assert_eq!(q16(curl_free_q32(&cfg, v)) as f64, want, "{v}");
        }
    }

    #[test]
    fn magnitude_is_the_norm_to_2e21() {
        assert_eq!(magnitude_q32([3 << 32, -(4 << 32)]), 5 << 32);
        assert_eq!(magnitude_q32([1, 1]), 1);
        assert_eq!(magnitude_q32([0, 0]), 0);
        let max = FIELD_MAX_Q32 as i64;
        let mut s = 12345u64;
        for case in 0..100_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let x = (s as i64 >> (case % 40 + 16)).clamp(-max, max);
            let y = ((s >> 7) as i64 >> (case % 23 + 16)).clamp(-max, max);
            let want = (x as f64).hypot(y as f64);
            let got = magnitude_q32([x, y]) as f64;
            assert!(
                got <= want * (1.0 + 1e-12) && got >= want * (1.0 - 2f64.powi(-21)) - 1.0,
                "{x} {y}"
            );
        }
    }
}
