//! The structure products of one row on the M4F and M7 (`m4_kernels`), in
//! five short loops, the residual with 64-bit multiply-accumulates
//! (`SMULL`/`SMLAL`), where `stages::products_of` is one loop over 22 rows
//! with the residual in 32-bit halves: more rows than the M4 has registers
//! (127 instructions a column, against 77 here with the gradients and the
//! last loop in assembly, `m4`; `scripts/embedded-check`'s profile). Same
//! values: every product is exact, and `Dn′` is `stages::rounded_residual`'s
//! (`wide_products_are_the_products`).
//!
//! | quantity | format | bound |
//! |---|---|---|
//! | `X, Y` (Sobel of `p0`), in the scratch rows | i16 | 1020 |
//! | `4·Q` (`Q`: central differences of `V`) | i32 | `4 · 16 144 560 < 2²⁶` |
//! | `R = κl·d + 4·p0·Q + 2^(σ−1) − 1` | i64 | `< 2²² + 2³⁴ + 2¹³ < 2³⁵` |
//! | `H = −(κh·d + ⌊R / 2^σ⌋)`, `L = R mod 2^σ` | i32 | `|κh·d| < 2²⁷`, `|⌊R/2^σ⌋| < 2²⁷`; `L < 2^σ` |
//! | `S = L + X·Vx + Y·Vy` | i64 | `< 2¹⁴ + 2 · 1020 · 6 854 400 < 2³⁴` |
//! | `Dn′ = H − ⌊S / 2^σ⌋` | i32 | `≤ 2²⁷` (`stages`) |
//!
//! With `κ = κh·2^σ + κl` and `Dn = −κ·d − X·Vx − Y·Vy − 4·p0·Q`,
//! `Dn′ = ⌊(Dn + 2^(σ−1)) / 2^σ⌋ = −κh·d − ⌊(R + X·Vx + Y·Vy) / 2^σ⌋`
//! (negating the sum turns the half-up floor into `⌊(x + 2^(σ−1) − 1) / 2^σ⌋`),
//! and `⌊(H′·2^σ + L + …) / 2^σ⌋ = H′ + ⌊(L + …) / 2^σ⌋`.

use crate::stages::{DN_SCALE, ResidualInputs, ScratchRows, cut, cut_rows};

/// `X², XY, Y²` and `X·Dn′·2⁻²⁰`, `Y·Dn′·2⁻²⁰` on columns `cols`, into
/// product rows already cut to them (the `M4` set's
/// `KernelSet::products_row`, `kernels/m4.rs`);
/// rows the memory
/// cannot serve (never, once an engine has validated it) leave them
/// untouched.
#[cfg_attr(not(m4_kernels), allow(dead_code))] // the M4 set's; tested everywhere
pub(crate) fn products_row(
    input: &ResidualInputs<'_>,
    [xx, xy, yy]: [&mut [i32]; 3],
    [xd, yd]: [&mut [f32]; 2],
    scratch: ScratchRows<'_>,
    cols: core::ops::Range<usize>,
) {
    let ResidualInputs {
        vx,
        vy: [vy_up, vy, vy_down],
        p0: [up, mid, down],
        d,
        kappa,
        shift,
    } = *input;
    let (start, len) = (cols.start, cols.len());
    // `p0` and `V` x one column wider either side; the rest as wide as the row.
    let first = start.wrapping_sub(1);
    let wide = |row| cut::<u8>(row, first, len + 2);
    let (Some(up), Some(mid), Some(down), Some(vx)) =
        (wide(up), wide(mid), wide(down), cut(vx, first, len + 2))
    else {
        return;
    };
    let ScratchRows { gx, gy, high, low } = scratch;
    cut_rows!(start, len => vy_up, vy, vy_down, d; mut gx, gy, high, low);
    // The M4F and M7 run two of the loops in assembly (`m4`).
    #[cfg(m4_kernels)]
    crate::kernels::m4::gradients(up, mid, down, gx, gy);
    #[cfg(not(m4_kernels))]
    gradients_of(up, mid, down, gx, gy);
    int_products_of(gx, gy, xx, xy, yy);
    divergence_of(vx, vy_up, vy_down, high);
    let (p0, vx) = (mid.get(1..).unwrap_or(&[]), vx.get(1..).unwrap_or(&[]));
    // σ is 8 for every `s ≥ 1/1024`: its shifts are constants there.
    if shift == 8 {
        residual_base_of::<8>(kappa, shift, p0, d, high, low);
        #[cfg(m4_kernels)]
        crate::kernels::m4::residual_products_8(gx, gy, vx, vy, high, low, xd, yd);
        #[cfg(not(m4_kernels))]
        residual_products_of::<8>(shift, gx, gy, vx, vy, high, low, xd, yd);
    } else {
        residual_base_of::<0>(kappa, shift, p0, d, high, low);
        residual_products_of::<0>(shift, gx, gy, vx, vy, high, low, xd, yd);
    }
}

/// No instruction, but a call the compiler cannot look into: LLVM's Arm
/// unroller leaves a loop that has one rolled. Unrolled two to four times,
/// these loops kept that many columns' values live, more than the M4's
/// registers, and spilled (412 instructions a pixel at 320×240 against 404
/// rolled, `scripts/embedded-check`).
#[inline(always)]
fn one_column_a_step() {
    core::hint::black_box(());
}

/// `X, Y` of every column from `p0`'s rows above, at and below it, one
/// column wider either side: column sums `u + 2m + d` (≤ 1020) and
/// differences `d − u` (±255) carried from column to column, three loads a
/// column.
#[inline(never)]
#[cfg_attr(m4_kernels, allow(dead_code))] // there `m4::gradients`'s twin (`kernel_check`)
pub(crate) fn gradients_of(up: &[u8], mid: &[u8], down: &[u8], gx: &mut [i16], gy: &mut [i16]) {
    let len = gx.len();
    let (Some(rows), Some(gy)) = (gradient_rows([up, mid, down], len), gy.get_mut(..len)) else {
        return;
    };
    let column = |k: usize| gradient_column(rows, k);
    let ((mut sum0, mut diff0), (mut sum1, mut diff1)) = (column(0), column(1));
    for i in 0..len {
        one_column_a_step();
        let (sum2, diff2) = column(i + 2);
        gx[i] = (sum2 - sum0) as i16;
        gy[i] = (diff0 + 2 * diff1 + diff2) as i16;
        (sum0, sum1, diff0, diff1) = (sum1, sum2, diff1, diff2);
    }
}

/// `p0`'s rows above, at and below `len` columns, one column wider either
/// side (`None` if one is shorter).
#[inline(always)]
pub(crate) fn gradient_rows([up, mid, down]: [&[u8]; 3], len: usize) -> Option<[&[u8]; 3]> {
    Some([
        up.get(..len + 2)?,
        mid.get(..len + 2)?,
        down.get(..len + 2)?,
    ])
}

/// Column `k`'s sum `u + 2m + d` and difference `d − u`.
#[inline(always)]
pub(crate) fn gradient_column([up, mid, down]: [&[u8]; 3], k: usize) -> (i32, i32) {
    let at = |row: &[u8]| row.get(k).copied().map_or(0, i32::from);
    let (u, m, d) = (at(up), at(mid), at(down));
    (u + 2 * m + d, d - u)
}

/// `X², XY, Y²` (each `≤ 1020²`).
#[inline(never)]
fn int_products_of(gx: &[i16], gy: &[i16], xx: &mut [i32], xy: &mut [i32], yy: &mut [i32]) {
    let len = xx.len();
    cut_rows!(len => gx, gy; mut xy, yy);
    for i in 0..len {
        one_column_a_step();
        let (x, y) = (i32::from(gx[i]), i32::from(gy[i]));
        xx[i] = x * x;
        xy[i] = x * y;
        yy[i] = y * y;
    }
}

/// `4·Q = 4·((Vx[i+1] − Vx[i−1]) + (Vy below − Vy above))`, `V` x one
/// column wider either side.
#[inline(never)]
fn divergence_of(vx: &[i32], vy_up: &[i32], vy_down: &[i32], q4: &mut [i32]) {
    let len = q4.len();
    let (Some(left), Some(right), Some(vy_up), Some(vy_down)) = (
        vx.get(..len),
        vx.get(2..len + 2),
        vy_up.get(..len),
        vy_down.get(..len),
    ) else {
        return;
    };
    for i in 0..len {
        one_column_a_step();
        q4[i] = 4 * ((right[i] - left[i]) + (vy_down[i] - vy_up[i]));
    }
}

/// `⌊x / 2^σ⌋` of an i64 whose quotient fits 32 bits, `σ ∈ [1, 31]` (`S`,
/// or `shift` when `S` is 0): from its two words, three instructions on a
/// 32-bit core where the 64-bit shift takes seven.
#[inline(always)]
fn shifted<const S: u32>(x: i64, shift: u32) -> i32 {
    let shift = if S == 0 { shift } else { S };
    let (low, high) = (x as u32, (x >> 32) as u32);
    ((low >> shift) | high.wrapping_shl(32 - shift)) as i32
}

/// `H` and `L` (module table) from `4·Q` (in `high`, which `H` replaces),
/// `p0` and `d`.
#[inline(never)]
fn residual_base_of<const S: u32>(
    [kappa_h, kappa_l]: [i32; 2],
    shift: u32,
    p0: &[u8],
    d: &[i16],
    high: &mut [i32],
    low: &mut [i32],
) {
    let shift = if S == 0 { shift } else { S };
    let len = high.len();
    cut_rows!(len => p0, d; mut low);
    let rounding = (1 << (shift - 1)) - 1;
    let mask = (1u32 << shift) - 1;
    for i in 0..len {
        one_column_a_step();
        let d = i32::from(d[i]);
        // `κl·d + 2^(σ−1) − 1` is within 2²³ in i32; one widening product.
        let r = i64::from(kappa_l * d + rounding) + i64::from(p0[i]) * i64::from(high[i]);
        high[i] = -(kappa_h * d + shifted::<S>(r, shift));
        low[i] = (r as u32 & mask) as i32;
    }
}

/// `X·Dn′·2⁻²⁰` and `Y·Dn′·2⁻²⁰` from the gradients, `V` and `H, L`.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn residual_products_of<const S: u32>(
    shift: u32,
    gx: &[i16],
    gy: &[i16],
    vx: &[i32],
    vy: &[i32],
    high: &[i32],
    low: &[i32],
    xd: &mut [f32],
    yd: &mut [f32],
) {
    let len = xd.len();
    cut_rows!(len => gx, gy, vx, vy, high, low; mut yd);
    let wide = |a: i32, b: i32| i64::from(a) * i64::from(b);
    for i in 0..len {
        one_column_a_step();
        let (x, y) = (i32::from(gx[i]), i32::from(gy[i]));
        let sum = i64::from(low[i]) + wide(x, vx[i]) + wide(y, vy[i]);
        let dn = high[i] - shifted::<S>(sum, shift);
        debug_assert!(dn.unsigned_abs() <= 1 << 27, "Dn′ = {dn} beyond 2²⁷");
        // `Dn′` rounds to 24 bits (from 28 at most); the scaling is exact.
        let dn = dn as f32 * DN_SCALE;
        xd[i] = x as f32 * dn;
        yd[i] = y as f32 * dn;
    }
}

#[cfg(test)]
mod tests {
    use std::vec::Vec;

    use super::*;
    use crate::params::residual_shift;
    use crate::stages::portable_products_row;

    /// The M4F's loops give the portable products, bit for bit, at every
    /// shift `σ`, on every length, with inputs at their bounds and between.
    #[test]
    fn wide_products_are_the_products() {
        let mut seed = 0x5eed_1234_abcd_ef01u64;
        let mut next = |range: i64| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            match seed % 6 {
                0 => range,
                1 => -range,
                _ => (seed >> 8) as i64 % (range + 1) * if seed & 64 == 0 { 1 } else { -1 },
            }
        };
        for kappa in [6144u64, 6144 * 255, 6144 * 1024, 1 << 27, 1 << 32] {
            let shift = residual_shift(kappa);
            let split = [(kappa >> shift) as i32, (kappa & ((1 << shift) - 1)) as i32];
            for n in 10..40 {
                let mut ints = |range| (0..n).map(|_| next(range) as i32).collect::<Vec<_>>();
                // `V` within a quarter of `Q`'s bound, so any four of its
                // differences stay within it (the engine's `V` does).
                let quarter = 16_144_560 / 4;
                let vx = ints(quarter);
                let vy = [ints(quarter), ints(quarter), ints(quarter)];
                let p0: [Vec<u8>; 3] =
                    core::array::from_fn(|_| ints(127).iter().map(|p| (p + 128) as u8).collect());
                let d: Vec<i16> = ints(255).iter().map(|&v| v as i16).collect();
                let input = ResidualInputs {
                    vx: &vx,
                    vy: vy.each_ref().map(|r| &r[..]),
                    p0: p0.each_ref().map(|r| &r[..]),
                    d: &d,
                    kappa: split,
                    shift,
                };
                let cols = 5..n - 5;
                let (mut want_i, mut want_f) = (
                    [(); 3].map(|_| std::vec![0; n]),
                    [(); 2].map(|_| std::vec![0.0; n]),
                );
                let (mut got_i, mut got_f) = (want_i.clone(), want_f.clone());
                // Product rows cut to the columns, as `stages::products_row` hands them.
                portable_products_row(
                    &input,
                    want_i.each_mut().map(|r| &mut r[cols.clone()]),
                    want_f.each_mut().map(|r| &mut r[cols.clone()]),
                    cols.clone(),
                );
                let (mut gx, mut gy, mut high, mut low) = (
                    std::vec![0; n],
                    std::vec![0; n],
                    std::vec![0; n],
                    std::vec![0; n],
                );
                let scratch = ScratchRows {
                    gx: &mut gx,
                    gy: &mut gy,
                    high: &mut high,
                    low: &mut low,
                };
                products_row(
                    &input,
                    got_i.each_mut().map(|r| &mut r[cols.clone()]),
                    got_f.each_mut().map(|r| &mut r[cols.clone()]),
                    scratch,
                    cols,
                );
                assert_eq!(got_i, want_i, "κ {kappa} n {n}");
                let bits = |rows: &[Vec<f32>; 2]| {
                    rows.each_ref()
                        .map(|r| r.iter().map(|v| v.to_bits()).collect::<Vec<_>>())
                };
                assert_eq!(bits(&got_f), bits(&want_f), "κ {kappa} n {n}");
            }
        }
    }
}
