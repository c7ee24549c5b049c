//! An exact integer square root. Where the FPU has a correctly rounded
//! `f64` root (x86-64, aarch64) it is that root's floor; elsewhere a table
//! seed, two Newton steps on the reciprocal root (multiplies and shifts
//! only) and a correction to the exact floor, about 20 operations where a
//! bit-by-bit root takes over a hundred. Both are the exact floor, so every
//! target gives the same bytes (the tests hold each to `u64::isqrt`).

/// `r0[k] ≈ 2³⁰ / √((k + ½) / 256)` for the top byte `k ∈ [64, 256)` of a
/// normalised argument: a seed good to 8 bits (Q30, in `(2³⁰, 2³¹]`).
const SEED: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut k = 64;
    while k < 256 {
        let top = 2 * (k as u128) + 1;
        table[k] = ((1u128 << 69) / top).isqrt() as u32;
        k += 1;
    }
    table
};

/// `a · b` widened: one 32×32→64 multiply on every 32-bit target.
#[inline(always)]
pub fn mul(a: u32, b: u32) -> u64 {
    u64::from(a) * u64::from(b)
}

/// Largest argument [`isqrt`] is exact for: the magnitudes' sums of squares
/// of two components below 2²⁴ stay below 2⁴⁹.
pub const ISQRT_MAX: u64 = (1 << 50) - 1;

/// `⌊√n⌋`, exact for every `n ≤` [`ISQRT_MAX`] (larger `n` are cut to it).
#[inline]
pub fn isqrt(n: u64) -> u32 {
    #[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
    let r = isqrt_by_fpu(n);
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    let r = isqrt_by_newton(n);
    r
}

/// [`isqrt`] from the correctly rounded `f64` root. Exact: `n < 2⁵²` converts
/// exactly, and with `k = ⌊√n⌋ < 2²⁶`, `√n ≤ √((k+1)² − 1) < k + 1 − 1/(2(k+1))`,
/// more than half an ulp (`≤ 2⁻²⁸` below 2²⁶) under `k + 1`, so rounding
/// cannot carry the root up to the next integer; the floor is `k`.
#[inline]
#[cfg(any(target_arch = "x86_64", target_arch = "aarch64"))]
fn isqrt_by_fpu(n: u64) -> u32 {
    sqrt(n.min(ISQRT_MAX) as f64) as u32
}

/// The correctly rounded `f64` root (`core` has no stable `sqrt`). On
/// x86-64 through the SSE2 intrinsic, which the compiler encodes for the
/// code around it (`vsqrtsd` inside the host's AVX2 pass): `libm`'s root is
/// an inline-assembly legacy `sqrtsd`, and that, amid AVX code, made
/// `reynoldsflow run` 5.5× slower per pair on this project's AMD EPYC
/// (3.0 s against 0.55 s for 30 pairs at 640×480) although it ran fewer
/// instructions; the multiply-only root instead takes 0.70 s. The
/// intrinsics are `unsafe` only because they carry `#[target_feature]`.
#[inline(always)]
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
fn sqrt(x: f64) -> f64 {
    use core::arch::x86_64::{_mm_cvtsd_f64, _mm_set_sd, _mm_sqrt_pd};
    // SAFETY: SSE2 is part of every x86-64 target (the baseline), and these
    // intrinsics touch registers only.
    unsafe { _mm_cvtsd_f64(_mm_sqrt_pd(_mm_set_sd(x))) }
}

/// The correctly rounded `f64` root: `libm`'s is the `fsqrt` instruction.
#[inline(always)]
#[cfg(target_arch = "aarch64")]
fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}

/// [`isqrt`] without a divide or an FPU. The correction is one step each
/// way, without loops: no data-dependent branch but the one for zero.
#[inline]
#[cfg_attr(
    any(target_arch = "x86_64", target_arch = "aarch64"),
    allow(dead_code, reason = "tested on every host")
)]
pub fn isqrt_by_newton(n: u64) -> u32 {
    // Zero is the common case (still parts of a frame): skip the root.
    if n < 4 {
        return u32::from(n != 0);
    }
    let n = n.min(ISQRT_MAX);
    // m = n·4^j ∈ [2⁶², 2⁶⁴); a = m's top 32 bits, read as x = a/2³² ∈ [¼, 1).
    let shift = n.leading_zeros() & !1;
    let a = ((n << shift) >> 32) as u32;
    // r ≈ 2³⁰/√x in Q30 ∈ (2³⁰, 2³¹]. One Newton step r·(3 − x·r²)/2, all in
    // 32×32→64 products: r²/2³¹ ≤ 2³¹ (Q29), a·that/2³² ≈ x·r² ≤ 2³¹ (Q29),
    // r·(3·2²⁹ − t)/2³⁰ < 1.5·2³¹ < 2³². Each step squares the relative
    // error: 2⁻⁸ from the seed, then about 2⁻¹⁵ and 2⁻²⁸ with truncations.
    let mut r = SEED[(a >> 24) as usize];
    for _ in 0..2 {
        let r2 = (mul(r, r) >> 31) as u32;
        let t = ((mul(a, r2) >> 32) as u32).min(3 << 29);
        r = (mul(r, (3 << 29) - t) >> 30) as u32;
    }
    // √m ≈ a·r/2³⁰, relative error below 2⁻²⁷ (also a's truncation, 2⁻³⁰), so
    // below ¼ absolute for √n < 2²⁵: within one of the floor either way.
    let q = ((mul(a, r) >> 30) >> (shift / 2)) as u32;
    let q = q - u32::from(mul(q, q) > n);
    q + u32::from(mul(q + 1, q + 1) <= n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n.isqrt()` within the domain, the root of the domain's end beyond it.
    fn want(n: u64) -> u32 {
        n.min(ISQRT_MAX).isqrt() as u32
    }

    #[test]
    fn exact_at_the_edges_and_beyond_the_domain() {
        for n in [
            0u64,
            1,
            2,
            3,
            4,
            5,
            8,
            9,
            15,
            16,
            17,
            ISQRT_MAX - 1,
            ISQRT_MAX,
        ]
        .into_iter()
        .chain([ISQRT_MAX + 1, 1 << 62, u64::MAX])
        {
            assert_eq!(isqrt(n), want(n), "{n}");
            assert_eq!(isqrt_by_newton(n), want(n), "{n}");
        }
    }

    /// Both sides of every perfect square in the domain, where a root that
    /// is one off would show.
    #[test]
    fn exact_on_both_sides_of_every_square() {
        let last = ISQRT_MAX.isqrt();
        let wrong = (1..=last)
            .filter(|&r| {
                let s = r * r;
                [isqrt, isqrt_by_newton].iter().any(|root| {
                    root(s) != r as u32
                        || root(s - 1) != (r - 1) as u32
                        || (s + r <= ISQRT_MAX && root(s + r) != r as u32)
                })
            })
            .count();
        assert_eq!(wrong, 0);
    }

    #[test]
    fn exact_on_random_values_of_every_size() {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for i in 0..2_000_000u64 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let n = s >> (i % 64);
            assert_eq!(isqrt(n), want(n), "{n}");
            assert_eq!(isqrt_by_newton(n), want(n), "{n}");
        }
    }
}
