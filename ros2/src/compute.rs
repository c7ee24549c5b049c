//! One frame pair to the `--variant` image (and the cues' magnitudes),
//! through the host crate: the bytes of `reynoldsflow run` by construction.
//!
//! On one thread without cues the node takes `run`'s own per-pair path (a
//! worker's: [`Compute::representation`] into the bytes, or the fields for
//! the colour wheel, then [`OutputSpec::arrange`]). With more threads it
//! takes the GStreamer element's, [`PairPool`], which spreads one pair's
//! tiles over the threads: frames arrive one by one and each result is
//! wanted at once, so the threads share a pair instead of taking one each
//! (every tiling gives the same bytes; the host's tests and
//! scripts/test-ros2 check them against `run`). Cues need every pixel's
//! magnitudes, which the pool keeps, so they take the pool on one thread too.

use reynoldsflow_core::{FlowPixel, Frame};
use reynoldsflow_host::fixed_engine::FrameEngine;
use reynoldsflow_host::outputs::OutputSpec;
use reynoldsflow_host::pair_pool::PairPool;
use reynoldsflow_host::pipeline::Compute;
use reynoldsflow_host::settings::Settings;
use reynoldsflow_host::{Gray, HostError};

/// The engine, built once from checked settings.
pub struct PairComputer {
    spec: OutputSpec,
    path: Path,
}

enum Path {
    /// `run`'s worker path.
    Run {
        compute: Compute,
        engine: FrameEngine,
    },
    /// The element's, tiles over the threads.
    Pool(PairPool),
}

impl PairComputer {
    /// Check `settings` as `reynoldsflow run` checks its flags (the same
    /// messages, naming the setting); `keep_pixels`: whether the pixels'
    /// magnitudes are wanted (for the cues).
    pub fn new(settings: &Settings, keep_pixels: bool) -> Result<Self, HostError> {
        let spec = OutputSpec {
            variant: settings.variant,
            ..OutputSpec::default()
        };
        let threads = settings.threads();
        let path = if threads == 1 && !keep_pixels {
            Path::Run {
                compute: settings.compute()?,
                engine: FrameEngine::new(),
            }
        } else {
            Path::Pool(PairPool::new(
                settings.scale,
                settings.intensity_scale,
                settings.lambda,
                threads,
            )?)
        };
        Ok(Self { spec, path })
    }

    /// The `--variant` image (RGB8, packed) of the pair `(prev, next)`,
    /// both of one size, and what `read` makes of every pixel (row-major)
    /// when the settings keep them.
    pub fn pair<T>(
        &mut self,
        prev: &Gray,
        next: &Gray,
        read: impl FnOnce(&[FlowPixel]) -> T,
    ) -> Result<(Vec<u8>, Option<T>), HostError> {
        match &mut self.path {
            Path::Run { compute, engine } => {
                let rgb = if self.spec.needs_fields() {
                    self.spec.image(&compute.pair_with(engine, prev, next)?)
                } else {
                    let mut rgb = Vec::new();
                    compute.representation(engine, prev, next, &mut rgb)?;
                    self.spec.arrange(&mut rgb);
                    rgb
                };
                Ok((rgb, None))
            }
            Path::Pool(pool) => {
                let prev = Frame::packed(&prev.pixels, prev.width, prev.height)?;
                let next = Frame::packed(&next.pixels, next.width, next.height)?;
                let pair = pool.compute(prev, next)?;
                Ok((pair.image(self.spec.variant), Some(read(pair.pixels()))))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use reynoldsflow_host::outputs::Variant;
    use reynoldsflow_host::settings::Setting;

    fn gray(width: usize, height: usize, seed: usize) -> Gray {
        let pixels = (0..width * height)
            .map(|i| ((i * 7 + seed).wrapping_mul(2_654_435_761) >> 13) as u8)
            .collect();
        Gray::new(width, height, pixels).unwrap()
    }

    fn settings(variant: Variant, threads: usize) -> Settings {
        Settings {
            variant,
            threads: Some(threads),
            ..Settings::default()
        }
    }

    #[test]
    fn every_path_gives_the_bytes_of_run() {
        let (a, b) = (gray(70, 33, 0), gray(70, 33, 1));
        for variant in [Variant::Dc, Variant::Dc0, Variant::Cd, Variant::Hsv] {
            // `run`'s computation of one pair (the `pair` subcommand's too).
            let compute = Settings::default().compute().unwrap();
            let spec = OutputSpec {
                variant,
                ..OutputSpec::default()
            };
            let expected = spec.image(&compute.pair(&a, &b).unwrap());
            for (threads, keep) in [(1, false), (1, true), (2, false), (3, true)] {
                let mut computer = PairComputer::new(&settings(variant, threads), keep).unwrap();
                let (rgb, pixels) = computer.pair(&a, &b, |p| p.len()).unwrap();
                assert!(
                    rgb == expected,
                    "{variant:?}, {threads} threads, pixels {keep}"
                );
                let kept = keep || threads > 1;
                assert_eq!(pixels, kept.then_some(70 * 33));
            }
        }
    }

    #[test]
    fn bad_settings_name_the_setting() {
        let mut s = settings(Variant::Dc, 1);
        s.lambda = 1e9;
        let err = PairComputer::new(&s, false).err().unwrap();
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
    }
}
