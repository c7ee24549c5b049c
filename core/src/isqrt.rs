//! An exact integer square root. Where the FPU has a correctly rounded
//! `f64` root (x86-64, aarch64) it is that root's floor; on the M4F its
//! `f32` root and one 32-bit division step; elsewhere a table seed, two
//! Newton steps on the reciprocal root (multiplies and shifts only) and a
//! correction to the exact floor, about 20 operations where a bit-by-bit
//! root takes over a hundred. All are the exact floor over the radicands
//! the magnitudes have, so every target gives the same bytes (the tests
//! hold each to `u64::isqrt`).

#[cfg(any(fpu_f64, fpu_f32))]
use crate::fpu;
use core::num::NonZeroU32;

/// `a · b` widened: one 32×32→64 multiply on every 32-bit target.
#[inline(always)]
pub fn mul(a: u32, b: u32) -> u64 {
    u64::from(a) * u64::from(b)
}

/// Largest argument [`isqrt`] is exact for: the magnitudes' sums of squares
/// of two components below 2²⁴ stay below 2⁴⁹.
pub const ISQRT_MAX: u64 = (1 << 50) - 1;

/// Smallest nonzero argument [`isqrt`] is exact for: the larger of the two
/// components is raised to 24 bits (`solve::Squares::of`), so a nonzero
/// radicand is at least 2⁴⁶.
pub const ISQRT_MIN: u64 = 1 << 46;

/// `⌊√n⌋`, exact for `n = 0` and every `n` in [`ISQRT_MIN`]`..=`[`ISQRT_MAX`]
/// (elsewhere some value, without a panic).
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline)]
pub fn isqrt(n: u64) -> u32 {
    debug_assert!(
        n == 0 || (ISQRT_MIN..=ISQRT_MAX).contains(&n),
        "radicand {n}"
    );
    #[cfg(fpu_f64)]
    let r = isqrt_by_fpu(n);
    #[cfg(fpu_f32)]
    let r = isqrt_by_f32_root(n, fpu::root_512);
    #[cfg(not(any(fpu_f64, fpu_f32)))]
    let r = isqrt_by_newton(n);
    r
}

/// [`isqrt`] from the correctly rounded `f64` root, in the form a batch
/// vectorises (`fpu`). `n < 2⁵²` enters exactly; with `k = ⌊√n⌋`,
/// `k ≤ √n < k + 1` and both bounds are `f64` integers, so the rounded root
/// lies in `[k, k + 1]` and its nearest integer is `k` or `k + 1`; one test
/// (`r² > n`, `r ≤ 2²⁵`) takes the floor.
#[inline(always)]
#[cfg(fpu_f64)]
fn isqrt_by_fpu(n: u64) -> u32 {
    let n = n.min(ISQRT_MAX);
    let r = fpu::nearest(fpu::sqrt(fpu::exact(n))) as u32;
    r - u32::from(mul(r, r) > n)
}

/// [`isqrt`] from a correctly rounded `f32` root (the M4F's `VSQRT.F32`,
/// one instruction where the Newton form takes about 60) and one 32-bit
/// division. Bounds, for `n` in the domain, `k = ⌊√n⌋ ∈ [2²³, 2²⁵)`:
/// - `a = ⌊n/2¹⁸⌋ < 2³²` enters `f32` with relative error `≤ 2⁻²⁴`, its
///   root leaves with `≤ 2⁻²⁴` more; `512·√a` lies within `2⁻⁵` below
///   `√n`. So `512·√(f32 a)` is within 3.3 of `√n` (`√n < 2²⁵`:
///   `1.6·2⁻²⁴·2²⁵ < 3.3`) and `seed`, its floor, in `[k − 4, k + 4]`.
/// - `s = seed − 4 = √n − ε` with `ε ∈ [0, 9)`; `e = n − s² = 2√n·ε − ε²`
///   lies in `[0, 18·2²⁵) ⊂ u32` (so the low words suffice).
/// - `e / (2s + 1) = ε + ε(ε − 1)/(2s + 1)`: within `2⁻¹⁷` of `ε` (below
///   it only for `ε < 1`, by at most `¼/(2s + 1)`); truncated, `q = s + ⌊·⌋
///   ∈ (√n − 1 − 2⁻¹⁷, √n + 2⁻¹⁷]`, i.e. `k − 1 ≤ q ≤ k + 1`, and the two
///   one-step tests of the Newton form end on `k`.
///
/// Outside the domain the arithmetic wraps (`2s + 1` is odd, never zero):
/// some value, no panic. `root_512(a) = ⌊512·√(f32 a)⌋` is a parameter so
/// that the host tests run this same code with the host's `f32` root
/// (IEEE's correctly rounded root: the same function as `VSQRT.F32`).
#[inline(always)]
#[cfg_attr(not(fpu_f32), allow(dead_code, reason = "tested on every host"))]
pub(crate) fn isqrt_by_f32_root(n: u64, root_512: impl Fn(u32) -> u32) -> u32 {
    // Zero is the common case (still parts of a frame): skip the root.
    if n == 0 {
        return 0;
    }
    let n = n.min(ISQRT_MAX);
    let a = (n >> 18) as u32;
    let seed = root_512(a);
    let s = seed.wrapping_sub(4);
    let e = (n as u32).wrapping_sub(s.wrapping_mul(s));
    let step = NonZeroU32::new(s.wrapping_mul(2) | 1).map_or(0, |d| e / d);
    let q = s.wrapping_add(step);
    let q = q.wrapping_sub(u32::from(mul(q, q) > n));
    q.wrapping_add(u32::from(mul(q.wrapping_add(1), q.wrapping_add(1)) <= n))
}

/// [`isqrt`] without a divide or an FPU. The correction is one step each
/// way, without loops: no data-dependent branch but the one for zero. The
/// domain's two octaves normalise by a constant shift each (32-bit targets
/// have no cheap 64-bit shift by a variable amount).
#[inline]
#[cfg_attr(
    any(fpu_f64, fpu_f32),
    allow(dead_code, reason = "tested on every host")
)]
pub fn isqrt_by_newton(n: u64) -> u32 {
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
    // Zero is the common case (still parts of a frame): skip the root.
    if n == 0 {
        return 0;
    }
    let n = n.min(ISQRT_MAX);
    // m = n·4^j ∈ [2⁶², 2⁶⁴) with 4^j = 2¹⁶ below 2⁴⁸ and 2¹⁴ from there;
    // a = m's top 32 bits, read as x = a/2³² ∈ [¼, 1).
    let upper = n >= 1 << 48;
    let a = if upper { n >> 18 } else { n >> 16 } as u32;
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
    let q = if upper {
        mul(a, r) >> 37
    } else {
        mul(a, r) >> 38
    } as u32;
    let q = q - u32::from(mul(q, q) > n);
    q + u32::from(mul(q + 1, q + 1) <= n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The M4F's form with the host's `f32` root: IEEE's correctly rounded
    /// root is one function, `VSQRT.F32` on the board and `sqrtss` here.
    fn by_f32_root(n: u64) -> u32 {
        // `as` rounds to nearest into `f32` and truncates out, as `VCVT`.
        isqrt_by_f32_root(n, |a| ((a as f32).sqrt() * 512.0) as u32)
    }

    /// `n.isqrt()` within the domain, the root of the domain's end beyond it.
    fn want(n: u64) -> u32 {
        n.min(ISQRT_MAX).isqrt() as u32
    }

    #[test]
    fn exact_at_the_edges_and_beyond_the_domain() {
        let octave = 1u64 << 48;
        for n in [
            0u64,
            ISQRT_MIN,
            ISQRT_MIN + 1,
            octave - 1,
            octave,
            octave + 1,
            ISQRT_MAX - 1,
            ISQRT_MAX,
            ISQRT_MAX + 1,
            1 << 62,
            u64::MAX,
        ] {
            assert_eq!(isqrt_by_newton(n), want(n), "{n}");
            assert_eq!(by_f32_root(n), want(n), "{n}");
            if n <= ISQRT_MAX {
                assert_eq!(isqrt(n), want(n), "{n}");
            }
        }
    }

    /// The FPU's root is exact below the domain too.
    #[test]
    #[cfg(fpu_f64)]
    fn fpu_root_is_exact_at_every_size() {
        for n in (0..100_000).chain((0..64).map(|b| 1u64 << b)) {
            assert_eq!(isqrt_by_fpu(n), want(n), "{n}");
        }
    }

    /// Both sides of every perfect square in the domain, where a root that
    /// is one off would show.
    #[test]
    fn exact_on_both_sides_of_every_square() {
        let (first, last) = (ISQRT_MIN.isqrt(), ISQRT_MAX.isqrt());
        let wrong = (first + 1..=last)
            .filter(|&r| {
                let s = r * r;
                [isqrt, isqrt_by_newton, by_f32_root].iter().any(|root| {
                    root(s) != r as u32
                        || root(s - 1) != (r - 1) as u32
                        || (s + r <= ISQRT_MAX && root(s + r) != r as u32)
                })
            })
            .count();
        assert_eq!(wrong, 0);
    }

    #[test]
    fn exact_on_random_values_of_the_domain() {
        let mut s = 0x9E37_79B9_7F4A_7C15u64;
        for i in 0..2_000_000u64 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let n = s >> (14 + i % 50);
            if n == 0 || (ISQRT_MIN..=ISQRT_MAX).contains(&n) {
                assert_eq!(isqrt(n), want(n), "{n}");
                assert_eq!(isqrt_by_newton(n), want(n), "{n}");
                assert_eq!(by_f32_root(n), want(n), "{n}");
            }
        }
    }

    /// Outside the domain: some value, never a panic.
    #[test]
    fn no_panic_below_the_domain() {
        for n in (1..1000).chain([ISQRT_MIN - 1, 1 << 40]) {
            let _ = isqrt_by_newton(n);
            let _ = by_f32_root(n);
        }
    }
}
