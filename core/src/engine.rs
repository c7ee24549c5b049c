//! The bounded-memory engine: one tile at a time, rows streaming down
//! through a ring per stage, so working memory is `O(COLS)` and fixed at
//! compile time.
//!
//! A tile of `w × h` output pixels is computed from a window of
//! `n = w + 14` columns and `h + 14` rows of clamped input (SPEC §6). Pushing
//! window row `t` completes `E` of row `t−2`, `V` of `t−4`, the structure
//! products of `t−5` and the output of `t−7` (the lags in `schedule.rs`),
//! so an output row leaves as soon as the input row 7 below it has arrived.
//! Because each stage depends only on its inputs, not on where the window
//! starts, every tiling yields the same bytes as one whole-frame window.

use fixed::types::{I16F16, U32F32};

use crate::ring::RowRing;
use crate::schedule::{
    D_DEPTH, E_DEPTH, E_LAG, E_RADIUS, E_START, HALO, OUTPUT_LAG, OUTPUT_START, P0_DEPTH,
    PRODUCT_LAG, PRODUCT_RADIUS, PRODUCT_START, SUM_DEPTH, SUM_RADIUS, V_DEPTH, V_LAG, V_RADIUS,
    V_START,
};
use crate::solve::{
    StructureSums, curl_free_magnitude_q32, curl_free_q16, divergence_free_magnitude_q32,
    divergence_free_q16, solve,
};
use crate::stages::{
    CHANNELS, Products, ResidualInputs, boundary_minus_domain, smooth, structure_row,
    vertical_binomial,
};
use crate::{Config, Job, Tile};

/// Everything the representation knows about one pixel.
///
/// The fields are computed only for sinks that ask for them
/// ([`Sink::reads_fields`]); for the others they are zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlowPixel {
    /// Curl-free field `v_c` (x, y), pixels, Q16.16, to nearest.
    pub v_c: [I16F16; 2],
    /// Divergence-free field `v_d` (x, y), pixels, Q16.16, to nearest
    /// (saturating at ±32 768 px).
    pub v_d: [I16F16; 2],
    /// `|v_c|`, Q32.32, from the exact `V` (relative error below 2⁻²¹,
    /// so per-frame min–max keeps its precision on small motions).
    pub m_c: U32F32,
    /// `|v_d|`, Q32.32, from the solve's numerators before any rounding
    /// (relative error below 2⁻²⁰; saturating at 65 536 px).
    pub m_d: U32F32,
    /// The pixel of `fⁿ` (the representation's B channel).
    pub luma: u8,
}

impl FlowPixel {
    const ZERO: Self = Self {
        v_c: [I16F16::ZERO; 2],
        v_d: [I16F16::ZERO; 2],
        m_c: U32F32::ZERO,
        m_d: U32F32::ZERO,
        luma: 0,
    };
}

/// Where output goes: one call per output row of a tile, in top-to-bottom
/// order within the tile.
pub trait Sink {
    /// Whether this sink reads `v_c` and `v_d` (the magnitudes and the
    /// luma are always there). A sink that only makes bytes or extremes says
    /// `false`, and the engine skips the fields' conversions. Asked once per
    /// output row (a method, not a constant, so `dyn Sink` works).
    fn reads_fields(&self) -> bool {
        true
    }

    /// Pixels `[x, x + pixels.len())` of frame row `y`.
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]);
}

impl<S: Sink + ?Sized> Sink for &mut S {
    #[inline(always)]
    fn reads_fields(&self) -> bool {
        (**self).reads_fields()
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]) {
        (**self).row(y, x, pixels)
    }
}

/// The sink that does nothing.
impl Sink for () {
    fn reads_fields(&self) -> bool {
        false
    }

    fn row(&mut self, _y: usize, _x: usize, _pixels: &[FlowPixel]) {}
}

/// Both sinks see every row.
impl<A: Sink, B: Sink> Sink for (A, B) {
    #[inline(always)]
    fn reads_fields(&self) -> bool {
        self.0.reads_fields() || self.1.reads_fields()
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]) {
        self.0.row(y, x, pixels);
        self.1.row(y, x, pixels);
    }
}

/// Where the current window lies in the frame and how far it has been fed.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Window {
    /// Frame column of window column 0 (`tile.x − 7`).
    pub x_first: isize,
    /// Window columns (`tile.width + 14`), at most `COLS`.
    pub n: usize,
    /// Frame row of window row 0 (`tile.y − 7`).
    pub y_first: isize,
    /// Window rows pushed so far.
    pub t: usize,
}

/// All working memory of the computation, for tiles up to `COLS − 14`
/// columns wide: `316 · COLS` bytes and a few more ([`working_bytes`]).
/// Each channel has its own plane of rows, so the row loops vectorise.
/// `repr(C)`, widest fields first, so [`working_bytes`] can follow the layout.
#[repr(C)]
pub struct Engine<const COLS: usize> {
    window: Window,
    products: Products<COLS>,
    sums: [RowRing<i32, COLS, SUM_DEPTH>; CHANNELS],
    e: [RowRing<i32, COLS, E_DEPTH>; 2],
    v: [RowRing<i32, COLS, V_DEPTH>; 2],
    vert_e: [[i32; COLS]; 2],
    out: [FlowPixel; COLS],
    d: RowRing<i16, COLS, D_DEPTH>,
    vert_d: [[i16; COLS]; 4],
    p0: RowRing<u8, COLS, P0_DEPTH>,
}

impl<const COLS: usize> Engine<COLS> {
    /// The widest tile this engine computes.
    pub const MAX_TILE_WIDTH: usize = {
        assert!(COLS > 2 * HALO, "an engine needs more than 14 columns");
        COLS - 2 * HALO
    };

    /// Bytes of working memory: everything the engine owns
    /// (`= working_bytes(COLS)`).
    pub const WORKING_BYTES: usize = core::mem::size_of::<Self>();

    /// A zeroed engine (`const`, so it can live in a `static`).
    pub const fn new() -> Self {
        let _ = Self::MAX_TILE_WIDTH;
        Self {
            p0: RowRing::new(0),
            d: RowRing::new(0),
            e: [RowRing::new(0), RowRing::new(0)],
            v: [RowRing::new(0), RowRing::new(0)],
            sums: [const { RowRing::new(0) }; CHANNELS],
            vert_d: [[0; COLS]; 4],
            vert_e: [[0; COLS]; 2],
            products: Products {
                rows: [[0; COLS]; CHANNELS],
            },
            out: [FlowPixel::ZERO; COLS],
            window: Window {
                x_first: 0,
                n: 0,
                y_first: 0,
                t: 0,
            },
        }
    }

    /// Compute every tile of the job into `sink`.
    #[inline(always)]
    pub fn run<S: Sink>(&mut self, job: &Job<'_, COLS>, sink: &mut S) {
        for tile in job.plan().tiles() {
            self.tile(job, tile, sink);
        }
    }

    /// Compute tile `index` of the job (for callers that spread tiles over
    /// cores): the tile computed, or `None` (and nothing done) past the
    /// last tile.
    #[inline(always)]
    pub fn run_tile<S: Sink>(
        &mut self,
        job: &Job<'_, COLS>,
        index: usize,
        sink: &mut S,
    ) -> Option<Tile> {
        let tile = job.plan().tile(index)?;
        self.tile(job, tile, sink);
        Some(tile)
    }

    #[inline(always)]
    fn tile<S: Sink>(&mut self, job: &Job<'_, COLS>, tile: Tile, sink: &mut S) {
        let (config, frames) = (job.plan().config(), job.frames());
        let y_first = tile.y as isize - HALO as isize;
        self.begin(Window {
            x_first: tile.x as isize - HALO as isize,
            n: tile.width + 2 * HALO,
            y_first,
            t: 0,
        });
        for y in y_first..y_first + (tile.height + 2 * HALO) as isize {
            let (prev, next) = (frames.prev().clamped_row(y), frames.next().clamped_row(y));
            self.push(config, prev, next, sink);
        }
    }

    #[inline(always)]
    pub(crate) fn begin(&mut self, window: Window) {
        debug_assert!(
            window.n <= COLS,
            "a window of {} columns in {COLS}",
            window.n
        );
        self.window = Window {
            n: window.n.min(COLS),
            t: 0,
            ..window
        };
    }

    /// Feed window row `t` (frame rows of `fⁿ` and `fⁿ⁺¹`, each the full
    /// frame width) and run every stage it completes.
    #[inline(always)]
    pub(crate) fn push<S: Sink>(
        &mut self,
        config: &Config,
        prev: &[u8],
        next: &[u8],
        sink: &mut S,
    ) {
        let Window { x_first, n, t, .. } = self.window;
        self.window.t += 1;
        load_row(
            prev,
            next,
            x_first,
            n,
            self.p0.row_mut(t),
            self.d.row_mut(t),
        );
        if t >= E_START {
            let [ex, ey] = &mut self.e;
            boundary_minus_domain(
                self.d.rows(t - 2 * E_RADIUS),
                &mut self.vert_d,
                (ex.row_mut(t - E_LAG), ey.row_mut(t - E_LAG)),
                n,
            );
        }
        if t >= V_START {
            let first = t - V_LAG - V_RADIUS;
            let e = [self.e[0].rows(first), self.e[1].rows(first)];
            let [vx, vy] = &mut self.v;
            smooth(
                e,
                &mut self.vert_e,
                (vx.row_mut(t - V_LAG), vy.row_mut(t - V_LAG)),
                n,
            );
        }
        if t >= PRODUCT_START {
            let j = t - PRODUCT_LAG;
            let input = ResidualInputs {
                vx: self.v[0].row(j),
                vy: self.v[1].rows(j - PRODUCT_RADIUS),
                p0: self.p0.rows(j - PRODUCT_RADIUS),
                d: self.d.row(j),
                kappa: config.kappa_split(),
                shift: config.dn_shift,
            };
            let sums = self.sums.each_mut().map(|ring| ring.row_mut(j));
            structure_row(&input, &mut self.products, sums, n);
        }
        if t >= OUTPUT_START {
            self.emit(config, t - OUTPUT_LAG, sink);
        }
    }

    /// Solve and hand over output row `o` (window rows; `o ≥ 7`).
    #[cfg_attr(feature = "profile", inline(never))]
    #[cfg_attr(not(feature = "profile"), inline(always))]
    fn emit<S: Sink>(&mut self, config: &Config, o: usize, sink: &mut S) {
        let Window {
            x_first,
            n,
            y_first,
            ..
        } = self.window;
        // The vertical G of the seven sums, into the product rows (free now).
        for (ring, out) in self.sums.iter().zip(self.products.rows.iter_mut()) {
            vertical_binomial(ring.rows(o - SUM_RADIUS), out, n, HALO);
        }
        let fields = sink.reads_fields();
        let [a, b, c, ph, pl, qh, ql] = &self.products.rows;
        let (vx, vy, luma) = (self.v[0].row(o), self.v[1].row(o), self.p0.row(o));
        let width = n.saturating_sub(2 * HALO);
        let cols = (HALO..(HALO + width).min(COLS)).zip(self.out.iter_mut());
        for (i, out) in cols {
            let sums = StructureSums {
                a: a[i],
                b: b[i],
                c: c[i],
                p: [ph[i], pl[i]],
                q: [qh[i], ql[i]],
            };
            let solved = solve(config, sums);
            let v = [vx[i], vy[i]];
            let (v_c, v_d) = if fields {
                (
                    v.map(|v| curl_free_q16(config, v)),
                    divergence_free_q16(config, &solved),
                )
            } else {
                ([0; 2], [0; 2])
            };
            *out = FlowPixel {
                v_c: v_c.map(I16F16::from_bits),
                v_d: v_d.map(I16F16::from_bits),
                m_c: U32F32::from_bits(curl_free_magnitude_q32(config, v)),
                m_d: U32F32::from_bits(divergence_free_magnitude_q32(config, &solved)),
                luma: luma[i],
            };
        }
        let (y, x) = (
            (y_first + o as isize) as usize,
            (x_first + HALO as isize) as usize,
        );
        sink.row(y, x, self.out.get(..width).unwrap_or(&[]));
    }
}

/// Window columns `[x_first, x_first + n)` of both rows, clamped into the
/// frame (SPEC §2), as `p0` and `d = p1 − p0`.
#[cfg_attr(feature = "profile", inline(never))]
#[cfg_attr(not(feature = "profile"), inline(always))]
fn load_row<const COLS: usize>(
    prev: &[u8],
    next: &[u8],
    x_first: isize,
    n: usize,
    p0: &mut [u8; COLS],
    d: &mut [i16; COLS],
) {
    let width = prev.len().min(next.len());
    let (Some(&first), Some(&last)) = (prev.first(), prev.get(width.wrapping_sub(1))) else {
        return;
    };
    let (first_next, last_next) = (
        next.first().copied().unwrap_or(0),
        next.get(width - 1).copied().unwrap_or(0),
    );
    let n = n.min(COLS);
    // Columns left of the frame, inside it, and right of it.
    let left = (-x_first).min(n as isize).max(0) as usize;
    let start = x_first.max(0) as usize;
    let inside = width.saturating_sub(start).min(n - left);
    let (p_left, p_rest) = p0.split_at_mut(left);
    let (d_left, d_rest) = d.split_at_mut(left);
    p_left.fill(first);
    d_left.fill(i16::from(first_next) - i16::from(first));
    let (src_p, src_n) = (
        prev.get(start..start + inside).unwrap_or(&[]),
        next.get(start..start + inside).unwrap_or(&[]),
    );
    for (((p, dd), &a), &b) in p_rest
        .iter_mut()
        .zip(d_rest.iter_mut())
        .zip(src_p)
        .zip(src_n)
    {
        *p = a;
        *dd = i16::from(b) - i16::from(a);
    }
    let right = left + inside..n;
    if let (Some(p), Some(dd)) = (p0.get_mut(right.clone()), d.get_mut(right)) {
        p.fill(last);
        dd.fill(i16::from(last_next) - i16::from(last));
    }
}

/// Working bytes of an `Engine<cols>`, for choosing `COLS` at run time
/// (budgets, the `budget` command): equal to `Engine::<cols>::WORKING_BYTES`.
/// Per window column: the product rows (7 × 4 bytes), the sums' rings
/// (7 × 5 × 4), the rings of `E` (2 × 5 × 4) and `V` (2 × 4 × 4), the
/// vertical parts (2 × 4 + 4 × 2), the output pixel (40), and the rings of
/// `d` (6 × 2) and `p0` (8 × 1): 316 bytes.
pub const fn working_bytes(cols: usize) -> usize {
    use core::mem::{align_of, size_of};
    // repr(C): each field at the next multiple of its alignment, in order.
    const fn field(offset: usize, size: usize, align: usize) -> usize {
        offset.next_multiple_of(align) + size
    }
    let words = CHANNELS + CHANNELS * SUM_DEPTH + 2 * E_DEPTH + 2 * V_DEPTH + 2;
    let mut end = size_of::<Window>();
    end = field(end, words * 4 * cols, 4);
    end = field(end, size_of::<FlowPixel>() * cols, align_of::<FlowPixel>());
    end = field(end, (D_DEPTH + 4) * 2 * cols, 2);
    end = field(end, P0_DEPTH * cols, 1);
    end.next_multiple_of(align_of::<Window>())
}

impl<const COLS: usize> Default for Engine<COLS> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn working_bytes_formula_is_the_struct_size() {
        assert_eq!(working_bytes(15), Engine::<15>::WORKING_BYTES);
        assert_eq!(working_bytes(78), Engine::<78>::WORKING_BYTES);
        assert_eq!(working_bytes(94), Engine::<94>::WORKING_BYTES);
        assert_eq!(working_bytes(142), Engine::<142>::WORKING_BYTES);
        assert_eq!(working_bytes(655), Engine::<655>::WORKING_BYTES);
        for cols in 15..40 {
            assert!(working_bytes(cols) >= 316 * cols);
        }
        assert_eq!(working_bytes(17), Engine::<17>::WORKING_BYTES);
        assert_eq!(working_bytes(33), Engine::<33>::WORKING_BYTES);
    }
}
