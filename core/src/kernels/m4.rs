//! The Cortex-M4F and M7 forms (`m4_kernels`: 32-bit Arm, hard float, DSP instructions) of the
//! row loops where the compiler's own code spent the most: the vertical
//! binomials two columns a step, one double-word load per row (`LDRD`,
//! `VLDM`); the horizontal ones with their taps carried in registers that
//! trade roles; `E`'s vertical parts in the 16-bit halves of a word
//! (`SADD16`, `SSUB16`); the Sobel gradients; the residual's products by
//! `SMLAL`; the magnitudes; the bytes.
//!
//! Why assembly: compiled from Rust, these loops ran unrolled two to four
//! times with every row's pointer and every column's values live at once,
//! more than the M4's 13 registers, and spilled (16 instructions a column
//! of the integer binomial where 9 do), and their counts moved with what
//! the compiler knew of the row's length (the C API's memory of run-time
//! width counted 5 % more than the Rust firmware's arrays). Each loop here
//! computes exactly what its portable twin computes, in the same order
//! where it is `f32`, and `kernel_check` (run by the firmware on the
//! emulated M4 and M7, `scripts/embedded-check`) holds each equal to its
//! twin on rows at their bounds and random ones, every length up to 41.
//!
//! Every loop reads and writes only the rows it is given, after checking
//! they hold what it reads, and touches no other memory and only the
//! registers it names; one saves `r7` on the stack while it counts there.
#![allow(unsafe_code)]

use core::ops::Range;

use super::{KernelSet, PlanarSums, wide_products};
use crate::ByteScale;
use crate::stages::{Binomial, ProductRows, ResidualInputs, vertical_parts_of};
use crate::tail::{TailConstants, TailOut, TailRows};

/// The M4F's and M7's set: the loops below, the structure products of
/// [`wide_products`], the structure sums in the portable layout.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct M4;

impl KernelSet for M4 {
    type Sums<'m> = PlanarSums<'m>;

    #[inline(always)]
    fn binomial_exact(binomial: Binomial<'_, i32>) {
        match binomial {
            Binomial::Rows(rows, out) => binomial_i32(rows, out),
            Binomial::Taps(taps, out) => running_binomial_i32(taps, out),
        }
    }

    #[inline(always)]
    fn binomial_float(binomial: Binomial<'_, f32>) {
        match binomial {
            Binomial::Rows(rows, out) => binomial_f32(rows, out),
            Binomial::Taps(taps, out) => sliding_binomial_f32(taps, out),
        }
    }

    /// The assembly loop; the portable one where the rows' lengths differ
    /// (never, as the engine cuts them).
    #[inline(always)]
    fn vertical_parts(d: [&[i16]; 5], [v1, v2, v3, v4]: [&mut [i16]; 4]) {
        if !vertical_parts(d, [&mut *v1, &mut *v2, &mut *v3, &mut *v4]) {
            vertical_parts_of(d, v1, v2, v3, v4);
        }
    }

    #[inline(always)]
    fn products_row(input: &ResidualInputs<'_>, rows: ProductRows<'_>, cols: Range<usize>) {
        wide_products::products_row(input, rows.ints, rows.floats, rows.scratch, cols);
    }

    /// The magnitudes a loop each, in assembly; the fields' rows in the
    /// portable loop.
    #[inline(always)]
    fn tail_row(k: &TailConstants, rows: &TailRows<'_>, out: TailOut<'_>) {
        if let TailOut {
            m: [m_d, m_c],
            fields: None,
            ..
        } = out
        {
            let TailRows {
                abc: [a, b, c],
                pq: [p, q],
                v: [vx, vy],
            } = *rows;
            let units = [k.units.det_floor, k.units.v_d];
            divergence_free_magnitudes(k.lambda4, units, a, b, c, p, q, m_d);
            curl_free_magnitudes(k.units.v_c, vx, vy, m_c);
            return;
        }
        crate::tail::tail_row(k, rows, out);
    }

    /// For as many pixels as all the rows hold.
    #[inline(always)]
    fn rgb_pixels(
        m_d: &[f32],
        m_c: &[f32],
        luma: &[u8],
        [scale_d, scale_c]: [&ByteScale; 2],
        out: &mut [[u8; 3]],
    ) {
        let n = out.len().min(m_d.len()).min(m_c.len()).min(luma.len());
        let (Some(out), Some(luma)) = (out.get_mut(..n), luma.get(..n)) else {
            return;
        };
        rgb_row([m_d, m_c], luma, [scale_d.parts(), scale_c.parts()], out);
    }
}

/// Whether every row the assembly reads holds the `n` elements it reads
/// (a row shorter than its loop leaves the output untouched).
fn hold(lens: &[usize], n: usize) -> bool {
    n > 0 && lens.iter().all(|&len| len >= n)
}

/// `out[i] = (a + e) + 4(b + d) + 6c` of the five rows' `i`-th values,
/// exactly (`stages::Sample::binomial` for `i32`): as
/// `(a + e) + 4b + 4d + 4c + 2c`, two columns a step. Rows shorter than
/// `out` leave it untouched.
pub(crate) fn binomial_i32(rows: [&[i32]; 5], out: &mut [i32]) {
    let len = out.len();
    let [Some(a), Some(b), Some(c), Some(d), Some(e)] = rows.map(|row| row.get(..len)) else {
        return;
    };
    let pairs = len / 2;
    if pairs > 0 {
        // SAFETY: each pointer reads (or writes, `out`) `2 · pairs ≤ len`
        // elements of its own slice, which is at least `len` long; `LDRD`
        // and `STRD` need word alignment, which `i32` rows have. The
        // registers written are the operands named here; flags are
        // clobbered (no `preserves_flags`).
        unsafe {
            core::arch::asm!(
                "2:",
                "ldrd {x0}, {x1}, [{a}], #8",
                "ldrd {t0}, {t1}, [{e}], #8",
                "add {x0}, {t0}",
                "add {x1}, {t1}",
                "ldrd {t0}, {t1}, [{b}], #8",
                "add {x0}, {x0}, {t0}, lsl #2",
                "add {x1}, {x1}, {t1}, lsl #2",
                "ldrd {t0}, {t1}, [{d}], #8",
                "add {x0}, {x0}, {t0}, lsl #2",
                "add {x1}, {x1}, {t1}, lsl #2",
                "ldrd {t0}, {t1}, [{c}], #8",
                "add {x0}, {x0}, {t0}, lsl #2",
                "add {x1}, {x1}, {t1}, lsl #2",
                "add {x0}, {x0}, {t0}, lsl #1",
                "add {x1}, {x1}, {t1}, lsl #1",
                "strd {x0}, {x1}, [{out}], #8",
                "subs {n}, #1",
                "bne 2b",
                a = inout(reg) a.as_ptr() => _,
                b = inout(reg) b.as_ptr() => _,
                c = inout(reg) c.as_ptr() => _,
                d = inout(reg) d.as_ptr() => _,
                e = inout(reg) e.as_ptr() => _,
                out = inout(reg) out.as_mut_ptr() => _,
                n = inout(reg) pairs => _,
                x0 = out(reg) _,
                x1 = out(reg) _,
                t0 = out(reg) _,
                t1 = out(reg) _,
                options(nostack),
            );
        }
    }
    if len % 2 == 1 {
        let i = len - 1;
        out[i] = (a[i] + e[i]) + ((b[i] + d[i]) << 2) + (c[i] << 2) + (c[i] << 1);
    }
}

/// `out[i] = ((a + e) + (b + d) · 4) + c · 6` of the five rows' `i`-th
/// values in `f32`, each step correctly rounded in this order
/// (`stages::Sample::binomial` for `f32`; `VMLA` rounds its product, then
/// its sum), two columns a step. Rows shorter than `out` leave it
/// untouched.
pub(crate) fn binomial_f32(rows: [&[f32]; 5], out: &mut [f32]) {
    let len = out.len();
    let [Some(a), Some(b), Some(c), Some(d), Some(e)] = rows.map(|row| row.get(..len)) else {
        return;
    };
    let pairs = len / 2;
    if pairs > 0 {
        // SAFETY: as in `binomial_i32`; `VLDM`/`VSTM` need word alignment,
        // which `f32` rows have. `s0`–`s7` (caller-saved) are named as
        // clobbered.
        unsafe {
            core::arch::asm!(
                "vmov s6, {four}",
                "vmov s7, {six}",
                "2:",
                "vldmia {a}!, {{s0, s1}}",
                "vldmia {e}!, {{s2, s3}}",
                "vadd.f32 s0, s0, s2",
                "vadd.f32 s1, s1, s3",
                "vldmia {b}!, {{s2, s3}}",
                "vldmia {d}!, {{s4, s5}}",
                "vadd.f32 s2, s2, s4",
                "vadd.f32 s3, s3, s5",
                "vmla.f32 s0, s2, s6",
                "vmla.f32 s1, s3, s6",
                "vldmia {c}!, {{s2, s3}}",
                "vmla.f32 s0, s2, s7",
                "vmla.f32 s1, s3, s7",
                "vstmia {out}!, {{s0, s1}}",
                "subs {n}, #1",
                "bne 2b",
                a = inout(reg) a.as_ptr() => _,
                b = inout(reg) b.as_ptr() => _,
                c = inout(reg) c.as_ptr() => _,
                d = inout(reg) d.as_ptr() => _,
                e = inout(reg) e.as_ptr() => _,
                out = inout(reg) out.as_mut_ptr() => _,
                n = inout(reg) pairs => _,
                four = in(reg) 4.0f32.to_bits(),
                six = in(reg) 6.0f32.to_bits(),
                out("s0") _,
                out("s1") _,
                out("s2") _,
                out("s3") _,
                out("s4") _,
                out("s5") _,
                out("s6") _,
                out("s7") _,
                options(nostack),
            );
        }
    }
    if len % 2 == 1 {
        let i = len - 1;
        out[i] = ((a[i] + e[i]) + (b[i] + d[i]) * 4.0) + c[i] * 6.0;
    }
}

/// `E`'s four vertical parts from five rows of `d` (`stages::vertical_parts_of`):
/// `v1 = b + 4c + d`, `v2 = (a + e) + 3(b + d) + 4c`, `v3 = d − b`,
/// `v4 = (d + e) − (a + b)`, two columns at once in the 16-bit halves of a
/// word (`SADD16`, `SSUB16`: each half its own lane). Every part is within
/// ±3060 (`stages`), so no lane leaves `i16`. Two passes, `v3, v4` then
/// `v1, v2`, so each keeps its rows' pointers in registers. Rows that are
/// not word-aligned (an engine of an odd width in memory of the caller's)
/// take the portable loop; so do rows shorter than `d0`.
pub(crate) fn vertical_parts(d: [&[i16]; 5], v: [&mut [i16]; 4]) -> bool {
    let len = d[0].len();
    let [Some(a), Some(b), Some(c), Some(dd), Some(e)] = d.map(|row| row.get(..len)) else {
        return false;
    };
    let [v1, v2, v3, v4] = v;
    let (Some(v1), Some(v2), Some(v3), Some(v4)) = (
        v1.get_mut(..len),
        v2.get_mut(..len),
        v3.get_mut(..len),
        v4.get_mut(..len),
    ) else {
        return false;
    };
    let aligned = |p: *const i16| (p as usize).is_multiple_of(4);
    let words = [a, b, c, dd, e].iter().all(|r| aligned(r.as_ptr()))
        && [&v1, &v2, &v3, &v4].iter().all(|r| aligned(r.as_ptr()));
    if !words {
        return false;
    }
    let pairs = len / 2;
    if pairs > 0 {
        // SAFETY: each pointer reads (writes: `v1`–`v4`) `2 · pairs ≤ len`
        // halves of its own slice, at least `len` long, word-aligned
        // (checked above). Flags are clobbered.
        unsafe {
            core::arch::asm!(
                "2:",
                "ldr {x}, [{b}], #4",
                "ldr {y}, [{d}], #4",
                "ssub16 {x}, {y}, {x}",
                "str {x}, [{v3}], #4",
                "ldr {y}, [{a}], #4",
                "ldr {z}, [{e}], #4",
                "ssub16 {y}, {z}, {y}",
                "sadd16 {x}, {x}, {y}",
                "str {x}, [{v4}], #4",
                "subs {n}, #1",
                "bne 2b",
                a = inout(reg) a.as_ptr() => _,
                b = inout(reg) b.as_ptr() => _,
                d = inout(reg) dd.as_ptr() => _,
                e = inout(reg) e.as_ptr() => _,
                v3 = inout(reg) v3.as_mut_ptr() => _,
                v4 = inout(reg) v4.as_mut_ptr() => _,
                n = inout(reg) pairs => _,
                x = out(reg) _,
                y = out(reg) _,
                z = out(reg) _,
                options(nostack),
            );
            core::arch::asm!(
                "2:",
                "ldr {x}, [{b}], #4",
                "ldr {y}, [{d}], #4",
                "sadd16 {bd}, {x}, {y}",
                "ldr {x}, [{c}], #4",
                "sadd16 {x}, {x}, {x}",
                "sadd16 {x}, {x}, {x}",
                "sadd16 {x}, {x}, {bd}",
                "str {x}, [{v1}], #4",
                "ldr {y}, [{a}], #4",
                "ldr {z}, [{e}], #4",
                "sadd16 {y}, {y}, {z}",
                "sadd16 {y}, {y}, {bd}",
                "sadd16 {y}, {y}, {bd}",
                "sadd16 {y}, {y}, {x}",
                "str {y}, [{v2}], #4",
                "subs {n}, #1",
                "bne 2b",
                a = inout(reg) a.as_ptr() => _,
                b = inout(reg) b.as_ptr() => _,
                c = inout(reg) c.as_ptr() => _,
                d = inout(reg) dd.as_ptr() => _,
                e = inout(reg) e.as_ptr() => _,
                v1 = inout(reg) v1.as_mut_ptr() => _,
                v2 = inout(reg) v2.as_mut_ptr() => _,
                n = inout(reg) pairs => _,
                bd = out(reg) _,
                x = out(reg) _,
                y = out(reg) _,
                z = out(reg) _,
                options(nostack),
            );
        }
    }
    if len % 2 == 1 {
        let i = len - 1;
        let (a, b, c, d, e) = (a[i], b[i], c[i], dd[i], e[i]);
        v1[i] = b + 4 * c + d;
        v2[i] = (a + e) + 3 * (b + d) + 4 * c;
        v3[i] = d - b;
        v4[i] = (d + e) - (a + b);
    }
    true
}

/// `|v_d|` of every pixel of `m_d` from the structure sums
/// (`tail::divergence_free_magnitudes`), one pixel a step, every `f32`
/// operation the portable one in the same order: `a4 = 4a + Λ4`, `c4`,
/// `b4 = 4b` in integers, converted; `det = a4·c4 − b4·b4` (`VMLS` rounds
/// its product, then its difference), clamped below at `det_floor` (a NaN,
/// which cannot occur, would take the floor as the portable select does);
/// `N = (c4·p − b4·q, a4·q − b4·p)`; `√(N0² + N1²) · (v_d / det)`. Rows
/// shorter than `m_d` leave it untouched.
#[allow(clippy::too_many_arguments)]
pub(crate) fn divergence_free_magnitudes(
    lambda4: i32,
    [det_floor, v_d]: [f32; 2],
    a: &[i32],
    b: &[i32],
    c: &[i32],
    p: &[f32],
    q: &[f32],
    m_d: &mut [f32],
) {
    let n = m_d.len();
    if !hold(&[a.len(), b.len(), c.len(), p.len(), q.len()], n) {
        return;
    }
    // SAFETY: each pointer reads (writes: `m_d`) `n` elements of its own
    // slice, at least `n` long; `VLDM`/`VSTM` need word alignment, which
    // `f32` rows have. `s0`–`s15` (caller-saved) are named as clobbered;
    // flags are clobbered.
    unsafe {
        core::arch::asm!(
            "vmov s14, {floor}",
            "vmov s15, {unit}",
            "2:",
            "ldr {ta}, [{a}], #4",
            "ldr {tb}, [{b}], #4",
            "ldr {tc}, [{c}], #4",
            "add {ta}, {lambda}, {ta}, lsl #2",
            "add {tc}, {lambda}, {tc}, lsl #2",
            "lsl {tb}, {tb}, #2",
            "vmov s0, s1, {ta}, {tb}",
            "vmov s2, {tc}",
            "vcvt.f32.s32 s0, s0",
            "vcvt.f32.s32 s1, s1",
            "vcvt.f32.s32 s2, s2",
            "vldmia {p}!, {{s3}}",
            "vldmia {q}!, {{s4}}",
            "vmul.f32 s5, s0, s2",
            "vmls.f32 s5, s1, s1",
            "vcmp.f32 s5, s14",
            "vmrs APSR_nzcv, fpscr",
            "it le",
            "vmovle.f32 s5, s14",
            "vdiv.f32 s6, s15, s5",
            "vmul.f32 s7, s2, s3",
            "vmls.f32 s7, s1, s4",
            "vmul.f32 s8, s0, s4",
            "vmls.f32 s8, s1, s3",
            "vmul.f32 s9, s7, s7",
            "vmla.f32 s9, s8, s8",
            "vsqrt.f32 s9, s9",
            "vmul.f32 s9, s9, s6",
            "vstmia {out}!, {{s9}}",
            "subs {n}, #1",
            "bne 2b",
            a = inout(reg) a.as_ptr() => _,
            b = inout(reg) b.as_ptr() => _,
            c = inout(reg) c.as_ptr() => _,
            p = inout(reg) p.as_ptr() => _,
            q = inout(reg) q.as_ptr() => _,
            out = inout(reg) m_d.as_mut_ptr() => _,
            n = inout(reg) n => _,
            lambda = in(reg) lambda4,
            floor = in(reg) det_floor.to_bits(),
            unit = in(reg) v_d.to_bits(),
            ta = out(reg) _,
            tb = out(reg) _,
            tc = out(reg) _,
            out("s0") _,
            out("s1") _,
            out("s2") _,
            out("s3") _,
            out("s4") _,
            out("s5") _,
            out("s6") _,
            out("s7") _,
            out("s8") _,
            out("s9") _,
            out("s14") _,
            out("s15") _,
            options(nostack),
        );
    }
}

/// `|v_c| = √(Vx² + Vy²) · v_c` of every pixel of `m_c`
/// (`tail::curl_free_magnitudes`), one pixel a step, in the portable
/// order. Rows shorter than `m_c` leave it untouched.
pub(crate) fn curl_free_magnitudes(v_c: f32, vx: &[i32], vy: &[i32], m_c: &mut [f32]) {
    let n = m_c.len();
    if !hold(&[vx.len(), vy.len()], n) {
        return;
    }
    // SAFETY: as in `divergence_free_magnitudes`; `s0`–`s3` are clobbered.
    unsafe {
        core::arch::asm!(
            "vmov s3, {unit}",
            "2:",
            "ldr {x}, [{vx}], #4",
            "ldr {y}, [{vy}], #4",
            "vmov s0, s1, {x}, {y}",
            "vcvt.f32.s32 s0, s0",
            "vcvt.f32.s32 s1, s1",
            "vmul.f32 s2, s0, s0",
            "vmla.f32 s2, s1, s1",
            "vsqrt.f32 s2, s2",
            "vmul.f32 s2, s2, s3",
            "vstmia {out}!, {{s2}}",
            "subs {n}, #1",
            "bne 2b",
            vx = inout(reg) vx.as_ptr() => _,
            vy = inout(reg) vy.as_ptr() => _,
            out = inout(reg) m_c.as_mut_ptr() => _,
            n = inout(reg) n => _,
            unit = in(reg) v_c.to_bits(),
            x = out(reg) _,
            y = out(reg) _,
            out("s0") _,
            out("s1") _,
            out("s2") _,
            out("s3") _,
            options(nostack),
        );
    }
}

/// The horizontal binomial of a row of exact sums as four running pair
/// sums (`stages::running_binomial`): `s₁ = x′ + x`, `s₂ = s₁′ + s₁`,
/// `s₃ = s₂′ + s₂`, output `s₃′ + s₃`, one load and four adds a column.
/// Five columns a step, so that the registers trade roles back to where
/// they started (the new tap lands in the register the last output left)
/// and no value moves; the columns after the last full step, and the taps
/// before the first output, in Rust. `taps` holds `out.len() + 4` values;
/// a shorter one leaves `out` untouched.
pub(crate) fn running_binomial_i32(taps: &[i32], out: &mut [i32]) {
    let len = out.len();
    let (Some(&[x0, x1, x2, x3]), Some(rest)) = (taps.get(..4), taps.get(4..len + 4)) else {
        return;
    };
    let (s1_a, s1_b, s1_c) = (x0 + x1, x1 + x2, x2 + x3);
    let (s2_a, s2_b) = (s1_a + s1_b, s1_b + s1_c);
    let (mut x, mut s1, mut s2, mut s3) = (x3, s1_c, s2_b, s2_a + s2_b);
    let steps = len / 5;
    if steps > 0 {
        // SAFETY: the assembly reads `5 · steps ≤ len` values of `rest`
        // and writes as many of `out`, both at least `len` long. Registers
        // written are the operands named here; flags are clobbered.
        unsafe {
            core::arch::asm!(
                "2:",
                "ldr {e}, [{taps}], #4",
                "add {a}, {a}, {e}",
                "add {b}, {b}, {a}",
                "add {c}, {c}, {b}",
                "add {d}, {d}, {c}",
                "str {d}, [{out}], #4",
                "ldr {d}, [{taps}], #4",
                "add {e}, {e}, {d}",
                "add {a}, {a}, {e}",
                "add {b}, {b}, {a}",
                "add {c}, {c}, {b}",
                "str {c}, [{out}], #4",
                "ldr {c}, [{taps}], #4",
                "add {d}, {d}, {c}",
                "add {e}, {e}, {d}",
                "add {a}, {a}, {e}",
                "add {b}, {b}, {a}",
                "str {b}, [{out}], #4",
                "ldr {b}, [{taps}], #4",
                "add {c}, {c}, {b}",
                "add {d}, {d}, {c}",
                "add {e}, {e}, {d}",
                "add {a}, {a}, {e}",
                "str {a}, [{out}], #4",
                "ldr {a}, [{taps}], #4",
                "add {b}, {b}, {a}",
                "add {c}, {c}, {b}",
                "add {d}, {d}, {c}",
                "add {e}, {e}, {d}",
                "str {e}, [{out}], #4",
                "subs {n}, #1",
                "bne 2b",
                taps = inout(reg) rest.as_ptr() => _,
                out = inout(reg) out.as_mut_ptr() => _,
                n = inout(reg) steps => _,
                a = inout(reg) x,
                b = inout(reg) s1,
                c = inout(reg) s2,
                d = inout(reg) s3,
                e = out(reg) _,
                options(nostack),
            );
        }
    }
    for (o, &next) in out.iter_mut().zip(rest).skip(5 * steps) {
        let t1 = x + next;
        let t2 = s1 + t1;
        let t3 = s2 + t2;
        *o = s3 + t3;
        (x, s1, s2, s3) = (next, t1, t2, t3);
    }
}

/// The horizontal binomial of a row of `f32` sums in the portable order
/// (`stages::sliding_binomial`): `((a + e) + (b + d) · 4) + c · 6` of the
/// last five taps, one load a column. Five columns a step, the taps in
/// `s0`–`s4` trading roles so that no value moves; the columns after the
/// last full step in Rust. `taps` holds `out.len() + 4` values; a shorter
/// one leaves `out` untouched.
pub(crate) fn sliding_binomial_f32(taps: &[f32], out: &mut [f32]) {
    let len = out.len();
    let (Some(&[x0, x1, x2, x3]), Some(rest)) = (taps.get(..4), taps.get(4..len + 4)) else {
        return;
    };
    let steps = len / 5;
    if steps > 0 {
        // SAFETY: as in `running_binomial_i32`; `s0`–`s8` (caller-saved)
        // are named as clobbered.
        unsafe {
            core::arch::asm!(
                "vmov s0, s1, {t0}, {t1}",
                "vmov s2, s3, {t2}, {t3}",
                "vmov s7, s8, {four}, {six}",
                "2:",
                "vldmia {taps}!, {{s4}}",
                "vadd.f32 s5, s0, s4",
                "vadd.f32 s6, s1, s3",
                "vmla.f32 s5, s6, s7",
                "vmla.f32 s5, s2, s8",
                "vstmia {out}!, {{s5}}",
                "vldmia {taps}!, {{s0}}",
                "vadd.f32 s5, s1, s0",
                "vadd.f32 s6, s2, s4",
                "vmla.f32 s5, s6, s7",
                "vmla.f32 s5, s3, s8",
                "vstmia {out}!, {{s5}}",
                "vldmia {taps}!, {{s1}}",
                "vadd.f32 s5, s2, s1",
                "vadd.f32 s6, s3, s0",
                "vmla.f32 s5, s6, s7",
                "vmla.f32 s5, s4, s8",
                "vstmia {out}!, {{s5}}",
                "vldmia {taps}!, {{s2}}",
                "vadd.f32 s5, s3, s2",
                "vadd.f32 s6, s4, s1",
                "vmla.f32 s5, s6, s7",
                "vmla.f32 s5, s0, s8",
                "vstmia {out}!, {{s5}}",
                "vldmia {taps}!, {{s3}}",
                "vadd.f32 s5, s4, s3",
                "vadd.f32 s6, s0, s2",
                "vmla.f32 s5, s6, s7",
                "vmla.f32 s5, s1, s8",
                "vstmia {out}!, {{s5}}",
                "subs {n}, #1",
                "bne 2b",
                taps = inout(reg) rest.as_ptr() => _,
                out = inout(reg) out.as_mut_ptr() => _,
                n = inout(reg) steps => _,
                t0 = in(reg) x0.to_bits(),
                t1 = in(reg) x1.to_bits(),
                t2 = in(reg) x2.to_bits(),
                t3 = in(reg) x3.to_bits(),
                four = in(reg) 4.0f32.to_bits(),
                six = in(reg) 6.0f32.to_bits(),
                out("s0") _,
                out("s1") _,
                out("s2") _,
                out("s3") _,
                out("s4") _,
                out("s5") _,
                out("s6") _,
                out("s7") _,
                out("s8") _,
                options(nostack),
            );
        }
    }
    // The taps before the first column after the assembly's last.
    let done = 5 * steps;
    let (Some(before), Some(out)) = (taps.get(done..done + 4), out.get_mut(done..)) else {
        return;
    };
    let (Some(&[mut a, mut b, mut c, mut d]), Some(rest)) = (before.get(..4), rest.get(done..))
    else {
        return;
    };
    for (o, &e) in out.iter_mut().zip(rest) {
        *o = ((a + e) + (b + d) * 4.0) + c * 6.0;
        (a, b, c, d) = (b, c, d, e);
    }
}

/// `X·Dn′·2⁻²⁰` and `Y·Dn′·2⁻²⁰` of every column at `σ = 8`
/// (`wide_products::residual_products_of::<8>`): `Dn′ = high −
/// ⌊(low + X·Vx + Y·Vy) / 2⁸⌋` with two `SMLAL`s into a 64-bit sum, its
/// quotient's low word from the sum's two words, then `Dn′·2⁻²⁰` by the
/// fixed-point `VCVT` (`#20` fraction bits: the portable
/// `Dn′ as f32 · 2⁻²⁰`, both rounding `Dn′` once, the scaling exact) and
/// the two products. Thirteen rows and temporaries fill the core's
/// registers; the column count runs in `r7` (the frame pointer), saved and
/// restored around the loop. Rows shorter than `xd` leave it untouched.
#[allow(clippy::too_many_arguments)]
pub(crate) fn residual_products_8(
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
    let rows = [
        gx.len(),
        gy.len(),
        vx.len(),
        vy.len(),
        high.len(),
        low.len(),
        yd.len(),
    ];
    if !hold(&rows, len) {
        return;
    }
    // SAFETY: each pointer reads (writes: `xd`, `yd`) `len` elements of its
    // own slice, at least `len` long; `VSTM` needs word alignment, which
    // `f32` rows have. `r7` is pushed before it counts and popped after
    // (the block uses the stack for that one word); `s0`–`s2` and the
    // flags are clobbered.
    unsafe {
        core::arch::asm!(
            "push {{r7}}",
            "mov r7, {n}",
            "2:",
            "ldrsh {x}, [{gx}], #2",
            "ldrsh {n}, [{gy}], #2",
            "vmov s1, s2, {x}, {n}",
            "ldr {lo}, [{low}], #4",
            "mov {hi}, #0",
            "ldr {t}, [{vx}], #4",
            "smlal {lo}, {hi}, {x}, {t}",
            "ldr {t}, [{vy}], #4",
            "smlal {lo}, {hi}, {n}, {t}",
            "lsr {lo}, {lo}, #8",
            "orr {lo}, {lo}, {hi}, lsl #24",
            "ldr {t}, [{high}], #4",
            "sub {lo}, {t}, {lo}",
            "vmov s0, {lo}",
            "vcvt.f32.s32 s0, s0, #20",
            "vcvt.f32.s32 s1, s1",
            "vcvt.f32.s32 s2, s2",
            "vmul.f32 s1, s1, s0",
            "vmul.f32 s2, s2, s0",
            "vstmia {xd}!, {{s1}}",
            "vstmia {yd}!, {{s2}}",
            "subs r7, #1",
            "bne 2b",
            "pop {{r7}}",
            gx = inout(reg) gx.as_ptr() => _,
            gy = inout(reg) gy.as_ptr() => _,
            vx = inout(reg) vx.as_ptr() => _,
            vy = inout(reg) vy.as_ptr() => _,
            high = inout(reg) high.as_ptr() => _,
            low = inout(reg) low.as_ptr() => _,
            xd = inout(reg) xd.as_mut_ptr() => _,
            yd = inout(reg) yd.as_mut_ptr() => _,
            n = inout(reg) len => _,
            x = out(reg) _,
            lo = out(reg) _,
            hi = out(reg) _,
            t = out(reg) _,
            out("s0") _,
            out("s1") _,
            out("s2") _,
        );
    }
}

/// The Sobel gradients `X, Y` of every column (`wide_products::gradients_of`)
/// from `p0`'s rows above, at and below it, one column wider either side:
/// column sums `u + 2m + d` and differences `d − u` carried from column to
/// column, two columns a step (the carried values move back into place at
/// the step's end). Rows shorter than `gx` leave it untouched.
pub(crate) fn gradients(up: &[u8], mid: &[u8], down: &[u8], gx: &mut [i16], gy: &mut [i16]) {
    use crate::kernels::wide_products::{gradient_column, gradient_rows};
    let len = gx.len();
    let (Some(rows), Some(gy)) = (gradient_rows([up, mid, down], len), gy.get_mut(..len)) else {
        return;
    };
    let column = |k: usize| gradient_column(rows, k);
    let ((mut sum0, mut diff0), (sum1, mut diff1)) = (column(0), column(1));
    let pairs = len / 2;
    if pairs > 0 {
        let [Some(up), Some(mid), Some(down)] = rows.map(|row| row.get(2..)) else {
            return;
        };
        // SAFETY: each pointer reads (writes: `gx`, `gy`) `2 · pairs ≤ len`
        // elements of its own slice, at least `len` long (the inputs from
        // their third column). Flags are clobbered.
        unsafe {
            core::arch::asm!(
                "2:",
                "ldrb {u}, [{up}], #1",
                "ldrb {m}, [{mid}], #1",
                "ldrb {x}, [{down}], #1",
                "add {m}, {u}, {m}, lsl #1",
                "add {m}, {m}, {x}",
                "sub {x}, {x}, {u}",
                "sub {u}, {m}, {s0}",
                "strh {u}, [{gx}], #2",
                "add {u}, {d0}, {d1}, lsl #1",
                "add {u}, {u}, {x}",
                "strh {u}, [{gy}], #2",
                // Now s0 = s1, s1 = m, d0 = d1, d1 = x; the second column.
                "ldrb {u}, [{up}], #1",
                "ldrb {s0}, [{mid}], #1",
                "ldrb {d0}, [{down}], #1",
                "add {s0}, {u}, {s0}, lsl #1",
                "add {s0}, {s0}, {d0}",
                "sub {d0}, {d0}, {u}",
                "sub {u}, {s0}, {s1}",
                "strh {u}, [{gx}], #2",
                "add {u}, {d1}, {x}, lsl #1",
                "add {u}, {u}, {d0}",
                "strh {u}, [{gy}], #2",
                // s0 = m, s1 = s0 (this column's sum), d0 = x, d1 = d0.
                "mov {s1}, {s0}",
                "mov {s0}, {m}",
                "mov {d1}, {d0}",
                "mov {d0}, {x}",
                "subs {n}, #1",
                "bne 2b",
                up = inout(reg) up.as_ptr() => _,
                mid = inout(reg) mid.as_ptr() => _,
                down = inout(reg) down.as_ptr() => _,
                gx = inout(reg) gx.as_mut_ptr() => _,
                gy = inout(reg) gy.as_mut_ptr() => _,
                n = inout(reg) pairs => _,
                s0 = inout(reg) sum0,
                s1 = inout(reg) sum1 => _,
                d0 = inout(reg) diff0,
                d1 = inout(reg) diff1,
                u = out(reg) _,
                m = out(reg) _,
                x = out(reg) _,
                options(nostack),
            );
        }
    }
    if len % 2 == 1 {
        let i = len - 1;
        let (sum2, diff2) = column(i + 2);
        gx[i] = (sum2 - sum0) as i16;
        gy[i] = (diff0 + 2 * diff1 + diff2) as i16;
    }
}

/// The representation's bytes of a row segment (`sink::rgb_row` on the
/// scalar boards): per pixel `min(255, max(0, ⌊(m − offset) · gain + ½⌋))`
/// of both magnitudes, each step one correctly rounded `f32` operation in
/// the portable order, `VCVT` truncating toward zero and saturating (NaN to
/// 0) as Rust's `as i32` does, then `USAT` for the clamp, and `fⁿ` beside
/// them. `scales` are `[offset, gain]` of `|v_d|` and of `|v_c|`. Rows
/// shorter than `out` leave it untouched.
pub(crate) fn rgb_row(
    [m_d, m_c]: [&[f32]; 2],
    luma: &[u8],
    [[offset_d, gain_d], [offset_c, gain_c]]: [[f32; 2]; 2],
    out: &mut [[u8; 3]],
) {
    let n = out.len();
    if !hold(&[m_d.len(), m_c.len(), luma.len()], n) {
        return;
    }
    // SAFETY: each pointer reads (writes: `out`, three bytes a pixel) `n`
    // pixels of its own slice, at least `n` long; `VLDM` needs word
    // alignment, which `f32` rows have. `s0`, `s1`, `s8`–`s12` and the
    // flags are clobbered.
    unsafe {
        core::arch::asm!(
            "vmov s8, s9, {od}, {gd}",
            "vmov s10, s11, {oc}, {gc}",
            "vmov s12, {half}",
            "2:",
            "vldmia {md}!, {{s0}}",
            "vldmia {mc}!, {{s1}}",
            "vsub.f32 s0, s0, s8",
            "vsub.f32 s1, s1, s10",
            "vmul.f32 s0, s0, s9",
            "vmul.f32 s1, s1, s11",
            "vadd.f32 s0, s0, s12",
            "vadd.f32 s1, s1, s12",
            "vcvt.s32.f32 s0, s0",
            "vcvt.s32.f32 s1, s1",
            "vmov {r}, {g}, s0, s1",
            "usat {r}, #8, {r}",
            "usat {g}, #8, {g}",
            "ldrb {b}, [{luma}], #1",
            "strb {r}, [{out}], #1",
            "strb {g}, [{out}], #1",
            "strb {b}, [{out}], #1",
            "subs {n}, #1",
            "bne 2b",
            md = inout(reg) m_d.as_ptr() => _,
            mc = inout(reg) m_c.as_ptr() => _,
            luma = inout(reg) luma.as_ptr() => _,
            out = inout(reg) out.as_mut_ptr() => _,
            n = inout(reg) n => _,
            od = in(reg) offset_d.to_bits(),
            gd = in(reg) gain_d.to_bits(),
            oc = in(reg) offset_c.to_bits(),
            gc = in(reg) gain_c.to_bits(),
            half = in(reg) 0.5f32.to_bits(),
            r = out(reg) _,
            g = out(reg) _,
            b = out(reg) _,
            out("s0") _,
            out("s1") _,
            out("s8") _,
            out("s9") _,
            out("s10") _,
            out("s11") _,
            out("s12") _,
            options(nostack),
        );
    }
}
