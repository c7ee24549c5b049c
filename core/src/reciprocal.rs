//! An exact reciprocal: `⌊(2⁶³ − 1) / d⌋` for a normalised 32-bit `d`. Where
//! the FPU divides `f64`, from its quotient; on the M4F, from its `f32`
//! quotient and one correction step; elsewhere without a divide, from a
//! table seed, two Newton steps (multiplies and shifts) and a correction
//! to the exact floor. A 64-bit divide is a library call of a hundred-odd
//! instructions on Cortex-M and RV32; these are about thirty.

#[cfg(any(fpu_f64, fpu_f32))]
use crate::fpu;
use crate::isqrt::mul;

/// `2⁴⁰ / (2k + 1)` for the top byte `k ∈ [128, 256)` of `d`: `2⁶³ / d` at
/// the middle of the byte's interval, good to 8 bits.
#[cfg_attr(
    any(fpu_f64, fpu_f32),
    allow(dead_code, reason = "tested on every host")
)]
const SEED: [u32; 128] = {
    let mut table = [0u32; 128];
    let mut k = 0;
    while k < 128 {
        table[k] = ((1u64 << 40) / (2 * (k as u64 + 128) + 1)) as u32;
        k += 1;
    }
    table
};

/// `⌊(2⁶³ − 1) / d⌋` for `d ∈ [2³¹, 2³²)`, in `[2³¹, 2³²)`; other `d` are
/// raised to 2³¹ (the caller normalises). Where the FPU divides `f64`
/// (x86-64, aarch64) from its quotient ([`reciprocal_by_fpu`], which a
/// batch vectorises); on 32-bit Arm with the hard-float ABI from the `f32`
/// quotient ([`reciprocal_by_f32_quotient`]); every other target takes
/// [`reciprocal_by_newton`]. All are the exact floor.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
pub fn reciprocal(d: u32) -> u32 {
    #[cfg(fpu_f64)]
    let r = reciprocal_by_fpu(d);
    #[cfg(fpu_f32)]
    let r = reciprocal_by_f32_quotient(d, fpu::quotient_2_63);
    #[cfg(not(any(fpu_f64, fpu_f32)))]
    let r = reciprocal_by_newton(d);
    r
}

/// [`reciprocal`] from the correctly rounded quotient `q = 2⁶³ / d` (both
/// exact in `f64`). With `T = ⌊(2⁶³ − 1)/d⌋ ≤ 2³² − 1`, the real quotient
/// is `(2⁶³ − 1)/d + 1/d`, in `[T, T + 1 + 2⁻³¹)`; rounding keeps `q ≥ T`
/// (an `f64` integer) and below `T + 1.5`, so its nearest integer, capped
/// at `2³² − 1 ≥ T`, is `T` or `T + 1`, and one test (`r·d > 2⁶³ − 1`,
/// below 2⁶⁴) takes the floor.
#[inline(always)]
#[cfg(fpu_f64)]
pub fn reciprocal_by_fpu(d: u32) -> u32 {
    let d = d.max(1 << 31);
    let q = 9_223_372_036_854_775_808.0 / fpu::exact(u64::from(d));
    let r = fpu::nearest(q).min(u64::from(u32::MAX)) as u32;
    r - u32::from(mul(r, d) > u64::MAX >> 1)
}

/// [`reciprocal`] from a correctly rounded `f32` quotient (the M4F's
/// `VDIV.F32`), 32×32→64 products and two one-step tests. `quotient(d) =
/// ⌊2³¹ / (f32 d / 2³²)⌋` is a parameter so that the host tests run this
/// code with the host's `f32` division (IEEE: the same function). Bounds,
/// with `Q = (2⁶³ − 1)/d` and `T = ⌊Q⌋`:
/// - two roundings and the truncation put `t` within `3·2⁸ + 1` of `Q`
///   (`Q < 2³²`), so `r = 2⁶³ − 1 − t·d` has `|r| < 2⁴²`: `r >> 16` fits
///   `i32`, and `t/2⁶³` is `1/d` within a relative `2⁻²¹`;
/// - `step = ⌊(r >> 16)·(t >> 1) / 2⁴⁶⌋` is `⌊r/d + ε⌋` with `|ε| < 2⁻¹⁰`
///   (`r/d·2⁻²¹`, the cut of `r` below `2¹⁶·2³²/2⁶³`, the cut of `t`), and
///   `Q = t + r/d`, so `y = t + step ∈ [T − 1, T + 1]`: one test down, one
///   up. `y ≤ T + 1 < 2³²` (`T = 2³² − 1` only at `d = 2³¹`, where
///   `t = T` and `step = 0`), so the wrapping operations never wrap in the
///   domain; outside it they keep a wrong `quotient` from panicking.
#[inline(always)]
#[cfg_attr(not(fpu_f32), allow(dead_code, reason = "tested on every host"))]
pub(crate) fn reciprocal_by_f32_quotient(d: u32, quotient: impl Fn(u32) -> u32) -> u32 {
    let d = d.max(1 << 31);
    let limit = u64::MAX >> 1;
    let t = quotient(d);
    let r = limit.wrapping_sub(mul(d, t)) as i64;
    let step = (i64::from((r >> 16) as i32) * i64::from(t >> 1)) >> 46;
    let y = t.wrapping_add_signed(step as i32);
    let y = y.wrapping_sub(u32::from(mul(d, y) > limit));
    y.wrapping_add(u32::from(mul(d, y) + u64::from(d) <= limit))
}

/// [`reciprocal`] without a divide.
#[inline]
#[cfg_attr(
    any(fpu_f64, fpu_f32),
    allow(dead_code, reason = "tested on every host")
)]
pub fn reciprocal_by_newton(d: u32) -> u32 {
    let d = d.max(1 << 31);
    let mut y = SEED[((d >> 24) as usize) % 128];
    // y ≈ 2⁶³/d < 2³² with relative error ε: err = 2⁶³ − d·y ≈ 2⁶³·ε (|·| < 2⁵⁶
    // after the seed), and y += y·err/2⁶³ squares ε: y·|err >> 31| < 2³²·2²⁵.
    for _ in 0..2 {
        let err = (1u64 << 63).wrapping_sub(mul(d, y)) as i64 >> 31;
        let step = (mul(y, err.unsigned_abs() as u32) >> 32) as u32;
        // The sign of `err` is a coin toss from pixel to pixel: select, don't branch.
        y = core::hint::select_unpredictable(err < 0, y.wrapping_sub(step), y.saturating_add(step));
    }
    // Now within [floor − 2, floor + 1] for every d (checked exhaustively):
    // one step down, two up, each a compare and an add.
    // d·(y + 1) as d·y + d: 32×32→64 products only, no overflow.
    let limit = u64::MAX >> 1;
    y -= u32::from(mul(d, y) > limit);
    y += u32::from(mul(d, y) + u64::from(d) <= limit);
    y += u32::from(mul(d, y) + u64::from(d) <= limit);
    y
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The M4F's form with the host's `f32` division (`as` rounds to
    /// nearest into `f32` and truncates out, as `VCVT`).
    fn by_f32_quotient(d: u32) -> u32 {
        let quotient = |d| ((1.0 / (d as f32 / 4_294_967_296.0)) * 2_147_483_648.0) as u32;
        reciprocal_by_f32_quotient(d, quotient)
    }

    /// Every form: the Newton steps, the M4F's, and the FPU's where this
    /// host has one.
    const FORMS: [fn(u32) -> u32; 3] = [reciprocal_by_newton, by_f32_quotient, reciprocal];

    /// All 2³¹ normalised divisors (25 s per form in release):
    /// `cargo test -p reynoldsflow-core --release -- --ignored every_divisor`.
    #[test]
    #[ignore = "exhaustive: seconds in release, minutes in debug"]
    fn exact_for_every_divisor() {
        let limit = u64::MAX >> 1;
        let wrong = (1u64 << 31..1 << 32)
            .filter(|&d| {
                FORMS
                    .iter()
                    .any(|form| u64::from(form(d as u32)) != limit / d)
            })
            .count();
        assert_eq!(wrong, 0);
    }

    #[test]
    fn exact_at_the_edges_and_on_a_dense_grid() {
        let limit = u64::MAX >> 1;
        for d in
            (1u64 << 31..1 << 32)
                .step_by(4093)
                .chain([1 << 31, (1 << 31) + 1, u32::MAX as u64])
        {
            for form in FORMS {
                assert_eq!(u64::from(form(d as u32)), limit / d, "{d}");
            }
        }
        let mut s = 0x1234_5678u64;
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let d = (s >> 32) | 1 << 31;
            for form in FORMS {
                assert_eq!(u64::from(form(d as u32)), limit / d, "{d}");
            }
        }
    }
}
