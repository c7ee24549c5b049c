//! The bounded-memory engine: one tile at a time, rows streaming down
//! through a ring per stage, so working memory is `O(window columns)`:
//! arrays fixed at compile time ([`Engine`]) or slices the caller sizes at
//! run time ([`SliceEngine`]). A tile wider than the memory's window runs
//! as several windows side by side.
//!
//! A tile of `w × h` output pixels is computed from a window of
//! `n = w + 14` columns and `h + 14` rows of clamped input (SPEC §6). Pushing
//! window row `t` completes `E` of row `t−2`, `V` of `t−4`, the structure
//! products of `t−5` and the output of `t−7` (the lags in `schedule.rs`),
//! so an output row leaves as soon as the input row 7 below it has arrived.
//! Because each stage depends only on its inputs, not on where the window
//! starts, every tiling yields the same bytes as one whole-frame window.

use crate::kernels::{KernelSet, Native, OutputRow, SumRings, WithKernels, from_first_output};
use crate::ring::{RowRing, take_rows};
use crate::schedule::{
    D_DEPTH, E_DEPTH, E_LAG, E_RADIUS, E_START, HALO, OUTPUT_LAG, OUTPUT_START, P0_DEPTH,
    PRODUCT_LAG, PRODUCT_RADIUS, PRODUCT_START, SUM_DEPTH, V_DEPTH, V_LAG, V_RADIUS, V_START,
};
use crate::stages::{
    FLOAT_CHANNELS, INT_CHANNELS, ResidualInputs, ScratchRows, StructureRows,
    boundary_minus_domain, smooth,
};
use crate::tail::{TailConstants, TailOut};
use crate::{Config, Error, ExtremesSink, Fields, Job, Pixels, Tile};

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
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>);

    /// Rows of the sink's own memory for the magnitudes `[|v_d|, |v_c|]`
    /// of pixels `[x, x + width)` of frame row `y`, each `width` long, or
    /// `None` (the default): the engine writes them into its own rows and
    /// hands them over in [`Sink::row`]. Asked only of sinks that do not
    /// read the fields. A sink that keeps every magnitude (per-frame
    /// min–max keeps the frame's before any byte) is spared a copy of each
    /// row; the engine then calls [`Sink::kept_row`], not [`Sink::row`].
    fn magnitude_rows(&mut self, y: usize, x: usize, width: usize) -> Option<[&mut [f32]; 2]> {
        let _ = (y, x, width);
        None
    }

    /// The magnitudes `|v_d|, |v_c|` of pixels `[x, x + luma.len())` of
    /// frame row `y` are in the rows [`Sink::magnitude_rows`] gave; `luma`
    /// is their `fⁿ`, and `extremes` the least and greatest value of each
    /// of the two rows, which SPEC §4's per-frame min–max reads over the
    /// frame: a sink that keeps them merges these
    /// ([`ExtremesSink::merge`]) instead of reading the rows again (the
    /// engine gives them for every row; some kernel sets find them as they
    /// write the rows).
    fn kept_row(&mut self, y: usize, x: usize, luma: &[u8], extremes: ExtremesSink) {
        let _ = (y, x, luma, extremes);
    }
}

impl<S: Sink + ?Sized> Sink for &mut S {
    #[inline(always)]
    fn reads_fields(&self) -> bool {
        (**self).reads_fields()
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        (**self).row(y, x, pixels)
    }

    #[inline(always)]
    fn magnitude_rows(&mut self, y: usize, x: usize, width: usize) -> Option<[&mut [f32]; 2]> {
        (**self).magnitude_rows(y, x, width)
    }

    #[inline(always)]
    fn kept_row(&mut self, y: usize, x: usize, luma: &[u8], extremes: ExtremesSink) {
        (**self).kept_row(y, x, luma, extremes)
    }
}

/// The sink that does nothing.
impl Sink for () {
    fn reads_fields(&self) -> bool {
        false
    }

    fn row(&mut self, _y: usize, _x: usize, _pixels: Pixels<'_>) {}
}

/// Both sinks see every row.
impl<A: Sink, B: Sink> Sink for (A, B) {
    #[inline(always)]
    fn reads_fields(&self) -> bool {
        self.0.reads_fields() || self.1.reads_fields()
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        self.0.row(y, x, pixels);
        self.1.row(y, x, pixels);
    }
}

/// Where the current window lies in the frame and how far it has been fed.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Window {
    /// Frame column of window column 0 (`tile.x − 7`).
    pub x_first: isize,
    /// Window columns (`tile.width + 14`), at most the memory's.
    pub n: usize,
    /// Frame row of window row 0 (`tile.y − 7`).
    pub y_first: isize,
    /// Window rows pushed so far.
    pub t: usize,
}

/// The rows a window of `cols` columns computes in, per [`Memory`] kind:
/// 32-bit integer words, `f32`s (the `f32` structure channels and the
/// output's magnitudes and fields), 16-bit halves and bytes.
const WORD_ROWS: usize = INT_CHANNELS + INT_CHANNELS * SUM_DEPTH + 2 * E_DEPTH + 2 * V_DEPTH + 2;
const FLOAT_ROWS: usize = FLOAT_CHANNELS + FLOAT_CHANNELS * SUM_DEPTH + MAGNITUDE_ROWS + FIELD_ROWS;
const HALF_ROWS: usize = D_DEPTH + 4;
const BYTE_ROWS: usize = P0_DEPTH;
const MAGNITUDE_ROWS: usize = 2;
const FIELD_ROWS: usize = 4;

/// Where an engine's working memory lives: arrays of a compile-time width
/// ([`Arrays`], for firmware and statics) or slices the caller owns, of a
/// width chosen at run time ([`Slices`], for hosts). Sealed: the engine
/// carves the memory into its rows itself.
pub trait Memory: memory::Carve {}

mod memory {
    /// The memory as four planes, one per element type.
    pub struct Planes<'a> {
        pub words: &'a mut [i32],
        pub floats: &'a mut [f32],
        pub halves: &'a mut [i16],
        pub bytes: &'a mut [u8],
    }

    /// The memory as planes, and the window columns it holds.
    pub trait Carve {
        fn cols(&self) -> usize;
        fn planes(&mut self) -> Planes<'_>;
    }
}

/// Working memory for windows of up to `COLS` columns, as arrays:
/// `252 · COLS` bytes and a few more ([`working_bytes`]). `repr(C)`, widest
/// fields first, so [`working_bytes`] can follow the layout.
#[repr(C)]
pub struct Arrays<const COLS: usize> {
    words: [[i32; COLS]; WORD_ROWS],
    floats: [[f32; COLS]; FLOAT_ROWS],
    halves: [[i16; COLS]; HALF_ROWS],
    bytes: [[u8; COLS]; BYTE_ROWS],
}

impl<const COLS: usize> Memory for Arrays<COLS> {}

impl<const COLS: usize> memory::Carve for Arrays<COLS> {
    #[inline(always)]
    fn cols(&self) -> usize {
        COLS
    }

    #[inline(always)]
    fn planes(&mut self) -> memory::Planes<'_> {
        memory::Planes {
            words: self.words.as_flattened_mut(),
            floats: self.floats.as_flattened_mut(),
            halves: self.halves.as_flattened_mut(),
            bytes: self.bytes.as_flattened_mut(),
        }
    }
}

/// Working memory the caller owns, for windows of a width chosen at run
/// time (a host's tile as wide as the frame): four slices, each at least
/// its [`MemorySize`] for the window.
pub struct Slices<'m> {
    cols: usize,
    words: &'m mut [i32],
    floats: &'m mut [f32],
    halves: &'m mut [i16],
    bytes: &'m mut [u8],
}

impl Memory for Slices<'_> {}

impl memory::Carve for Slices<'_> {
    #[inline(always)]
    fn cols(&self) -> usize {
        self.cols
    }

    #[inline(always)]
    fn planes(&mut self) -> memory::Planes<'_> {
        memory::Planes {
            words: &mut *self.words,
            floats: &mut *self.floats,
            halves: &mut *self.halves,
            bytes: &mut *self.bytes,
        }
    }
}

/// Elements of each slice a [`SliceEngine`] needs for tiles up to a width.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemorySize {
    /// `i32`s.
    pub words: usize,
    /// `f32`s.
    pub floats: usize,
    /// `i16`s.
    pub halves: usize,
    /// `u8`s.
    pub bytes: usize,
}

impl MemorySize {
    /// For tiles up to `tile_width` columns (windows of `tile_width + 14`);
    /// `None` if the sizes overflow `usize`.
    pub const fn for_tile_width(tile_width: usize) -> Option<Self> {
        let Some(cols) = tile_width.checked_add(2 * HALO) else {
            return None;
        };
        match cols.checked_mul(WORD_ROWS) {
            Some(words) => Some(Self {
                words,
                floats: cols * FLOAT_ROWS,
                halves: cols * HALF_ROWS,
                bytes: cols * BYTE_ROWS,
            }),
            None => None,
        }
    }
}

/// The engine: a tile at a time, rows streaming down through a ring per
/// stage, in the working memory `M`. [`Engine`] keeps it in arrays of a
/// compile-time width, [`SliceEngine`] in slices the caller owns.
#[repr(C)]
pub struct TileEngine<M> {
    window: Window,
    memory: M,
}

/// An engine whose working memory is arrays for windows of `COLS` columns
/// (tiles up to `COLS − 14` wide): its size is known at compile time, so it
/// can live in a `static` or on a firmware's stack.
pub type Engine<const COLS: usize> = TileEngine<Arrays<COLS>>;

/// An engine in memory the caller owns, of a width chosen at run time.
pub type SliceEngine<'m> = TileEngine<Slices<'m>>;

impl<const COLS: usize> Engine<COLS> {
    /// The widest tile this engine computes in one window.
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
            window: Window {
                x_first: 0,
                n: 0,
                y_first: 0,
                t: 0,
            },
            memory: Arrays {
                words: [[0; COLS]; WORD_ROWS],
                floats: [[0.0; COLS]; FLOAT_ROWS],
                halves: [[0; COLS]; HALF_ROWS],
                bytes: [[0; COLS]; BYTE_ROWS],
            },
        }
    }
}

impl<const COLS: usize> Default for Engine<COLS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'m> SliceEngine<'m> {
    /// An engine in the caller's slices (each at least its
    /// [`MemorySize`]; longer is fine): tiles up to the widest window all
    /// four hold, minus the 14-column halo. Fails with
    /// [`Error::BufferTooShort`] (in `i32`s) when they hold no window wider
    /// than the halo.
    pub fn new(
        words: &'m mut [i32],
        floats: &'m mut [f32],
        halves: &'m mut [i16],
        bytes: &'m mut [u8],
    ) -> Result<Self, Error> {
        let cols = (words.len() / WORD_ROWS)
            .min(floats.len() / FLOAT_ROWS)
            .min(halves.len() / HALF_ROWS)
            .min(bytes.len() / BYTE_ROWS);
        if cols <= 2 * HALO {
            return Err(Error::BufferTooShort {
                needed: (2 * HALO + 1) * WORD_ROWS,
                got: cols * WORD_ROWS,
            });
        }
        Ok(Self {
            window: Window::default(),
            memory: Slices {
                cols,
                words,
                floats,
                halves,
                bytes,
            },
        })
    }
}

/// The engine's rows, carved from its memory for one window width, for
/// the kernel set `K` (which lays out the structure sums).
struct Rows<'m, K: KernelSet> {
    int_products: [&'m mut [i32]; INT_CHANNELS],
    sums: K::Sums<'m>,
    e: [RowRing<'m, i32, E_DEPTH>; 2],
    v: [RowRing<'m, i32, V_DEPTH>; 2],
    /// `E` before its horizontal smoothing (the ring keeps it smoothed).
    e_scratch: [&'m mut [i32]; 2],
    float_products: [&'m mut [f32]; FLOAT_CHANNELS],
    /// The output's `[|v_d|, |v_c|]`.
    magnitudes: [&'m mut [f32]; MAGNITUDE_ROWS],
    /// The output's `[v_c x, v_c y, v_d x, v_d y]`.
    fields: [&'m mut [f32]; FIELD_ROWS],
    d: RowRing<'m, i16, D_DEPTH>,
    vert_d: [&'m mut [i16]; 4],
    p0: RowRing<'m, u8, P0_DEPTH>,
}

impl<'m, K: KernelSet> Rows<'m, K> {
    /// Rows of `cols` elements, in the order [`WORD_ROWS`] and its
    /// neighbours count them.
    #[inline(always)]
    fn carve(planes: memory::Planes<'m>, cols: usize, kernels: K) -> Self {
        let memory::Planes {
            mut words,
            mut floats,
            mut halves,
            mut bytes,
        } = planes;
        let words = &mut words;
        let floats = &mut floats;
        let halves = &mut halves;
        // Fields in carving order: each kind of memory in the order of
        // `WORD_ROWS` and its neighbours.
        Self {
            int_products: take_rows(words, cols),
            float_products: take_rows(floats, cols),
            sums: K::Sums::carve(kernels, words, floats, cols),
            e: core::array::from_fn(|_| RowRing::carve(words, cols)),
            v: core::array::from_fn(|_| RowRing::carve(words, cols)),
            e_scratch: take_rows(words, cols),
            magnitudes: take_rows(floats, cols),
            fields: take_rows(floats, cols),
            d: RowRing::carve(halves, cols),
            vert_d: take_rows(halves, cols),
            p0: RowRing::carve(&mut bytes, cols),
        }
    }
}

/// One tile of a job, to run with the kernel set the job chose.
struct TileWork<'e, 'j, M, S> {
    engine: &'e mut TileEngine<M>,
    job: &'e Job<'j>,
    tile: Tile,
    sink: &'e mut S,
}

impl<M: Memory, S: Sink> WithKernels for TileWork<'_, '_, M, S> {
    #[inline(always)]
    fn run<K: KernelSet>(self, kernels: K) {
        self.engine
            .tile_with(kernels, self.job, self.tile, self.sink);
    }
}

impl<M: Memory> TileEngine<M> {
    /// The widest tile this engine computes in one window (wider tiles of a
    /// plan run as several windows: same bytes, more halo).
    pub fn max_tile_width(&self) -> usize {
        self.memory.cols().saturating_sub(2 * HALO)
    }

    /// Compute every tile of the job into `sink`.
    #[inline(always)]
    pub fn run<S: Sink>(&mut self, job: &Job<'_>, sink: &mut S) {
        for tile in job.plan().tiles() {
            self.tile(job, tile, sink);
        }
    }

    /// Compute tile `index` of the job (for callers that spread tiles over
    /// cores): the tile computed, or `None` (and nothing done) past the
    /// last tile.
    #[inline(always)]
    pub fn run_tile<S: Sink>(&mut self, job: &Job<'_>, index: usize, sink: &mut S) -> Option<Tile> {
        let tile = job.plan().tile(index)?;
        self.tile(job, tile, sink);
        Some(tile)
    }

    /// Tile `tile` with the kernel set the job chose.
    #[inline(always)]
    fn tile<S: Sink>(&mut self, job: &Job<'_>, tile: Tile, sink: &mut S) {
        let work = TileWork {
            engine: self,
            job,
            tile,
            sink,
        };
        job.kernels().run(work);
    }

    /// Tile `tile` as windows of at most [`max_tile_width`](Self::max_tile_width)
    /// columns plus the halo, left to right.
    #[inline(always)]
    fn tile_with<K: KernelSet, S: Sink>(
        &mut self,
        kernels: K,
        job: &Job<'_>,
        tile: Tile,
        sink: &mut S,
    ) {
        let (config, frames) = (job.config(), job.frames());
        let step = self.max_tile_width().max(1);
        let y_first = tile.y as isize - HALO as isize;
        for x in (tile.x..tile.x + tile.width).step_by(step) {
            self.begin(Window {
                x_first: x as isize - HALO as isize,
                n: step.min(tile.x + tile.width - x) + 2 * HALO,
                y_first,
                t: 0,
            });
            // The rows are carved once per window, not once per row: with
            // memory of run-time width (`Slices`) carving is real work.
            let mut pass = self.pass(kernels);
            for y in y_first..y_first + (tile.height + 2 * HALO) as isize {
                let (prev, next) = (frames.prev().clamped_row(y), frames.next().clamped_row(y));
                pass.push(config, prev, next, sink);
            }
        }
    }

    /// Start a window (at most the memory's columns wide).
    #[inline(always)]
    pub(crate) fn begin(&mut self, window: Window) {
        let cols = self.memory.cols();
        debug_assert!(
            window.n <= cols,
            "a window of {} columns in {cols}",
            window.n
        );
        self.window = Window {
            n: window.n.min(cols),
            t: 0,
            ..window
        };
    }

    /// Feed the window's next row (see [`Pass::push`]).
    #[inline(always)]
    pub(crate) fn push<S: Sink>(
        &mut self,
        config: &Config,
        prev: &[u8],
        next: &[u8],
        sink: &mut S,
    ) {
        self.pass(Native::default()).push(config, prev, next, sink);
    }

    /// The current window with the rows it computes in.
    #[inline(always)]
    fn pass<K: KernelSet>(&mut self, kernels: K) -> Pass<'_, K> {
        let cols = self.memory.cols();
        Pass {
            window: &mut self.window,
            rows: Rows::carve(self.memory.planes(), cols, kernels),
        }
    }
}

/// One window in progress: where it lies, and its rows.
struct Pass<'m, K: KernelSet> {
    window: &'m mut Window,
    rows: Rows<'m, K>,
}

impl<K: KernelSet> Pass<'_, K> {
    /// Feed window row `t` (frame rows of `fⁿ` and `fⁿ⁺¹`, each the full
    /// frame width) and run every stage it completes.
    #[inline(always)]
    fn push<S: Sink>(&mut self, config: &Config, prev: &[u8], next: &[u8], sink: &mut S) {
        let Window { x_first, n, t, .. } = *self.window;
        self.window.t += 1;
        let rows = &mut self.rows;
        load_row::<K>(
            prev,
            next,
            x_first,
            n,
            rows.p0.row_mut(t),
            rows.d.row_mut(t),
        );
        if t >= E_START {
            let [ex, ey] = &mut rows.e;
            let [scratch_x, scratch_y] = &mut rows.e_scratch;
            boundary_minus_domain::<K>(
                rows.d.rows(t - 2 * E_RADIUS),
                &mut rows.vert_d,
                (scratch_x, scratch_y),
                (ex.row_mut(t - E_LAG), ey.row_mut(t - E_LAG)),
                n,
            );
        }
        if t >= V_START {
            let first = t - V_LAG - V_RADIUS;
            let e = [rows.e[0].rows(first), rows.e[1].rows(first)];
            let [vx, vy] = &mut rows.v;
            smooth::<K>(e, (vx.row_mut(t - V_LAG), vy.row_mut(t - V_LAG)), n);
        }
        if t >= PRODUCT_START {
            let j = t - PRODUCT_LAG;
            let input = ResidualInputs {
                vx: rows.v[0].row(j),
                vy: rows.v[1].rows(j - PRODUCT_RADIUS),
                p0: rows.p0.rows(j - PRODUCT_RADIUS),
                d: rows.d.row(j),
                kappa: config.kappa_split(),
                shift: config.dn_shift,
            };
            let structure = StructureRows {
                int_products: &mut rows.int_products,
                float_products: &mut rows.float_products,
                // Free once `E` of this push is in its ring.
                scratch: {
                    let [gx, gy, ..] = &mut rows.vert_d;
                    let [high, low] = &mut rows.e_scratch;
                    ScratchRows { gx, gy, high, low }
                },
            };
            rows.sums.push_structure(j, &input, structure, n);
        }
        if t >= OUTPUT_START {
            self.emit(config, t - OUTPUT_LAG, sink);
        }
    }

    /// Solve and hand over output row `o` (window rows; `o ≥ 7`).
    #[inline(always)]
    fn emit<S: Sink>(&mut self, config: &Config, o: usize, sink: &mut S) {
        let Window {
            x_first,
            n,
            y_first,
            ..
        } = *self.window;
        let rows = &mut self.rows;
        let reads_fields = sink.reads_fields();
        let width = n.saturating_sub(2 * HALO);
        let constants = TailConstants {
            lambda4: config.lambda4,
            units: config.units(),
        };
        let row = OutputRow {
            o,
            n,
            products: (&mut rows.int_products, &mut rows.float_products),
            v: [rows.v[0].row(o), rows.v[1].row(o)],
            constants: &constants,
        };
        // The row's place in the frame, worked out where each call needs it:
        // held across the tail, it cost the Cortex-M4F's registers (445 → 451
        // per pixel at 320×240, `scripts/embedded-check`; its kernels:
        // `kernels/m4.rs`).
        let at = || {
            (
                (y_first + o as isize) as usize,
                (x_first + HALO as isize) as usize,
            )
        };
        if !reads_fields {
            let (y, x) = at();
            if let Some([m_d, m_c]) = sink.magnitude_rows(y, x, width) {
                let out = TailOut {
                    m: [&mut *m_d, &mut *m_c],
                    fields: None,
                    extremes: true,
                };
                let found = rows.sums.tail_row(row, out);
                let extremes = found.unwrap_or_else(|| ExtremesSink::of_rows(m_d, m_c));
                let luma = first(from_first_output(rows.p0.row(o)), width);
                sink.kept_row(y, x, luma, extremes);
                return;
            }
        }
        let [v_c_x, v_c_y, v_d_x, v_d_y] = rows.fields.each_mut().map(|row| first_mut(row, width));
        let out = TailOut {
            m: rows.magnitudes.each_mut().map(|row| first_mut(row, width)),
            fields: reads_fields.then_some([v_c_x, v_c_y, v_d_x, v_d_y]),
            extremes: false,
        };
        rows.sums.tail_row(row, out);
        let [m_d, m_c] = rows.magnitudes.each_ref().map(|row| first(row, width));
        let [v_c_x, v_c_y, v_d_x, v_d_y] = rows.fields.each_ref().map(|row| first(row, width));
        let pixels = Pixels {
            m_d,
            m_c,
            luma: first(from_first_output(rows.p0.row(o)), width),
            fields: reads_fields.then_some(Fields {
                v_c: [v_c_x, v_c_y],
                v_d: [v_d_x, v_d_y],
            }),
        };
        let (y, x) = at();
        sink.row(y, x, pixels);
    }
}

/// The first `width` values of a row (all the engine's rows are a
/// window wide, so never fewer). Split within clamped bounds, so the
/// result always points into the row (see `RowRing::row`).
#[inline(always)]
fn first<T>(row: &[T], width: usize) -> &[T] {
    row.split_at(width.min(row.len())).0
}

/// [`first`], to write.
#[inline(always)]
fn first_mut<T>(row: &mut [T], width: usize) -> &mut [T] {
    let width = width.min(row.len());
    row.split_at_mut(width).0
}

/// Window columns `[x_first, x_first + n)` of both rows, clamped into the
/// frame (SPEC §2), as `p0` and `d = p1 − p0`.
#[inline(always)]
fn load_row<K: KernelSet>(
    prev: &[u8],
    next: &[u8],
    x_first: isize,
    n: usize,
    p0: &mut [u8],
    d: &mut [i16],
) {
    let width = prev.len().min(next.len());
    let (Some(&first), Some(&last)) = (prev.first(), prev.get(width.wrapping_sub(1))) else {
        return;
    };
    let (first_next, last_next) = (
        next.first().copied().unwrap_or(0),
        next.get(width - 1).copied().unwrap_or(0),
    );
    let n = n.min(p0.len()).min(d.len());
    // Columns left of the frame, inside it, and right of it.
    let left = (-x_first).min(n as isize).max(0) as usize;
    let start = x_first.max(0) as usize;
    let inside = width.saturating_sub(start).min(n - left);
    let (Some((p_left, p_rest)), Some((d_left, d_rest))) =
        (p0.split_at_mut_checked(left), d.split_at_mut_checked(left))
    else {
        return; // left ≤ n ≤ both lengths: never taken
    };
    p_left.fill(first);
    d_left.fill(i16::from(first_next) - i16::from(first));
    let (src_p, src_n) = (
        prev.get(start..start + inside).unwrap_or(&[]),
        next.get(start..start + inside).unwrap_or(&[]),
    );
    K::load_pixels([src_p, src_n], p_rest, d_rest);
    let right = left + inside..n;
    if let (Some(p), Some(dd)) = (p0.get_mut(right.clone()), d.get_mut(right)) {
        p.fill(last);
        dd.fill(i16::from(last_next) - i16::from(last));
    }
}

/// Working bytes of an `Engine<cols>`, for choosing `COLS` at run time
/// (budgets, the `budget` command): equal to `Engine::<cols>::WORKING_BYTES`.
/// Per window column: the product rows (5 × 4 bytes), the sums' rings
/// (5 × 5 × 4), the rings of `E` (2 × 5 × 4) and `V` (2 × 4 × 4), the
/// vertical parts (2 × 4 + 4 × 2), the output's magnitudes (2 × 4) and
/// fields (4 × 4), and the rings of `d` (6 × 2) and `p0` (8 × 1): 252
/// bytes.
pub const fn working_bytes(cols: usize) -> usize {
    use core::mem::{align_of, size_of};
    // repr(C): each field at the next multiple of its alignment, in order.
    const fn field(offset: usize, size: usize, align: usize) -> usize {
        offset.next_multiple_of(align) + size
    }
    // The window, then the arrays.
    let mut end = size_of::<Window>();
    end = field(end, WORD_ROWS * 4 * cols, 4);
    end = field(end, FLOAT_ROWS * 4 * cols, 4);
    end = field(end, HALF_ROWS * 2 * cols, 2);
    end = field(end, BYTE_ROWS * cols, 1);
    end.next_multiple_of(align_of::<Window>())
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
            assert!(working_bytes(cols) >= 252 * cols);
        }
        assert_eq!(working_bytes(17), Engine::<17>::WORKING_BYTES);
        assert_eq!(working_bytes(33), Engine::<33>::WORKING_BYTES);
    }
}
