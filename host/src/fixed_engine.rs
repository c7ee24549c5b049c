//! One frame pair through the fixed-point core, collected into whole-frame
//! planes: the fields (Q16.16) and magnitudes (Q32.32) as exact f64 copies
//! of the core's values, and the RGB8 representation.

use fixed::types::U32F32;
use rayon::prelude::*;
use reynoldsflow_core::{
    ByteScale, Config, Engine, ExtremesSink, FlowPixel, FramePair, Params, Plan, Scaling, Sink, rgb,
};

use crate::dispatch::{self, Isa, Pass};
use crate::{FlowPlanes, Gray, HostError};

/// Window columns of the host's engine: tiles up to
/// [`MAX_TILE_WIDTH`] = 128 columns, about 45 KiB of working memory.
/// Wider frames are cut into strips; every tiling gives the same bytes.
pub const ENGINE_COLS: usize = 142;

/// The host engine.
pub type HostEngine = Engine<ENGINE_COLS>;

/// Widest tile `compute_fixed` accepts (wider requests are refused with
/// [`reynoldsflow_core::Error::TileTooWide`] rather than silently cut).
pub const MAX_TILE_WIDTH: usize = HostEngine::MAX_TILE_WIDTH;

/// The core's output for a frame pair, row-major planes of `width · height`.
#[derive(Clone, Debug, PartialEq)]
pub struct FixedOutput {
    /// `v_c` and `v_d`, the exact values of the core's Q16.16 (`bits / 65536`).
    pub planes: FlowPlanes,
    /// `|v_d|` as the core computes it (the exact value of its Q32.32).
    pub m_d: Vec<f64>,
    /// `|v_c|`.
    pub m_c: Vec<f64>,
    /// The RGB8 representation, `3 · width · height` bytes.
    pub rep: Vec<u8>,
}

/// A whole frame of the core's output pixels, row-major: a [`Sink`] that
/// each tile writes its rows into.
struct PixelPlane {
    width: usize,
    pixels: Vec<FlowPixel>,
}

impl PixelPlane {
    fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            pixels: vec![FlowPixel::default(); width * height],
        }
    }
}

impl Sink for PixelPlane {
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]) {
        let start = y * self.width + x;
        self.pixels[start..start + pixels.len()].copy_from_slice(pixels);
    }
}

/// Checked geometry of one run: configuration, tiling and the frames.
fn prepare<'a>(
    prev: &'a Gray,
    next: &'a Gray,
    params: Params,
    tile: Option<(usize, usize)>,
) -> Result<(Plan<ENGINE_COLS>, FramePair<'a>), HostError> {
    if prev.size() != next.size() {
        return Err(HostError::SizeMismatch {
            prev: prev.size(),
            next: next.size(),
        });
    }
    let (width, height) = prev.size();
    let config = Config::new(width, height, params)?;
    let plan = match tile {
        None => Plan::strips(config)?,
        Some((tw, th)) => Plan::new(config, tw, th)?,
    };
    let frames = FramePair::packed(&config, &prev.pixels, &next.pixels)?;
    Ok((plan, frames))
}

/// The planes of a [`FixedOutput`] from the core's pixels; every conversion
/// is exact (Q16.16 and Q32.32 below 2⁴⁸ fit f64's mantissa).
fn output(width: usize, height: usize, pixels: &[FlowPixel], rep: Vec<u8>) -> FixedOutput {
    let plane = |f: &dyn Fn(&FlowPixel) -> f64| pixels.iter().map(f).collect();
    FixedOutput {
        planes: FlowPlanes {
            width,
            height,
            vcx: plane(&|p| p.v_c[0].to_num()),
            vcy: plane(&|p| p.v_c[1].to_num()),
            vdx: plane(&|p| p.v_d[0].to_num()),
            vdy: plane(&|p| p.v_d[1].to_num()),
        },
        m_d: plane(&|p| p.m_d.to_num()),
        m_c: plane(&|p| p.m_c.to_num()),
        rep,
    }
}

/// Run the core on `(prev, next)` with `params`, in full-height strips as
/// wide as the engine allows, or in `tile = (width, height)` tiles when
/// given, the way firmware does: one engine, two passes for per-frame
/// min–max (the core's `represent`), the widest instructions the CPU has.
/// Fails when the frames differ in size, or the core refuses the size, the
/// parameters or the tile (e.g. wider than [`MAX_TILE_WIDTH`]).
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
    let (plan, frames) = prepare(prev, next, params, tile)?;
    let (width, height) = prev.size();
    // Boxed: the engine is too large to keep on a test thread's stack for long.
    let mut engine = Box::new(HostEngine::new());
    let mut pixels = PixelPlane::new(width, height);
    let mut rep = vec![0u8; 3 * width * height];
    let pass = Pass::Represent(scaling, &mut rep);
    dispatch::run(isa, &mut engine, &plan, &frames, pass, &mut pixels)?;
    Ok(output(width, height, &pixels.pixels, rep))
}

/// The same output as [`compute_fixed`], bit for bit, in one engine pass:
/// every pixel is kept, so per-frame min–max needs no second pass (what
/// `run` uses per pair; its parallelism is across pairs). For one pair over
/// many cores, see [`represent_parallel`].
pub fn compute_fixed_one_pass(
    prev: &Gray,
    next: &Gray,
    params: Params,
    tile: Option<(usize, usize)>,
    scaling: Scaling,
) -> Result<FixedOutput, HostError> {
    let (plan, frames) = prepare(prev, next, params, tile)?;
    let (width, height) = prev.size();
    let mut frame = PixelPlane::new(width, height);
    let mut engine = Box::new(HostEngine::new());
    dispatch::run(
        Isa::Best,
        &mut engine,
        &plan,
        &frames,
        Pass::All,
        &mut frame,
    )?;
    let (scale_d, scale_c) = scaling.byte_scales(|| {
        let mut extremes = ExtremesSink::default();
        extremes.row(0, 0, &frame.pixels);
        Ok::<_, HostError>(extremes)
    })?;
    let rep = frame
        .pixels
        .iter()
        .flat_map(|p| rgb(p, &scale_d, &scale_c))
        .collect();
    Ok(output(width, height, &frame.pixels, rep))
}

/// The representation alone, its full-height strips spread over `pool`:
/// bit for bit the bytes of [`compute_fixed`], with no per-pixel planes.
/// Each strip owns its columns of every output row, so strips write the RGB
/// frame concurrently; per-frame min–max first gathers the extremes in a
/// parallel pass of its own, as the core's `represent` does.
pub fn represent_parallel(
    prev: &Gray,
    next: &Gray,
    params: Params,
    scaling: Scaling,
    pool: &rayon::ThreadPool,
) -> Result<Vec<u8>, HostError> {
    let (plan, frames) = prepare(prev, next, params, None)?;
    let (width, height) = prev.size();
    let engine = || Box::new(HostEngine::new());
    let (scale_d, scale_c) = scaling.byte_scales(|| {
        pool.install(|| {
            (0..plan.tile_count())
                .into_par_iter()
                .map_init(engine, |engine, index| {
                    let mut extremes = ExtremesSink::default();
                    strip(engine, &plan, &frames, index, &mut extremes).map(|()| extremes)
                })
                .try_reduce(ExtremesSink::default, |mut a, b| {
                    a.merge(b);
                    Ok(a)
                })
        })
    })?;
    let mut rep = vec![0u8; 3 * width * height];
    // Split every row into the strips' column segments.
    let mut strips: Vec<Vec<&mut [u8]>> = (0..plan.tile_count())
        .map(|_| Vec::with_capacity(height))
        .collect();
    for row in rep.chunks_mut(3 * width) {
        let mut rest = row;
        for strip in &mut strips {
            let (segment, tail) = rest.split_at_mut((3 * plan.tile_width()).min(rest.len()));
            strip.push(segment);
            rest = tail;
        }
    }
    pool.install(|| {
        strips
            .par_iter_mut()
            .enumerate()
            .try_for_each_init(engine, |engine, (index, rows)| {
                let mut sink = StripRgb {
                    rows,
                    scale_d,
                    scale_c,
                };
                strip(engine, &plan, &frames, index, &mut sink)
            })
    })?;
    Ok(rep)
}

/// The RGB representation of pair after pair, with nothing else computed
/// and nothing allocated once the buffers have grown to the frame size:
/// the engine and the magnitudes kept for per-frame min–max live as long
/// as this value (one per worker). Bit for bit the bytes of
/// [`compute_fixed`].
pub struct RgbEngine {
    engine: Box<HostEngine>,
    /// `[|v_d|, |v_c|]` of every pixel of the last pair (per-frame min–max
    /// only): all that the byte step needs besides `fⁿ`, which waits in
    /// the RGB frame's B channel.
    magnitudes: Vec<[U32F32; 2]>,
}

impl Default for RgbEngine {
    fn default() -> Self {
        Self::new()
    }
}

impl RgbEngine {
    /// An engine with empty buffers.
    pub fn new() -> Self {
        Self {
            // Boxed: the engine is too large for a worker's stack.
            engine: Box::new(HostEngine::new()),
            magnitudes: Vec::new(),
        }
    }

    /// The representation of `(prev, next)` into `rgb` (resized to
    /// `3 · width · height`), in one engine pass whatever the scaling:
    /// `Fixed` gains stream the engine's rows straight into the bytes;
    /// per-frame min–max keeps each pixel's two magnitudes and the frame's
    /// extremes, then maps them to bytes. Fails as [`compute_fixed`] does.
    pub fn represent(
        &mut self,
        prev: &Gray,
        next: &Gray,
        params: Params,
        tile: Option<(usize, usize)>,
        scaling: Scaling,
        rgb: &mut Vec<u8>,
    ) -> Result<(), HostError> {
        let (plan, frames) = prepare(prev, next, params, tile)?;
        let (width, height) = prev.size();
        // Every byte is overwritten below; resizing a reused buffer of the same size is free.
        rgb.resize(3 * width * height, 0);
        let engine = &mut *self.engine;
        if !matches!(scaling, Scaling::PerFrameMinMax) {
            // Known gains: the core's `represent` streams rows into the bytes in one pass.
            let pass = Pass::Represent(scaling, rgb);
            return Ok(dispatch::run(
                Isa::Best,
                engine,
                &plan,
                &frames,
                pass,
                &mut (),
            )?);
        }
        self.magnitudes.resize(width * height, [U32F32::ZERO; 2]);
        let mut sink = (
            ExtremesSink::default(),
            KeptMagnitudes {
                width,
                magnitudes: &mut self.magnitudes,
                rgb,
            },
        );
        dispatch::run(Isa::Best, engine, &plan, &frames, Pass::All, &mut sink)?;
        let (scale_d, scale_c) = scaling.byte_scales(|| Ok::<_, HostError>(sink.0))?;
        for (dst, &[m_d, m_c]) in rgb.chunks_exact_mut(3).zip(&self.magnitudes) {
            let px = FlowPixel {
                m_d,
                m_c,
                luma: dst[2],
                ..FlowPixel::default()
            };
            dst.copy_from_slice(&reynoldsflow_core::rgb(&px, &scale_d, &scale_c));
        }
        Ok(())
    }
}

/// The first step of per-frame min–max: each pixel's magnitudes into a
/// plane, its `fⁿ` byte straight into the RGB frame.
struct KeptMagnitudes<'a> {
    width: usize,
    magnitudes: &'a mut [[U32F32; 2]],
    rgb: &'a mut [u8],
}

impl Sink for KeptMagnitudes<'_> {
    fn reads_fields(&self) -> bool {
        false
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: &[FlowPixel]) {
        let start = y * self.width + x;
        let end = start + pixels.len();
        let rgb = self.rgb[3 * start..3 * end].chunks_exact_mut(3);
        for ((m, dst), px) in self.magnitudes[start..end].iter_mut().zip(rgb).zip(pixels) {
            *m = [px.m_d, px.m_c];
            dst[2] = px.luma;
        }
    }
}

/// Strip `index` of `plan` into `sink`, with the CPU's widest instructions.
fn strip<S: Sink>(
    engine: &mut HostEngine,
    plan: &Plan<ENGINE_COLS>,
    frames: &FramePair<'_>,
    index: usize,
    sink: &mut S,
) -> Result<(), reynoldsflow_core::Error> {
    dispatch::run(Isa::Best, engine, plan, frames, Pass::Tile(index), sink)
}

/// One full-height strip's segments of the RGB rows (row `y` of the frame is
/// `rows[y]`, starting at the strip's first column).
struct StripRgb<'a, 'b> {
    rows: &'a mut [&'b mut [u8]],
    scale_d: ByteScale,
    scale_c: ByteScale,
}

impl Sink for StripRgb<'_, '_> {
    fn reads_fields(&self) -> bool {
        false
    }

    fn row(&mut self, y: usize, _x: usize, pixels: &[FlowPixel]) {
        if let Some(row) = self.rows.get_mut(y) {
            for (dst, px) in row.chunks_exact_mut(3).zip(pixels) {
                dst.copy_from_slice(&rgb(px, &self.scale_d, &self.scale_c));
            }
        }
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

    #[test]
    fn one_pass_equals_the_serial_engine() {
        let (a, b) = (frame(300, 45, 0), frame(300, 45, 1));
        for scaling in SCALINGS {
            let serial = compute_fixed(&a, &b, Params::DEFAULT, None, scaling).unwrap();
            for tile in [None, Some((17, 9)), Some((128, 45)), Some((1, 45))] {
                let one_pass =
                    compute_fixed_one_pass(&a, &b, Params::DEFAULT, tile, scaling).unwrap();
                assert!(one_pass == serial, "tile {tile:?}, {scaling:?}");
            }
        }
    }

    #[test]
    fn parallel_representation_equals_the_serial_engine() {
        let (a, b) = (frame(300, 45, 2), frame(300, 45, 3));
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        for scaling in SCALINGS {
            let serial = compute_fixed(&a, &b, Params::DEFAULT, None, scaling).unwrap();
            let parallel = represent_parallel(&a, &b, Params::DEFAULT, scaling, &pool).unwrap();
            assert!(parallel == serial.rep, "{scaling:?}");
        }
    }

    #[test]
    fn rgb_engine_equals_the_serial_engine_while_reused() {
        let mut engine = RgbEngine::new();
        let mut rgb = Vec::new();
        // Reused across sizes: larger, smaller, then larger again.
        for (width, height, seed) in [(300, 45, 4), (17, 9, 6), (300, 45, 8)] {
            let (a, b) = (frame(width, height, seed), frame(width, height, seed + 1));
            for scaling in SCALINGS {
                let serial = compute_fixed(&a, &b, Params::DEFAULT, None, scaling).unwrap();
                for tile in [None, Some((17, 9))] {
                    engine
                        .represent(&a, &b, Params::DEFAULT, tile, scaling, &mut rgb)
                        .unwrap();
                    assert!(rgb == serial.rep, "{width}x{height} {tile:?} {scaling:?}");
                }
            }
        }
        let wide = engine.represent(
            &frame(200, 4, 0),
            &frame(200, 4, 1),
            Params::DEFAULT,
            Some((129, 4)),
            Scaling::PerFrameMinMax,
            &mut rgb,
        );
        assert!(matches!(
            wide,
            Err(HostError::Core(
                reynoldsflow_core::Error::TileTooWide { .. }
            ))
        ));
    }

    #[test]
    fn every_tiling_gives_the_same_output() {
        let (a, b) = (frame(150, 20, 0), frame(150, 20, 1));
        let strips = compute_fixed(&a, &b, Params::DEFAULT, None, Scaling::PerFrameMinMax).unwrap();
        for tile in [(1, 1), (7, 5), (128, 20), (64, 3)] {
            let tiled = compute_fixed(&a, &b, Params::DEFAULT, Some(tile), Scaling::PerFrameMinMax)
                .unwrap();
            assert!(tiled == strips, "tile {tile:?}");
        }
        assert!(strips.m_d.iter().any(|&m| m > 0.0));
    }

    #[test]
    fn refuses_wide_tiles_and_mismatched_frames() {
        let (a, b) = (frame(200, 4, 0), frame(200, 4, 1));
        let wide = compute_fixed(
            &a,
            &b,
            Params::DEFAULT,
            Some((129, 4)),
            Scaling::PerFrameMinMax,
        );
        assert!(matches!(
            wide,
            Err(HostError::Core(reynoldsflow_core::Error::TileTooWide {
                max: 128
            }))
        ));
        let c = frame(4, 200, 0);
        let mismatch = compute_fixed(&a, &c, Params::DEFAULT, None, Scaling::PerFrameMinMax);
        assert!(matches!(mismatch, Err(HostError::SizeMismatch { .. })));
    }
}
