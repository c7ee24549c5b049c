//! The host's one whole-frame path through the fixed-point core: what
//! `run`, `dataset`, `pair`, the GStreamer element, the Python package, the
//! evaluation and the golden and conformance tests all compute with. One
//! engine pass per pair whatever the scaling; per-frame min–max keeps what
//! the byte step needs (each pixel's magnitudes, or every pixel when the
//! fields are wanted) instead of running the engine twice.
//!
//! Two outputs of the same pass: [`FrameEngine::represent`], the RGB bytes
//! alone (what `run` writes when no output needs the fields), and
//! [`FrameEngine::compute`], every plane ([`FixedOutput`]). The tiles of
//! one pair can also be spread over threads ([`pixels_on`], the element's
//! latency path); every tiling gives the same bytes.

use std::sync::Mutex;

use reynoldsflow_core::{
    ByteScale, Config, ExtremesSink, FlowPixel, FramePair, MemorySize, Params, Pixels, Plan,
    Scaling, Sink, SliceEngine, rgb, rgb_batch,
};

use crate::dispatch::{self, Isa, Pass};
use crate::page_buffer::{ByteBuffer, PageBuffer};
use crate::{Flow, FlowPlanes, Gray, HostError, workers};

/// The widest of the host's default tiles: full-height strips of at most
/// 1 280 columns (windows of 1 294, 409 KiB of working memory, inside a
/// core's L2 cache on current x86-64 and Arm server cores).
pub const MAX_STRIP_WIDTH: usize = 1280;

/// The host's default tile width for a frame `width` wide: the fewest
/// full-height strips of at most [`MAX_STRIP_WIDTH`] columns, of equal
/// width (one strip up to 1 280 columns). Every row loop then runs the
/// strip's whole width, and the halo's 14 columns are paid once per strip:
/// `reynoldsflow run` (640×480, one thread) counted 286 M instructions
/// for 4 pairs in 128-column strips, 231 M in one strip, and ran in 0.79
/// of the time; at 1280×720, 0.75 (`farm-bench`, side by side). Any other
/// tile width up to the frame's runs too, in an engine grown to it; every
/// tiling gives the same bytes.
pub fn strip_width(width: usize) -> usize {
    let strips = width.div_ceil(MAX_STRIP_WIDTH).max(1);
    width.div_ceil(strips).max(1)
}

/// The host's engine memory: vectors grown to the widest tile asked for,
/// kept pair after pair, lent to the core as a [`SliceEngine`]. The one
/// place the host's engine is named (benches, tests and the element use it).
#[derive(Default)]
pub struct HostEngine {
    words: Vec<i32>,
    floats: Vec<f32>,
    halves: Vec<i16>,
    bytes: Vec<u8>,
}

impl HostEngine {
    /// Empty memory: the first engine asked for sizes it.
    pub fn new() -> Self {
        Self::default()
    }

    /// A core engine in this memory for every tile of `plan` in one window
    /// (the memory grows to the plan's tile width first).
    pub fn engine(&mut self, plan: &Plan) -> Result<SliceEngine<'_>, HostError> {
        let size = MemorySize::for_tile_width(plan.tile_width())
            .ok_or(HostError::Core(reynoldsflow_core::Error::FrameTooLarge))?;
        grow(&mut self.words, size.words, 0);
        grow(&mut self.floats, size.floats, 0.0);
        grow(&mut self.halves, size.halves, 0);
        grow(&mut self.bytes, size.bytes, 0);
        Ok(SliceEngine::new(
            &mut self.words,
            &mut self.floats,
            &mut self.halves,
            &mut self.bytes,
        )?)
    }
}

/// `buffer` at least `len` long (never shrunk: the engine reuses it).
fn grow<T: Clone>(buffer: &mut Vec<T>, len: usize, zero: T) {
    if buffer.len() < len {
        buffer.resize(len, zero);
    }
}

/// The core's output for a frame pair, row-major planes of `width · height`.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedOutput {
    /// `v_c` and `v_d`, the exact values of the core's `f32`s.
    pub planes: FlowPlanes,
    /// `|v_d|` as the core computes it (the exact value of its `f32`).
    pub m_d: Vec<f64>,
    /// `|v_c|`.
    pub m_c: Vec<f64>,
    /// The RGB8 representation, `3 · width · height` bytes.
    pub rep: Vec<u8>,
}

/// Checked geometry of one pair: configuration, tiling and the frames.
pub fn prepare<'a>(
    prev: &'a Gray,
    next: &'a Gray,
    params: Params,
    tile: Option<(usize, usize)>,
) -> Result<(Plan, FramePair<'a>), HostError> {
    if prev.size() != next.size() {
        return Err(HostError::SizeMismatch {
            prev: prev.size(),
            next: next.size(),
        });
    }
    let (width, height) = prev.size();
    let config = Config::new(width, height, params)?;
    let plan = match tile {
        None => Plan::strips(config, strip_width(width))?,
        Some((tw, th)) => Plan::new(config, tw, th)?,
    };
    let frames = FramePair::packed(&config, &prev.pixels, &next.pixels)?;
    Ok((plan, frames))
}

/// One tile's (or the whole frame's) segments of a frame-sized plane of
/// pixels, and the extremes of the magnitudes it received: the sink that
/// keeps every pixel. Row `k` of `rows` is frame row `origin.1 + k` from
/// column `origin.0` on.
struct PixelRows<'a> {
    rows: Vec<&'a mut [FlowPixel]>,
    origin: (usize, usize),
    extremes: ExtremesSink,
}

impl<'a> PixelRows<'a> {
    /// The whole of `pixels`, a `width`-wide plane.
    fn whole(pixels: &'a mut [FlowPixel], width: usize) -> Self {
        Self {
            rows: pixels.chunks_mut(width.max(1)).collect(),
            origin: (0, 0),
            extremes: ExtremesSink::default(),
        }
    }
}

impl Sink for PixelRows<'_> {
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let (x0, y0) = self.origin;
        let start = x.saturating_sub(x0);
        if let Some(dst) = self
            .rows
            .get_mut(y.saturating_sub(y0))
            .and_then(|row| row.get_mut(start..start + pixels.len()))
        {
            for (dst, px) in dst.iter_mut().zip(pixels.iter()) {
                *dst = px;
            }
        }
        self.extremes.row(y, x, pixels);
    }
}

/// Every pixel of `frames` into `pixels` (resized to the frame), each tile
/// of `plan` once, spread over `threads` threads with an engine each;
/// returns the extremes of the magnitudes.
pub fn pixels_on(
    threads: usize,
    plan: &Plan,
    frames: &FramePair<'_>,
    pixels: &mut Vec<FlowPixel>,
) -> Result<ExtremesSink, HostError> {
    let (width, height) = (frames.prev().width(), frames.prev().height());
    pixels.clear();
    pixels.resize(width * height, FlowPixel::default());
    let (tile_width, tile_height) = (plan.tile_width(), plan.tile_height());
    // Each tile owns its segments of the rows it covers.
    let mut tiles: Vec<PixelRows<'_>> = plan
        .tiles()
        .map(|tile| PixelRows {
            rows: Vec::with_capacity(tile.height),
            origin: (tile.x, tile.y),
            extremes: ExtremesSink::default(),
        })
        .collect();
    for (y, row) in pixels.chunks_mut(width).enumerate() {
        let first = (y / tile_height) * plan.tiles_across();
        let segments = row.chunks_mut(tile_width);
        for (tile, segment) in tiles[first..].iter_mut().zip(segments) {
            tile.rows.push(segment);
        }
    }
    // One lock per tile, taken once: it hands the tile's rows to its thread.
    let tiles: Vec<Mutex<PixelRows<'_>>> = tiles.into_iter().map(Mutex::new).collect();
    let results = workers::map_indices(threads, tiles.len(), HostEngine::new, |engine, index| {
        let mut tile = tiles[index].lock().expect("each tile is taken once");
        let pass = Pass::Tile(index);
        let engine = &mut engine.engine(plan)?;
        dispatch::run(Isa::Best, engine, plan, frames, pass, &mut *tile)?;
        Ok::<_, HostError>(tile.extremes)
    });
    let mut extremes = ExtremesSink::default();
    for tile in results {
        extremes.merge(tile?);
    }
    Ok(extremes)
}

/// One `f64` plane of a field of the core's pixels; exact (`f32` to `f64`).
fn plane_of(pixels: &[FlowPixel], f: fn(&FlowPixel) -> f32) -> Vec<f64> {
    pixels.iter().map(|p| f64::from(f(p))).collect()
}

/// The fields `v_c`, `v_d` of the core's pixels of a `width × height` frame.
pub fn planes_of(width: usize, height: usize, pixels: &[FlowPixel]) -> FlowPlanes {
    let field = |x, y| Flow::from_parts(width, height, plane_of(pixels, x), plane_of(pixels, y));
    FlowPlanes {
        v_c: field(|p| p.v_c[0], |p| p.v_c[1]),
        v_d: field(|p| p.v_d[0], |p| p.v_d[1]),
    }
}

/// The planes of a [`FixedOutput`] from the core's pixels.
fn output(width: usize, height: usize, pixels: &[FlowPixel], rep: Vec<u8>) -> FixedOutput {
    FixedOutput {
        planes: planes_of(width, height, pixels),
        m_d: plane_of(pixels, |p| p.m_d),
        m_c: plane_of(pixels, |p| p.m_c),
        rep,
    }
}

/// The RGB bytes of every pixel of a `width`-wide frame, in `scaling` once
/// the frame's `extremes` are known; bands of rows spread over `threads`
/// threads.
pub fn rgb_of(
    pixels: &[FlowPixel],
    width: usize,
    extremes: ExtremesSink,
    scaling: Scaling,
    threads: usize,
) -> Vec<u8> {
    let (scale_d, scale_c) = scaling
        .byte_scales(|| Ok::<_, std::convert::Infallible>(extremes))
        .unwrap_or_else(|never| match never {});
    let bytes = |band: &[FlowPixel]| -> Vec<u8> {
        band.iter()
            .flat_map(|p| rgb(p, &scale_d, &scale_c))
            .collect()
    };
    let threads = threads.max(1);
    if threads == 1 {
        return bytes(pixels);
    }
    let rows = pixels.len().div_ceil(width.max(1));
    let band = width.max(1) * rows.div_ceil(threads);
    let bands: Vec<&[FlowPixel]> = pixels.chunks(band.max(1)).collect();
    workers::map_indices(threads, bands.len(), || (), |(), i| bytes(bands[i])).concat()
}

/// Run the core on `(prev, next)` with `params`, in full-height strips
/// [`strip_width`] wide, or in `tile = (width, height)` tiles when given,
/// the widest instructions the CPU has: [`FrameEngine::compute`] on a fresh
/// engine. Fails when the frames differ in size, or the core refuses the
/// size, the parameters or the tile (empty).
pub fn compute_fixed(
    prev: &Gray,
    next: &Gray,
    params: Params,
    tile: Option<(usize, usize)>,
    scaling: Scaling,
) -> Result<FixedOutput, HostError> {
    compute_fixed_on(Isa::Best, prev, next, params, tile, scaling)
}

/// [`compute_fixed`] with the engine pass compiled for `isa`: every `isa`
/// gives the same output, bit for bit.
pub fn compute_fixed_on(
    isa: Isa,
    prev: &Gray,
    next: &Gray,
    params: Params,
    tile: Option<(usize, usize)>,
    scaling: Scaling,
) -> Result<FixedOutput, HostError> {
    FrameEngine::on(isa).compute(prev, next, params, tile, scaling)
}

/// The host's whole-frame engine, reused pair after pair (one per worker):
/// the engine and the magnitudes kept for per-frame min–max live as long as
/// this value, so the RGB path allocates nothing once its buffers have
/// grown to the frame size.
pub struct FrameEngine {
    engine: HostEngine,
    /// Which compilation of the engine pass runs.
    isa: Isa,
    /// `|v_d|` and `|v_c|` of every pixel of the last pair (per-frame
    /// min–max of [`Self::represent`] only): all that the byte step needs
    /// besides `fⁿ`.
    kept: Kept,
}

impl Default for FrameEngine {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameEngine {
    /// An engine with empty buffers, the widest instructions the CPU has.
    pub fn new() -> Self {
        Self::on(Isa::Best)
    }

    /// An engine whose pass is compiled for `isa` (every `isa` gives the
    /// same bytes).
    pub fn on(isa: Isa) -> Self {
        Self {
            engine: HostEngine::new(),
            isa,
            kept: Kept::default(),
        }
    }

    /// Every plane of `(prev, next)`: fields, magnitudes and the
    /// representation, in one engine pass. Fails as [`compute_fixed`] does.
    pub fn compute(
        &mut self,
        prev: &Gray,
        next: &Gray,
        params: Params,
        tile: Option<(usize, usize)>,
        scaling: Scaling,
    ) -> Result<FixedOutput, HostError> {
        let (plan, frames) = prepare(prev, next, params, tile)?;
        let (width, height) = prev.size();
        let mut pixels = vec![FlowPixel::default(); width * height];
        let mut sink = PixelRows::whole(&mut pixels, width);
        let engine = &mut self.engine.engine(&plan)?;
        dispatch::run(self.isa, engine, &plan, &frames, Pass::All, &mut sink)?;
        let extremes = sink.extremes;
        let rep = rgb_of(&pixels, width, extremes, scaling, 1);
        Ok(output(width, height, &pixels, rep))
    }

    /// The representation of `(prev, next)` alone into `rgb` (resized to
    /// `3 · width · height`), in one engine pass whatever the scaling:
    /// `Fixed` gains stream the engine's rows straight into the bytes;
    /// per-frame min–max keeps each pixel's two magnitudes and the frame's
    /// extremes, then maps them to bytes. The bytes of [`Self::compute`]'s
    /// `rep`; fails as [`compute_fixed`] does.
    pub fn represent(
        &mut self,
        prev: &Gray,
        next: &Gray,
        params: Params,
        tile: Option<(usize, usize)>,
        scaling: Scaling,
        rgb: &mut impl ByteBuffer,
    ) -> Result<(), HostError> {
        let (plan, frames) = prepare(prev, next, params, tile)?;
        let (width, height) = prev.size();
        let engine = &mut self.engine.engine(&plan)?;
        // Every byte is overwritten below; a reused buffer of the same size
        // costs nothing. Min–max asks for it only once the pass is done.
        let bytes = 3 * width * height;
        if !matches!(scaling, Scaling::PerFrameMinMax) {
            // Known gains: the core's `represent` streams rows into the bytes in one pass.
            let pass = Pass::Represent(scaling, rgb.overwrite(bytes)?);
            return Ok(dispatch::run(
                self.isa,
                engine,
                &plan,
                &frames,
                pass,
                &mut (),
            )?);
        }
        let mut sink = KeptMagnitudes::new(width, self.kept.planes(width * height)?);
        dispatch::run(self.isa, engine, &plan, &frames, Pass::All, &mut sink)?;
        sink.into_bytes(self.isa, &prev.pixels, rgb)
    }

    /// The engine memory, the compilation and the kept planes, for a pair
    /// whose tiles several workers compute ([`crate::shared_pair`]).
    pub(crate) fn parts(&mut self) -> (&mut HostEngine, Isa, &mut Kept) {
        (&mut self.engine, self.isa, &mut self.kept)
    }
}

/// Pixels per batch of the min–max byte step ([`rgb_batch`]).
const BYTE_BATCH: usize = reynoldsflow_core::RGB_BATCH;

/// The second step of per-frame min–max: each pixel's kept magnitudes and
/// its `fⁿ` byte (`luma`: the frame itself, the B channel unchanged) to its
/// three RGB bytes, once the frame's scales are known. Compiled for each
/// ISA by [`dispatch::kept_to_bytes`].
#[inline(always)]
pub(crate) fn bytes_from_kept(
    [m_d, m_c]: [&[f32]; 2],
    luma: &[u8],
    rgb: &mut [u8],
    scales: &[ByteScale; 2],
) {
    let [scale_d, scale_c] = scales;
    let pixels = luma.len().min(m_d.len()).min(m_c.len());
    let (m_d, m_c, luma) = (&m_d[..pixels], &m_c[..pixels], &luma[..pixels]);
    let out = rgb.as_chunks_mut::<3>().0;
    let (batches, rest) = out.as_chunks_mut::<BYTE_BATCH>();
    let inputs = m_d
        .as_chunks::<BYTE_BATCH>()
        .0
        .iter()
        .zip(m_c.as_chunks::<BYTE_BATCH>().0)
        .zip(luma.as_chunks::<BYTE_BATCH>().0);
    let whole = batches.len().min(pixels / BYTE_BATCH);
    for (out, ((m_d, m_c), luma)) in batches.iter_mut().zip(inputs) {
        rgb_batch([m_d, m_c], luma, [scale_d, scale_c], out);
    }
    let start = whole * BYTE_BATCH;
    let tail = m_d[start..].iter().zip(&m_c[start..]).zip(&luma[start..]);
    for (out, ((&m_d, &m_c), &luma)) in rest.iter_mut().zip(tail) {
        let pixel = FlowPixel {
            m_d,
            m_c,
            luma,
            ..FlowPixel::default()
        };
        *out = reynoldsflow_core::rgb(&pixel, scale_d, scale_c);
    }
}

/// What per-frame min–max keeps of a pair until its scales are known: both
/// magnitudes of every pixel, each in its own plane (so that the byte step
/// reads them in lanes), in a [`PageBuffer`] (7.4 MB at 1280×720).
#[derive(Default)]
pub(crate) struct Kept {
    buffer: PageBuffer,
}

impl Kept {
    /// The planes `[|v_d|, |v_c|]` of `pixels` each (the memory grows,
    /// never shrinks: every value is overwritten).
    pub(crate) fn planes(&mut self, pixels: usize) -> Result<[&mut [f32]; 2], HostError> {
        let floats = self.buffer.floats(2 * pixels)?;
        let (m_d, m_c) = floats.split_at_mut(pixels);
        Ok([m_d, m_c])
    }
}

/// The first step of per-frame min–max: each row's magnitudes into the
/// kept planes (the engine's tail writes them there, [`Sink::magnitude_rows`]),
/// and the frame's extremes.
pub(crate) struct KeptMagnitudes<'a> {
    width: usize,
    /// Whole-frame planes `[|v_d|, |v_c|]`, row-major.
    pub(crate) planes: [&'a mut [f32]; 2],
    /// Of every pixel received so far.
    pub(crate) extremes: ExtremesSink,
}

impl<'a> KeptMagnitudes<'a> {
    /// Nothing received yet into `planes`, each `width` wide.
    pub(crate) fn new(width: usize, planes: [&'a mut [f32]; 2]) -> Self {
        Self {
            width,
            planes,
            extremes: ExtremesSink::default(),
        }
    }

    /// The second step, once every pixel is kept: the frame's scales from
    /// the extremes, then the bytes (`luma`: `fⁿ`) into `rgb`.
    pub(crate) fn into_bytes(
        self,
        isa: Isa,
        luma: &[u8],
        rgb: &mut impl ByteBuffer,
    ) -> Result<(), HostError> {
        let (scale_d, scale_c) = self.extremes.byte_scales();
        let [m_d, m_c] = self.planes;
        let rgb = rgb.overwrite(3 * luma.len())?;
        dispatch::kept_to_bytes(isa, [m_d, m_c], luma, rgb, &[scale_d, scale_c]);
        Ok(())
    }

    /// Where pixels `[x, x + len)` of frame row `y` are kept.
    #[inline(always)]
    fn range(&self, y: usize, x: usize, len: usize) -> std::ops::Range<usize> {
        let start = y * self.width + x;
        start..start + len
    }
}

impl Sink for KeptMagnitudes<'_> {
    fn reads_fields(&self) -> bool {
        false
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        let range = self.range(y, x, pixels.len());
        for (plane, row) in self.planes.iter_mut().zip([pixels.m_d, pixels.m_c]) {
            if let Some(kept) = plane.get_mut(range.clone()) {
                kept.copy_from_slice(row);
            }
        }
        self.extremes.row(y, x, pixels);
    }

    #[inline(always)]
    fn magnitude_rows(&mut self, y: usize, x: usize, width: usize) -> Option<[&mut [f32]; 2]> {
        let range = self.range(y, x, width);
        let [m_d, m_c] = &mut self.planes;
        Some([m_d.get_mut(range.clone())?, m_c.get_mut(range)?])
    }

    #[inline(always)]
    fn kept_row(&mut self, _y: usize, _x: usize, _luma: &[u8], extremes: ExtremesSink) {
        self.extremes.merge(extremes);
    }
}

#[cfg(test)]
mod tests {
    use fixed::types::U16F16;

    use super::*;

    /// Both scale modes: per-frame min–max, and gains 8 (|v_d|) and 32 (|v_c|).
    const SCALINGS: [Scaling; 2] = [
        Scaling::PerFrameMinMax,
        Scaling::Fixed {
            k_d: U16F16::lit("8"),
            k_c: U16F16::lit("32"),
        },
    ];

    fn frame(width: usize, height: usize, seed: usize) -> Gray {
        let pixels = (0..width * height)
            .map(|i| ((i * 7 + seed).wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        Gray::new(width, height, pixels).unwrap()
    }

    /// The core's own whole-frame `represent` (two engine passes for
    /// per-frame min–max), the bytes the one-pass path must give.
    fn core_represent(a: &Gray, b: &Gray, scaling: Scaling) -> Vec<u8> {
        let (plan, frames) = prepare(a, b, Params::DEFAULT, None).unwrap();
        let mut rgb = vec![0u8; 3 * a.width * a.height];
        let job = plan.bind(frames).unwrap();
        let mut memory = HostEngine::new();
        let engine = &mut memory.engine(&plan).unwrap();
        reynoldsflow_core::represent(engine, &job, scaling, &mut rgb, ()).unwrap();
        rgb
    }

    #[test]
    fn one_pass_gives_the_cores_two_pass_bytes_for_every_tiling() {
        let (a, b) = (frame(300, 45, 0), frame(300, 45, 1));
        for scaling in SCALINGS {
            let strips = compute_fixed(&a, &b, Params::DEFAULT, None, scaling).unwrap();
            assert!(strips.rep == core_represent(&a, &b, scaling), "{scaling:?}");
            assert!(strips.m_d.iter().any(|&m| m > 0.0));
            for tile in [
                (17, 9),
                (128, 45),
                (1, 45),
                (7, 5),
                (64, 3),
                (300, 7),
                (129, 45),
            ]
            .map(Some)
            {
                let tiled = compute_fixed(&a, &b, Params::DEFAULT, tile, scaling).unwrap();
                assert!(tiled == strips, "tile {tile:?}, {scaling:?}");
            }
        }
    }

    #[test]
    fn tiles_over_threads_give_the_serial_pixels() {
        let (a, b) = (frame(300, 45, 2), frame(300, 45, 3));
        let serial = compute_fixed(&a, &b, Params::DEFAULT, None, Scaling::PerFrameMinMax).unwrap();
        let mut pixels = Vec::new();
        for threads in [1, 2, 3] {
            for tile in [None, Some((17, 9)), Some((100, 20))] {
                let (plan, frames) = prepare(&a, &b, Params::DEFAULT, tile).unwrap();
                let extremes = pixels_on(threads, &plan, &frames, &mut pixels).unwrap();
                for scaling in SCALINGS {
                    let rep = rgb_of(&pixels, a.width, extremes, scaling, threads);
                    let expected = compute_fixed(&a, &b, Params::DEFAULT, None, scaling).unwrap();
                    assert!(
                        rep == expected.rep,
                        "{threads} threads, {tile:?}, {scaling:?}"
                    );
                }
                let m_d: Vec<f64> = pixels.iter().map(|p| f64::from(p.m_d)).collect();
                assert!(m_d == serial.m_d, "{threads} threads, {tile:?}");
            }
        }
    }

    #[test]
    fn the_rgb_path_gives_the_planes_bytes_while_reused() {
        let mut rgb = Vec::new();
        // Both compilations of the pass and of the min–max byte step.
        for isa in [Isa::Best, Isa::Portable] {
            let mut engine = FrameEngine::on(isa);
            // Reused across sizes: larger, smaller, then larger again.
            for (width, height, seed) in [(300, 45, 4), (17, 9, 6), (300, 45, 8)] {
                let (a, b) = (frame(width, height, seed), frame(width, height, seed + 1));
                for scaling in SCALINGS {
                    let planes =
                        compute_fixed_on(Isa::Portable, &a, &b, Params::DEFAULT, None, scaling)
                            .unwrap();
                    for tile in [None, Some((17, 9))] {
                        engine
                            .represent(&a, &b, Params::DEFAULT, tile, scaling, &mut rgb)
                            .unwrap();
                        let what = format!("{isa:?} {width}x{height} {tile:?} {scaling:?}");
                        assert!(rgb == planes.rep, "{what}");
                    }
                }
            }
        }
        // A tile as wide as the frame: the engine grows to it, same bytes.
        let mut engine = FrameEngine::new();
        let (a, b) = (frame(300, 45, 10), frame(300, 45, 11));
        let strips = engine
            .compute(&a, &b, Params::DEFAULT, None, Scaling::PerFrameMinMax)
            .unwrap();
        engine
            .represent(
                &a,
                &b,
                Params::DEFAULT,
                Some((300, 4)),
                Scaling::PerFrameMinMax,
                &mut rgb,
            )
            .unwrap();
        assert!(rgb == strips.rep);
    }

    /// The min–max byte step of both compilations (AVX2 lanes where the
    /// CPU has them) gives the bytes of `ByteScale::byte` one pixel at a
    /// time, on every length around the lanes' steps and on magnitudes of
    /// every kind: zeros, ties, the range's ends, beyond them, huge, NaN.
    #[test]
    fn the_byte_step_is_the_byte_of_each_pixel() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let scales = [
            ByteScale::min_max(0.25, 3.5),
            ByteScale::min_max(1e-3, 1e-3),
            ByteScale::min_max(0.0, 1e-30),
            ByteScale::fixed(U16F16::lit("8")),
            ByteScale::fixed(U16F16::MAX),
            ByteScale::fixed(U16F16::ZERO),
        ];
        for len in (0..100).chain([1000, 1031]) {
            let mut magnitude = |kind: u64| -> f32 {
                let r = next();
                match kind % 8 {
                    0 => 0.0,
                    1 => 0.25 + (r % 15) as f32 * (3.25 / 255.0) * 0.5,
                    2 => f32::from_bits((r >> 40) as u32 & 0x7F7F_FFFF),
                    3 => [f32::MAX, f32::INFINITY, f32::NAN, -1.0][(r % 4) as usize],
                    4 => 3.5 + (r % 100) as f32,
                    _ => (r % 1_000_000) as f32 * 4e-6,
                }
            };
            let planes: [Vec<f32>; 2] =
                std::array::from_fn(|_| (0..len as u64).map(&mut magnitude).collect());
            let luma: Vec<u8> = (0..len).map(|i| (i * 37 % 256) as u8).collect();
            for pair in scales.windows(2) {
                let scales = [pair[0], pair[1]];
                let want: Vec<u8> = (0..len)
                    .flat_map(|i| {
                        let [d, c] = [&planes[0][i], &planes[1][i]];
                        [scales[0].byte(*d), scales[1].byte(*c), luma[i]]
                    })
                    .collect();
                for isa in [Isa::Best, Isa::Portable] {
                    let mut rgb = vec![7u8; 3 * len];
                    let [m_d, m_c] = planes.each_ref().map(|p| &p[..]);
                    dispatch::kept_to_bytes(isa, [m_d, m_c], &luma, &mut rgb, &scales);
                    assert!(rgb == want, "{isa:?} {len} {scales:?}");
                }
            }
        }
    }

    #[test]
    fn refuses_empty_tiles_and_mismatched_frames() {
        let (a, b) = (frame(200, 4, 0), frame(200, 4, 1));
        let empty = compute_fixed(
            &a,
            &b,
            Params::DEFAULT,
            Some((0, 4)),
            Scaling::PerFrameMinMax,
        );
        assert!(matches!(
            empty,
            Err(HostError::Core(reynoldsflow_core::Error::TileOutOfFrame))
        ));
        let c = frame(4, 200, 0);
        let mismatch = compute_fixed(&a, &c, Params::DEFAULT, None, Scaling::PerFrameMinMax);
        assert!(matches!(mismatch, Err(HostError::SizeMismatch { .. })));
    }
}
