//! One frame pair at a time over a pool of threads, for a consumer that
//! gets frames one by one and wants each result at once (the GStreamer
//! element): the host's whole-frame path ([`fixed_engine`]) with the tiles
//! balanced over the threads ([`fixed_engine::pixels_on`]), so no latency
//! is added. `run` instead spreads whole pairs over its workers
//! ([`pipeline`]); both keep every core busy, and every
//! tiling gives the same bytes.

use reynoldsflow_core::{
    Config, ExtremesSink, FlowPixel, Frame, FramePair, HALO, IntensityScale, Params, Plan, Scaling,
};

use crate::fixed_engine::{self, MAX_STRIP_WIDTH};
use crate::outputs::{OutputSpec, PairFields, Variant};
use crate::pipeline::{self, Compute};
use crate::settings::{EngineKind, ScaleArg};
use crate::{Flow, FlowPlanes, HostError};

/// The fixed engine's parameters, checked once, and the threads that run it.
pub struct PairPool {
    params: Params,
    scaling: Scaling,
    threads: usize,
    /// The last pair's pixels, row-major (kept to reuse the allocation).
    pixels: Vec<FlowPixel>,
}

/// The core's output of one pair: every pixel, and the byte scales.
pub struct PairPixels<'a> {
    width: usize,
    height: usize,
    pixels: &'a [FlowPixel],
    extremes: ExtremesSink,
    scaling: Scaling,
    threads: usize,
}

impl PairPool {
    /// The fixed engine with `reynoldsflow run`'s parameters, checked as
    /// `run` checks them (same messages), on `threads` threads (at least 1).
    pub fn new(
        scale: ScaleArg,
        intensity_scale: IntensityScale,
        lambda: f64,
        threads: usize,
    ) -> Result<Self, HostError> {
        Compute::new(EngineKind::Fixed, scale, intensity_scale, lambda, None)?;
        let threads = threads.max(1);
        Ok(Self {
            params: pipeline::core_params(intensity_scale, lambda)?,
            scaling: pipeline::core_scaling(scale)?,
            threads,
            pixels: Vec::new(),
        })
    }

    /// The core's parameters.
    pub fn params(&self) -> Params {
        self.params
    }

    /// Run the engine on `(prev, next)`: every tile once, spread over the
    /// threads. Fails when the frames differ in size or the core refuses them.
    pub fn compute(
        &mut self,
        prev: Frame<'_>,
        next: Frame<'_>,
    ) -> Result<PairPixels<'_>, HostError> {
        let (width, height) = (prev.width(), prev.height());
        if (next.width(), next.height()) != (width, height) {
            return Err(HostError::SizeMismatch {
                prev: (width, height),
                next: (next.width(), next.height()),
            });
        }
        let config = Config::new(width, height, self.params)?;
        let (tile_width, tile_height) = balanced_tile(width, height, self.threads);
        let plan = Plan::new(config, tile_width, tile_height)?;
        let frames = FramePair::new(&config, prev, next)?;
        let extremes = fixed_engine::pixels_on(self.threads, &plan, &frames, &mut self.pixels)?;
        Ok(PairPixels {
            width,
            height,
            pixels: &self.pixels,
            extremes,
            scaling: self.scaling,
            threads: self.threads,
        })
    }
}

/// Tile size for `threads`: the host's widest strip, or narrower
/// ones, in as many rows of tiles as gives the shortest pass, counting each
/// tile's halo (`HALO` px on every side) and `⌈tiles / threads⌉` rounds.
fn balanced_tile(width: usize, height: usize, threads: usize) -> (usize, usize) {
    let min_across = width.div_ceil(MAX_STRIP_WIDTH);
    let mut best = (usize::MAX, (width.min(MAX_STRIP_WIDTH), height));
    for across in min_across..=min_across + threads {
        for down in 1..=(2 * threads).min(height) {
            let (tw, th) = (width.div_ceil(across), height.div_ceil(down));
            let tiles = width.div_ceil(tw) * height.div_ceil(th);
            let cost = tiles.div_ceil(threads) * (tw + 2 * HALO) * (th + 2 * HALO);
            if cost < best.0 {
                best = (cost, (tw, th));
            }
        }
    }
    best.1
}

impl PairPixels<'_> {
    /// Frame size.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Every pixel, row-major.
    pub fn pixels(&self) -> &[FlowPixel] {
        self.pixels
    }

    /// The RGB8 image of `variant`, row-major: exactly what `reynoldsflow
    /// run --variant` writes for this pair.
    pub fn image(&self, variant: Variant) -> Vec<u8> {
        let rep = fixed_engine::rgb_of(
            self.pixels,
            self.width,
            self.extremes,
            self.scaling,
            self.threads,
        );
        // Only the colour wheel reads the fields.
        let plane = |f: fn(&FlowPixel) -> f64| match variant {
            Variant::Hsv => self.pixels.iter().map(f).collect(),
            _ => Vec::new(),
        };
        let fields = PairFields {
            planes: FlowPlanes {
                v_c: Flow {
                    width: self.width,
                    height: self.height,
                    u: plane(|p| f64::from(p.v_c[0])),
                    v: plane(|p| f64::from(p.v_c[1])),
                },
                v_d: Flow {
                    width: self.width,
                    height: self.height,
                    u: plane(|p| f64::from(p.v_d[0])),
                    v: plane(|p| f64::from(p.v_d[1])),
                },
            },
            rep,
        };
        OutputSpec {
            variant,
            ..OutputSpec::default()
        }
        .image(&fields)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Gray;
    use crate::fixed_engine::compute_fixed;

    fn frame(width: usize, height: usize, seed: usize) -> Vec<u8> {
        (0..width * height)
            .map(|i| ((i * 7 + seed).wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect()
    }

    #[test]
    fn tiles_are_balanced_over_the_threads() {
        // One thread: the engine's widest full-height strips.
        assert_eq!(balanced_tile(640, 480, 1), (640, 480));
        // Two or four threads get an even count of tiles.
        for threads in [2, 4] {
            let (tw, th) = balanced_tile(640, 480, threads);
            let tiles = 640usize.div_ceil(tw) * 480usize.div_ceil(th);
            assert_eq!(tiles % threads, 0, "{threads} threads: {tw}x{th}");
            assert!(tw <= MAX_STRIP_WIDTH);
        }
    }

    #[test]
    fn every_thread_count_gives_the_serial_engines_bytes() {
        let (w, h) = (300, 45);
        let (a, b) = (frame(w, h, 0), frame(w, h, 1));
        let scales = [
            ScaleArg::MinMax,
            ScaleArg::Fixed {
                k_d: 8.0,
                k_c: 32.0,
            },
        ];
        for scale in scales {
            let scaling = pipeline::core_scaling(scale).unwrap();
            let (ga, gb) = (
                Gray::new(w, h, a.clone()).unwrap(),
                Gray::new(w, h, b.clone()).unwrap(),
            );
            let serial = compute_fixed(&ga, &gb, Params::DEFAULT, None, scaling).unwrap();
            for threads in [1, 2, 3, 7] {
                let mut pool =
                    PairPool::new(scale, IntensityScale::PER_255, 1e-4, threads).unwrap();
                let prev = Frame::packed(&a, w, h).unwrap();
                let next = Frame::packed(&b, w, h).unwrap();
                let out = pool.compute(prev, next).unwrap();
                assert!(out.image(Variant::Dc) == serial.rep, "{threads} threads");
                let m_d: Vec<f64> = out.pixels().iter().map(|p| f64::from(p.m_d)).collect();
                assert!(m_d == serial.m_d);
            }
        }
    }

    #[test]
    fn frames_of_two_sizes_are_refused() {
        let mut pool = PairPool::new(ScaleArg::MinMax, IntensityScale::PER_255, 1e-4, 2).unwrap();
        let (a, b) = (frame(20, 10, 0), frame(20, 12, 1));
        let err = pool
            .compute(
                Frame::packed(&a, 20, 10).unwrap(),
                Frame::packed(&b, 20, 12).unwrap(),
            )
            .err()
            .unwrap();
        assert!(matches!(err, HostError::SizeMismatch { .. }));
    }
}
