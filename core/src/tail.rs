//! An output row's per-pixel tail (SPEC §3 steps 9–10): the solve, its
//! three exact floors (the determinant's reciprocal and two roots), the
//! magnitudes and, for sinks that read them, the fields.
//!
//! On x86-64 pixels go through in batches of [`LANES`], one array per
//! quantity, so that the compiler takes a batch in vector lanes: inside
//! the host's AVX2 pass every step of the magnitudes has a vector form
//! (the floors from the FPU, `fpu.rs`: `vdivpd`, `vsqrtpd`; 32×32→64
//! multiplies, variable shifts), and `reynoldsflow run` counts 17 % fewer
//! instructions. Elsewhere the row is a plain per-pixel loop: arrays of
//! one pixel cost the M4 about 70 instructions per pixel in stack traffic,
//! and on aarch64 NEON's two `f64` lanes counted 313 per pixel against the
//! loop's 294 (`scripts/embedded-check`). Both call the same per-pixel
//! steps.

use fixed::types::{I16F16, U32F32};

use crate::isqrt::isqrt;
use crate::reciprocal::reciprocal;
use crate::solve::{
    Solved, Squares, StructureSums, curl_free_magnitude_q32, curl_free_q16,
    divergence_free_magnitude_q32, divergence_free_q16, solve,
};
use crate::{Config, FlowPixel};

/// Pixels per batch: eight on x86-64 (two AVX2 vectors of four `f64`), one
/// (no batches) elsewhere.
pub const LANES: usize = if cfg!(target_arch = "x86_64") { 8 } else { 1 };

/// The rows the tail reads, each from the first output column: the seven
/// structure sums (`a, b, c, p_h, p_l, q_h, q_l`), `V` and `fⁿ`.
pub struct TailRows<'a> {
    /// `G256 ⋆` the seven products, in [`StructureSums`] order.
    pub sums: [&'a [i32]; 7],
    /// `V` (x, y).
    pub v: [&'a [i32]; 2],
    /// The bytes of `fⁿ`.
    pub luma: &'a [u8],
}

/// The tail of every pixel of `out` (as many as the shortest row has); the
/// fields only if `fields`, else zero.
#[inline(always)]
pub fn tail_row(config: &Config, fields: bool, rows: &TailRows<'_>, out: &mut [FlowPixel]) {
    if LANES == 1 {
        per_pixel(config, fields, rows, out);
    } else {
        batched(config, fields, rows, out);
    }
}

/// One pixel's way to its magnitudes: the solve, its reciprocal (kept for
/// the fields), both roots.
#[inline(always)]
fn magnitudes(config: &Config, sums: [i32; 7], v: [i32; 2]) -> (Solved, u32, [u64; 2]) {
    let [a, b, c, ph, pl, qh, ql] = sums;
    let solved = solve(
        config,
        StructureSums {
            a,
            b,
            c,
            p: [ph, pl],
            q: [qh, ql],
        },
    );
    let (d, cf) = (Squares::divergence_free(solved.n), Squares::curl_free(v));
    let rd = reciprocal(solved.det32);
    let (root_d, root_c) = (isqrt(d.radicand), isqrt(cf.radicand));
    let m_d = divergence_free_magnitude_q32(config, solved.exp, rd, root_d, d.mu);
    let m_c = curl_free_magnitude_q32(config, root_c, cf.mu);
    (solved, rd, [m_d, m_c])
}

/// One pixel's fields `(v_c, v_d)` in Q16.16 bits.
#[inline(always)]
fn fields_of(config: &Config, solved: &Solved, rd: u32, v: [i32; 2]) -> [[i32; 2]; 2] {
    [
        v.map(|v| curl_free_q16(config, v)),
        divergence_free_q16(config, solved, rd),
    ]
}

/// The pixel the sink sees.
#[inline(always)]
fn flow_pixel(fields: [[i32; 2]; 2], [m_d, m_c]: [u64; 2], luma: u8) -> FlowPixel {
    let [v_c, v_d] = fields;
    FlowPixel {
        v_c: v_c.map(I16F16::from_bits),
        v_d: v_d.map(I16F16::from_bits),
        m_c: U32F32::from_bits(m_c),
        m_d: U32F32::from_bits(m_d),
        luma,
    }
}

/// The row one pixel at a time.
#[inline(always)]
fn per_pixel(config: &Config, fields: bool, rows: &TailRows<'_>, out: &mut [FlowPixel]) {
    let [a, b, c, ph, pl, qh, ql] = rows.sums.map(<[i32]>::iter);
    let sums = a.zip(b).zip(c).zip(ph).zip(pl).zip(qh).zip(ql);
    let pixels = rows.v[0].iter().zip(rows.v[1]).zip(rows.luma);
    for (out, (((((((&a, &b), &c), &ph), &pl), &qh), &ql), ((&vx, &vy), &luma))) in
        out.iter_mut().zip(sums.zip(pixels))
    {
        let v = [vx, vy];
        let (solved, rd, m) = magnitudes(config, [a, b, c, ph, pl, qh, ql], v);
        let f = if fields {
            fields_of(config, &solved, rd, v)
        } else {
            [[0; 2]; 2]
        };
        *out = flow_pixel(f, m, luma);
    }
}

/// The row in batches of `LANES` (the last padded).
#[inline(always)]
#[cfg_attr(
    not(target_arch = "x86_64"),
    allow(clippy::modulo_one, reason = "compiled but unused where LANES is 1")
)]
fn batched(config: &Config, fields: bool, rows: &TailRows<'_>, out: &mut [FlowPixel]) {
    // Batches as arrays (`as_chunks`): no length test or index product per
    // batch and row (`chunks_exact` and a `try_into` each cost `run` 7.4
    // instructions per pixel in the AVX2 pass, callgrind).
    let [a, b, c, ph, pl, qh, ql] = rows.sums.map(|row| row.as_chunks::<LANES>().0.iter());
    let [vx, vy] = rows.v.map(|row| row.as_chunks::<LANES>().0.iter());
    let sums = a.zip(b).zip(c).zip(ph).zip(pl).zip(qh).zip(ql);
    let pixels = vx.zip(vy).zip(rows.luma.as_chunks::<LANES>().0);
    let columns = out.len() - out.len() % LANES..out.len();
    let Some((whole_batches, rest)) = out.split_at_mut_checked(columns.start) else {
        return;
    };
    // Zipped by value (not through `&mut`), so the zip indexes every row
    // from one counter instead of stepping eleven iterators.
    let batches = whole_batches.as_chunks_mut::<LANES>().0;
    for (out, (((((((a, b), c), ph), pl), qh), ql), ((vx, vy), luma))) in
        batches.iter_mut().zip(sums.zip(pixels))
    {
        // Written out, not `[…].map(…)`: inside the host's AVX2 pass the
        // compiler kept such a `map` out of line, a call per batch that cost
        // `run` 18 instructions per pixel (callgrind).
        let batch = Batch {
            sums: [*a, *b, *c, *ph, *pl, *qh, *ql],
            v: [*vx, *vy],
            luma: *luma,
        };
        batch.tail(config, fields, out);
    }
    // The row's last, partial batch.
    if !rest.is_empty() {
        let batch = Batch {
            sums: rows.sums.map(|row| padded(row, columns.clone())),
            v: rows.v.map(|row| padded(row, columns.clone())),
            luma: padded(rows.luma, columns),
        };
        let mut pixels = [FlowPixel::default(); LANES];
        batch.tail(config, fields, &mut pixels);
        for (out, pixel) in rest.iter_mut().zip(&pixels) {
            *out = *pixel;
        }
    }
}

/// The values of `row` in `columns` (fewer than `LANES`), then
/// `T::default()`: for a row's last, partial batch. The default is inside
/// every step's domain (zero sums solve to zero with `det = Λ4²`; a zero
/// vector's radicand is 0), and no column past the output is read.
#[inline(always)]
fn padded<T: Copy + Default>(row: &[T], columns: core::ops::Range<usize>) -> [T; LANES] {
    let mut lanes = [T::default(); LANES];
    for (lane, &value) in lanes.iter_mut().zip(row.get(columns).unwrap_or(&[])) {
        *lane = value;
    }
    lanes
}

/// One batch's inputs, one array per quantity.
struct Batch {
    sums: [[i32; LANES]; 7],
    v: [[i32; LANES]; 2],
    luma: [u8; LANES],
}

impl Batch {
    /// The tail of the batch's pixels into `out` (its first `LANES`).
    #[inline(always)]
    fn tail(&self, config: &Config, fields: bool, out: &mut [FlowPixel]) {
        let [a, b, c, ph, pl, qh, ql] = &self.sums;
        let [vx, vy] = &self.v;
        // Every lane's magnitudes in one loop over arrays, one per quantity
        // (the vectoriser's form: an array of pairs here costs the x86-64
        // pass a third more instructions), the fields after it, only where
        // they are read.
        let (mut m_d, mut m_c) = ([0u64; LANES], [0u64; LANES]);
        let mut solved = [Solved::default(); LANES];
        let mut rd = [0u32; LANES];
        for i in 0..LANES {
            let sums = [a[i], b[i], c[i], ph[i], pl[i], qh[i], ql[i]];
            let (s, r, [d, c]) = magnitudes(config, sums, [vx[i], vy[i]]);
            (solved[i], rd[i], m_d[i], m_c[i]) = (s, r, d, c);
        }
        let mut f = [[[0i32; 2]; 2]; LANES];
        if fields {
            for i in 0..LANES {
                f[i] = fields_of(config, &solved[i], rd[i], [vx[i], vy[i]]);
            }
        }
        let pixels = f.iter().zip(m_d.iter().zip(&m_c)).zip(&self.luma);
        for (out, ((&f, (&m_d, &m_c)), &luma)) in out.iter_mut().zip(pixels) {
            *out = flow_pixel(f, [m_d, m_c], luma);
        }
    }
}

#[cfg(test)]
mod tests {
    use std::vec::Vec;

    use super::*;
    use crate::Params;
    use crate::solve::tests::pixel_sums;

    /// The batches give the per-pixel loop's pixels, fields included, for
    /// every row length around the batch size (whole and partial batches)
    /// and sums from small to the largest gradients and residuals.
    #[test]
    fn batches_are_the_per_pixel_loop() {
        let config = Config::new(64, 8, Params::DEFAULT).unwrap();
        let mut seed = 0x0DDB_1A5E_5BAD_5EEDu64;
        for width in 0..=3 * LANES + 1 {
            for (gmax, dmax) in [(3, 40), (1020, 1 << 20), (1020, (1 << 27) - 1)] {
                let sums: Vec<StructureSums> = (0..width)
                    .map(|_| pixel_sums(&mut seed, gmax, dmax))
                    .collect();
                let plane = |f: fn(&StructureSums) -> i32| sums.iter().map(f).collect::<Vec<_>>();
                let planes = [
                    plane(|s| s.a),
                    plane(|s| s.b),
                    plane(|s| s.c),
                    plane(|s| s.p[0]),
                    plane(|s| s.p[1]),
                    plane(|s| s.q[0]),
                    plane(|s| s.q[1]),
                ];
                let v: [Vec<i32>; 2] = core::array::from_fn(|k| {
                    (0..width as i32)
                        .map(|i| (i * 7919 + k as i32 * 104_729) % 6_854_400 - 3_000_000)
                        .collect()
                });
                let luma: Vec<u8> = (0..width).map(|i| (i * 37) as u8).collect();
                let rows = TailRows {
                    sums: planes.each_ref().map(|p| &p[..]),
                    v: [&v[0][..], &v[1][..]],
                    luma: &luma,
                };
                for fields in [false, true] {
                    let mut by_pixel = std::vec![FlowPixel::default(); width];
                    let mut by_batch = std::vec![FlowPixel::default(); width];
                    per_pixel(&config, fields, &rows, &mut by_pixel);
                    batched(&config, fields, &rows, &mut by_batch);
                    assert_eq!(by_batch, by_pixel, "width {width}, fields {fields}");
                    assert!(
                        by_pixel
                            .iter()
                            .all(|p| fields || p.v_d == [I16F16::ZERO; 2])
                    );
                }
            }
        }
    }
}
