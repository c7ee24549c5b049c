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

use crate::Config;
use crate::isqrt::isqrt;
use crate::reciprocal::reciprocal;
use crate::solve::{
    Solved, Squares, StructureSums, curl_free_magnitude_q32, curl_free_q16,
    divergence_free_magnitude_q32, divergence_free_q16, solve,
};

/// Pixels per batch: eight on x86-64 (two AVX2 vectors of four `f64`), one
/// (no batches) elsewhere.
pub const LANES: usize = if cfg!(target_arch = "x86_64") { 8 } else { 1 };

/// The rows the tail reads, each from the first output column: the seven
/// structure sums (`a, b, c, p_h, p_l, q_h, q_l`) and `V`.
pub struct TailRows<'a> {
    /// `G256 ⋆` the seven products, in [`StructureSums`] order.
    pub sums: [&'a [i32]; 7],
    /// `V` (x, y).
    pub v: [&'a [i32]; 2],
}

/// The rows the tail writes, as long as the output: the magnitudes
/// `[|v_d|, |v_c|]` and, for sinks that read them, the fields
/// `[v_c x, v_c y, v_d x, v_d y]`.
pub struct TailOut<'a> {
    /// `|v_d|`, `|v_c|`.
    pub m: [&'a mut [U32F32]; 2],
    /// `v_c`, `v_d`, or `None` when no sink reads them.
    pub fields: Option<[&'a mut [I16F16]; 4]>,
}

/// The tail of every pixel of `out` (as many as the shortest row has).
#[inline(always)]
pub fn tail_row(config: &Config, rows: &TailRows<'_>, out: TailOut<'_>) {
    if LANES == 1 {
        per_pixel(config, rows, out);
    } else {
        batched(config, rows, out);
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

/// One pixel's fields `[v_c x, v_c y, v_d x, v_d y]` in Q16.16 bits.
#[inline(always)]
fn fields_of(config: &Config, solved: &Solved, rd: u32, v: [i32; 2]) -> [i32; 4] {
    let [v_c_x, v_c_y] = v.map(|v| curl_free_q16(config, v));
    let [v_d_x, v_d_y] = divergence_free_q16(config, solved, rd);
    [v_c_x, v_c_y, v_d_x, v_d_y]
}

/// The row one pixel at a time.
#[inline(always)]
fn per_pixel(config: &Config, rows: &TailRows<'_>, out: TailOut<'_>) {
    let [a, b, c, ph, pl, qh, ql] = rows.sums.map(<[i32]>::iter);
    let sums = a.zip(b).zip(c).zip(ph).zip(pl).zip(qh).zip(ql);
    let inputs = sums.zip(rows.v[0].iter().zip(rows.v[1]));
    let [m_d, m_c] = out.m;
    let magnitudes_out = m_d.iter_mut().zip(m_c.iter_mut());
    let pixel = |(((((((&a, &b), &c), &ph), &pl), &qh), &ql), (&vx, &vy))| {
        let v = [vx, vy];
        let (solved, rd, m) = magnitudes(config, [a, b, c, ph, pl, qh, ql], v);
        (solved, rd, m, v)
    };
    match out.fields {
        // Two loops, so that the magnitudes' loop writes nothing else.
        None => {
            for ((m_d, m_c), input) in magnitudes_out.zip(inputs) {
                let (_, _, [d, c], _) = pixel(input);
                (*m_d, *m_c) = (U32F32::from_bits(d), U32F32::from_bits(c));
            }
        }
        Some([v_c_x, v_c_y, v_d_x, v_d_y]) => {
            let fields_out = v_c_x.iter_mut().zip(v_c_y).zip(v_d_x).zip(v_d_y);
            for (((m_d, m_c), (((v_c_x, v_c_y), v_d_x), v_d_y)), input) in
                magnitudes_out.zip(fields_out).zip(inputs)
            {
                let (solved, rd, [d, c], v) = pixel(input);
                (*m_d, *m_c) = (U32F32::from_bits(d), U32F32::from_bits(c));
                let f = fields_of(config, &solved, rd, v).map(I16F16::from_bits);
                (*v_c_x, *v_c_y, *v_d_x, *v_d_y) = (f[0], f[1], f[2], f[3]);
            }
        }
    }
}

/// The row in batches of `LANES` (the last padded).
#[inline(always)]
#[cfg_attr(
    not(target_arch = "x86_64"),
    allow(clippy::modulo_one, reason = "compiled but unused where LANES is 1")
)]
fn batched(config: &Config, rows: &TailRows<'_>, out: TailOut<'_>) {
    let TailOut {
        m: [m_d, m_c],
        fields,
    } = out;
    let len = m_d.len().min(m_c.len());
    let whole = len - len % LANES;
    // Batches as arrays (`as_chunks`): no length test or index product per
    // batch and row (`chunks_exact` and a `try_into` each cost `run` 7.4
    // instructions per pixel in the AVX2 pass, callgrind).
    let [a, b, c, ph, pl, qh, ql] = rows.sums.map(|row| row.as_chunks::<LANES>().0.iter());
    let [vx, vy] = rows.v.map(|row| row.as_chunks::<LANES>().0.iter());
    let sums = a.zip(b).zip(c).zip(ph).zip(pl).zip(qh).zip(ql);
    let inputs = sums.zip(vx.zip(vy));
    let (m_d, m_d_rest) = m_d.split_at_mut(whole);
    let (m_c, m_c_rest) = m_c.split_at_mut(whole.min(m_c.len()));
    let outputs = m_d.as_chunks_mut::<LANES>().0.iter_mut();
    let outputs = outputs.zip(m_c.as_chunks_mut::<LANES>().0);
    let mut fields = fields.map(|rows| rows.map(|row| row.split_at_mut(whole.min(row.len()))));
    let mut field_batches = fields.as_mut().map(|rows| {
        rows.each_mut()
            .map(|(whole, _)| whole.as_chunks_mut::<LANES>().0.iter_mut())
    });
    // Zipped by value (not through `&mut`), so the zip indexes every row
    // from one counter instead of stepping eleven iterators.
    for ((m_d, m_c), (((((((a, b), c), ph), pl), qh), ql), (vx, vy))) in outputs.zip(inputs) {
        // Written out, not `[…].map(…)`: inside the host's AVX2 pass the
        // compiler kept such a `map` out of line, a call per batch that cost
        // `run` 18 instructions per pixel (callgrind).
        let batch = Batch {
            sums: [*a, *b, *c, *ph, *pl, *qh, *ql],
            v: [*vx, *vy],
        };
        let done = batch.tail(config, field_batches.is_some());
        *m_d = done.m[0].map(U32F32::from_bits);
        *m_c = done.m[1].map(U32F32::from_bits);
        if let Some(batches) = &mut field_batches {
            for (batch, values) in batches.iter_mut().zip(done.fields) {
                if let Some(out) = batch.next() {
                    *out = values.map(I16F16::from_bits);
                }
            }
        }
    }
    // The row's last, partial batch.
    if whole < len {
        let columns = whole..len;
        let batch = Batch {
            sums: rows.sums.map(|row| padded(row, columns.clone())),
            v: rows.v.map(|row| padded(row, columns.clone())),
        };
        let done = batch.tail(config, fields.is_some());
        let rest = [m_d_rest, m_c_rest];
        for (out, values) in rest.into_iter().zip(done.m) {
            for (out, value) in out.iter_mut().zip(values) {
                *out = U32F32::from_bits(value);
            }
        }
        if let Some(rows) = fields {
            for ((_, out), values) in rows.into_iter().zip(done.fields) {
                for (out, value) in out.iter_mut().zip(values) {
                    *out = I16F16::from_bits(value);
                }
            }
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
}

/// One batch's outputs: `[|v_d|, |v_c|]` in Q32.32 bits and, if asked for,
/// `[v_c x, v_c y, v_d x, v_d y]` in Q16.16 bits (else zero).
struct BatchOut {
    m: [[u64; LANES]; 2],
    fields: [[i32; LANES]; 4],
}

impl Batch {
    /// The tail of the batch's pixels.
    #[inline(always)]
    fn tail(&self, config: &Config, fields: bool) -> BatchOut {
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
        let mut f = [[0i32; LANES]; 4];
        if fields {
            for i in 0..LANES {
                let [v_c_x, v_c_y, v_d_x, v_d_y] =
                    fields_of(config, &solved[i], rd[i], [vx[i], vy[i]]);
                (f[0][i], f[1][i], f[2][i], f[3][i]) = (v_c_x, v_c_y, v_d_x, v_d_y);
            }
        }
        BatchOut {
            m: [m_d, m_c],
            fields: f,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::vec::Vec;

    use super::*;
    use crate::Params;
    use crate::solve::tests::pixel_sums;

    /// Every output row of one tail, filled with a sentinel first.
    struct Rows {
        m: [Vec<U32F32>; 2],
        fields: [Vec<I16F16>; 4],
    }

    impl Rows {
        fn new(width: usize) -> Self {
            Self {
                m: core::array::from_fn(|_| std::vec![U32F32::MAX; width]),
                fields: core::array::from_fn(|_| std::vec![I16F16::MAX; width]),
            }
        }

        fn out(&mut self, fields: bool) -> TailOut<'_> {
            let [a, b, c, d] = self.fields.each_mut().map(|row| &mut row[..]);
            TailOut {
                m: self.m.each_mut().map(|row| &mut row[..]),
                fields: fields.then_some([a, b, c, d]),
            }
        }
    }

    /// The batches give the per-pixel loop's rows, fields included, for
    /// every row length around the batch size (whole and partial batches)
    /// and sums from small to the largest gradients and residuals; every
    /// output column is written, and the fields only when asked for.
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
                let rows = TailRows {
                    sums: planes.each_ref().map(|p| &p[..]),
                    v: [&v[0][..], &v[1][..]],
                };
                for fields in [false, true] {
                    let (mut by_pixel, mut by_batch) = (Rows::new(width), Rows::new(width));
                    per_pixel(&config, &rows, by_pixel.out(fields));
                    batched(&config, &rows, by_batch.out(fields));
                    let what = std::format!("width {width}, fields {fields}");
                    assert_eq!(by_batch.m, by_pixel.m, "{what}");
                    assert_eq!(by_batch.fields, by_pixel.fields, "{what}");
                    assert!(
                        by_pixel.m.iter().flatten().all(|&m| m < U32F32::MAX),
                        "{what}"
                    );
                    let untouched = by_pixel.fields.iter().flatten().all(|&f| f == I16F16::MAX);
                    assert_eq!(untouched, !fields || width == 0, "{what}");
                }
            }
        }
    }
}
