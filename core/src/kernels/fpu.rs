//! The correctly rounded `f32` square root (IEEE 754's `squareRoot`), the
//! one operation of the tail (`tail.rs`) that `core` does not provide on
//! stable Rust. Every form below rounds correctly, so every target gives
//! the same bits:
//! - x86-64: SSE's `sqrtss` through its intrinsic, which the compiler
//!   takes into vector lanes with the loop around it (`vsqrtps` in the
//!   host's AVX2 pass); `libm`'s form is inline assembly, which stops the
//!   vectoriser (and a legacy-SSE root amid AVX code once made the whole
//!   pass 5.5× slower);
//! - aarch64: NEON's `fsqrt` through its intrinsic, for the same reason;
//! - 32-bit Arm with the hard-float ABI (the M4F): `VSQRT.F32` in `asm!`
//!   (`core::arch` has no scalar VFP root);
//! - elsewhere (M0, RV32: no FPU): `libm`'s software `sqrtf`.
//!
//! The intrinsics are `unsafe` only because they carry `#[target_feature]`
//! (SSE and NEON are part of their targets' baselines).
//!
//! And the byte of a clamped value ([`byte`]): on x86-64 a conversion
//! without Rust's saturating checks, which the compiler takes one lane at a
//! time there.

/// `√x`, correctly rounded.
#[inline(always)]
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
pub fn sqrt(x: f32) -> f32 {
    use core::arch::x86_64::{_mm_cvtss_f32, _mm_set_ss, _mm_sqrt_ss};
    // SAFETY: SSE is part of every x86-64 target (the baseline), and these
    // intrinsics touch registers only.
    unsafe { _mm_cvtss_f32(_mm_sqrt_ss(_mm_set_ss(x))) }
}

/// `√x`, correctly rounded.
#[inline(always)]
#[cfg(target_arch = "aarch64")]
#[allow(unsafe_code)]
pub fn sqrt(x: f32) -> f32 {
    use core::arch::aarch64::{vdup_n_f32, vget_lane_f32, vsqrt_f32};
    // SAFETY: NEON is part of every aarch64 target (the baseline), and
    // these intrinsics touch registers only.
    unsafe { vget_lane_f32::<0>(vsqrt_f32(vdup_n_f32(x))) }
}

/// `√x`, correctly rounded: `VSQRT.F32` (every Arm FPU of the hard-float
/// ABI has it). Rust's `sreg` operands need double-precision `vfp2`, which
/// the M4F lacks, so the value crosses in a core register and `s15` is
/// named as clobbered (an explicit register, which needs no feature).
#[inline(always)]
#[cfg(fpu_f32)]
#[allow(unsafe_code)]
pub fn sqrt(x: f32) -> f32 {
    let root: u32;
    // SAFETY: one FPU instruction on `s15`, declared clobbered; no memory
    // of the program's, no flags the compiler relies on (`VSQRT` and
    // `VMOV` set only the FPSCR's cumulative exception bits).
    unsafe {
        core::arch::asm!(
            "vmov s15, {x}",
            "vsqrt.f32 s15, s15",
            "vmov {root}, s15",
            x = in(reg) x.to_bits(),
            root = lateout(reg) root,
            out("s15") _,
            options(pure, nomem, nostack, preserves_flags),
        );
    }
    f32::from_bits(root)
}

/// `√x`, correctly rounded, in software.
#[inline(always)]
#[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64", fpu_f32)))]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// `⌊t⌋` of `t` clamped to `[0, 255]` (NaN to 0): SPEC §4's
/// `min(255, ⌊x · k + ½⌋)` for `t = x · k + ½`, 0 below. On x86-64 the
/// conversion of the clamped value without Rust's saturating checks: the
/// checked `t as u8` kept every lane of the AVX2 byte loops scalar (a
/// compare-and-move per value: 193 instructions for 32 bytes, 57 this way).
#[inline(always)]
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
pub fn byte(t: f32) -> u8 {
    // Selects that a NaN cannot pass: `NaN > 0` is false.
    let t = if t > 0.0 { t } else { 0.0 };
    let t = if t < 255.0 { t } else { 255.0 };
    // SAFETY: `t` is finite and in `[0, 255]`, inside `i32`'s range, so the
    // conversion (truncation toward zero) is defined.
    let truncated: i32 = unsafe { t.to_int_unchecked() };
    truncated as u8
}

/// [`byte`] elsewhere: Rust's saturating conversion (NaN to 0), which
/// Arm's `VCVT` is, then the clamp in integers (`USAT`): two instructions
/// on the M4 where the float clamps took eight.
#[inline(always)]
#[cfg(not(target_arch = "x86_64"))]
pub fn byte(t: f32) -> u8 {
    (t as i32).clamp(0, 255) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The byte is the saturating conversion's on every kind of value.
    #[test]
    fn byte_is_the_saturating_conversion() {
        let specials = [
            0.0,
            -0.0,
            0.5,
            1.0,
            254.999,
            255.0,
            255.5,
            1e30,
            -3.0,
            f32::NAN,
        ];
        for t in specials {
            let want = t as u8;
            assert_eq!(byte(t), want, "{t}");
        }
        let mut s = 0x2545_F491u32;
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let t = f32::from_bits(s);
            if !t.is_nan() {
                assert_eq!(byte(t), t as u8, "{t:e}");
            }
        }
    }

    /// The root is the correctly rounded one: at and around perfect
    /// squares, and against `f64`'s root (exact before its one rounding to
    /// `f32`, since 53 > 2·24 + 2) at random values of every exponent.
    #[test]
    fn sqrt_is_correctly_rounded() {
        for r in 0..5000u32 {
            let x = (r * r) as f32;
            assert_eq!(sqrt(x), r as f32);
        }
        let mut s = 0x9E37_79B9u32;
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let x = f32::from_bits(s & 0x7F7F_FFFF);
            assert_eq!(sqrt(x), (f64::from(x)).sqrt() as f32, "{x:e}");
        }
        assert_eq!(sqrt(0.0).to_bits(), 0);
    }
}
