//! The engine's row loops in NEON lanes, through intrinsics, for
//! aarch64 (companion boards: Raspberry Pi 4/5, Jetson Orin's CPU). NEON is
//! part of every aarch64 target this builds for (`target_feature = "neon"`),
//! so the set is fixed at compile time: the firmware's and the host's
//! [`Native`](super::Native).
//!
//! With it the engine keeps the structure sums in blocks of [`BLOCK`]
//! output columns (`blocked`: the layout, the horizontal and vertical
//! `G`); one pass makes a row's structure products and their horizontal
//! `G` into the blocks, the products never stored
//! ([`structure_sums_steps`]); and one loop does an output row's tail,
//! four pixels a step, where a block of each ring loads whole, four
//! vectors an instruction (`LD1` of four registers, in `asm!`:
//! [`block_sums`]), finding the magnitudes' extremes only for a sink that
//! takes them. The portable layout (a ring per channel) read 25 rows
//! through 25 pointers and took the sums to memory and back between the
//! vertical `G` and the tail.
//!
//! The stages before the sums take their narrowest exact lanes: `p0` and
//! `d` sixteen pixels a step; the Sobel gradients eight columns a step in
//! `i16`; `E` in one loop from `d`, eight columns a step: its vertical
//! parts and horizontal parts in `i16`, each part's taps shifted out of
//! the vectors of two steps (`EXT`), `E` widened to `i32` and smoothed
//! along the row, none of it leaving the registers (the portable pass
//! wrote the parts and `E` to rows and read them back at five taps);
//! `V`'s vertical binomials eight columns a step, both components in one
//! loop; the residual in 64-bit lanes (`SMLSL`, rounded by `SRSHL`), where the
//! portable loop sums it exactly in two 32-bit halves. Each of these loops
//! ends a row with one more step that ends at the row's end, over columns
//! the step before it already wrote (the same values again), where the
//! portable loops finish one column at a time; rows shorter than a step
//! take the portable loop.
//!
//! The representation's bytes take sixteen pixels a step: both
//! magnitudes' bytes in lanes and `fⁿ`'s, interleaved by one `ST3`, where
//! the portable batches went through the stack and an interleaving loop
//! the compiler kept scalar.
//!
//! Every operation is the portable one, in the same order, so the bytes
//! are the same (`kernel_check`, run under `qemu-aarch64`): exact integer
//! sums, and the `f32` steps of `stages` and `tail` each rounded once. The
//! one fused multiply-add is exact: in an `f32` binomial `((a + e) + (b +
//! d)·4) + c·6`, `(b + d)·4` is exact (a power of two, no overflow, no
//! subnormal: the products are 0 or at least 2⁻²⁰), so `fma(a + e, b + d,
//! 4)` rounds the same sum once, as the two steps do. Integer binomials
//! take two multiply-adds by a constant (`MLA`), exact as every sum is;
//! the binomials' constants are [`held`] in registers, so that a
//! multiply-add by a power of two stays one `MLA` and none is made again
//! each step.
//! `FMAX` takes the
//! determinant's clamp: it differs from the portable select only on NaNs
//! and signed zeros, and the determinant is neither (`tail`'s table).
//!
//! `unsafe` here: the calls of the `#[target_feature(enable = "neon")]`
//! functions, which the module's `cfg` (NEON in the build's features)
//! makes sound, the loads and stores of four to sixteen lanes, each
//! within a row whose length is checked once a row, and two kinds of
//! `asm!`: the tail's loads of a ring's block ([`block_sums`]) and empty
//! ones that hide a constant ([`held`]) or a row's pointer ([`opaque`])
//! from the compiler.
#![allow(unsafe_code)]

use core::arch::aarch64::{
    float32x4_t, float32x4x2_t, int16x8_t, int32x4_t, int32x4x2_t, int32x4x3_t, int64x2_t,
    uint8x8_t, uint8x16_t, uint8x16x3_t, vaddq_f32, vaddq_s16, vaddq_s32, vcvtq_f32_s32,
    vcvtq_n_f32_s32, vcvtq_u32_f32, vdivq_f32, vdupq_n_f32, vdupq_n_s32, vdupq_n_s64, vdupq_n_u32,
    vextq_f32, vextq_s16, vextq_s32, vfmaq_f32, vget_low_s16, vget_low_s32, vget_low_u8, vld1_u8,
    vld1q_f32, vld1q_s16, vld1q_s32, vld1q_s32_x2, vld1q_u8, vmaxq_f32, vmaxq_u32, vmaxvq_u32,
    vminq_u32, vminvq_u32, vmlaq_s16, vmlaq_s32, vmlsl_high_n_s16, vmlsl_high_s32, vmlsl_n_s16,
    vmlsl_s32, vmlsq_n_s16, vmlsq_n_s32, vmovl_high_s16, vmovl_s16, vmull_high_n_s32,
    vmull_high_s16, vmull_n_s32, vmull_s16, vmulq_f32, vqmovn_high_u16, vqmovn_high_u32,
    vqmovn_u16, vqmovn_u32, vreinterpretq_f32_s32, vreinterpretq_s16_s32, vreinterpretq_s16_u16,
    vreinterpretq_s32_s64, vreinterpretq_u32_f32, vrshlq_s64, vshll_n_u8, vshlq_n_s32, vsqrtq_f32,
    vst1q_f32, vst1q_f32_x2, vst1q_s16, vst1q_s32, vst1q_s32_x2, vst1q_s32_x3, vst1q_u8, vst3q_u8,
    vsubl_high_u8, vsubl_u8, vsubq_f32, vsubq_s16, vsubq_s32, vuzp1q_s32,
};
use core::arch::asm;

use super::KernelSet;
use super::blocked::{
    self, Blocked, BlockedRows, BlockedSums, FLOATS, FloatLanes, INTS, IntLanes, Lanes, blocks,
};
use crate::schedule::{HALO, SUM_DEPTH};
use crate::stages::{
    Pair, ResidualInputs, cut, cut_mut, load_pixels_of, portable_boundary_minus_domain,
    portable_smooth,
};
use crate::tail::TailConstants;
use crate::{ByteScale, Extremes, ExtremesSink};

/// The NEON set: the portable row kernels, the structure sums in blocks
/// ([`BlockedSums`]) and the tail in lanes.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Neon;

impl KernelSet for Neon {
    type Sums<'m> = BlockedSums<'m, Neon>;

    /// [`RGB_STEP`] pixels a step in lanes ([`rgb_steps`]), the rest one
    /// at a time.
    #[inline(always)]
    fn rgb_row(pixels: crate::Pixels<'_>, scales: [&ByteScale; 2], out: &mut [[u8; 3]]) {
        let crate::Pixels { m_d, m_c, luma, .. } = pixels;
        let n = out.len().min(m_d.len()).min(m_c.len()).min(luma.len());
        let whole = n - n % RGB_STEP;
        let (Some((m_d, d_rest)), Some((m_c, c_rest)), Some((luma, l_rest)), Some((out, o_rest))) = (
            m_d.split_at_checked(whole),
            m_c.split_at_checked(whole),
            luma.split_at_checked(whole),
            out.split_at_mut_checked(whole),
        ) else {
            return;
        };
        // SAFETY: NEON is in the build's features (the module's `cfg`).
        unsafe { rgb_steps([m_d, m_c], luma, scales.map(ByteScale::parts), out) };
        Self::rgb_pixels(d_rest, c_rest, l_rest, scales, o_rest);
    }

    /// Sixteen pixels a step in lanes ([`load_pixels_steps`]); rows
    /// shorter than a step by the portable loop.
    #[inline(always)]
    fn load_pixels(rows: [&[u8]; 2], p: &mut [u8], d: &mut [i16]) {
        let len = p.len().min(d.len()).min(rows[0].len()).min(rows[1].len());
        if len < LOAD_STEP {
            load_pixels_of(rows, p, d);
        } else {
            // SAFETY: NEON is in the build's features (the module's `cfg`).
            unsafe { load_pixels_steps(rows, p, d, len) };
        }
    }

    /// [`E_STEP`] columns a step in lanes ([`boundary_minus_domain_steps`]),
    /// `E`'s vertical parts and `E` itself never leaving them (`vert` and
    /// `e` are left as they were); rows shorter than two steps by the
    /// portable loops.
    #[inline(always)]
    fn boundary_minus_domain(
        d: [&[i16]; 5],
        vert: &mut [&mut [i16]; 4],
        e: Pair<'_, i32>,
        e_smoothed: Pair<'_, i32>,
        n: usize,
    ) {
        if n < E_STEP + 8 {
            portable_boundary_minus_domain::<Self>(d, vert, e, e_smoothed, n);
        } else {
            // SAFETY: NEON is in the build's features (the module's `cfg`).
            unsafe { boundary_minus_domain_steps(d, e_smoothed, n) };
        }
    }

    /// [`SMOOTH_STEP`] columns a step in lanes, both components in one
    /// loop ([`smooth_steps`]); rows shorter than a step by the portable
    /// loops.
    #[inline(always)]
    fn smooth(e_smoothed: [[&[i32]; 5]; 2], v: Pair<'_, i32>, n: usize) {
        if n < SMOOTH_STEP + 8 {
            portable_smooth::<Self>(e_smoothed, v, n);
        } else {
            // SAFETY: NEON is in the build's features (the module's `cfg`).
            unsafe { smooth_steps(e_smoothed, v, n) };
        }
    }
}

/// Pixels a step of [`load_pixels_steps`]: sixteen bytes.
const LOAD_STEP: usize = 16;

/// `p0` and `d = p1 − p0` (`u8`; `i16` from `USUBL`, exact within ±255)
/// of the first `len ≥ 16` pixels, sixteen a step, the last step ending at
/// `len` (it writes again, the same values, the pixels the step before it
/// wrote).
#[inline(never)]
#[target_feature(enable = "neon")]
fn load_pixels_steps([prev, next]: [&[u8]; 2], p: &mut [u8], d: &mut [i16], len: usize) {
    let (Some(prev), Some(next), Some(p), Some(d), Some(last)) = (
        prev.get(..len),
        next.get(..len),
        p.get_mut(..len),
        d.get_mut(..len),
        len.checked_sub(LOAD_STEP),
    ) else {
        return;
    };
    let (p, d) = (p.as_mut_ptr(), d.as_mut_ptr());
    let step = |i: usize| {
        // SAFETY: `i ≤ last = len − 16`: pixels `i .. i + 16` lie in
        // every row.
        unsafe {
            let (a, b) = (
                vld1q_u8(prev.as_ptr().add(i)),
                vld1q_u8(next.as_ptr().add(i)),
            );
            vst1q_u8(p.add(i), a);
            vst1q_s16(
                d.add(i),
                vreinterpretq_s16_u16(vsubl_u8(vget_low_u8(b), vget_low_u8(a))),
            );
            vst1q_s16(d.add(i + 8), vreinterpretq_s16_u16(vsubl_high_u8(b, a)));
        }
    };
    // `step` called from one place, so that it is inlined.
    for s in 0..len.div_ceil(LOAD_STEP) {
        step((s * LOAD_STEP).min(last));
    }
}

/// `p`, which the compiler can no longer relate to the value it came from:
/// a row loop's pointers advanced through it stay one register each, which
/// each load or store advances (`LDP …, [x], #32`), where the compiler
/// rewrote them as offsets from one index and added it to each pointer
/// every step (`LDP` takes no register offset).
#[inline(always)]
// The template reads no memory through `p`: `nomem` is its contract.
#[allow(clippy::pointers_in_nomem_asm_block)]
fn opaque<T>(mut p: *const T) -> *const T {
    // SAFETY: an empty template: it reads and writes no memory and leaves
    // the register as it was.
    unsafe {
        asm!(
            "/* {0} */",
            inout(reg) p,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    p
}

/// Output columns a step of [`boundary_minus_domain_steps`]: eight, one
/// vector of `i16`.
const E_STEP: usize = 8;

/// The vertical parts [`e_of`] takes, of the eight columns from `rows`
/// (`d` of five rows `a … e`) on, `[w, v2, u, v4]`:
///
/// | quantity | format, lanes | bound |
/// |---|---|---|
/// | `d`: `a, b, c, d, e` | i16 ×8 | 255 |
/// | `a + e`, `b + d`; `v1 = (b + d) + 4·c` | i16 ×8 | 510; 1530 |
/// | `v2 = ((a + e) + 2·(b + d)) + v1 = (a + e) + 3·(b + d) + 4·c` | i16 ×8 | 1530 + 1530 = 3060 |
/// | `w = v1 − 3·v2 = −3·(a + e) − 8·(b + c + d)` | i16 ×8 | 7650 (`3·v2`: 9180) |
/// | `v3 = d − b`; `v4 = v3 + (e − a) = (d + e) − (a + b)` | i16 ×8 | 510; 1020 |
/// | `u = v3 − 3·v4 = 3·(a − e) + 2·(b − d)` | i16 ×8 | 2550 (`3·v4`: 3060) |
///
/// `v1 … v4` are `stages::vertical_parts_of`'s. Exact.
///
/// # Safety
/// Eight values from each of `rows` are readable; NEON runs here.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn parts_at(rows: [*const i16; 5]) -> [int16x8_t; 4] {
    // SAFETY: the caller's.
    let [a, b, c, d, e] = rows.map(|row| unsafe { vld1q_s16(row) });
    let (a_e, b_d) = (vaddq_s16(a, e), vaddq_s16(b, d));
    let v1 = vmlaq_s16(b_d, c, held_s16(4));
    let v2 = vaddq_s16(vmlaq_s16(a_e, b_d, held_s16(2)), v1);
    let w = vmlsq_n_s16(v1, v2, 3);
    let v3 = vsubq_s16(d, b);
    let v4 = vaddq_s16(v3, vsubq_s16(e, a));
    let u = vmlsq_n_s16(v3, v4, 3);
    [w, v2, u, v4]
}

/// Lanes `k … k + 8` of the sixteen `lo`, `hi` (`EXT`; `lo` itself at 0,
/// `hi` at 8).
#[inline]
#[target_feature(enable = "neon")]
fn lanes_from(lo: int16x8_t, hi: int16x8_t, k: usize) -> int16x8_t {
    match k {
        0 => lo,
        1 => vextq_s16::<1>(lo, hi),
        2 => vextq_s16::<2>(lo, hi),
        3 => vextq_s16::<3>(lo, hi),
        4 => vextq_s16::<4>(lo, hi),
        5 => vextq_s16::<5>(lo, hi),
        6 => vextq_s16::<6>(lo, hi),
        7 => vextq_s16::<7>(lo, hi),
        _ => hi,
    }
}

/// `E` (x, then y; each as two vectors of four `i32`s) of eight columns
/// whose taps `t = 0 … 4` (column offsets `t − 2`) lie `offset + t` lanes
/// into the vertical parts ([`parts_at`]) `lo` and `hi` of sixteen
/// columns: `stages::boundary_minus_domain_x` and `_y` regrouped by tap
/// (primes: one and two columns right, back-primes left),
///
/// | quantity | format, lanes | bound |
/// |---|---|---|
/// | `Ax = w′ − w‵ = Kbx3 − 3·(v2′ − v2‵)` | i16 ×8 | 15 300 |
/// | `Bx = v2″ − v2‴`, so `Ax − 3·Bx = Kbx3 − 3·Box⋆Sobx` | i16 ×8 | 6120 |
/// | `Ay = (u‵ + u′) + 4·u = Kby3 − 3·((v4‵ + v4′) + 4·v4)` | i16 ×8 | 15 300 (`u‵ + u′`: 5100) |
/// | `By = (v4‴ + v4″) + 2·(v4‵ + v4′)`, so `Ay − 3·By = Kby3 − 3·Box⋆Soby` | i16 ×8 | 6120 |
/// | `E = A − 3·B` (`SMLSL` by 3 of the widened parts) | i32 ×4 | 33 660 |
///
/// Exact. `offset` is a constant where this is inlined.
#[inline]
#[target_feature(enable = "neon")]
fn e_of(lo: [int16x8_t; 4], hi: [int16x8_t; 4], offset: usize) -> [[int32x4_t; 2]; 2] {
    let [w, v2, u, v4] = [0, 1, 2, 3].map(|p| move |t: usize| lanes_from(lo[p], hi[p], offset + t));
    let a_x = vsubq_s16(w(3), w(1));
    let b_x = vsubq_s16(v2(4), v2(0));
    let a_y = vmlaq_s16(vaddq_s16(u(1), u(3)), u(2), held_s16(4));
    let b_y = vmlaq_s16(
        vaddq_s16(v4(0), v4(4)),
        vaddq_s16(v4(1), v4(3)),
        held_s16(2),
    );
    let e = |a: int16x8_t, b: int16x8_t| {
        [
            vmlsl_n_s16(vmovl_s16(vget_low_s16(a)), vget_low_s16(b), 3),
            vmlsl_high_n_s16(vmovl_high_s16(a), b, 3),
        ]
    };
    [e(a_x, b_x), e(a_y, b_y)]
}

/// `E` smoothed along the row on `[4, n − 4)`
/// ([`KernelSet::boundary_minus_domain`]) from the five rows of `d`
/// (valid on `[0, n)`, `n ≥ 16`), eight columns a step: each step takes
/// the vertical parts ([`parts_at`]) of the eight columns `8 + i …` and
/// those of the eight before them from the step before, `E` ([`e_of`])
/// six to fourteen columns right of its first output `i`, and the `E` of
/// the four left of them from the step before. Two steps a pass of the
/// loop, so that each step's parts and `E` take the registers the step
/// before the last freed (no moves). The first step's carried values, and
/// the last's, come from the parts of sixteen columns; the last step ends
/// at the row's end (it writes again, the same values, the columns the
/// step before it wrote).
#[inline(never)]
#[target_feature(enable = "neon")]
fn boundary_minus_domain_steps(d: [&[i16]; 5], (sx, sy): Pair<'_, i32>, n: usize) {
    let [a, b, c, dd, e] = d.map(|row| cut(row, 0, n));
    let (Some(a), Some(b), Some(c), Some(dd), Some(e)) = (a, b, c, dd, e) else {
        return;
    };
    let Some(len) = n.checked_sub(8) else {
        return;
    };
    let (Some(sx), Some(sy), Some(last)) = (
        cut_mut(sx, 4, len),
        cut_mut(sy, 4, len),
        len.checked_sub(E_STEP),
    ) else {
        return;
    };
    let rows = [a, b, c, dd, e].map(<[i16]>::as_ptr);
    let out = [sx.as_mut_ptr(), sy.as_mut_ptr()];
    // The parts of columns `i … i + 8`, and `E` of columns `2 + i … 6 + i`
    // (from the parts of `i … i + 16`).
    // SAFETY: `i ≤ last = n − 16`: columns `i … i + 16` lie in every row.
    let start = |i: usize| unsafe {
        let lo = parts_at(rows.map(|row| row.add(i)));
        let hi = parts_at(rows.map(|row| row.add(i + 8)));
        (lo, e_of(lo, hi, 0).map(|[left, _]| left))
    };
    // Outputs `i … i + 8` (at `out`), from `d` at `8 + i` (at `src`), the
    // parts of `i … i + 8` and `E` of `2 + i … 6 + i`.
    let step = |src: [*const i16; 5], out: [*mut i32; 2], lo, left: [int32x4_t; 2]| {
        // SAFETY: every `src` and `out` lies `i ≤ last = n − 16` columns
        // into its row: `8 + i + 8 ≤ n` columns of `d`, outputs `i + 8 ≤
        // len`.
        unsafe {
            let hi = parts_at(src);
            let e = e_of(lo, hi, 4);
            for ((row, [a, b]), left) in out.iter().zip(e).zip(left) {
                i32::store(*row, along_row_s32(left, a));
                i32::store(row.add(4), along_row_s32(a, b));
            }
            (hi, e.map(|[_, b]| b))
        }
    };
    // SAFETY: after step `s` (`8·(s + 1) ≤ len`), `d` `8·(s + 2) ≤ n`
    // columns in, outputs `8·(s + 1) ≤ len`: within or one past the rows.
    let advance = |(src, out): ([*const i16; 5], [*mut i32; 2])| unsafe {
        (
            src.map(|row| opaque(row.add(E_STEP))),
            out.map(|row| opaque(row.add(E_STEP)).cast_mut()),
        )
    };
    let (mut lo, mut left) = start(0);
    // SAFETY: column 8 of `d`, within its rows (`n ≥ 16`).
    let mut at = (rows.map(|row| unsafe { row.add(8) }), out);
    for _ in 0..len / (2 * E_STEP) {
        (lo, left) = step(at.0, at.1, lo, left);
        at = advance(at);
        (lo, left) = step(at.0, at.1, lo, left);
        at = advance(at);
    }
    if len % (2 * E_STEP) >= E_STEP {
        step(at.0, at.1, lo, left);
    }
    if !len.is_multiple_of(E_STEP) {
        let (lo, left) = start(last);
        // SAFETY: `last + 16 = n`, `last + 8 = len`.
        let at = unsafe {
            (
                rows.map(|row| row.add(last + 8)),
                out.map(|row| row.add(last)),
            )
        };
        step(at.0, at.1, lo, left);
    }
}

/// `(a + e) + 4·(b + d) + 6·c` of exact `i32` lanes, in two multiply-adds
/// by a constant (four instructions; the 4 and the 6 [`held`], so that
/// they stay multiply-adds, made once): exact where the sum and every
/// partial sum lie within `i32` (all of the engine's, within `2²⁸`).
#[inline]
#[target_feature(enable = "neon")]
fn binomial_mla(a: int32x4_t, b: int32x4_t, c: int32x4_t, d: int32x4_t, e: int32x4_t) -> int32x4_t {
    vmlaq_s32(
        vmlaq_s32(vaddq_s32(a, e), vaddq_s32(b, d), held(4)),
        c,
        held(6),
    )
}

/// `k` in every lane, through an empty `asm!` the compiler cannot see
/// into, so that a multiply-add by it stays one `MLA` (by a power of two
/// LLVM takes a shift and an add: two instructions). The `asm!` is pure,
/// so the compiler hoists it out of a loop with the `MOVI`: the constant
/// is made once and held in a register.
#[inline]
#[target_feature(enable = "neon")]
fn held(k: i32) -> int32x4_t {
    let mut v = vdupq_n_s32(k);
    // SAFETY: the template is a comment: no instruction, no memory
    // touched, the register passed through as it is.
    unsafe {
        asm!("// {v:v}", v = inout(vreg) v, options(pure, nomem, nostack, preserves_flags));
    }
    v
}

/// [`held`] in four `f32` lanes (the same register, reinterpreted).
#[inline]
#[target_feature(enable = "neon")]
fn held_f32(k: f32) -> float32x4_t {
    vreinterpretq_f32_s32(held(k.to_bits().cast_signed()))
}

/// [`held`] in eight `i16` lanes (the same register, reinterpreted).
#[inline]
#[target_feature(enable = "neon")]
fn held_s16(k: i16) -> int16x8_t {
    let pair = u32::from(k.cast_unsigned()) * 0x0001_0001;
    vreinterpretq_s16_s32(held(pair.cast_signed()))
}

/// Columns a step of [`smooth_steps`]: eight, two vectors of `i32`.
const SMOOTH_STEP: usize = 8;

/// `V`'s vertical binomials (`stages::portable_smooth`) on `[4, n − 4)`
/// (`n ≥ 16`) of both components, from the five rows of `E` smoothed
/// along the row (`|·| ≤ 16 · 33 660`) centred on them, eight columns a
/// step ([`binomial_mla`]: `|V| ≤ 256 · 33 660 < 2²⁴`, every partial sum
/// within `i32`, exact), the last step ending at the rows' end (it writes
/// again, the same values, the columns the step before it wrote).
#[inline(never)]
#[target_feature(enable = "neon")]
fn smooth_steps([ex, ey]: [[&[i32]; 5]; 2], (vx, vy): Pair<'_, i32>, n: usize) {
    let Some(len) = n.checked_sub(8) else {
        return;
    };
    let [ax, bx, cx, dx, fx] = ex.map(|row| cut(row, 4, len));
    let [ay, by, cy, dy, fy] = ey.map(|row| cut(row, 4, len));
    let (Some(ax), Some(bx), Some(cx), Some(dx), Some(fx)) = (ax, bx, cx, dx, fx) else {
        return;
    };
    let (Some(ay), Some(by), Some(cy), Some(dy), Some(fy)) = (ay, by, cy, dy, fy) else {
        return;
    };
    let (Some(vx), Some(vy), Some(last)) = (
        cut_mut(vx, 4, len),
        cut_mut(vy, 4, len),
        len.checked_sub(SMOOTH_STEP),
    ) else {
        return;
    };
    let rows = [[ax, bx, cx, dx, fx], [ay, by, cy, dy, fy]].map(|r| r.map(<[i32]>::as_ptr));
    let out = [vx.as_mut_ptr(), vy.as_mut_ptr()];
    // Columns `i … i + 8` of every row, from `rows` and `out` `i` columns in.
    let step = |rows: [[*const i32; 5]; 2], out: [*mut i32; 2]| {
        // SAFETY: `i ≤ last = len − 8`: columns `i .. i + 8` lie in every
        // row.
        unsafe {
            for (taps, row) in rows.iter().zip(out) {
                let [a, b, c, d, e] = taps.map(|tap| vld1q_s32_x2(tap));
                let sums = int32x4x2_t(
                    binomial_mla(a.0, b.0, c.0, d.0, e.0),
                    binomial_mla(a.1, b.1, c.1, d.1, e.1),
                );
                vst1q_s32_x2(row, sums);
            }
        }
    };
    // Whole steps from column 0, every pointer advanced a step through
    // [`opaque`] (each load and store then advances its own: `LDP …, [x],
    // #32`), then the last at `last`.
    let (mut taps, mut outs) = (rows, out);
    for _ in 0..len / SMOOTH_STEP {
        step(taps, outs);
        // SAFETY: after step `s`, `8·(s + 1) ≤ len` columns in: within or
        // one past every row.
        unsafe {
            taps = taps.map(|r| r.map(|tap| opaque(tap.add(SMOOTH_STEP))));
            outs = outs.map(|row| opaque(row.add(SMOOTH_STEP)).cast_mut());
        }
    }
    if !len.is_multiple_of(SMOOTH_STEP) {
        // SAFETY: `last = len − 8`.
        unsafe {
            step(
                rows.map(|r| r.map(|tap| tap.add(last))),
                out.map(|row| row.add(last)),
            );
        }
    }
}

/// The products' inputs (`ResidualInputs`), each row from window column 0
/// and long enough for [`products_at`] at every column a row's
/// [`structure_sums_steps`] reads ([`StructureInputs::new`] checks it once
/// a row), and the residual's constants.
struct StructureInputs<'a> {
    p0: [&'a [u8]; 3],
    vx: &'a [i32],
    vy: [&'a [i32]; 3],
    d: &'a [i16],
    /// `[κh, κl]`.
    kappa: [i32; 2],
    /// `−σ` in both lanes (`SRSHL` shifts right by it).
    right_shift: int64x2_t,
    /// Blocks of the row's output columns, at least two.
    blocks: usize,
}

impl<'a> StructureInputs<'a> {
    /// The inputs of a window of `n` columns, or `None` where the window
    /// has fewer than two blocks of output columns or a row is shorter
    /// than the columns [`structure_sums_steps`] reads (never, for the
    /// engine's rows, a window wide).
    #[inline(always)]
    fn new(input: &ResidualInputs<'a>, n: usize) -> Option<Self> {
        let ResidualInputs {
            vx,
            vy,
            p0,
            d,
            kappa,
            shift,
        } = *input;
        let blocks = blocks::<BLOCK>(n.checked_sub(2 * HALO)?);
        // `products_at` at columns up to `4·(blocks − 2) + 9` reads
        // columns up to `4·blocks + 9` (`≤ n − 2`).
        let reach = BLOCK * blocks + 10;
        let long = p0.iter().map(|r| r.len()).chain(vy.iter().map(|r| r.len()));
        if blocks < 2 || long.chain([vx.len(), d.len()]).any(|len| len < reach) {
            return None;
        }
        Some(Self {
            p0,
            vx,
            vy,
            d,
            kappa,
            // SAFETY: NEON is in the build's features (the module's `cfg`).
            right_shift: unsafe { vdupq_n_s64(-i64::from(shift)) },
            blocks,
        })
    }
}

/// Where [`products_at`] reads: each row of [`StructureInputs`] at one
/// window column.
#[derive(Clone, Copy)]
struct ProductTaps {
    p0: [*const u8; 3],
    vx: *const i32,
    vy: [*const i32; 3],
    d: *const i16,
}

impl ProductTaps {
    /// Column `c` of each row.
    ///
    /// # Safety
    /// `c ≤` every row's length.
    #[inline(always)]
    unsafe fn at(inputs: &StructureInputs<'_>, c: usize) -> Self {
        // SAFETY: the caller's.
        unsafe {
            Self {
                p0: inputs.p0.map(|row| row.as_ptr().add(c)),
                vx: inputs.vx.as_ptr().add(c),
                vy: inputs.vy.map(|row| row.as_ptr().add(c)),
                d: inputs.d.as_ptr().add(c),
            }
        }
    }

    /// [`STRUCTURE_STEP`] columns right ([`opaque`]: each row's own
    /// register, advanced by its loads).
    ///
    /// # Safety
    /// The columns lie within, or one past, every row.
    #[inline(always)]
    unsafe fn advance(self) -> Self {
        // SAFETY: the caller's.
        unsafe {
            Self {
                p0: self.p0.map(|row| opaque(row.add(STRUCTURE_STEP))),
                vx: opaque(self.vx.add(STRUCTURE_STEP)),
                vy: self.vy.map(|row| opaque(row.add(STRUCTURE_STEP))),
                d: opaque(self.d.add(STRUCTURE_STEP)),
            }
        }
    }
}

/// Window columns a step of [`structure_sums_steps`]: the products of two
/// blocks' columns.
const STRUCTURE_STEP: usize = 2 * BLOCK;

/// The five structure products of eight window columns, as two vectors of
/// four each: `X², XY, Y²` and `X·Dn′·2⁻²⁰, Y·Dn′·2⁻²⁰`.
struct Products8 {
    ints: [[int32x4_t; 2]; INTS],
    floats: [[float32x4_t; 2]; FLOATS],
}

/// `stages::products_of` at window columns `c .. c + 8`:
///
/// | quantity | format, lanes | bound |
/// |---|---|---|
/// | `p0` (3×3 neighbourhood) | u8 ×8 | 255 |
/// | differences of `p0`, `X`, `Y` (Sobel), `4·p0` | i16 ×8 | 255, 1020, 1020 |
/// | `X², XY, Y²` (`SMULL` of `i16`) | i32 ×4 | `1020² < 2²⁰` |
/// | `V` x, y; `Q = (Vx′ − Vx‵) + (Vy′ − Vy‵)` | i32 ×4 | `6 854 400 < 2²³`; `16 144 560 < 2²⁴` |
/// | `T = −κl·d − X·Vx − Y·Vy − 4·p0·Q` (`SMULL`/`SMLSL`) | i64 ×2 | `2²² + 2·2³³ + 2³⁴ < 2³⁵` |
/// | `⌊(T + 2^(σ−1)) / 2^σ⌋` (`SRSHL` by `−σ`, then narrowed) | i32 ×4 | `< 2²⁷` (`σ ≥ 8`) |
/// | `Dn′ = that − κh·d` | i32 ×4 | `≤ 2²⁷` (`stages`) |
/// | `Dn′·2⁻²⁰` (`SCVTF` with 20 fraction bits), `X·…`, `Y·…` | f32 ×4 | `stages` |
///
/// With `κ = κh·2^σ + κl`, `Dn = −κh·d·2^σ + T`, so `Dn′ = ⌊(Dn +
/// 2^(σ−1)) / 2^σ⌋ = −κh·d + ⌊(T + 2^(σ−1)) / 2^σ⌋`: `stages::
/// rounded_residual`'s value, which sums the same `Dn` in 32-bit halves.
/// `SRSHL` adds `2^(σ−1)` before its arithmetic shift without overflow.
/// Every integer step is exact (the lanes' wrapping never happens within
/// the bounds); `SCVTF` with fraction bits rounds `Dn′ / 2²⁰` once, which
/// is `Dn′ as f32 · 2⁻²⁰` (scaling by a power of two is exact: no overflow,
/// no subnormal), and each `f32` product rounds once, as the portable.
///
/// # Safety
/// Columns `c − 1 .. c + 9` lie in every row `at` points into (at column
/// `c`); NEON runs here.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn products_at(inputs: &StructureInputs<'_>, at: &ProductTaps) -> Products8 {
    let StructureInputs {
        kappa: [kappa_high, kappa_low],
        right_shift,
        ..
    } = *inputs;
    let ProductTaps {
        p0: [up, mid, down],
        vx,
        vy: [vy_up, vy, vy_down],
        d,
    } = *at;
    // SAFETY (every load below): the caller's, columns `c − 1 .. c + 9`.
    let taps = |row: *const u8| -> [uint8x8_t; 3] {
        [0, 1, 2].map(|k| unsafe { vld1_u8(row.add(k).sub(1)) })
    };
    let (pu, pm, pd) = (taps(up), taps(mid), taps(down));
    // Every load before the first use, so that neighbouring four-lane
    // loads pair (`LDP`).
    let pair = |p: *const i32| unsafe { [i32::load(p), i32::load(p.add(4))] };
    let (vx_l, vx_c, vx_r) = unsafe { (pair(vx.sub(1)), pair(vx), pair(vx.add(1))) };
    let (vy_u, vy_c, vy_d) = (pair(vy_up), pair(vy), pair(vy_down));
    let d = unsafe { vld1q_s16(d) };
    let diff = |a, b| vreinterpretq_s16_u16(vsubl_u8(a, b));
    let two = held_s16(2);
    let twice_plus = |a: int16x8_t, b: int16x8_t, c: int16x8_t| vmlaq_s16(vaddq_s16(a, c), b, two);
    let x = twice_plus(diff(pu[2], pu[0]), diff(pm[2], pm[0]), diff(pd[2], pd[0]));
    let y = twice_plus(diff(pd[0], pu[0]), diff(pd[1], pu[1]), diff(pd[2], pu[2]));
    let square = |a: int16x8_t, b: int16x8_t| {
        [
            vmull_s16(vget_low_s16(a), vget_low_s16(b)),
            vmull_high_s16(a, b),
        ]
    };
    let ints = [square(x, x), square(x, y), square(y, y)];
    let widen = |a: int16x8_t| [vmovl_s16(vget_low_s16(a)), vmovl_high_s16(a)];
    let (x, y) = (widen(x), widen(y));
    let p4 = widen(vreinterpretq_s16_u16(vshll_n_u8::<2>(pm[1])));
    let d = widen(d);
    let mut floats = [[vdupq_n_f32(0.0); 2]; FLOATS];
    for h in 0..2 {
        let (vx_l, vx_c, vx_r) = (vx_l[h], vx_c[h], vx_r[h]);
        let (vy_u, vy_c, vy_d) = (vy_u[h], vy_c[h], vy_d[h]);
        let q = vaddq_s32(vsubq_s32(vx_r, vx_l), vsubq_s32(vy_d, vy_u));
        let low = |a: int32x4_t| vget_low_s32(a);
        let mut t_low = vmull_n_s32(low(d[h]), -kappa_low);
        t_low = vmlsl_s32(t_low, low(x[h]), low(vx_c));
        t_low = vmlsl_s32(t_low, low(y[h]), low(vy_c));
        t_low = vmlsl_s32(t_low, low(p4[h]), low(q));
        let mut t_high = vmull_high_n_s32(d[h], -kappa_low);
        t_high = vmlsl_high_s32(t_high, x[h], vx_c);
        t_high = vmlsl_high_s32(t_high, y[h], vy_c);
        t_high = vmlsl_high_s32(t_high, p4[h], q);
        let rounded = vuzp1q_s32(
            vreinterpretq_s32_s64(vrshlq_s64(t_low, right_shift)),
            vreinterpretq_s32_s64(vrshlq_s64(t_high, right_shift)),
        );
        let dn = vcvtq_n_f32_s32::<20>(vmlsq_n_s32(rounded, d[h], kappa_high));
        floats[0][h] = vmulq_f32(vcvtq_f32_s32(x[h]), dn);
        floats[1][h] = vmulq_f32(vcvtq_f32_s32(y[h]), dn);
    }
    Products8 { ints, floats }
}

/// The binomial along the row of four `i32` columns: the taps `left`,
/// its three shifts into `right` (`EXT`) and `right`, the vector after it
/// ([`binomial_mla`]; exact for `E`, within `16 · 33 660 < 2²⁰`, and for
/// the structure products, within `16 · 2²⁰`).
#[inline]
#[target_feature(enable = "neon")]
fn along_row_s32(left: int32x4_t, right: int32x4_t) -> int32x4_t {
    let (b, c, d) = (
        vextq_s32::<1>(left, right),
        vextq_s32::<2>(left, right),
        vextq_s32::<3>(left, right),
    );
    binomial_mla(left, b, c, d, right)
}

/// [`along_row_s32`] of `f32` columns ([`binomial_f`]: the taps in
/// `Sample::binomial`'s order).
#[inline]
#[target_feature(enable = "neon")]
fn along_row_f32(left: float32x4_t, right: float32x4_t) -> float32x4_t {
    let (b, c, d) = (
        vextq_f32::<1>(left, right),
        vextq_f32::<2>(left, right),
        vextq_f32::<3>(left, right),
    );
    binomial_f(left, b, c, d, right)
}

/// The five structure products of a window row and their horizontal `G`
/// into slot `slot` of the blocked rings ([`Blocked::structure_sums`]),
/// the products never leaving the lanes: two blocks a step. Block `b`'s
/// taps start at window column `5 + 4b` (`blocked::horizontal_sums`), so
/// its sums are [`along_row_s32`] / [`along_row_f32`] of the products of
/// columns `5 + 4b ..` and `9 + 4b ..`: a step ([`structure_pair`])
/// makes the products of the eight columns from `9 + 4b`
/// ([`products_at`]) and takes those of the four before from the step
/// before it (the first step makes them: the upper half of
/// [`products_at`] from column 1). With an odd number of blocks, the
/// first step covers blocks 0 and 1 and the next ones start at block 1
/// (block 1 written twice, the same sums). Lanes past the row's last output
/// column get sums of products of the columns after it (bounded like any,
/// from rows that hold earlier values; the tail discards them). Exact as
/// [`products_at`] and the binomials are.
#[inline(never)]
#[target_feature(enable = "neon")]
fn structure_sums_steps(
    inputs: &StructureInputs<'_>,
    (int_ring, float_ring, slot): (&mut [i32], &mut [f32], usize),
) {
    let blocks = inputs.blocks;
    let slot = slot % SUM_DEPTH;
    let (Some(int_ring), Some(float_ring)) = (
        int_ring.get_mut(slot * INTS * BLOCK..blocks * INT_BLOCK),
        float_ring.get_mut(slot * FLOATS * BLOCK..blocks * FLOAT_BLOCK),
    ) else {
        return;
    };
    let out = (int_ring.as_mut_ptr(), float_ring.as_mut_ptr());
    // SAFETY: the reach checked (`blocks ≥ 2`): columns 0 .. 10 lie in
    // every row, and `products_at` at column `4b + 9` reads columns
    // `4b + 8 .. 4b + 18 ≤ 4·blocks + 10` for every `b ≤ blocks − 2`;
    // the rings hold blocks `0 .. blocks` (their lengths, above).
    unsafe {
        let mut carry = Products4::upper(&products_at(inputs, &ProductTaps::at(inputs, 1)));
        let mut at = (ProductTaps::at(inputs, 9), out);
        if blocks % 2 == 1 {
            // Blocks 0 and 1 first; then pairs from block 1.
            carry = Products4::lower(&structure_pair(inputs, &at.0, out, carry));
            at = (
                ProductTaps::at(inputs, 13),
                (out.0.add(INT_BLOCK), out.1.add(FLOAT_BLOCK)),
            );
        }
        for _ in 0..blocks / 2 {
            carry = Products4::upper(&structure_pair(inputs, &at.0, at.1, carry));
            at = (
                at.0.advance(),
                (
                    opaque(at.1.0.add(2 * INT_BLOCK)).cast_mut(),
                    opaque(at.1.1.add(2 * FLOAT_BLOCK)).cast_mut(),
                ),
            );
        }
    }
}

/// The sums of two blocks, `b` and `b + 1`, into their slot at `out`,
/// from the products of the four columns before them (`carry`): the
/// products of their columns (`at`, window column `4b + 9`), which it
/// returns.
///
/// # Safety
/// As [`products_at`]'s; `out` points to the slot's channels of block
/// `b`, and block `b + 1` lies in both rings; NEON runs here.
#[inline(always)]
unsafe fn structure_pair(
    inputs: &StructureInputs<'_>,
    at: &ProductTaps,
    (ints, floats): (*mut i32, *mut f32),
    carry: Products4,
) -> Products8 {
    // SAFETY: the caller's; channel `ch` of a block's slot at `ch · 4`
    // from its first (`blocked::at`).
    unsafe {
        let next = products_at(inputs, at);
        let (lower, upper) = (Products4::lower(&next), Products4::upper(&next));
        for (k, (left, right)) in [(carry, lower), (lower, upper)].into_iter().enumerate() {
            let int = |ch: usize| along_row_s32(left.ints[ch], right.ints[ch]);
            let sums = int32x4x3_t(int(0), int(1), int(2));
            vst1q_s32_x3(ints.add(k * INT_BLOCK), sums);
            let float = |ch: usize| along_row_f32(left.floats[ch], right.floats[ch]);
            let sums = float32x4x2_t(float(0), float(1));
            vst1q_f32_x2(floats.add(k * FLOAT_BLOCK), sums);
        }
        next
    }
}

/// The products of four window columns: a half of a [`Products8`].
#[derive(Clone, Copy)]
struct Products4 {
    ints: [int32x4_t; INTS],
    floats: [float32x4_t; FLOATS],
}

impl Products4 {
    /// Columns `c .. c + 4` of the products of `c .. c + 8`.
    #[inline(always)]
    fn lower(products: &Products8) -> Self {
        Self {
            ints: products.ints.map(|[low, _]| low),
            floats: products.floats.map(|[low, _]| low),
        }
    }

    /// Columns `c + 4 .. c + 8` of the products of `c .. c + 8`.
    #[inline(always)]
    fn upper(products: &Products8) -> Self {
        Self {
            ints: products.ints.map(|[_, high]| high),
            floats: products.floats.map(|[_, high]| high),
        }
    }
}

/// Pixels a step of [`rgb_steps`]: sixteen bytes a channel, one `ST3`.
const RGB_STEP: usize = 16;

/// `ByteScale::byte` of sixteen magnitudes from `m`: `(m − offset) · gain
/// + ½`, each step rounded once as the portable one (no fused step), then
/// `FCVTZU` (toward zero, saturating to `u32`, NaN to 0) and two
/// saturating narrowings: Rust's saturating `t as u8`, lane by lane.
///
/// # Safety
/// `m` points to sixteen readable values.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn bytes_at(m: *const f32, [offset, gain]: [float32x4_t; 2]) -> uint8x16_t {
    let word = |k: usize| {
        // SAFETY: the caller's (`k < 4`).
        let m = unsafe { vld1q_f32(m.add(4 * k)) };
        let t = vaddq_f32(vmulq_f32(vsubq_f32(m, offset), gain), vdupq_n_f32(0.5));
        vcvtq_u32_f32(t)
    };
    let low = vqmovn_high_u32(vqmovn_u32(word(0)), word(1));
    let high = vqmovn_high_u32(vqmovn_u32(word(2)), word(3));
    vqmovn_high_u16(vqmovn_u16(low), high)
}

/// The bytes of `out.len() / RGB_STEP` steps of [`RGB_STEP`] pixels: each
/// magnitude's bytes ([`bytes_at`]) and `fⁿ`, interleaved by one `ST3`.
/// `scales`: `ByteScale::parts` of `|v_d|`'s and `|v_c|`'s.
#[target_feature(enable = "neon")]
fn rgb_steps([m_d, m_c]: [&[f32]; 2], luma: &[u8], scales: [[f32; 2]; 2], out: &mut [[u8; 3]]) {
    let steps = out.len().min(m_d.len()).min(m_c.len()).min(luma.len()) / RGB_STEP;
    let [d, c] = scales.map(|[offset, gain]| [vdupq_n_f32(offset), vdupq_n_f32(gain)]);
    for s in 0..steps {
        let i = s * RGB_STEP;
        // SAFETY: `i + RGB_STEP` is within every row (`steps`).
        unsafe {
            let r = bytes_at(m_d.as_ptr().add(i), d);
            let g = bytes_at(m_c.as_ptr().add(i), c);
            let b = vld1q_u8(luma.as_ptr().add(i));
            vst3q_u8(out.as_mut_ptr().add(i).cast::<u8>(), uint8x16x3_t(r, g, b));
        }
    }
}

/// Output columns a block: one NEON vector of each channel of each row.
const BLOCK: usize = 4;

/// Values a block of the integer sums' ring and of the `f32` sums' ring
/// (`blocked::ring_block`): fifteen and ten vectors of four lanes.
const INT_BLOCK: usize = blocked::ring_block::<BLOCK>(INTS);
const FLOAT_BLOCK: usize = blocked::ring_block::<BLOCK>(FLOATS);
const _: () = assert!(INT_BLOCK == 60 && FLOAT_BLOCK == 40);

impl Blocked for Neon {
    /// In one pass ([`structure_sums_steps`]) where the window has two
    /// blocks of output columns or more.
    #[inline(always)]
    fn structure_sums(
        self,
        input: &ResidualInputs<'_>,
        rings: (&mut [i32], &mut [f32], usize),
        n: usize,
    ) -> bool {
        let Some(inputs) = StructureInputs::new(input, n) else {
            return false;
        };
        // SAFETY: NEON is in the build's features (the module's `cfg`).
        unsafe { structure_sums_steps(&inputs, rings) };
        true
    }

    #[inline(always)]
    fn horizontal_sums(
        self,
        ints: [&[i32]; INTS],
        floats: [&[f32]; FLOATS],
        rings: (&mut [i32], &mut [f32], usize),
        n: usize,
    ) {
        // SAFETY: NEON is enabled for the whole build (the module's `cfg`).
        unsafe { horizontal_sums_neon(ints, floats, rings, n) }
    }

    #[inline(always)]
    fn tail_row<const FIELDS: bool, const EXTREMES: bool, const FIRST: usize>(
        self,
        k: &TailConstants,
        rows: &BlockedRows<'_>,
        m: [&mut [f32]; 2],
        fields: [&mut [f32]; 4],
    ) -> ExtremesSink {
        // SAFETY: NEON is enabled for the whole build (the module's `cfg`).
        unsafe { tail_row_neon::<FIELDS, EXTREMES, FIRST>(k, rows, m, fields) }
    }
}

/// `((a + e) + (b + d)·4) + c·6`, rounded as `Sample::binomial` for `f32`
/// (module doc: the one FMA is exact).
#[inline]
#[target_feature(enable = "neon")]
fn binomial_f(
    a: float32x4_t,
    b: float32x4_t,
    c: float32x4_t,
    d: float32x4_t,
    e: float32x4_t,
) -> float32x4_t {
    let sum = vfmaq_f32(vaddq_f32(a, e), vaddq_f32(b, d), held_f32(4.0));
    vaddq_f32(sum, vmulq_f32(c, held_f32(6.0)))
}

/// Exact `i32` sums, four a vector ([`binomial_mla`]).
impl Lanes<BLOCK> for i32 {
    type Vector = int32x4_t;

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn load(p: *const i32) -> int32x4_t {
        // SAFETY: the caller's; no alignment needed.
        unsafe { vld1q_s32(p) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn store(p: *mut i32, v: int32x4_t) {
        // SAFETY: the caller's.
        unsafe { vst1q_s32(p, v) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn binomial_lanes([a, b, c, d, e]: [int32x4_t; 5]) -> int32x4_t {
        binomial_mla(a, b, c, d, e)
    }
}

/// `f32` sums, four a vector ([`binomial_f`]).
impl Lanes<BLOCK> for f32 {
    type Vector = float32x4_t;

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn load(p: *const f32) -> float32x4_t {
        // SAFETY: the caller's; no alignment needed.
        unsafe { vld1q_f32(p) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn store(p: *mut f32, v: float32x4_t) {
        // SAFETY: the caller's.
        unsafe { vst1q_f32(p, v) }
    }

    #[inline]
    #[target_feature(enable = "neon")]
    unsafe fn binomial_lanes([a, b, c, d, e]: [float32x4_t; 5]) -> float32x4_t {
        binomial_f(a, b, c, d, e)
    }
}

/// [`blocked::horizontal_sums`] in NEON lanes.
#[inline(never)]
#[target_feature(enable = "neon")]
fn horizontal_sums_neon(
    ints: [&[i32]; INTS],
    floats: [&[f32]; FLOATS],
    rings: (&mut [i32], &mut [f32], usize),
    n: usize,
) {
    // SAFETY: NEON is enabled here.
    unsafe { blocked::horizontal_sums::<BLOCK>(ints, floats, rings, n) }
}

/// [`blocked::block_sums`] of the block whose rings' values start at
/// `*ints` and `*floats` (the five rows from slot `FIRST` on), which then
/// point to the next block: the whole block loaded four vectors an
/// instruction (`LD1` of four registers, the pointer advanced by the
/// load: four of the integer ring, three of the `f32` ring, where the
/// vectors one at a time take thirteen `LDP`s and `LDR`s and an `ADD`),
/// each channel's taps then picked from them in the binomial's order
/// ([`binomial_mla`], [`binomial_f`]).
///
/// The loads are `asm!`: the intrinsics of multi-register `LD1`
/// (`vld1q_s32_x4`) reach LLVM as plain loads, which it takes as `LDP`s.
/// `LD1`'s registers are consecutive, so each `asm!` names its own
/// (`v16` on; the integer ring's are dead once its sums are taken, and
/// the `f32` ring's take the same).
///
/// # Safety
/// `*ints` points to [`INT_BLOCK`] readable values and `*floats` to
/// [`FLOAT_BLOCK`]; NEON runs here.
#[inline]
#[target_feature(enable = "neon")]
unsafe fn block_sums<const FIRST: usize>(
    ints: &mut *const i32,
    floats: &mut *const f32,
) -> ([IntLanes<BLOCK>; INTS], [FloatLanes<BLOCK>; FLOATS]) {
    // The vector of channel `ch` of tap `k` (slot `(FIRST + k) mod 5`) of
    // a ring of `channels`.
    let tap = |channels: usize, ch: usize, k: usize| {
        blocked::at::<BLOCK>(channels, 0, (FIRST + k) % SUM_DEPTH, ch) / BLOCK
    };
    let int: [int32x4_t; INT_BLOCK / BLOCK];
    let (i0, i1, i2, i3, i4, i5, i6, i7, i8, i9, i10, i11, i12, i13, i14);
    // SAFETY: the caller's: the sixty values (240 bytes) from `*ints`
    // are readable; the `asm!` reads them, advances the pointer past
    // them and writes only its output registers.
    unsafe {
        asm!(
            "ld1 {{ v16.4s, v17.4s, v18.4s, v19.4s }}, [{p}], #64",
            "ld1 {{ v20.4s, v21.4s, v22.4s, v23.4s }}, [{p}], #64",
            "ld1 {{ v24.4s, v25.4s, v26.4s, v27.4s }}, [{p}], #64",
            "ld1 {{ v28.4s, v29.4s, v30.4s }}, [{p}], #48",
            p = inout(reg) *ints,
            out("v16") i0, out("v17") i1, out("v18") i2, out("v19") i3,
            out("v20") i4, out("v21") i5, out("v22") i6, out("v23") i7,
            out("v24") i8, out("v25") i9, out("v26") i10, out("v27") i11,
            out("v28") i12, out("v29") i13, out("v30") i14,
            options(pure, readonly, nostack, preserves_flags),
        );
        int = [
            i0, i1, i2, i3, i4, i5, i6, i7, i8, i9, i10, i11, i12, i13, i14,
        ];
    }
    let sum_int = |ch: usize| {
        let t = |k: usize| int[tap(INTS, ch, k)];
        binomial_mla(t(0), t(1), t(2), t(3), t(4))
    };
    let abc = [sum_int(0), sum_int(1), sum_int(2)];
    let float: [float32x4_t; FLOAT_BLOCK / BLOCK];
    let (f0, f1, f2, f3, f4, f5, f6, f7, f8, f9);
    // SAFETY: the caller's: the forty values (160 bytes) from `*floats`
    // are readable; as above.
    unsafe {
        asm!(
            "ld1 {{ v16.4s, v17.4s, v18.4s, v19.4s }}, [{p}], #64",
            "ld1 {{ v20.4s, v21.4s, v22.4s, v23.4s }}, [{p}], #64",
            "ld1 {{ v24.4s, v25.4s }}, [{p}], #32",
            p = inout(reg) *floats,
            out("v16") f0, out("v17") f1, out("v18") f2, out("v19") f3,
            out("v20") f4, out("v21") f5, out("v22") f6, out("v23") f7,
            out("v24") f8, out("v25") f9,
            options(pure, readonly, nostack, preserves_flags),
        );
        float = [f0, f1, f2, f3, f4, f5, f6, f7, f8, f9];
    }
    let sum_float = |ch: usize| {
        let t = |k: usize| float[tap(FLOATS, ch, k)];
        binomial_f(t(0), t(1), t(2), t(3), t(4))
    };
    (abc, [sum_float(0), sum_float(1)])
}

/// The constants of the tail in lanes.
struct Constants {
    lambda4: int32x4_t,
    det_floor: float32x4_t,
    v_d: float32x4_t,
    v_c: float32x4_t,
}

/// [`Blocked::tail_row`] in NEON lanes.
#[inline(never)]
#[target_feature(enable = "neon")]
fn tail_row_neon<const FIELDS: bool, const EXTREMES: bool, const FIRST: usize>(
    k: &TailConstants,
    rows: &BlockedRows<'_>,
    [m_d, m_c]: [&mut [f32]; 2],
    fields: [&mut [f32]; 4],
) -> ExtremesSink {
    let w = m_d.len();
    let (nb, whole) = (blocks::<BLOCK>(w), w / BLOCK);
    let Some([vx, vy]) = blocked::tail_v::<FIELDS, BLOCK>(rows, w, m_c, &fields) else {
        return ExtremesSink::default();
    };
    let c = Constants {
        lambda4: vdupq_n_s32(k.lambda4),
        det_floor: vdupq_n_f32(k.units.det_floor),
        v_d: vdupq_n_f32(k.units.v_d),
        v_c: vdupq_n_f32(k.units.v_c),
    };
    let (ints, floats) = (rows.ints.as_ptr(), rows.floats.as_ptr());
    let [v_c_x, v_c_y, v_d_x, v_d_y] = fields;
    let out = [
        m_d.as_mut_ptr(),
        m_c.as_mut_ptr(),
        v_c_x.as_mut_ptr(),
        v_c_y.as_mut_ptr(),
        v_d_x.as_mut_ptr(),
        v_d_y.as_mut_ptr(),
    ];
    // The magnitudes' extremes as `Extremes::add_all` finds them: minima
    // and maxima of their bits (non-negative `f32`s order as their bits).
    let empty = Extremes::EMPTY;
    let mut min = [vdupq_n_u32(empty.min.to_bits()); 2];
    let mut max = [vdupq_n_u32(empty.max.to_bits()); 2];
    // Block `b`'s values in the rings, advanced a block a step.
    let (mut int_at, mut float_at) = (ints, floats);
    for b in 0..whole {
        let at = BLOCK * b;
        // SAFETY: block `b < nb` lies in both rings (`int_at`, `float_at`
        // point to it: `b` blocks advanced), and `at + 4 ≤ w` in `V` and
        // the outputs (the fields when `FIELDS`): the lengths `tail_v`
        // checked; NEON is enabled here.
        unsafe {
            let (abc, pq) = block_sums::<FIRST>(&mut int_at, &mut float_at);
            let v = [
                i32::load(vx.as_ptr().add(at)),
                i32::load(vy.as_ptr().add(at)),
            ];
            let px = pixels(&c, abc, pq, v);
            if EXTREMES {
                let bits = [vreinterpretq_u32_f32(px.m_d), vreinterpretq_u32_f32(px.m_c)];
                for k in 0..2 {
                    min[k] = vminq_u32(min[k], bits[k]);
                    max[k] = vmaxq_u32(max[k], bits[k]);
                }
            }
            for (row, lanes) in out.iter().zip(outputs::<FIELDS>(&c, &px)) {
                f32::store(row.add(at), lanes);
            }
        }
    }
    let mut extremes = [0, 1].map(|k| Extremes {
        min: f32::from_bits(vminvq_u32(min[k]).min(empty.min.to_bits())),
        max: f32::from_bits(vmaxvq_u32(max[k]).max(empty.max.to_bits())),
    });
    if whole < nb {
        // The last, partial block: `V` past the row's end reads as 0, and
        // only the row's columns are written.
        let at = BLOCK * whole;
        let (vx, vy) = (
            blocked::padded::<BLOCK>(vx, at),
            blocked::padded::<BLOCK>(vy, at),
        );
        let mut local = [[0.0f32; BLOCK]; 6];
        // SAFETY: block `whole < nb` lies in both rings; `V` and the
        // results are local arrays of four lanes; NEON is enabled here.
        unsafe {
            let (abc, pq) = block_sums::<FIRST>(
                &mut ints.add(whole * INT_BLOCK),
                &mut floats.add(whole * FLOAT_BLOCK),
            );
            let v = [i32::load(vx.as_ptr()), i32::load(vy.as_ptr())];
            let px = pixels(&c, abc, pq, v);
            for (row, lanes) in local.iter_mut().zip(outputs::<FIELDS>(&c, &px)) {
                f32::store(row.as_mut_ptr(), lanes);
            }
        }
        let rows = [m_d, m_c, v_c_x, v_c_y, v_d_x, v_d_y];
        blocked::finish_partial(rows, &local, (at, w), &mut extremes);
    }
    let [m_d, m_c] = extremes;
    ExtremesSink { m_d, m_c }
}

/// One block's results: the magnitudes, and the fields' parts.
struct Pixels {
    m_d: float32x4_t,
    m_c: float32x4_t,
    /// `V` in `f32`, the numerators `N` and `1/det` (in `v_d`'s units).
    v: [float32x4_t; 2],
    n: [float32x4_t; 2],
    inv: float32x4_t,
}

/// The tail of four pixels: `tail::solve` and the magnitudes, operation
/// for operation.
#[inline]
#[target_feature(enable = "neon")]
fn pixels(
    c: &Constants,
    [a, b, cc]: [IntLanes<BLOCK>; INTS],
    [p, q]: [FloatLanes<BLOCK>; FLOATS],
    v: [int32x4_t; 2],
) -> Pixels {
    let a4 = vcvtq_f32_s32(vaddq_s32(vshlq_n_s32::<2>(a), c.lambda4));
    let c4 = vcvtq_f32_s32(vaddq_s32(vshlq_n_s32::<2>(cc), c.lambda4));
    let b4 = vcvtq_f32_s32(vshlq_n_s32::<2>(b));
    let det = vsubq_f32(vmulq_f32(a4, c4), vmulq_f32(b4, b4));
    // `det > floor ? det : floor` (module doc: no NaN, no zero).
    let det = vmaxq_f32(det, c.det_floor);
    let n = [
        vsubq_f32(vmulq_f32(c4, p), vmulq_f32(b4, q)),
        vsubq_f32(vmulq_f32(a4, q), vmulq_f32(b4, p)),
    ];
    let inv = vdivq_f32(c.v_d, det);
    let norm = |[x, y]: [float32x4_t; 2]| vsqrtq_f32(vaddq_f32(vmulq_f32(x, x), vmulq_f32(y, y)));
    let v = [vcvtq_f32_s32(v[0]), vcvtq_f32_s32(v[1])];
    Pixels {
        m_d: vmulq_f32(norm(n), inv),
        m_c: vmulq_f32(norm(v), c.v_c),
        v,
        n,
        inv,
    }
}

/// A block's results in the order of the rows `[|v_d|, |v_c|, v_c x, v_c
/// y, v_d x, v_d y]`, as `tail::pixels_of` makes them: the magnitudes,
/// and the fields only when `FIELDS` (their lanes are the magnitudes'
/// otherwise, for rows that take nothing).
#[inline]
#[target_feature(enable = "neon")]
fn outputs<const FIELDS: bool>(c: &Constants, px: &Pixels) -> impl Iterator<Item = float32x4_t> {
    let fields = if FIELDS {
        [
            vmulq_f32(px.v[0], c.v_c),
            vmulq_f32(px.v[1], c.v_c),
            vmulq_f32(px.n[0], px.inv),
            vmulq_f32(px.n[1], px.inv),
        ]
    } else {
        [px.m_d; 4]
    };
    let count = if FIELDS { 6 } else { 2 };
    [px.m_d, px.m_c].into_iter().chain(fields).take(count)
}
