//! Exact integer floors from the FPU's correctly rounded `f64` operations,
//! for the targets whose FPU has them (x86-64, aarch64), written so that a
//! batch of them vectorises (the per-pixel tail takes them eight at a time,
//! `tail.rs`): integers enter `f64` through the 2⁵² magic number (an OR and
//! a subtraction, exact below 2⁵²) and leave it the same way, rounded to
//! nearest, because AVX2 has no vector conversion between 64-bit integers
//! and `f64` (the compiler takes `as` one lane at a time). Each caller
//! then corrects the nearest integer to the exact floor with one integer
//! test, so the result is the same integer the Newton forms give on
//! targets without an FPU. On 32-bit Arm with the hard-float ABI (the M4F,
//! whose FPU has no `f64`) only the `f32` root, which `isqrt` corrects the
//! same way.

/// 2⁵²: adding it to `0 ≤ x < 2⁵²` leaves `round(x)` in the mantissa bits.
#[cfg(fpu_f64)]
const TWO_52: f64 = 4_503_599_627_370_496.0;

/// `n` as `f64`, exactly, for `n < 2⁵²` (the caller's bound).
#[cfg(fpu_f64)]
#[inline(always)]
pub fn exact(n: u64) -> f64 {
    f64::from_bits(TWO_52.to_bits() | n) - TWO_52
}

/// `x` rounded to the nearest integer (ties to even), for `0 ≤ x < 2⁵²`.
#[cfg(fpu_f64)]
#[inline(always)]
pub fn nearest(x: f64) -> u64 {
    (x + TWO_52).to_bits() & ((1 << 52) - 1)
}

/// The correctly rounded `f64` root (`core` has no stable `sqrt`). On
/// x86-64 through the SSE2 intrinsic, which the compiler encodes for the
/// code around it (`vsqrtpd` across a batch inside the host's AVX2 pass):
/// `libm`'s root is an inline-assembly legacy `sqrtsd`, and that, amid AVX
/// code, made `reynoldsflow run` 5.5× slower per pair on this project's
/// AMD EPYC (3.0 s against 0.55 s for 30 pairs at 640×480) although it ran
/// fewer instructions. The intrinsics are `unsafe` only because they carry
/// `#[target_feature]`.
#[inline(always)]
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
pub fn sqrt(x: f64) -> f64 {
    use core::arch::x86_64::{_mm_cvtsd_f64, _mm_set_sd, _mm_sqrt_pd};
    // SAFETY: SSE2 is part of every x86-64 target (the baseline), and these
    // intrinsics touch registers only.
    unsafe { _mm_cvtsd_f64(_mm_sqrt_pd(_mm_set_sd(x))) }
}

/// The correctly rounded `f64` root: `libm`'s is the `fsqrt` instruction.
#[inline(always)]
#[cfg(target_arch = "aarch64")]
pub fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}

/// `⌊512·√a⌋` from the correctly rounded `f32` root, `VSQRT.F32` (every
/// Arm FPU of the hard-float ABI has it; `core` has no `sqrt` on stable and
/// `libm`'s is software on 32-bit Arm): `a` enters `f32` rounded to nearest
/// as the fixed-point `a/2¹⁴`, leaves truncated as the fixed point of
/// `√(a/2¹⁴)·2¹⁶` (power-of-two scalings, exact), so the value is that of
/// `((a as f32).sqrt() * 512.0) as u32` on any IEEE machine.
#[inline(always)]
#[cfg(fpu_f32)]
#[allow(unsafe_code)]
pub fn root_512(a: u32) -> u32 {
    let root: u32;
    // SAFETY: FPU instructions on `s0`, saved and restored around them on
    // the stack (Rust's `sreg` operands need double-precision `vfp2`, which
    // the M4F does not have); no memory of the program's, no flags the
    // compiler relies on (`VSQRT` and `VCVT` set only the FPSCR's
    // cumulative exception bits).
    unsafe {
        core::arch::asm!(
            "vpush {{s0}}",
            "vmov s0, {a}",
            "vcvt.f32.u32 s0, s0, #14",
            "vsqrt.f32 s0, s0",
            "vcvt.u32.f32 s0, s0, #16",
            "vmov {root}, s0",
            "vpop {{s0}}",
            a = in(reg) a,
            root = lateout(reg) root,
            options(pure, nomem, preserves_flags),
        );
    }
    root
}

/// `⌊2³¹ / (f32 d / 2³²)⌋`, saturating, from the correctly rounded `f32`
/// quotient, `VDIV.F32`: `d` enters rounded to nearest as the fixed point
/// `d/2³²`, the quotient leaves truncated as the fixed point of `·2³¹`
/// (power-of-two scalings, exact), so the value is that of
/// `(2³¹ · (1 / (d as f32 / 2³²))) as u32` on any IEEE machine.
#[inline(always)]
#[cfg(fpu_f32)]
#[allow(unsafe_code)]
pub fn quotient_2_63(d: u32) -> u32 {
    let quotient: u32;
    // SAFETY: as `root_512`, on `s0` and `s1`, saved and restored.
    unsafe {
        core::arch::asm!(
            "vpush {{s0, s1}}",
            "vmov s0, {d}",
            "vcvt.f32.u32 s0, s0, #32",
            "vmov.f32 s1, #1.0",
            "vdiv.f32 s0, s1, s0",
            "vcvt.u32.f32 s0, s0, #31",
            "vmov {quotient}, s0",
            "vpop {{s0, s1}}",
            d = in(reg) d,
            quotient = lateout(reg) quotient,
            options(pure, nomem, preserves_flags),
        );
    }
    quotient
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integers_cross_exactly() {
        let mut s = 0x2545_F491_4F6C_DD1Du64;
        for i in 0..100_000u64 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let n = (s >> 12) >> (i % 52);
            assert_eq!(exact(n), n as f64, "{n}");
            assert_eq!(nearest(exact(n)), n, "{n}");
        }
        assert_eq!(nearest(2.5), 2);
        assert_eq!(nearest(3.5), 4);
        assert_eq!(nearest(7.499_999), 7);
        assert_eq!(nearest(4_294_967_296.0), 1 << 32);
    }
}
