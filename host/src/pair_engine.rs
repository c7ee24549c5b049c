//! One pair at a time, for a consumer that gets frames one by one and
//! wants each result at once (the GStreamer element, the ROS 2 node,
//! Python): [`Settings`] to the image of the pair, on one or more threads,
//! on the tuned path `run` takes ([`Compute::representation`]: the
//! magnitudes alone, no fields unless the colour wheel asks for them).
//!
//! On one thread it is `run`'s own per-pair path. On more, the pair's
//! tiles are spread over the threads (`run` instead gives each worker
//! whole pairs, [`crate::pipeline`]), each thread writing its tiles'
//! magnitudes straight into the pair's kept planes (as per-frame min–max
//! keeps them on one thread, [`crate::fixed_engine`]), then, once the
//! frame's scales are known, its tiles' bytes. Every tiling and thread
//! count gives the same bytes. The kept magnitudes are what the cues read
//! ([`PairEngine::magnitudes`], [`crate::cues`]).

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};

use reynoldsflow_core::{ExtremesSink, FlowPixel, HALO, Params, Pixels, Plan, Scaling, Sink};

use crate::dispatch::{self, Isa, Pass};
use crate::fixed_engine::{self, FrameEngine, HostEngine, prepare};
use crate::outputs::{OutputSpec, PairFields};
use crate::page_buffer::ByteBuffer;
use crate::pipeline::Compute;
use crate::settings::Settings;
use crate::{Gray, HostError, workers};

/// The engine of a stream of pairs: settings checked once, and each
/// thread's engine memory kept from pair to pair.
pub struct PairEngine {
    compute: Compute,
    spec: OutputSpec,
    /// Keep every pixel's magnitudes ([`Self::magnitudes`]).
    keep: bool,
    /// This thread's engine memory and kept planes.
    engine: FrameEngine,
    /// The other threads' engine memory.
    helpers: Vec<HostEngine>,
    /// The other threads, kept from pair to pair (none on one thread):
    /// starting them for each pair cost more than waking them.
    pool: Option<rayon::ThreadPool>,
    /// The size of the last pair whose magnitudes are kept.
    kept: Option<(usize, usize)>,
    /// The colour wheel's pixels (it reads the fields).
    pixels: Vec<FlowPixel>,
    /// `fⁿ` of the last pair whose magnitudes are kept.
    luma: Vec<u8>,
}

/// The magnitudes of a pair, row-major planes of `width · height`.
pub struct Magnitudes<'a> {
    /// Frame width.
    pub width: usize,
    /// Frame height.
    pub height: usize,
    /// `|v_d|`.
    pub m_d: &'a [f32],
    /// `|v_c|`.
    pub m_c: &'a [f32],
    /// `fⁿ`, the pair's first frame.
    pub luma: &'a [u8],
}

impl PairEngine {
    /// The engine of `settings` (engine, scale, intensity scale, λ, tile,
    /// variant, colour-wheel radius, threads), checked: an error names the
    /// setting at fault.
    pub fn new(settings: &Settings) -> Result<Self, HostError> {
        let compute = settings.compute()?;
        let threads = settings.threads().max(1);
        let pool = match threads {
            1 => None,
            n => Some(workers::kept_pool(n - 1, "reynoldsflow-pair")?),
        };
        Ok(Self {
            compute,
            spec: OutputSpec {
                variant: settings.variant,
                hsv_max: settings.hsv_max,
                ..OutputSpec::default()
            },
            keep: false,
            engine: FrameEngine::new(),
            helpers: (1..threads).map(|_| HostEngine::new()).collect(),
            pool,
            kept: None,
            pixels: Vec::new(),
            luma: Vec::new(),
        })
    }

    /// Keep every pixel's magnitudes of each pair (what the cues read),
    /// or not (the default: the bytes alone where that is faster).
    pub fn keep_magnitudes(mut self, keep: bool) -> Self {
        self.keep = keep;
        self
    }

    /// Threads that compute each pair.
    pub fn threads(&self) -> usize {
        self.helpers.len() + 1
    }

    /// The image of the pair `(prev, next)` (the variant's, RGB8, packed)
    /// into `rgb`, `3 · width · height` bytes: exactly what `reynoldsflow
    /// run` writes for it. Fails when the frames differ in size, the core
    /// refuses them, or `rgb` has another length.
    pub fn image(&mut self, prev: &Gray, next: &Gray, rgb: &mut [u8]) -> Result<(), HostError> {
        self.kept = None;
        let (width, height) = prev.size();
        if prev.size() != next.size() {
            return Err(HostError::SizeMismatch {
                prev: prev.size(),
                next: next.size(),
            });
        }
        if rgb.len() != 3 * width * height {
            return Err(HostError::invalid(
                "image buffer",
                format!(
                    "{} bytes for a {width}x{height} RGB image of {}",
                    rgb.len(),
                    3 * width * height
                ),
            ));
        }
        let fixed = self.compute.fixed();
        let Some((params, scaling)) = fixed else {
            // The float reference: the oracle, one thread.
            let fields = self.compute.pair_with(&mut self.engine, prev, next)?;
            rgb.copy_from_slice(&self.spec.image(&fields));
            return Ok(());
        };
        if self.spec.image_needs_fields() {
            return self.wheel(prev, next, params, rgb);
        }
        if self.helpers.is_empty() && !self.keep {
            // `run`'s path, to the byte.
            self.compute
                .representation(&mut self.engine, prev, next, &mut Exact(rgb))?;
            self.spec.arrange(rgb);
            return Ok(());
        }
        self.tiles(prev, next, params, scaling, rgb)
    }

    /// The fields of the pair `(prev, next)` (and the float engine's
    /// representation), for a consumer that reads them: the vector fields,
    /// the motion score. One thread.
    pub fn fields(&mut self, prev: &Gray, next: &Gray) -> Result<PairFields, HostError> {
        self.kept = None;
        self.compute.pair_with(&mut self.engine, prev, next)
    }

    /// The image of `fields` (from [`Self::fields`]): the bytes
    /// [`Self::image`] writes for the same pair.
    pub fn image_of(&self, fields: &PairFields) -> Vec<u8> {
        self.spec.image(fields)
    }

    /// [`Self::image`] into a new buffer.
    pub fn image_vec(&mut self, prev: &Gray, next: &Gray) -> Result<Vec<u8>, HostError> {
        let mut rgb = vec![0; 3 * prev.pixels.len()];
        self.image(prev, next, &mut rgb)?;
        Ok(rgb)
    }

    /// The magnitudes of the last pair, when kept ([`Self::keep_magnitudes`]).
    pub fn magnitudes(&mut self) -> Option<Magnitudes<'_>> {
        let (width, height) = self.kept?;
        let (_, _, kept) = self.engine.parts();
        let [m_d, m_c] = kept.planes(width * height).ok()?;
        Some(Magnitudes {
            width,
            height,
            m_d,
            m_c,
            luma: &self.luma,
        })
    }

    /// The tile size of a pair `width × height` on this engine's threads.
    fn tile(&self, width: usize, height: usize) -> (usize, usize) {
        match self.compute.tile() {
            Some(t) => (t.width, t.height),
            None => balanced_tile(width, height, self.threads()),
        }
    }

    /// The magnitudes of every tile into the kept planes, the tiles spread
    /// over the threads; then, once the frame's scales are known, each
    /// tile's bytes.
    fn tiles(
        &mut self,
        prev: &Gray,
        next: &Gray,
        params: Params,
        scaling: Scaling,
        rgb: &mut [u8],
    ) -> Result<(), HostError> {
        let (width, height) = prev.size();
        let (plan, frames) = prepare(prev, next, params, Some(self.tile(width, height)))
            .map_err(crate::pipeline::tile_error)?;
        let (memory, isa, kept) = self.engine.parts();
        let [m_d, m_c] = kept.planes(width * height)?;
        let tiles = TileRows::split(&plan, width, [m_d, m_c], rgb);
        let tiles: Vec<Mutex<TileRows<'_>>> = tiles.into_iter().map(Mutex::new).collect();
        let threads = self.helpers.len() + 1;
        let shared = Shared {
            plan: &plan,
            frames: &frames,
            isa,
            luma: &prev.pixels,
            width,
            scaling,
            spec: &self.spec,
            tiles: &tiles,
            computed: AtomicUsize::new(0),
            progress: Mutex::new(Progress::default()),
            finished: Condvar::new(),
        };
        let helpers = &mut self.helpers[..threads.min(tiles.len()).max(1) - 1];
        match &self.pool {
            // This thread takes tiles too; the pool's threads join it.
            Some(pool) if !helpers.is_empty() => pool.in_place_scope(|scope| {
                for memory in helpers.iter_mut() {
                    let shared = &shared;
                    scope.spawn(move |_| shared.work(memory));
                }
                shared.work(memory);
            }),
            _ => shared.work(memory),
        }
        let progress = shared.progress.into_inner();
        if let Some(e) = progress.expect("no panic while holding it").failed {
            return Err(e);
        }
        if self.keep {
            self.kept = Some((width, height));
            self.luma.clear();
            self.luma.extend_from_slice(&prev.pixels);
        }
        Ok(())
    }

    /// The colour wheel: every pixel's fields, the tiles spread over the
    /// threads.
    fn wheel(
        &mut self,
        prev: &Gray,
        next: &Gray,
        params: Params,
        rgb: &mut [u8],
    ) -> Result<(), HostError> {
        let (width, height) = prev.size();
        let (plan, frames) = prepare(prev, next, params, Some(self.tile(width, height)))
            .map_err(crate::pipeline::tile_error)?;
        fixed_engine::pixels_on(self.threads(), &plan, &frames, &mut self.pixels)?;
        let pixels = &self.pixels;
        let fields = PairFields {
            planes: fixed_engine::planes_of(width, height, pixels),
            rep: Vec::new(),
        };
        rgb.copy_from_slice(&self.spec.image(&fields));
        if self.keep {
            let (_, _, kept) = self.engine.parts();
            let [m_d, m_c] = kept.planes(width * height)?;
            for ((d, c), p) in m_d.iter_mut().zip(m_c.iter_mut()).zip(pixels) {
                (*d, *c) = (p.m_d, p.m_c);
            }
            self.kept = Some((width, height));
            self.luma.clear();
            self.luma.extend_from_slice(&prev.pixels);
        }
        Ok(())
    }
}

/// What every thread of one pair shares.
struct Shared<'a, 'p> {
    plan: &'a Plan,
    frames: &'a reynoldsflow_core::FramePair<'p>,
    isa: Isa,
    /// `fⁿ`, packed.
    luma: &'a [u8],
    width: usize,
    scaling: Scaling,
    spec: &'a OutputSpec,
    tiles: &'a [Mutex<TileRows<'a>>],
    /// The next tile to compute.
    computed: AtomicUsize,
    progress: Mutex<Progress>,
    /// Signalled when every tile is computed, or one failed.
    finished: Condvar,
}

/// How far the tiles' computation is.
#[derive(Default)]
struct Progress {
    /// Tiles computed.
    computed: usize,
    /// The first failure.
    failed: Option<HostError>,
}

impl Shared<'_, '_> {
    fn lock(&self) -> std::sync::MutexGuard<'_, Progress> {
        self.progress.lock().expect("no panic while holding it")
    }

    /// One thread's part: tiles until none is left, then (once every tile
    /// is computed, the scales need them all) the bytes of the tiles it
    /// computed, whose magnitudes are still in its core's cache (taking
    /// the other thread's made the conversion twice as slow at 640×480). The
    /// others wait for the tiles, not for the threads: one that starts
    /// late finds every tile taken and only leaves.
    fn work(&self, memory: &mut HostEngine) {
        let mut mine = Vec::new();
        let computed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let next = || {
                Some(self.computed.fetch_add(1, Ordering::Relaxed))
                    .filter(|&index| index < self.tiles.len())
            };
            let Some(mut index) = next() else {
                return Ok(());
            };
            let mut engine = memory.engine(self.plan)?;
            loop {
                let mut tile = self.tiles[index]
                    .lock()
                    .expect("each tile is taken once at a time");
                let pass = Pass::Tile(index);
                dispatch::run(
                    self.isa,
                    &mut engine,
                    self.plan,
                    self.frames,
                    pass,
                    &mut *tile,
                )?;
                drop(tile);
                mine.push(index);
                let mut progress = self.lock();
                progress.computed += 1;
                if progress.computed == self.tiles.len() {
                    self.finished.notify_all();
                }
                drop(progress);
                match next() {
                    Some(i) => index = i,
                    None => return Ok(()),
                }
            }
        }))
        .unwrap_or_else(|_| {
            Err(HostError::invalid(
                "pair",
                "internal error (panic) while computing a tile",
            ))
        });
        let mut progress = self.lock();
        if let Err(e) = computed {
            // Nobody waits for the tiles of a failed pair.
            progress.failed.get_or_insert(e);
            self.finished.notify_all();
        }
        while progress.computed < self.tiles.len() && progress.failed.is_none() {
            progress = self
                .finished
                .wait(progress)
                .expect("no panic while holding it");
        }
        if progress.failed.is_some() {
            return;
        }
        drop(progress);
        let scales = {
            let merged = || {
                let mut extremes = ExtremesSink::default();
                for tile in self.tiles {
                    extremes.merge(tile.lock().expect("no panic while holding it").extremes);
                }
                Ok::<_, std::convert::Infallible>(extremes)
            };
            let (d, c) = self
                .scaling
                .byte_scales(merged)
                .unwrap_or_else(|n| match n {});
            [d, c]
        };
        for index in mine {
            let mut tile = self.tiles[index]
                .lock()
                .expect("each tile is taken once at a time");
            tile.bytes(self.isa, self.luma, self.width, &scales, self.spec);
        }
    }
}

/// One tile's segments of the frame's kept planes and of its RGB image,
/// row by row, and the extremes of the magnitudes it received: the sink a
/// thread computes the tile into. Row `k` of each is frame row
/// `origin.1 + k` from column `origin.0` on.
struct TileRows<'a> {
    origin: (usize, usize),
    m_d: Vec<&'a mut [f32]>,
    m_c: Vec<&'a mut [f32]>,
    rgb: Vec<&'a mut [u8]>,
    extremes: ExtremesSink,
}

impl<'a> TileRows<'a> {
    /// Every tile of `plan` with its segments of `planes` and `rgb`, all
    /// `width` pixels wide.
    fn split(
        plan: &Plan,
        width: usize,
        planes: [&'a mut [f32]; 2],
        rgb: &'a mut [u8],
    ) -> Vec<Self> {
        let mut tiles: Vec<Self> = plan
            .tiles()
            .map(|tile| TileRows {
                origin: (tile.x, tile.y),
                m_d: Vec::with_capacity(tile.height),
                m_c: Vec::with_capacity(tile.height),
                rgb: Vec::with_capacity(tile.height),
                extremes: ExtremesSink::default(),
            })
            .collect();
        let (tile_width, tile_height) = (plan.tile_width(), plan.tile_height());
        let [m_d, m_c] = planes;
        let rows = m_d
            .chunks_mut(width)
            .zip(m_c.chunks_mut(width))
            .zip(rgb.chunks_mut(3 * width));
        for (y, ((m_d, m_c), rgb)) in rows.enumerate() {
            let first = (y / tile_height) * plan.tiles_across();
            let segments = m_d
                .chunks_mut(tile_width)
                .zip(m_c.chunks_mut(tile_width))
                .zip(rgb.chunks_mut(3 * tile_width));
            for (tile, ((m_d, m_c), rgb)) in tiles[first..].iter_mut().zip(segments) {
                tile.m_d.push(m_d);
                tile.m_c.push(m_c);
                tile.rgb.push(rgb);
            }
        }
        tiles
    }

    /// The tile's bytes from its kept magnitudes, in `scales`, arranged
    /// as `spec`'s variant (`luma`: the frame `width` wide).
    fn bytes(
        &mut self,
        isa: Isa,
        luma: &[u8],
        width: usize,
        scales: &[reynoldsflow_core::ByteScale; 2],
        spec: &OutputSpec,
    ) {
        let (x0, y0) = self.origin;
        let rows = self.m_d.iter().zip(&self.m_c).zip(self.rgb.iter_mut());
        for (k, ((m_d, m_c), rgb)) in rows.enumerate() {
            let start = (y0 + k) * width + x0;
            let luma = &luma[start..start + m_d.len()];
            dispatch::kept_to_bytes(isa, [m_d, m_c], luma, rgb, scales);
            spec.arrange(rgb);
        }
    }

    /// The segments of row `y`, columns `[x, x + len)`.
    #[inline(always)]
    fn at(&mut self, y: usize, x: usize, len: usize) -> Option<[&mut [f32]; 2]> {
        let (x0, y0) = self.origin;
        let row = y.checked_sub(y0)?;
        let start = x.checked_sub(x0)?;
        let m_d = self.m_d.get_mut(row)?.get_mut(start..start + len)?;
        let m_c = self.m_c.get_mut(row)?.get_mut(start..start + len)?;
        Some([m_d, m_c])
    }
}

impl Sink for TileRows<'_> {
    fn reads_fields(&self) -> bool {
        false
    }

    #[inline(always)]
    fn row(&mut self, y: usize, x: usize, pixels: Pixels<'_>) {
        if let Some([m_d, m_c]) = self.at(y, x, pixels.len()) {
            m_d.copy_from_slice(pixels.m_d);
            m_c.copy_from_slice(pixels.m_c);
        }
        self.extremes.row(y, x, pixels);
    }

    #[inline(always)]
    fn magnitude_rows(&mut self, y: usize, x: usize, width: usize) -> Option<[&mut [f32]; 2]> {
        self.at(y, x, width)
    }

    #[inline(always)]
    fn kept_row(&mut self, _y: usize, _x: usize, _luma: &[u8], extremes: ExtremesSink) {
        self.extremes.merge(extremes);
    }
}

/// An RGB buffer of exactly the image's length.
struct Exact<'a>(&'a mut [u8]);

impl ByteBuffer for Exact<'_> {
    fn overwrite(&mut self, len: usize) -> Result<&mut [u8], HostError> {
        let have = self.0.len();
        self.0
            .get_mut(..len)
            .filter(|_| len == have)
            .ok_or_else(|| {
                HostError::invalid(
                    "image buffer",
                    format!("{have} bytes for an image of {len}"),
                )
            })
    }
}

/// Tile size for `threads`: the host's full-width strips (one thread's
/// strips, at most [`fixed_engine::MAX_STRIP_WIDTH`] wide) cut into as many bands as
/// gives the shortest pass, counting each band's halo (`HALO` rows above
/// and below) and `⌈tiles / threads⌉` rounds. Bands, not columns: a
/// tile's cost grows with its rows (each row is a step of the engine's
/// row rings), and bands keep each tile's planes and image rows whole.
fn balanced_tile(width: usize, height: usize, threads: usize) -> (usize, usize) {
    let strip = fixed_engine::strip_width(width);
    let across = width.div_ceil(strip);
    let mut best = (usize::MAX, height.max(1));
    for down in 1..=(2 * threads).min(height).max(1) {
        let band = height.div_ceil(down);
        let tiles = across * height.div_ceil(band);
        let cost = tiles.div_ceil(threads) * (band + 2 * HALO);
        if cost < best.0 {
            best = (cost, band);
        }
    }
    (strip, best.1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outputs::Variant;
    use crate::settings::{EngineKind, ScaleArg, Setting, TileSize};

    fn gray(width: usize, height: usize, seed: usize) -> Gray {
        let pixels = (0..width * height)
            .map(|i| ((i * 7 + seed).wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        Gray::new(width, height, pixels).unwrap()
    }

    /// `run`'s bytes of one pair: the `pair` subcommand's computation and
    /// the variant's image.
    fn expected(settings: &Settings, a: &Gray, b: &Gray) -> Vec<u8> {
        let spec = OutputSpec {
            variant: settings.variant,
            hsv_max: settings.hsv_max,
            ..OutputSpec::default()
        };
        spec.image(&settings.compute().unwrap().pair(a, b).unwrap())
    }

    #[test]
    fn tiles_are_balanced_over_the_threads() {
        assert_eq!(balanced_tile(640, 480, 1), (640, 480));
        assert_eq!(balanced_tile(3000, 20, 1), (1000, 20));
        for threads in [2, 4] {
            let (tw, th) = balanced_tile(640, 480, threads);
            let tiles = 640usize.div_ceil(tw) * 480usize.div_ceil(th);
            assert_eq!(tiles % threads, 0, "{threads} threads: {tw}x{th}");
        }
    }

    #[test]
    fn every_thread_count_variant_and_scale_gives_the_bytes_of_run() {
        let scales = [
            ScaleArg::MinMax,
            ScaleArg::Fixed {
                k_d: 8.0,
                k_c: 32.0,
            },
        ];
        let variants = [Variant::Dc, Variant::Dc0, Variant::Cd, Variant::Hsv];
        // Odd sizes; the engine reused across sizes: larger, smaller, larger.
        let sizes = [(70, 33), (9, 20), (131, 41)];
        for scale in scales {
            for variant in variants {
                for threads in [1, 2, 3, 5] {
                    for keep in [false, true] {
                        let settings = Settings {
                            scale,
                            variant,
                            threads: Some(threads),
                            ..Settings::default()
                        };
                        let mut engine = PairEngine::new(&settings).unwrap().keep_magnitudes(keep);
                        for (seed, &(w, h)) in sizes.iter().enumerate() {
                            let (a, b) = (gray(w, h, seed), gray(w, h, seed + 1));
                            let what = format!(
                                "{scale} {variant:?} {threads} threads keep {keep} {w}x{h}"
                            );
                            let rgb = engine.image_vec(&a, &b).unwrap();
                            assert!(rgb == expected(&settings, &a, &b), "{what}");
                            let kept = engine
                                .magnitudes()
                                .map(|m| (m.m_c.to_vec(), m.luma.to_vec()));
                            if keep {
                                let (m_c, luma) = kept.expect(&what);
                                let fixed = crate::fixed_engine::compute_fixed(
                                    &a,
                                    &b,
                                    Params::DEFAULT,
                                    None,
                                    Scaling::PerFrameMinMax,
                                )
                                .unwrap();
                                let m_c: Vec<f64> = m_c.iter().map(|&m| f64::from(m)).collect();
                                assert!(m_c == fixed.m_c, "{what}");
                                assert!(luma == a.pixels, "{what}");
                            } else {
                                assert!(kept.is_none(), "{what}");
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn tiles_and_the_float_engine_give_the_bytes_of_run() {
        let (a, b) = (gray(50, 30, 4), gray(50, 30, 5));
        for threads in [1, 2] {
            let settings = Settings {
                tile: Some(TileSize {
                    width: 17,
                    height: 9,
                }),
                threads: Some(threads),
                ..Settings::default()
            };
            let mut engine = PairEngine::new(&settings).unwrap();
            assert!(engine.image_vec(&a, &b).unwrap() == expected(&settings, &a, &b));
        }
        let float = Settings {
            engine: EngineKind::Float,
            threads: Some(2),
            ..Settings::default()
        };
        let mut engine = PairEngine::new(&float).unwrap();
        assert!(engine.image_vec(&a, &b).unwrap() == expected(&float, &a, &b));
    }

    #[test]
    fn bad_settings_frames_and_buffers_are_refused() {
        let settings = Settings {
            lambda: 1e9,
            ..Settings::default()
        };
        let err = PairEngine::new(&settings).err().unwrap();
        assert!(
            matches!(
                err,
                HostError::Setting {
                    setting: Setting::Lambda,
                    ..
                }
            ),
            "{err}"
        );
        let settings = Settings {
            threads: Some(0),
            ..Settings::default()
        };
        assert!(PairEngine::new(&settings).is_err());
        for threads in [1, 2] {
            let settings = Settings {
                threads: Some(threads),
                ..Settings::default()
            };
            let mut engine = PairEngine::new(&settings).unwrap();
            let (a, b) = (gray(20, 10, 0), gray(20, 12, 1));
            let err = engine.image_vec(&a, &b).err().unwrap();
            assert!(matches!(err, HostError::SizeMismatch { .. }));
            let mut short = vec![0; 10];
            assert!(engine.image(&a, &a, &mut short).is_err());
            let tiny = Settings {
                tile: Some(TileSize {
                    width: 0,
                    height: 4,
                }),
                ..settings
            };
            let mut engine = PairEngine::new(&tiny).unwrap();
            let err = engine.image_vec(&a, &a).err().unwrap();
            assert!(
                matches!(
                    err,
                    HostError::Setting {
                        setting: Setting::Tile,
                        ..
                    }
                ),
                "{err}"
            );
        }
    }
}
