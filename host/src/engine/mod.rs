//! The host's one engine: [`Settings`] to one pair's results, on one or
//! more threads. Every front end computes its pairs here: `run`,
//! `dataset` and `verify` (one [`PairEngine`] per worker of
//! [`crate::pipeline`]), the GStreamer element, the ROS 2 node, Python and
//! the evaluation.
//!
//! - `compute`: the settings checked once ([`Compute`]); the float64
//!   reference ([`crate::reference`]) is the oracle the fixed engine is
//!   held to, reached from here for the float engine, not an engine of
//!   its own.
//! - `lane`: one thread's path (engine memory and kept planes, reused).
//! - `bands`: the one tiling policy and the one way a pair is spread
//!   over threads (its tiles taken by whichever thread is free: the
//!   caller and the engine's kept pool).
//! - `sinks`: where a tile's rows go.
//! - `bytes`: the engine pass and the min–max byte step, compiled per
//!   instruction set: where a new backend plugs in.
//!
//! On one thread a pair takes the tuned path (the magnitudes alone, no
//! fields unless an output asks for them). On more, the pair's tiles are
//! spread over the threads, each writing its tiles' magnitudes straight
//! into the pair's kept planes, then, once the frame's scales are known,
//! its tiles' bytes. Every tiling and thread count gives the same bytes.
//! The kept magnitudes are what the cues read ([`PairEngine::magnitudes`],
//! [`crate::cues`]).

use std::sync::{Arc, Mutex};

use reynoldsflow_core::{ExtremesSink, FlowPixel, Params, Scaling};

pub(crate) mod bands;
pub(crate) mod bytes;
mod compute;
mod image;
pub(crate) mod lane;
pub(crate) mod memory;
pub(crate) mod page_buffer;
mod sinks;
pub(crate) mod viz;

pub use compute::Compute;
pub use image::{Image, PairFields};

use lane::planes_of;
use memory::HostEngine;

use bands::{Bands, balanced_tile, prepare, spread};
use compute::tile_error;
use lane::Lane;
use sinks::{Exact, PixelRows, TileRows};

use crate::engine::page_buffer::ByteBuffer;
use crate::settings::Settings;
use crate::{Gray, HostError, workers};

/// The engine of a stream of pairs: settings checked once, and each
/// thread's engine memory kept from pair to pair.
pub struct PairEngine {
    compute: Compute,
    image: Image,
    /// Keep every pixel's magnitudes ([`Self::magnitudes`]).
    keep: bool,
    /// This thread's engine memory and kept planes.
    lane: Lane,
    /// The other threads' engine memory.
    helpers: Vec<HostEngine>,
    /// The other threads, kept from pair to pair (none on one thread):
    /// starting them for each pair cost more than waking them.
    pool: Option<Arc<rayon::ThreadPool>>,
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
            n => Some(Arc::new(workers::kept_pool(n - 1, "reynoldsflow-pair")?)),
        };
        let image = Image {
            variant: settings.variant,
            hsv_max: settings.hsv_max,
        };
        Ok(Self::with_pool(compute, image, pool, threads - 1))
    }

    /// The engine of `compute` showing `image`, whose pairs
    /// [`Self::representation`] may spread over `pool` with `helpers` of
    /// its threads (several engines may share one pool: `run`'s workers).
    pub(crate) fn with_pool(
        compute: Compute,
        image: Image,
        pool: Option<Arc<rayon::ThreadPool>>,
        helpers: usize,
    ) -> Self {
        let helpers = if pool.is_some() { helpers } else { 0 };
        Self {
            compute,
            image,
            keep: false,
            lane: Lane::new(),
            helpers: (0..helpers).map(|_| HostEngine::new()).collect(),
            pool,
            kept: None,
            pixels: Vec::new(),
            luma: Vec::new(),
        }
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
        let Some((params, scaling)) = self.compute.fixed() else {
            // The float reference: the oracle, one thread.
            let fields = self.compute.pair_with(&mut self.lane, prev, next)?;
            rgb.copy_from_slice(&self.image.of(&fields));
            return Ok(());
        };
        if self.image.needs_fields() {
            return self.wheel(prev, next, params, rgb);
        }
        if self.helpers.is_empty() && !self.keep {
            // `run`'s path, to the byte.
            self.compute
                .representation(&mut self.lane, prev, next, &mut Exact(rgb))?;
            self.image.arrange(rgb);
            return Ok(());
        }
        let image = self.image;
        self.tiles(prev, next, params, scaling, rgb, image)
    }

    /// The representation `[|v_d|, |v_c|, fⁿ]` of `(prev, next)` into
    /// `rgb`: the bytes of [`Self::fields`]' `rep`. On this thread alone,
    /// unless `spread` (and the engine has a pool, the fixed engine runs
    /// in per-frame min–max): then its tiles are spread over the pool too
    /// (`run`'s last pairs, which idle threads help finish).
    pub(crate) fn representation(
        &mut self,
        prev: &Gray,
        next: &Gray,
        rgb: &mut impl ByteBuffer,
        spread: bool,
    ) -> Result<(), HostError> {
        self.kept = None;
        match self.compute.fixed() {
            Some((params, scaling @ Scaling::PerFrameMinMax))
                if spread && !self.helpers.is_empty() && prev.size() == next.size() =>
            {
                let rgb = rgb.overwrite(3 * prev.pixels.len())?;
                self.tiles(prev, next, params, scaling, rgb, Image::default())
            }
            _ => self.compute.representation(&mut self.lane, prev, next, rgb),
        }
    }

    /// The fields of the pair `(prev, next)` (and the float engine's
    /// representation), for a consumer that reads them: the vector fields,
    /// the motion score. One thread.
    pub fn fields(&mut self, prev: &Gray, next: &Gray) -> Result<PairFields, HostError> {
        self.kept = None;
        self.compute.pair_with(&mut self.lane, prev, next)
    }

    /// The image of `fields` (from [`Self::fields`]): the bytes
    /// [`Self::image`] writes for the same pair.
    pub fn image_of(&self, fields: &PairFields) -> Vec<u8> {
        self.image.of(fields)
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
        let (_, _, kept) = self.lane.parts();
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
    /// tile's bytes, arranged as `image`.
    fn tiles(
        &mut self,
        prev: &Gray,
        next: &Gray,
        params: Params,
        scaling: Scaling,
        rgb: &mut [u8],
        image: Image,
    ) -> Result<(), HostError> {
        let (width, height) = prev.size();
        let (plan, frames) =
            prepare(prev, next, params, Some(self.tile(width, height))).map_err(tile_error)?;
        let (memory, isa, kept) = self.lane.parts();
        let [m_d, m_c] = kept.planes(width * height)?;
        let tiles = TileRows::split(&plan, width, [m_d, m_c], rgb);
        let tiles: Vec<Mutex<TileRows<'_>>> = tiles.into_iter().map(Mutex::new).collect();
        let bands = Bands::new(&plan, &frames, isa, &tiles);
        let luma = &prev.pixels;
        let finish = |mine: &[usize]| {
            let merged = || {
                let mut extremes = ExtremesSink::default();
                for tile in &tiles {
                    extremes.merge(tile.lock().expect("no panic while holding it").extremes);
                }
                Ok::<_, std::convert::Infallible>(extremes)
            };
            let (d, c) = scaling.byte_scales(merged).unwrap_or_else(|n| match n {});
            for &index in mine {
                let mut tile = tiles[index]
                    .lock()
                    .expect("each tile is taken once at a time");
                tile.bytes(isa, luma, width, &[d, c], &image);
            }
        };
        spread(
            &bands,
            self.pool.as_deref(),
            memory,
            &mut self.helpers,
            &finish,
        );
        bands.result()?;
        if self.keep {
            self.keep_luma(prev, width, height);
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
        let (plan, frames) =
            prepare(prev, next, params, Some(self.tile(width, height))).map_err(tile_error)?;
        self.pixels.clear();
        self.pixels.resize(width * height, FlowPixel::default());
        let (memory, isa, _) = self.lane.parts();
        let tiles = PixelRows::split(&plan, width, &mut self.pixels);
        let tiles: Vec<Mutex<PixelRows<'_>>> = tiles.into_iter().map(Mutex::new).collect();
        let bands = Bands::new(&plan, &frames, isa, &tiles);
        spread(
            &bands,
            self.pool.as_deref(),
            memory,
            &mut self.helpers,
            &|_| (),
        );
        bands.result()?;
        drop(tiles);
        let pixels = &self.pixels;
        let fields = PairFields {
            planes: planes_of(width, height, pixels),
            rep: Vec::new(),
        };
        rgb.copy_from_slice(&self.image.of(&fields));
        if self.keep {
            let (_, _, kept) = self.lane.parts();
            let [m_d, m_c] = kept.planes(width * height)?;
            for ((d, c), p) in m_d.iter_mut().zip(m_c.iter_mut()).zip(pixels) {
                (*d, *c) = (p.m_d, p.m_c);
            }
            self.keep_luma(prev, width, height);
        }
        Ok(())
    }

    /// The kept magnitudes are those of `prev`'s pair.
    fn keep_luma(&mut self, prev: &Gray, width: usize, height: usize) {
        self.kept = Some((width, height));
        self.luma.clear();
        self.luma.extend_from_slice(&prev.pixels);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::Variant;
    use crate::settings::{EngineKind, ScaleArg, Setting, TileSize};
    use lane::compute_fixed;

    fn gray(width: usize, height: usize, seed: usize) -> Gray {
        let pixels = (0..width * height)
            .map(|i| ((i * 7 + seed).wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        Gray::new(width, height, pixels).unwrap()
    }

    /// `run`'s bytes of one pair: the `pair` subcommand's computation and
    /// the variant's image.
    fn expected(settings: &Settings, a: &Gray, b: &Gray) -> Vec<u8> {
        let image = Image {
            variant: settings.variant,
            hsv_max: settings.hsv_max,
        };
        image.of(&settings.compute().unwrap().pair(a, b).unwrap())
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
                                let fixed = compute_fixed(
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
