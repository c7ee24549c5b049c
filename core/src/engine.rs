//! The bounded-memory engine: one tile at a time, rows streaming down
//! through a ring per stage, so working memory is `O(COLS)` and fixed at
//! compile time.
//!
//! A tile of `w × h` output pixels is computed from a window of
//! `n = w + 14` columns and `h + 14` rows of clamped input (SPEC §6). Pushing
//! window row `t` completes `E` of row `t−2`, `V` of `t−4`, the structure
//! products of `t−5` and the output of `t−7`, so an output row leaves as
//! soon as the input row 7 below it has arrived. Because each stage depends
//! only on its inputs, not on where the window starts, every tiling yields
//! the same bytes as one whole-frame window.

use fixed::types::{I16F16, U16F16};

use crate::ring::RowRing;
use crate::solve::{curl_free_q16, divergence_free_q16, magnitude_q16};
use crate::stages::{ResidualInputs, boundary_minus_domain, smooth, structure_row, structure_sums};
use crate::{Config, Error, FramePair, Plan, Tile};

/// Radius of input that one output pixel depends on (SPEC §6).
pub const HALO: usize = 7;

/// Everything the representation knows about one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FlowPixel {
    /// Curl-free field `v_c` (x, y), pixels, Q16.16 (saturating).
    pub v_c: [I16F16; 2],
    /// Divergence-free field `v_d` (x, y), pixels, Q16.16 (saturating).
    pub v_d: [I16F16; 2],
    /// `|v_c|`, floor of the norm of the Q16.16 components.
    pub m_c: U16F16,
    /// `|v_d|`, likewise.
    pub m_d: U16F16,
    /// The pixel of `fⁿ` (the representation's B channel).
    pub luma: u8,
}

impl FlowPixel {
    const ZERO: Self = Self {
        v_c: [I16F16::ZERO; 2],
        v_d: [I16F16::ZERO; 2],
        m_c: U16F16::ZERO,
        m_d: U16F16::ZERO,
        luma: 0,
    };
}

/// Where output goes: one call per output row of a tile, in top-to-bottom
/// order within the tile.
pub trait Sink {
    /// Pixels `[x, x + pixels.len())` of frame row `y`.
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]);
}

impl<S: Sink + ?Sized> Sink for &mut S {
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]) {
        (**self).row(y, x, pixels)
    }
}

/// Both sinks see every row.
impl<A: Sink, B: Sink> Sink for (A, B) {
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
/// columns wide: `304 · COLS` bytes and a few more ([`working_bytes`]).
pub struct Engine<const COLS: usize> {
    p0: RowRing<u8, COLS, 8>,
    d: RowRing<i16, COLS, 6>,
    e: RowRing<[i32; 2], COLS, 5>,
    v: RowRing<[i32; 2], COLS, 4>,
    sum3: RowRing<[i32; 3], COLS, 5>,
    sum2: RowRing<[i64; 2], COLS, 5>,
    vert_d: [[i16; 4]; COLS],
    vert_e: [[i32; 2]; COLS],
    prod3: [[i32; 3]; COLS],
    prod2: [[i64; 2]; COLS],
    out: [FlowPixel; COLS],
    window: Window,
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
            e: RowRing::new([0; 2]),
            v: RowRing::new([0; 2]),
            sum3: RowRing::new([0; 3]),
            sum2: RowRing::new([0; 2]),
            vert_d: [[0; 4]; COLS],
            vert_e: [[0; 2]; COLS],
            prod3: [[0; 3]; COLS],
            prod2: [[0; 2]; COLS],
            out: [FlowPixel::ZERO; COLS],
            window: Window {
                x_first: 0,
                n: 0,
                y_first: 0,
                t: 0,
            },
        }
    }

    /// Compute every tile of `plan` into `sink`. Fails only when the frames
    /// are not of the plan's size.
    pub fn run<S: Sink>(
        &mut self,
        plan: &Plan<COLS>,
        frames: &FramePair<'_>,
        sink: &mut S,
    ) -> Result<(), Error> {
        check_size(plan.config(), frames)?;
        for tile in plan.tiles() {
            self.tile(plan.config(), frames, tile, sink);
        }
        Ok(())
    }

    /// Compute tile `index` of `plan` (for callers that spread tiles over
    /// cores). Fails when the frames are not of the plan's size or the index
    /// is past the last tile.
    pub fn run_tile<S: Sink>(
        &mut self,
        plan: &Plan<COLS>,
        frames: &FramePair<'_>,
        index: usize,
        sink: &mut S,
    ) -> Result<(), Error> {
        check_size(plan.config(), frames)?;
        let tile = plan.tile(index).ok_or(Error::TileOutOfFrame)?;
        self.tile(plan.config(), frames, tile, sink);
        Ok(())
    }

    fn tile<S: Sink>(&mut self, config: &Config, frames: &FramePair<'_>, tile: Tile, sink: &mut S) {
        self.begin(Window {
            x_first: tile.x as isize - HALO as isize,
            n: tile.width + 2 * HALO,
            y_first: tile.y as isize - HALO as isize,
            t: 0,
        });
        for k in 0..tile.height + 2 * HALO {
            let y = tile.y as isize - HALO as isize + k as isize;
            self.push(
                config,
                frames.prev().clamped_row(y),
                frames.next().clamped_row(y),
                sink,
            );
        }
    }

    pub(crate) fn begin(&mut self, window: Window) {
        self.window = Window {
            n: window.n.min(COLS),
            t: 0,
            ..window
        };
    }

    /// Feed window row `t` (frame rows of `fⁿ` and `fⁿ⁺¹`, each the full
    /// frame width) and run every stage it completes.
    pub(crate) fn push<S: Sink>(
        &mut self,
        config: &Config,
        prev: &[u8],
        next: &[u8],
        sink: &mut S,
    ) {
        let Window { x_first, n, t, .. } = self.window;
        self.window.t += 1;

        // Input: the window's columns of both rows, clamped into the frame.
        let last = prev.len().min(next.len()).saturating_sub(1) as isize;
        let (p0, d) = (self.p0.row_mut(t), self.d.row_mut(t));
        for (i, (p, dd)) in p0.iter_mut().zip(d.iter_mut()).take(n).enumerate() {
            let x = (x_first + i as isize).clamp(0, last) as usize;
            let (a, b) = (
                prev.get(x).copied().unwrap_or(0),
                next.get(x).copied().unwrap_or(0),
            );
            *p = a;
            *dd = i16::from(b) - i16::from(a);
        }
        if t >= 4 {
            let rows = [t - 4, t - 3, t - 2, t - 1, t].map(|k| self.d.row(k));
            boundary_minus_domain(rows, &mut self.vert_d, self.e.row_mut(t - 2), n);
        }
        if t >= 8 {
            let rows = [t - 6, t - 5, t - 4, t - 3, t - 2].map(|k| self.e.row(k));
            smooth(rows, &mut self.vert_e, self.v.row_mut(t - 4), n);
        }
        if t >= 10 {
            let j = t - 5;
            let input = ResidualInputs {
                v: [j - 1, j, j + 1].map(|k| self.v.row(k)),
                p0: [j - 1, j, j + 1].map(|k| self.p0.row(k)),
                d: self.d.row(j),
                kappa: config.kappa,
            };
            let products = (&mut self.prod3, &mut self.prod2);
            structure_row(
                &input,
                products,
                (self.sum3.row_mut(j), self.sum2.row_mut(j)),
                n,
            );
        }
        if t >= 2 * HALO {
            self.emit(config, t - HALO, sink);
        }
    }

    /// Solve and hand over output row `o` (window rows; `o ≥ 7`).
    fn emit<S: Sink>(&mut self, config: &Config, o: usize, sink: &mut S) {
        let Window {
            x_first,
            n,
            y_first,
            ..
        } = self.window;
        let sum3 = [o - 2, o - 1, o, o + 1, o + 2].map(|k| self.sum3.row(k));
        let sum2 = [o - 2, o - 1, o, o + 1, o + 2].map(|k| self.sum2.row(k));
        let (v, luma) = (self.v.row(o), self.p0.row(o));
        let width = n.saturating_sub(2 * HALO);
        let cols = (HALO..HALO + width).zip(self.out.iter_mut());
        for (i, out) in cols {
            let v_d = divergence_free_q16(config, structure_sums(sum3, sum2, i));
            let v_c = v[i].map(|c| curl_free_q16(config, c));
            *out = FlowPixel {
                v_c: v_c.map(I16F16::from_bits),
                v_d: v_d.map(I16F16::from_bits),
                m_c: U16F16::from_bits(magnitude_q16(v_c)),
                m_d: U16F16::from_bits(magnitude_q16(v_d)),
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

/// Bytes per window column: rings of `p0` (8 rows × 1 B), `d` (6 × 2),
/// `E` (5 × 8), `V` (4 × 8), the sums (5 × 12 and 5 × 16), one row each of
/// the vertical parts (8 + 8) and products (12 + 16), and the output row (28).
const BYTES_PER_COLUMN: usize = 8 + 12 + 40 + 32 + 60 + 80 + 8 + 8 + 12 + 16 + 28;

/// Working bytes of an `Engine<cols>`, for choosing `COLS` at run time
/// (budgets, the `budget` command): equal to `Engine::<cols>::WORKING_BYTES`.
pub const fn working_bytes(cols: usize) -> usize {
    let align = core::mem::align_of::<Engine<16>>();
    (BYTES_PER_COLUMN * cols + core::mem::size_of::<Window>()).next_multiple_of(align)
}

impl<const COLS: usize> Default for Engine<COLS> {
    fn default() -> Self {
        Self::new()
    }
}

fn check_size(config: &Config, frames: &FramePair<'_>) -> Result<(), Error> {
    let size = (config.width(), config.height());
    let prev = (frames.prev().width(), frames.prev().height());
    let next = (frames.next().width(), frames.next().height());
    if prev != size || next != size {
        return Err(Error::SizeMismatch);
    }
    Ok(())
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
    }
}
