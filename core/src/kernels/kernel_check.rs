//! The check of the target's own row loops against their portable twins,
//! on rows at the bounds of their inputs and random ones, every length
//! from 0 to [`LEN`] (both parities of the two-column loops, every position
//! of a partial lane block): the M4F's and M7's assembly (`m4`), which the
//! firmware runs on the emulated M4 and M7, and aarch64's NEON sums,
//! tail, bytes, products with their horizontal `G`, `E` smoothed along
//! the row, `V`'s vertical binomials and the rows of `d` (`neon`), which `tests/kernel_check.rs` runs under `qemu-aarch64`
//! (`scripts/embedded-check`). Targets without such loops pass trivially.
//! Not part of the stable surface.

/// The longest row checked.
pub const LEN: usize = 41;

/// Rows compared, or the first loop whose output differs from its twin's.
pub fn run() -> Result<usize, &'static str> {
    #[cfg(m4_kernels)]
    return m4::run();
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    return neon::run();
    #[cfg(not(any(m4_kernels, all(target_arch = "aarch64", target_feature = "neon"))))]
    Ok(0)
}

/// xorshift64: values across a range, and its ends one time in four.
#[cfg(any(m4_kernels, all(target_arch = "aarch64", target_feature = "neon")))]
struct Values(u64);

#[cfg(any(m4_kernels, all(target_arch = "aarch64", target_feature = "neon")))]
impl Values {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// In `[−bound, bound]`.
    fn within(&mut self, bound: i64) -> i64 {
        let r = self.next();
        match r % 8 {
            0 => bound,
            1 => -bound,
            _ => (r >> 8) as i64 % (bound + 1) * if r & 16 == 0 { 1 } else { -1 },
        }
    }
}

/// The parameters the tails are checked at: the SPEC's defaults and
/// `s = 1/1024, λ = 1e-6`.
#[cfg(any(m4_kernels, all(target_arch = "aarch64", target_feature = "neon")))]
fn tail_params() -> Result<[crate::Params; 2], &'static str> {
    let Ok(scale) = crate::IntensityScale::new(1, 1024) else {
        return Err("magnitudes: scale");
    };
    let small = crate::Params {
        scale,
        lambda: fixed::types::U32F32::from_bits(4295),
    };
    Ok([crate::Params::DEFAULT, small])
}

#[cfg(m4_kernels)]
mod m4 {
    use super::{LEN, Values, tail_params};
    use crate::kernels::m4;
    use crate::kernels::wide_products;
    use crate::sink::portable_rgb_tail;
    use crate::stages::{binomial_of, running_binomial, sliding_binomial, vertical_parts_of};
    use crate::tail::{TailConstants, TailOut, TailRows, tail_row as tail_row_portable};
    use crate::{ByteScale, Config};
    use fixed::types::U16F16;

    pub(super) fn run() -> Result<usize, &'static str> {
        let mut values = Values(0x2545_f491_4f6c_dd1d);
        let mut rows = 0;
        for len in 0..=LEN {
            rows += binomials(&mut values, len)?;
            rows += vertical_parts(&mut values, len)?;
            rows += products(&mut values, len)?;
            rows += bytes(&mut values, len)?;
            rows += magnitudes(&mut values, len)?;
        }
        Ok(rows)
    }

    /// The vertical and horizontal binomials, on sums at the bound of the
    /// engine's largest (`E` smoothed and the structure products'
    /// horizontal sums, `< 2²⁴`), and `f32` sums with every mantissa bit in
    /// use.
    fn binomials(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        let ints: [[i32; LEN + 4]; 5] =
            core::array::from_fn(|_| core::array::from_fn(|_| values.within((1 << 24) - 1) as i32));
        let floats: [[f32; LEN + 4]; 5] = core::array::from_fn(|_| {
            core::array::from_fn(|_| values.within(1 << 45) as f32 * (1.0 / 1_048_576.0))
        });
        let [a, b, c, d, e] = ints.each_ref().map(|r| &r[..len]);
        let (mut want, mut got) = ([0i32; LEN], [0i32; LEN]);
        binomial_of(a, b, c, d, e, &mut want[..len]);
        m4::binomial_i32([a, b, c, d, e], &mut got[..len]);
        if want != got {
            return Err("binomial_i32");
        }
        let [a, b, c, d, e] = floats.each_ref().map(|r| &r[..len]);
        let (mut want, mut got) = ([0f32; LEN], [0f32; LEN]);
        binomial_of(a, b, c, d, e, &mut want[..len]);
        m4::binomial_f32([a, b, c, d, e], &mut got[..len]);
        if want.map(f32::to_bits) != got.map(f32::to_bits) {
            return Err("binomial_f32");
        }
        // The horizontal ones, on `len + 4` taps.
        let [taps, ..] = &ints;
        let (mut want, mut got) = ([0i32; LEN], [0i32; LEN]);
        if let Some(taps) = taps.get(..len + 4) {
            running_binomial(taps, &mut want[..len]);
            m4::running_binomial_i32(taps, &mut got[..len]);
        }
        if want != got {
            return Err("running_binomial_i32");
        }
        let [taps, ..] = &floats;
        let (mut want, mut got) = ([0f32; LEN], [0f32; LEN]);
        if let Some(taps) = taps.get(..len + 4) {
            sliding_binomial(taps, &mut want[..len]);
            m4::sliding_binomial_f32(taps, &mut got[..len]);
        }
        if want.map(f32::to_bits) != got.map(f32::to_bits) {
            return Err("sliding_binomial_f32");
        }
        Ok(4)
    }

    /// `E`'s vertical parts on rows of `d` at ±255 and between, in
    /// word-aligned rows (the assembly's) and at an odd offset (the
    /// portable loop's fallback).
    fn vertical_parts(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        #[repr(align(4))]
        struct Row([i16; LEN + 1]);
        let d: [Row; 5] =
            core::array::from_fn(|_| Row(core::array::from_fn(|_| values.within(255) as i16)));
        for offset in [0, 1] {
            let [d0, d1, d2, d3, d4] = d.each_ref().map(|r| &r.0[offset..offset + len]);
            let mut want = [
                Row([0; LEN + 1]),
                Row([0; LEN + 1]),
                Row([0; LEN + 1]),
                Row([0; LEN + 1]),
            ];
            let mut got = [
                Row([0; LEN + 1]),
                Row([0; LEN + 1]),
                Row([0; LEN + 1]),
                Row([0; LEN + 1]),
            ];
            let [w1, w2, w3, w4] = want.each_mut().map(|r| &mut r.0[offset..offset + len]);
            vertical_parts_of([d0, d1, d2, d3, d4], w1, w2, w3, w4);
            let assembled = m4::vertical_parts(
                [d0, d1, d2, d3, d4],
                got.each_mut().map(|r| &mut r.0[offset..offset + len]),
            );
            if assembled != (offset == 0) {
                return Err("vertical_parts: alignment");
            }
            if assembled && want.each_ref().map(|r| r.0) != got.each_ref().map(|r| r.0) {
                return Err("vertical_parts");
            }
        }
        Ok(1)
    }

    /// The gradients on rows of `p0` from 0 to 255, and the residual's
    /// products at `σ = 8` from gradients, `V` and the residual's parts at
    /// their bounds (`wide_products`).
    fn products(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        let p0: [[u8; LEN + 2]; 3] =
            core::array::from_fn(|_| core::array::from_fn(|_| (values.within(127) + 128) as u8));
        let [up, mid, down] = p0.each_ref().map(|r| &r[..len + 2]);
        let (mut want, mut got) = ([[0i16; LEN]; 2], [[0i16; LEN]; 2]);
        let [wx, wy] = want.each_mut().map(|r| &mut r[..len]);
        wide_products::gradients_of(up, mid, down, wx, wy);
        let [gx, gy] = got.each_mut().map(|r| &mut r[..len]);
        m4::gradients(up, mid, down, gx, gy);
        if want != got {
            return Err("gradients");
        }
        let mut row =
            |bound: i64| -> [i32; LEN] { core::array::from_fn(|_| values.within(bound) as i32) };
        let (vx, vy, high, low) = (row(6_854_400), row(6_854_400), row((1 << 28) - 1), row(127));
        let low = low.map(|l| l.abs());
        let [gx, gy] = got.each_ref().map(|r| &r[..len]);
        let (mut want, mut got) = ([[0f32; LEN]; 2], [[0f32; LEN]; 2]);
        let [xd, yd] = want.each_mut().map(|r| &mut r[..len]);
        let (vx, vy, high, low) = (&vx[..len], &vy[..len], &high[..len], &low[..len]);
        wide_products::residual_products_of::<8>(8, gx, gy, vx, vy, high, low, xd, yd);
        let [xd, yd] = got.each_mut().map(|r| &mut r[..len]);
        m4::residual_products_8(gx, gy, vx, vy, high, low, xd, yd);
        if want.map(|r| r.map(f32::to_bits)) != got.map(|r| r.map(f32::to_bits)) {
            return Err("residual_products_8");
        }
        Ok(2)
    }

    /// The representation's bytes from magnitudes of every size (zero,
    /// tiny, past the top byte), under fixed gains and per-frame min–max
    /// maps.
    fn bytes(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        let mut row = || -> [f32; LEN] {
            core::array::from_fn(|_| {
                let v = values.next();
                f32::from_bits((v as u32 >> 9) | 0x3000_0000)
                    * [0.0, 1.0, 64.0, 1e6][(v >> 40) as usize % 4]
            })
        };
        let (m_d, m_c) = (row(), row());
        let luma: [u8; LEN] = core::array::from_fn(|_| values.next() as u8);
        let mut rows = 0;
        for (scale_d, scale_c) in [
            (
                ByteScale::fixed(U16F16::from_num(8)),
                ByteScale::fixed(U16F16::from_num(32)),
            ),
            (
                ByteScale::min_max(0.001, 3.5),
                ByteScale::min_max(0.0, 1e-3),
            ),
        ] {
            let (mut want, mut got) = ([[0u8; 3]; LEN], [[0u8; 3]; LEN]);
            portable_rgb_tail(
                &m_d[..len],
                &m_c[..len],
                &luma[..len],
                [&scale_d, &scale_c],
                &mut want[..len],
            );
            m4::rgb_row(
                [&m_d[..len], &m_c[..len]],
                &luma[..len],
                [scale_d.parts(), scale_c.parts()],
                &mut got[..len],
            );
            if want != got {
                return Err("rgb_row");
            }
            rows += 1;
        }
        Ok(rows)
    }

    /// Both magnitudes against the portable tail, on structure sums built
    /// from 25 pixels of gradients and residuals as the engine builds them
    /// (flat to the largest), `V` at its bound, at the default parameters
    /// and at `s = 1/1024, λ = 1e-6`.
    fn magnitudes(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        let mut rows = 0;
        for params in tail_params()? {
            let Ok(config) = Config::new(8, 8, params) else {
                return Err("magnitudes: configuration");
            };
            let k = TailConstants {
                lambda4: config.lambda4,
                units: config.units(),
            };
            let (mut abc, mut pq, mut v) = ([[0i32; LEN]; 3], [[0f32; LEN]; 2], [[0i32; LEN]; 2]);
            for i in 0..len {
                let (gmax, dmax) = [
                    (1020, 1 << 27),
                    (30, 1 << 20),
                    (3, 1 << 27),
                    (1020, 1000),
                    (0, 1),
                ][values.next() as usize % 5];
                let g = [1i64, 4, 6, 4, 1];
                let (mut sums, mut products) = ([0i64; 3], [0i64; 2]);
                for j in 0..25 {
                    let w = g[j / 5] * g[j % 5];
                    let (x, y, dn) = (
                        values.within(gmax),
                        values.within(gmax),
                        values.within(dmax),
                    );
                    sums[0] += w * x * x;
                    sums[1] += w * x * y;
                    sums[2] += w * y * y;
                    products[0] += w * x * dn;
                    products[1] += w * y * dn;
                }
                for ch in 0..3 {
                    abc[ch][i] = sums[ch] as i32;
                }
                for ch in 0..2 {
                    pq[ch][i] = (products[ch] as f64 * (1.0 / 1_048_576.0)) as f32;
                    v[ch][i] = values.within(6_854_400) as i32;
                }
            }
            let tail_rows = TailRows {
                abc: abc.each_ref().map(|r| &r[..len]),
                pq: pq.each_ref().map(|r| &r[..len]),
                v: v.each_ref().map(|r| &r[..len]),
            };
            let mut want = [[0f32; LEN]; 2];
            let out = TailOut {
                m: want.each_mut().map(|r| &mut r[..len]),
                fields: None,
                extremes: false,
            };
            tail_row_portable(&k, &tail_rows, out);
            let mut got = [[0f32; LEN]; 2];
            let [a, b, c] = tail_rows.abc;
            let [p, q] = tail_rows.pq;
            let units = [k.units.det_floor, k.units.v_d];
            m4::divergence_free_magnitudes(k.lambda4, units, a, b, c, p, q, &mut got[0][..len]);
            m4::curl_free_magnitudes(
                k.units.v_c,
                tail_rows.v[0],
                tail_rows.v[1],
                &mut got[1][..len],
            );
            if want[0].map(f32::to_bits) != got[0].map(f32::to_bits) {
                return Err("divergence_free_magnitudes");
            }
            if want[1].map(f32::to_bits) != got[1].map(f32::to_bits) {
                return Err("curl_free_magnitudes");
            }
            rows += 2;
        }
        Ok(rows)
    }
}

/// aarch64's NEON sums and tail (`kernels/neon.rs`) against the portable
/// layout's: the horizontal `G` of product rows into the sums' rings, then
/// each output row's vertical `G`, solve, magnitudes, extremes and fields,
/// for outputs of every length from 0 to `LEN` (every position of a
/// partial four-lane block) and every ring slot of an output row's first
/// sums row; its bytes against the portable pixels', rows of every
/// length from 0 to `LEN` (two sixteen-pixel steps and every remainder);
/// its rows of `p0` and `d`, `E`'s vertical parts, the structure
/// products and `E` smoothed along the row against the portable loops',
/// rows of every length from 0 to `LEN` (two sixteen-column or five
/// eight-column steps and every remainder).
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
mod neon {
    use super::{LEN, Values, tail_params};
    use crate::kernels::neon::Neon;
    use crate::kernels::{KernelSet, OutputRow, Portable, SumRings};
    use crate::ring::take_rows;
    use crate::schedule::{HALO, SUM_DEPTH, SUM_RADIUS};
    use crate::sink::portable_rgb_tail;
    use crate::stages::{
        DN_SCALE, FLOAT_CHANNELS, INT_CHANNELS, ResidualInputs, ScratchRows, StructureRows,
        load_pixels_of,
    };
    use crate::tail::{TailConstants, TailOut};
    use crate::{ByteScale, Pixels};
    use crate::{Config, ExtremesSink};
    use fixed::types::U16F16;

    /// The widest window checked.
    const COLS: usize = LEN + 2 * HALO;
    /// Window rows stored: the first output row is `2 · SUM_RADIUS` rows
    /// in, and the outputs then take every slot of the ring.
    const ROWS: usize = HALO + SUM_RADIUS + 2 * SUM_DEPTH;

    pub(super) fn run() -> Result<usize, &'static str> {
        let mut values = Values(0x2545_f491_4f6c_dd1d);
        let mut rows = 0;
        for len in 0..=LEN {
            for params in tail_params()? {
                let Ok(config) = Config::new(8, 8, params) else {
                    return Err("neon: configuration");
                };
                let k = TailConstants {
                    lambda4: config.lambda4,
                    units: config.units(),
                };
                for out in [(false, true), (false, false), (true, false)] {
                    rows += sums_and_tail(&mut values, &k, len, out)?;
                }
            }
            rows += bytes(&mut values, len)?;
            rows += structure(&mut values, len)?;
            rows += boundary_minus_domain(&mut values, len)?;
            rows += smooth(&mut values, len)?;
            rows += rows_of_d(&mut values, len)?;
        }
        Ok(rows)
    }

    /// `p0` and `d` of a row (`KernelSet::load_pixels`) from bytes 0 to
    /// 255 against the portable loop's, `len` columns.
    fn rows_of_d(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        let frames: [[u8; LEN]; 2] =
            core::array::from_fn(|_| core::array::from_fn(|_| values.next() as u8));
        let [prev, next] = frames.each_ref().map(|r| &r[..len]);
        let (mut p, mut d) = ([[0u8; LEN]; 2], [[0i16; LEN]; 2]);
        let ([p_want, p_got], [d_want, d_got]) = (&mut p, &mut d);
        load_pixels_of([prev, next], &mut p_want[..len], &mut d_want[..len]);
        Neon::load_pixels([prev, next], &mut p_got[..len], &mut d_got[..len]);
        if p[0] != p[1] || d[0] != d[1] {
            return Err("neon: load_pixels");
        }
        Ok(1)
    }

    /// `E` smoothed along the row (`KernelSet::boundary_minus_domain`)
    /// against the portable loops', `len` outputs of a window `len + 8`
    /// wide, from five rows of `d`: within ±255 (at its ends one time in
    /// four), and ±255 changing sign across one column in every row, or
    /// across one row in every column, where `E` x or y reaches its bound
    /// (`132 · 255`) at the edge.
    fn boundary_minus_domain(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        const COLS: usize = LEN + 8;
        let n = len + 8;
        let random: [[i16; COLS]; 5] =
            core::array::from_fn(|_| core::array::from_fn(|_| values.within(255) as i16));
        let sign = |before: bool| if before { 255 } else { -255 };
        let across_columns: [[i16; COLS]; 5] =
            core::array::from_fn(|_| core::array::from_fn(|c| sign(c < n / 2)));
        let across_rows: [[i16; COLS]; 5] = core::array::from_fn(|r| [sign(r < 2); COLS]);
        let negated = |rows: [[i16; COLS]; 5]| rows.map(|row| row.map(|v| -v));
        let patterns = [
            random,
            across_columns,
            negated(across_columns),
            across_rows,
            negated(across_rows),
        ];
        for d in &patterns {
            let d = d.each_ref().map(|r| &r[..n]);
            let mut out = [[[0i32; COLS]; 2]; 2];
            for (neon, [sx, sy]) in [false, true].into_iter().zip(out.each_mut()) {
                let mut parts = [[0i16; COLS]; 4];
                let mut vert = parts.each_mut().map(|r| &mut r[..n]);
                let (mut ex, mut ey) = ([0i32; COLS], [0i32; COLS]);
                let e = (&mut ex[..n], &mut ey[..n]);
                let e_smoothed = (&mut sx[..n], &mut sy[..n]);
                if neon {
                    Neon::boundary_minus_domain(d, &mut vert, e, e_smoothed, n);
                } else {
                    Portable::boundary_minus_domain(d, &mut vert, e, e_smoothed, n);
                }
            }
            if out[0] != out[1] {
                return Err("neon: boundary_minus_domain");
            }
        }
        Ok(patterns.len())
    }

    /// `V`'s vertical binomials (`KernelSet::smooth`) against the portable
    /// loops', `len` outputs of a window `len + 8` wide, from rows of `E`
    /// smoothed along the row within their bound (`16 · 132 · 255`), at
    /// its ends one time in four.
    fn smooth(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        const COLS: usize = LEN + 8;
        const BOUND: i64 = 16 * 132 * 255;
        let n = len + 8;
        let e: [[[i32; COLS]; 5]; 2] = core::array::from_fn(|_| {
            core::array::from_fn(|_| core::array::from_fn(|_| values.within(BOUND) as i32))
        });
        let e = e.each_ref().map(|rows| rows.each_ref().map(|r| &r[..n]));
        let mut out = [[[0i32; COLS]; 2]; 2];
        for (neon, [vx, vy]) in [false, true].into_iter().zip(out.each_mut()) {
            let v = (&mut vx[..n], &mut vy[..n]);
            if neon {
                Neon::smooth(e, v, n);
            } else {
                Portable::smooth(e, v, n);
            }
        }
        if out[0] != out[1] {
            return Err("neon: smooth");
        }
        Ok(1)
    }

    /// The structure products and their horizontal `G`
    /// (`SumRings::push_structure`: one pass in NEON lanes where a window
    /// has two blocks of output columns) against the portable products
    /// and sums, through both sets' tails (which `sums_and_tail` holds
    /// equal), at the smallest and largest residual shifts and the SPEC's
    /// default scale: `p0` from 0 to 255, `d` within ±255 and `V` within
    /// half its bound (so that `Q` reaches its own), each at its ends one
    /// time in four; windows `len + 14` wide, as the engine's.
    fn structure(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        let n = len + 2 * HALO;
        let mut rows = 0;
        for (num, den) in [(1, 1), (1, 255), (1, 699_050)] {
            let Ok(scale) = crate::IntensityScale::new(num, den) else {
                return Err("neon: products' scale");
            };
            // An admissible λ at this scale (`κ` and `σ` do not depend on it).
            let s = f64::from(num) / f64::from(den);
            let lambda = fixed::types::U32F32::from_num(1000.0 * s * s / 65_536.0)
                .max(fixed::types::U32F32::DELTA);
            let Ok(config) = Config::new(8, 8, crate::Params { scale, lambda }) else {
                return Err("neon: products' configuration");
            };
            let k = TailConstants {
                lambda4: config.lambda4,
                units: config.units(),
            };
            let (mut words, mut floats) = ([[0i32; WORDS]; 2], [[0f32; FLOATS]; 2]);
            let [words_p, words_n] = &mut words;
            let [floats_p, floats_n] = &mut floats;
            let mut portable = Side::new(Portable, words_p, floats_p, n);
            let mut neon = Side::new(Neon, words_n, floats_n, n);
            for t in 0..ROWS {
                let mut v_row = || -> [i32; COLS] {
                    core::array::from_fn(|_| values.within(6_854_400 / 2) as i32)
                };
                let (vx, vy) = (v_row(), [v_row(), v_row(), v_row()]);
                let p0: [[u8; COLS]; 3] = core::array::from_fn(|_| {
                    core::array::from_fn(|_| (values.within(128) + 127).clamp(0, 255) as u8)
                });
                let d: [i16; COLS] = core::array::from_fn(|_| values.within(255) as i16);
                let input = ResidualInputs {
                    vx: &vx[..n],
                    vy: vy.each_ref().map(|r| &r[..n]),
                    p0: p0.each_ref().map(|r| &r[..n]),
                    d: &d[..n],
                    kappa: config.kappa_split(),
                    shift: config.dn_shift,
                };
                portable.push(t, &input, n);
                neon.push(t, &input, n);
                let Some(o) = t.checked_sub(SUM_RADIUS).filter(|&o| o >= HALO) else {
                    continue;
                };
                let v = [&vx[..n], &vy[1][..n]];
                let want = portable.tail(o, v, &k, len, (false, true));
                if neon.tail(o, v, &k, len, (false, true)).rows != want.rows {
                    return Err("neon: structure sums");
                }
                rows += 1;
            }
        }
        Ok(rows)
    }

    /// The representation's bytes (`KernelSet::rgb_row`) against the
    /// portable pixels, on magnitudes of every size and kind (zero, tiny,
    /// past the top byte, below the map's minimum, at a byte's half, and
    /// the NaN, infinity and signed zero no engine's magnitude is, which
    /// the saturating conversion maps all the same), under fixed gains and
    /// per-frame min–max maps, one of them flat.
    fn bytes(values: &mut Values, len: usize) -> Result<usize, &'static str> {
        const ODD: [f32; 8] = [
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            -0.0,
            0.0,
            0.5,
            31.9375,
            1e30,
        ];
        let mut row = || -> [f32; LEN] {
            core::array::from_fn(|_| {
                let v = values.next();
                match (v >> 40) % 8 {
                    0 => ODD[(v >> 44) as usize % ODD.len()],
                    k => {
                        f32::from_bits((v as u32 >> 9) | 0x3000_0000)
                            * [0.0, 1.0, 64.0, 1e6, 1e-3, 8.0, 255.0][k as usize - 1]
                    }
                }
            })
        };
        let (m_d, m_c) = (row(), row());
        let luma: [u8; LEN] = core::array::from_fn(|_| values.next() as u8);
        let mut rows = 0;
        for [scale_d, scale_c] in [
            [
                ByteScale::fixed(U16F16::from_num(8)),
                ByteScale::fixed(U16F16::from_num(32)),
            ],
            [
                ByteScale::min_max(0.001, 3.5),
                ByteScale::min_max(0.0, 1e-3),
            ],
            [ByteScale::min_max(2.0, 2.0), ByteScale::min_max(-1.0, 1e7)],
        ] {
            let (mut want, mut got) = ([[0u8; 3]; LEN], [[0u8; 3]; LEN]);
            let (m_d, m_c, luma) = (&m_d[..len], &m_c[..len], &luma[..len]);
            let scales = [&scale_d, &scale_c];
            portable_rgb_tail(m_d, m_c, luma, scales, &mut want[..len]);
            let pixels = Pixels {
                m_d,
                m_c,
                luma,
                fields: None,
            };
            Neon::rgb_row(pixels, scales, &mut got[..len]);
            if want != got {
                return Err("neon: rgb_row");
            }
            rows += 1;
        }
        Ok(rows)
    }

    /// One window row's product rows and `V`, as the engine makes them:
    /// gradients within ±1020 and residuals within ±2²⁷ (their bounds,
    /// one time in four), `V` within its bound.
    struct Window {
        ints: [[i32; COLS]; INT_CHANNELS],
        floats: [[f32; COLS]; FLOAT_CHANNELS],
        v: [[i32; COLS]; 2],
    }

    fn window(values: &mut Values) -> Window {
        let mut w = Window {
            ints: [[0; COLS]; INT_CHANNELS],
            floats: [[0.0; COLS]; FLOAT_CHANNELS],
            v: [[0; COLS]; 2],
        };
        for i in 0..COLS {
            let (x, y) = (values.within(1020) as i32, values.within(1020) as i32);
            let dn = values.within(1 << 27) as i32 as f32 * DN_SCALE;
            w.ints[0][i] = x * x;
            w.ints[1][i] = x * y;
            w.ints[2][i] = y * y;
            w.floats[0][i] = x as f32 * dn;
            w.floats[1][i] = y as f32 * dn;
            w.v[0][i] = values.within(6_854_400) as i32;
            w.v[1][i] = values.within(6_854_400) as i32;
        }
        w
    }

    /// What one set wrote for an output row: the magnitudes, the fields
    /// (when asked for) and the extremes.
    struct Written {
        rows: [[u32; LEN]; 6],
        extremes: [u32; 4],
    }

    /// Memory for one set: its rings, and the product rows and free rows
    /// the engine lends an output row.
    const WORDS: usize = (SUM_DEPTH + 2) * INT_CHANNELS * COLS;
    const FLOATS: usize = (SUM_DEPTH + 2) * FLOAT_CHANNELS * COLS;

    /// One set's rings over windows of `n` columns, with the product rows
    /// it stores from and the rows its tail may use (`OutputRow`).
    struct Side<'m, K: KernelSet> {
        sums: K::Sums<'m>,
        ints: [&'m mut [i32]; INT_CHANNELS],
        floats: [&'m mut [f32]; FLOAT_CHANNELS],
        scratch_ints: [&'m mut [i32]; INT_CHANNELS],
        scratch_floats: [&'m mut [f32]; FLOAT_CHANNELS],
    }

    impl<'m, K: KernelSet> Side<'m, K> {
        fn new(kernels: K, mut words: &'m mut [i32], mut floats: &'m mut [f32], n: usize) -> Self {
            let sums = <K::Sums<'m> as SumRings<'m, K>>::carve(kernels, &mut words, &mut floats, n);
            Self {
                sums,
                ints: take_rows(&mut words, n),
                floats: take_rows(&mut floats, n),
                scratch_ints: take_rows(&mut words, n),
                scratch_floats: take_rows(&mut floats, n),
            }
        }

        /// Window row `t`'s products into the rings.
        fn store(&mut self, t: usize, w: &Window, n: usize) {
            for (row, from) in self.ints.iter_mut().zip(&w.ints) {
                row.copy_from_slice(&from[..n]);
            }
            for (row, from) in self.floats.iter_mut().zip(&w.floats) {
                row.copy_from_slice(&from[..n]);
            }
            self.sums
                .store_row(t, (&mut self.ints, &mut self.floats), n);
        }

        /// Window row `t`'s products, made from `input`, into the rings.
        fn push(&mut self, t: usize, input: &ResidualInputs<'_>, n: usize) {
            let (mut gx, mut gy, mut high, mut low) =
                ([0i16; COLS], [0i16; COLS], [0; COLS], [0; COLS]);
            let rows = StructureRows {
                int_products: &mut self.ints,
                float_products: &mut self.floats,
                scratch: ScratchRows {
                    gx: &mut gx[..n],
                    gy: &mut gy[..n],
                    high: &mut high[..n],
                    low: &mut low[..n],
                },
            };
            self.sums.push_structure(t, input, rows, n);
        }

        /// Output row `o`'s tail, `len` columns.
        fn tail(
            &mut self,
            o: usize,
            v: [&[i32]; 2],
            k: &TailConstants,
            len: usize,
            (fields, extremes): (bool, bool),
        ) -> Written {
            let n = len + 2 * HALO;
            let mut out = [[0f32; LEN]; 6];
            let [m_d, m_c, f0, f1, f2, f3] = out.each_mut().map(|r| &mut r[..len]);
            let row = OutputRow {
                o,
                n,
                products: (&mut self.scratch_ints, &mut self.scratch_floats),
                v,
                constants: k,
            };
            let m = [m_d, m_c];
            let found = self.sums.tail_row(
                row,
                TailOut {
                    m,
                    fields: fields.then_some([f0, f1, f2, f3]),
                    extremes,
                },
            );
            let found =
                found.unwrap_or_else(|| ExtremesSink::of_rows(&out[0][..len], &out[1][..len]));
            let extremes = [found.m_d.min, found.m_d.max, found.m_c.min, found.m_c.max];
            Written {
                rows: out.map(|r| r.map(f32::to_bits)),
                extremes: extremes.map(f32::to_bits),
            }
        }
    }

    /// Both sets' rings, over windows of `len + 14` columns, their tails
    /// writing the fields or not, and finding the magnitudes' extremes or
    /// not (`out`: `TailOut::fields`, `TailOut::extremes`).
    fn sums_and_tail(
        values: &mut Values,
        k: &TailConstants,
        len: usize,
        out: (bool, bool),
    ) -> Result<usize, &'static str> {
        let n = len + 2 * HALO;
        let (mut words, mut floats) = ([[0i32; WORDS]; 2], [[0f32; FLOATS]; 2]);
        let [words_p, words_n] = &mut words;
        let [floats_p, floats_n] = &mut floats;
        let mut portable = Side::new(Portable, words_p, floats_p, n);
        let mut neon = Side::new(Neon, words_n, floats_n, n);
        let mut rows = 0;
        for t in 0..ROWS {
            let w = window(values);
            portable.store(t, &w, n);
            neon.store(t, &w, n);
            let Some(o) = t.checked_sub(SUM_RADIUS).filter(|&o| o >= HALO) else {
                continue;
            };
            let v = w.v.each_ref().map(|r| &r[..n]);
            let want = portable.tail(o, v, k, len, out);
            let got = neon.tail(o, v, k, len, out);
            if want.rows != got.rows {
                return Err("neon: sums and tail");
            }
            // The extremes the tail was asked for (the others the
            // engine's to find).
            let (_, extremes) = out;
            if extremes && want.extremes != got.extremes {
                return Err("neon: extremes");
            }
            rows += 1;
        }
        Ok(rows)
    }
}
