//! One thread's whole-frame path through the fixed-point core ([`Lane`]):
//! its engine memory and kept planes, reused pair after pair. One engine
//! pass per pair whatever the scaling; per-frame min–max keeps what the
//! byte step needs (each pixel's magnitudes, or every pixel when the
//! fields are wanted) instead of running the engine twice. The pair
//! engine ([`super::PairEngine`]) runs its one-thread pairs here.
//!
//! Two outputs of the same pass: [`Lane::represent`], the RGB bytes alone,
//! and [`Lane::compute`], every plane ([`FixedOutput`]). Every tiling
//! gives the same bytes.

use reynoldsflow_core::{FlowPixel, Params, Scaling, rgb};

use super::bands::prepare;
use super::bytes::{self, Isa, Pass};
use super::memory::HostEngine;
use super::sinks::{Kept, KeptMagnitudes, PixelRows};
use crate::engine::page_buffer::ByteBuffer;
use crate::{Flow, FlowPlanes, Gray, HostError};

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

/// The RGB bytes of every pixel, in `scaling` once the frame's `extremes`
/// are known.
fn rgb_of(
    pixels: &[FlowPixel],
    extremes: reynoldsflow_core::ExtremesSink,
    scaling: Scaling,
) -> Vec<u8> {
    let (scale_d, scale_c) = scaling
        .byte_scales(|| Ok::<_, std::convert::Infallible>(extremes))
        .unwrap_or_else(|never| match never {});
    pixels
        .iter()
        .flat_map(|p| rgb(p, &scale_d, &scale_c))
        .collect()
}

/// Run the core on `(prev, next)` with `params`, in full-height strips
/// `strip_width` wide, or in `tile = (width, height)` tiles when given,
/// the widest instructions the CPU has: `Lane::compute` on a fresh
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
    Lane::on(isa).compute(prev, next, params, tile, scaling)
}

/// The host's whole-frame engine, reused pair after pair (one per worker):
/// the engine and the magnitudes kept for per-frame min–max live as long as
/// this value, so the RGB path allocates nothing once its buffers have
/// grown to the frame size.
pub(crate) struct Lane {
    engine: HostEngine,
    /// Which compilation of the engine pass runs.
    isa: Isa,
    /// `|v_d|` and `|v_c|` of every pixel of the last pair (per-frame
    /// min–max of [`Self::represent`] only): all that the byte step needs
    /// besides `fⁿ`.
    kept: Kept,
}

impl Default for Lane {
    fn default() -> Self {
        Self::new()
    }
}

impl Lane {
    /// An engine with empty buffers, the widest instructions the CPU has.
    pub(crate) fn new() -> Self {
        Self::on(Isa::Best)
    }

    /// An engine whose pass is compiled for `isa` (every `isa` gives the
    /// same bytes).
    pub(crate) fn on(isa: Isa) -> Self {
        Self {
            engine: HostEngine::new(),
            isa,
            kept: Kept::default(),
        }
    }

    /// Every plane of `(prev, next)`: fields, magnitudes and the
    /// representation, in one engine pass. Fails as [`compute_fixed`] does.
    pub(crate) fn compute(
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
        bytes::run(self.isa, engine, &plan, &frames, Pass::All, &mut sink)?;
        let extremes = sink.extremes;
        let rep = rgb_of(&pixels, extremes, scaling);
        Ok(output(width, height, &pixels, rep))
    }

    /// The representation of `(prev, next)` alone into `rgb` (resized to
    /// `3 · width · height`), in one engine pass whatever the scaling:
    /// `Fixed` gains stream the engine's rows straight into the bytes;
    /// per-frame min–max keeps each pixel's two magnitudes and the frame's
    /// extremes, then maps them to bytes. The bytes of [`Self::compute`]'s
    /// `rep`; fails as [`compute_fixed`] does.
    pub(crate) fn represent(
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
            return Ok(bytes::run(self.isa, engine, &plan, &frames, pass, &mut ())?);
        }
        let mut sink = KeptMagnitudes::new(width, self.kept.planes(width * height)?);
        bytes::run(self.isa, engine, &plan, &frames, Pass::All, &mut sink)?;
        sink.into_bytes(self.isa, &prev.pixels, rgb)
    }

    /// The engine memory, the compilation and the kept planes, for a pair
    /// whose tiles several threads compute ([`super::bands`]).
    pub(crate) fn parts(&mut self) -> (&mut HostEngine, Isa, &mut Kept) {
        (&mut self.engine, self.isa, &mut self.kept)
    }
}

#[cfg(test)]
mod tests {
    use fixed::types::U16F16;

    use super::*;
    use reynoldsflow_core::ByteScale;

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
    fn the_rgb_path_gives_the_planes_bytes_while_reused() {
        let mut rgb = Vec::new();
        // Both compilations of the pass and of the min–max byte step.
        for isa in [Isa::Best, Isa::Portable] {
            let mut engine = Lane::on(isa);
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
        let mut engine = Lane::new();
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
    /// CPU has them, NEON's on aarch64: `scripts/test-resample-aarch64`
    /// runs this under `qemu-aarch64`) gives the bytes of
    /// `ByteScale::byte` one pixel at a time, on every length around the
    /// lanes' steps (32 pixels, 16) and on magnitudes of every kind: zeros
    /// of both signs, ties, the range's ends, beyond them, subnormal, huge,
    /// infinite, negative, NaN; `fⁿ` from 0 to 255.
    #[test]
    fn the_byte_step_is_the_byte_of_each_pixel() {
        // On aarch64 `Best` is the NEON step, not the portable one again.
        #[cfg(target_arch = "aarch64")]
        assert_eq!(bytes::best_name(), "neon");
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
                    3 => [
                        f32::MAX,
                        f32::INFINITY,
                        f32::NAN,
                        -1.0,
                        -0.0,
                        f32::MIN,
                        f32::NEG_INFINITY,
                        f32::MIN_POSITIVE,
                        f32::from_bits(1),
                        -f32::NAN,
                    ][(r % 10) as usize],
                    4 => 3.5 + (r % 100) as f32,
                    _ => (r % 1_000_000) as f32 * 4e-6,
                }
            };
            let planes: [Vec<f32>; 2] =
                std::array::from_fn(|_| (0..len as u64).map(&mut magnitude).collect());
            let luma: Vec<u8> = (0..len)
                .map(|i| [0, 255, (i * 37 % 256) as u8][i % 3])
                .collect();
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
                    bytes::kept_to_bytes(isa, [m_d, m_c], &luma, &mut rgb, &scales);
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
